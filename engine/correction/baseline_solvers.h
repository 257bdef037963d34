// engine/correction/baseline_solvers.h (internal): the comparison solvers of
// the correction (correction.h): "lsq-plain", the minimum-norm unregularised
// least squares in raw parameter units, and "pso", the particle swarm of the
// published method (Jiang 2015; MODEL.md §6).
//
//   const Eigen::VectorXd delta = SolvePlainLeastSquares(problem);
#ifndef GEARLOOP_ENGINE_CORRECTION_BASELINE_SOLVERS_H_
#define GEARLOOP_ENGINE_CORRECTION_BASELINE_SOLVERS_H_

#include <Eigen/Core>

#include "engine/correction/correction.h"
#include "engine/correction/problem.h"

namespace gearloop {
namespace correction_internal {

// dzeta = pinv(W^1/2 S_free) (-W^1/2 e) over the used points, clamped to the
// bounds; no regularisation, no refinement. Returns delta (num_parameters).
Eigen::VectorXd SolvePlainLeastSquares(const CorrectionProblem& problem);

// The global-best particle swarm over the free coefficients, each within
// +-pso_box of the current value (the cone angle's box in degrees) and the
// bounds, minimising the stock-limited objective sum_i w_i f_i^2, f_i = S_i
// dzeta - delta_i where S_i dzeta < 0, else -delta_i (delta = t - m). Seeded by
// options.pso_seed. Returns delta (num_parameters).
Eigen::VectorXd SolveParticleSwarm(const CorrectionOptions& options,
                                   const CorrectionProblem& problem);

}  // namespace correction_internal
}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_CORRECTION_BASELINE_SOLVERS_H_
