// engine/correction/exact_search.h (internal): the exact-model search, a stage
// between the regularised answer and the safe step.
//
// Where the linear model stalls (robustness benchmark, BENCHMARKS.md "Where
// the narrow gears' reach is": a lead crowning on a narrow gear is made only
// with axis motions on their bound, by the exact model's curvature, where
// every linearisation sees a best reachable of 2.4 um), the regularised answer
// is continued on the exact model at the linearisation point: sequential QPs
// (RefineWithinMotionBound) over every direction above the weak-flank floor
// (not only those the filter kept), fitting the noise-filtered error (the
// measured part of each direction shrunk as the filter did, what no direction
// reaches kept whole), within the motion bound; then, from its end point, the
// wide search over the directions down to 1e-6 of the floor as well (a wheel
// cone change that makes a lead crowning on a narrow gear lies just under the
// floor), while each pass lowers the cost by 1 %. The lower end point is the
// search's answer; it replaces the regularised one only where its exact
// prediction at the linearisation point is below (1 - kSearchGainShare) x the
// regularised answer's - kSearchGainMinUm (20 % and 0.02 um lower); either
// then goes through the safe step, and where it refuses every fraction of the
// search's answer the regularised one goes through it instead
// (solve_problem.cc). It runs
// only where the regularised answer's linear and exact predictions both stay
// above the filter's noise + 0.05 um. The wide search only where no order
// 4-6 is free.
//
//   delta = SearchOnExactModel(options, problem, ls, delta, &summary);
#ifndef GEARLOOP_ENGINE_CORRECTION_EXACT_SEARCH_H_
#define GEARLOOP_ENGINE_CORRECTION_EXACT_SEARCH_H_

#include <Eigen/Core>

#include "engine/correction/correction.h"
#include "engine/correction/problem.h"
#include "engine/correction/regularisation.h"

namespace gearloop {
namespace correction_internal {

// The rms over the used points of the exact prediction e + d(p + delta) -
// d(p) at the linearisation point p; infinity where a used point is lost.
double ExactRms(const CorrectionProblem& problem, const Eigen::VectorXd& delta);

Eigen::VectorXd SearchOnExactModel(const CorrectionOptions& options,
                                   const CorrectionProblem& problem,
                                   const LinearSolve& ls,
                                   const Eigen::VectorXd& delta,
                                   CorrectionSummary* summary);

}  // namespace correction_internal
}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_CORRECTION_EXACT_SEARCH_H_
