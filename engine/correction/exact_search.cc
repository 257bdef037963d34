// The exact-model search (exact_search.h).
#include "engine/correction/exact_search.h"

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "engine/correction/rework_qp.h"

namespace gearloop {
namespace correction_internal {
namespace {

// The search's answer is taken where its exact prediction is below
// (1 - kSearchGainShare) x the regularised answer's - kSearchGainMinUm.
constexpr double kSearchGainShare = 0.2;
constexpr double kSearchGainMinUm = 0.1;
// The search runs only where the regularised answer's linear and exact
// predictions are above kSearchNoiseShare x the noise + kSearchGainMinUm:
// closer to the noise there is little to find.
constexpr double kSearchNoiseShare = 2.0;
// The search's light damping of each direction, a share of its singular value
// (the penalty |mu z|^2 of the QPs): keeps them definite without holding a
// direction back.
constexpr double kSearchDampingShare = 1e-3;

// The exact rms at the linearisation point over the used points after
// `delta` (infinity when a used point is lost).
double ExactRms(const CorrectionProblem& problem,
                const Eigen::VectorXd& delta) {
  ModelEvaluation eval;
  problem.model->Evaluate(problem.parameters + delta, false, &eval);
  double sum = 0.0;
  for (int i : problem.used) {
    if (eval.status[i] != PointStatus::kOk) return kInf;
    const double r =
        problem.error_um(i) + eval.deviations_um(i) - problem.d0()(i);
    sum += r * r;
  }
  return problem.used.empty() ? 0.0 : std::sqrt(sum / problem.used.size());
}

// An exact prediction for the summary: infinity is a lost point.
std::string PredictionText(double um) {
  return std::isfinite(um) ? FormatUm(um) + " um" : "inf (a used point lost)";
}

}  // namespace

Eigen::VectorXd SearchOnExactModel(const CorrectionOptions& options,
                                   const CorrectionProblem& problem,
                                   const LinearSolve& ls,
                                   const Eigen::VectorXd& delta,
                                   CorrectionSummary* summary) {
  summary->exact_search = "not run: no per-direction filter";
  if (!(problem.signal_noise_um > 0.0) ||
      problem.mode == CorrectionMode::kRework || problem.has_bounds ||
      options.max_num_iterations <= 0 || ls.svd.rank == 0 ||
      ls.svd.u.rows() != static_cast<int>(problem.used.size()))
    return delta;
  // The trigger on the linear prediction (no model evaluation for the many
  // answers near the noise); the comparison on the exact one.
  const Eigen::VectorXd linear = problem.error_um + problem.jacobian_um * delta;
  const double threshold =
      kSearchNoiseShare * problem.signal_noise_um + kSearchGainMinUm;
  if (Rms(linear, problem.used) <= threshold) {
    summary->exact_search = "not run: the answer is near the noise";
    return delta;
  }
  const double before = ExactRms(problem, delta);
  summary->exact_search_before_rms_um = before;
  if (std::isfinite(before) && before <= threshold) {
    summary->exact_search = "not run: the answer is near the noise";
    return delta;
  }
  const int rank = ls.svd.rank;
  // The noise-filtered error: e + (sum_i (1 - f_i) beta_i u_i) / sqrt(w).
  Eigen::VectorXd removed = Eigen::VectorXd::Zero(ls.svd.u.rows());
  for (int i = 0; i < rank; ++i) {
    const double f = i < ls.filter.size() ? ls.filter(i) : 0.0;
    removed += (1.0 - f) * ls.beta(i) * ls.svd.u.col(i);
  }
  CorrectionProblem filtered = problem;
  for (size_t r = 0; r < problem.used.size(); ++r) {
    const int i = problem.used[r];
    filtered.error_um(i) += removed(r) / std::sqrt(problem.weights(i));
  }
  // Every direction above the floor, a light damping on each.
  KeptSubspace full;
  full.k = rank;
  full.sigma1 = ls.svd.sigma(0);
  full.ridge = 1e-12 * full.sigma1 * full.sigma1;
  full.vk = ls.svd.v.leftCols(rank);
  full.tv = problem.t_map * full.vk;
  full.mu = kSearchDampingShare * ls.svd.sigma.head(rank);
  // The regularised answer in these coordinates (T has full column rank).
  const Eigen::VectorXd y = problem.t_map.colPivHouseholderQr().solve(delta);
  Eigen::VectorXd z = full.vk.transpose() * y;
  full.z = z;
  Eigen::VectorXd searched;
  std::string not_converged;
  RefineWithinMotionBound(
      options, filtered, full, &z, &searched, &not_converged);
  const double after =
      searched.size() == delta.size() ? ExactRms(problem, searched) : kInf;
  summary->exact_search_after_rms_um = after;
  if (after < (1.0 - kSearchGainShare) * before - kSearchGainMinUm) {
    summary->exact_search =
        "taken: the exact model at the linearisation point predicts " +
        PredictionText(after) + " against " + PredictionText(before);
    return searched;
  }
  summary->exact_search = "kept the regularised answer: the search predicts " +
                          PredictionText(after) + " against " +
                          PredictionText(before) + ", not lower by " +
                          FormatUm(100.0 * kSearchGainShare) + " % and " +
                          FormatUm(kSearchGainMinUm) + " um";
  return delta;
}

}  // namespace correction_internal
}  // namespace gearloop
