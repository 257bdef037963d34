// engine/correction/solve_problem.h (internal): one prepared correction
// problem solved (correction.h, steps 2-4): the outlier test, the regularised
// linear solve, the exact-model refinement and search (or the rework passes,
// or a baseline solver), the safe step, the exact prediction and its band.
//
//   CorrectionProblem problem;  // PrepareCorrectionProblem (problem.h)
//   const CorrectionResult result = SolveProblem(options, problem);
#ifndef GEARLOOP_ENGINE_CORRECTION_SOLVE_PROBLEM_H_
#define GEARLOOP_ENGINE_CORRECTION_SOLVE_PROBLEM_H_

#include "engine/correction/correction.h"
#include "engine/correction/problem.h"

namespace gearloop {
namespace correction_internal {

// Solve, SafeStep, PredictExactly and the prediction band for one prepared
// problem; `state`: the machine-state solve it is linearised at (reported), or
// null.
CorrectionResult SolveProblem(const CorrectionOptions& options,
                              CorrectionProblem problem,
                              const CorrectionResult* state = nullptr);

}  // namespace correction_internal
}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_CORRECTION_SOLVE_PROBLEM_H_
