// engine/correction/machine_state.h (internal): step 0 of the correction
// (correction.h, estimate_machine_state). The machine really runs commanded +
// unknown errors h. The state problem takes the model's own flank d(commanded)
// as the "measurement" and the measured flank as the "target" (same freedom, no
// bounds, next-part mode, the probe noise of the teeth average): its change is
// an estimate h^ of h within the reachable directions. The correction is then
// linearised and refined at commanded + h^ (RelinearisedAt, problem.h).
//
//   CorrectionProblem state_problem;
//   if (MachineStateProblem(problem, &state_problem)) {
//     const CorrectionResult state = /* solve state_problem */;
//     Eigen::VectorXd at_state;
//     if (AcceptMachineState(problem, state, &at_state)) { /* solve
//     RelinearisedAt(problem, at_state) */ }
//   }
#ifndef GEARLOOP_ENGINE_CORRECTION_MACHINE_STATE_H_
#define GEARLOOP_ENGINE_CORRECTION_MACHINE_STATE_H_

#include <Eigen/Core>

#include "engine/correction/correction.h"
#include "engine/correction/problem.h"

namespace gearloop {
namespace correction_internal {

// The state problem of `commanded` (a problem linearised at the commanded
// parameters): e = d0 - m (NaN where the model or the measurement has no
// value), the noise sigma / sqrt(mean teeth averaged) with no per-point shares,
// no bounds, next-part mode; the rule, weights, roll range, free set and
// linearisation are kept. A state estimate in orders 4-6 makes the spur gear's
// root contacts singular just as a correction in them does (see
// default_max_order), so it has the same max orders. False when no point is
// usable.
bool MachineStateProblem(const CorrectionProblem& commanded,
                         CorrectionProblem* state);

// Whether the solved state is used: usable, finite, and every grid point
// reached at the commanded parameters still reached at commanded + h^ (then
// `state_parameters`). Otherwise the correction is computed at the commanded
// parameters, as without the option.
bool AcceptMachineState(const CorrectionProblem& commanded,
                        const CorrectionResult& state,
                        Eigen::VectorXd* state_parameters);

// The state's correction size and misfit into `summary`
// (machine_state_estimated = true).
void ReportMachineState(const CorrectionResult& state,
                        CorrectionSummary* summary);

}  // namespace correction_internal
}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_CORRECTION_MACHINE_STATE_H_
