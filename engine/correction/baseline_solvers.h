// engine/correction/baseline_solvers.h (internal): the comparison solvers of
// the correction (correction.h): "lsq-plain", the minimum-norm unregularised
// least squares in raw parameter units, and "pso", the particle swarm of the
// published method (Jiang 2015; MODEL.md §6).
//
//   const Eigen::VectorXd delta = SolvePlainLeastSquares(problem);
#ifndef GEARLOOP_ENGINE_CORRECTION_BASELINE_SOLVERS_H_
#define GEARLOOP_ENGINE_CORRECTION_BASELINE_SOLVERS_H_

#include <Eigen/Core>
#include <vector>

#include "engine/correction/correction.h"
#include "engine/correction/problem.h"

namespace gearloop {
namespace correction_internal {

// dzeta = pinv(W^1/2 S_free) (-W^1/2 e) over the used points, clamped to the
// bounds; no regularisation, no refinement. Returns delta (num_parameters).
Eigen::VectorXd SolvePlainLeastSquares(const CorrectionProblem& problem);

// What the swarm went through: the best objective after the start and after
// each generation (pso_generations + 1 entries, never increasing).
struct SwarmTrace {
  std::vector<double> best_objective;
};

// The published particle swarm (MODEL.md §6) over the free coefficients, each
// within +-pso_box of the current value in its own unit (mm, rad, 1/mm) and
// within the bounds. It searches the model linearised at the current
// parameters over the used points, with the point weights w_i and delta = t -
// m: next part, sum_i w_i (S_i dzeta - delta_i)^2; rework, the paper's
// one-sided sum_i w_i f_i^2, f_i = S_i dzeta - delta_i where S_i dzeta < 0,
// else -delta_i. Deterministic in options.pso_seed. Returns delta
// (num_parameters); `trace` (optional) receives the best objective per
// generation.
Eigen::VectorXd SolveParticleSwarm(const CorrectionOptions& options,
                                   const CorrectionProblem& problem,
                                   SwarmTrace* trace = nullptr);

}  // namespace correction_internal
}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_CORRECTION_BASELINE_SOLVERS_H_
