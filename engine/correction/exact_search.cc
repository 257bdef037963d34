// The exact-model search (exact_search.h).
#include "engine/correction/exact_search.h"

#include <Eigen/LU>
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
// The search runs only where the regularised answer's linear and exact
// predictions are above kSearchNoiseShare x the noise + kSearchNoiseMarginUm:
// closer to the noise there is little to find. Robustness benchmark, five
// seeds (BENCHMARKS.md, "The search nearer the noise"): 0.1 um and 2 x the
// noise left parts of 0.15-0.5 um where the true state reaches 0.001-0.07 um
// (seed 7, 112: a 2 um flank twist, 0.204 um final, the search's answer
// 0.111 against 0.201 um predicted, made 0.063 um); a 5 % bar instead of 20 %
// took a wide search's 1.34 against 1.48 um that moved 100 x the regularised
// answer and made 2.54 -> 14.2 um (seed 4, 196).
constexpr double kSearchGainShare = 0.2;
constexpr double kSearchGainMinUm = 0.02;
constexpr double kSearchNoiseShare = 1.0;
constexpr double kSearchNoiseMarginUm = 0.05;
// The search's light damping of each direction, a share of its singular value
// (the penalty |mu z|^2 of the QPs), never below that share of the weak-flank
// floor: keeps them definite without holding a direction back.
constexpr double kSearchDampingShare = 1e-3;
// The wide search continues the search's end point over the directions down to
// kWideSearchShare x the weak-flank floor as well (a wheel cone change of tens
// of mrad that makes a lead crowning on a narrow gear moves the flank by ~1e-5
// to 1e-4 um per unit of correction size at the linearisation point, just
// under the floor), for at most kWideSearchPasses passes and only while each
// pass lowers the cost by kWideSearchStopShare of it (most wide searches gain
// almost nothing and stop after one pass; those that matter fall by tens of
// % per pass). Robustness benchmark (BENCHMARKS.md, "The wide search"). Not
// where orders 4-6 are free: there the directions under the floor are many
// (17 of 33 on seed 1's 30, a 13 um root relief) and a wide answer predicted
// 0.93 um made 1.17 -> 4.75 um.
constexpr double kWideSearchShare = 1e-6;
constexpr int kWideSearchPasses = 8;
constexpr double kWideSearchStopShare = 1e-2;

// The exact rms at the linearisation point over the used points of the model
// `eval` (infinity when a used point is lost).
double ExactRmsOf(const CorrectionProblem& problem,
                  const ModelEvaluation& eval) {
  double sum = 0.0;
  for (int i : problem.used) {
    if (eval.status[i] != PointStatus::kOk) return kInf;
    const double r =
        problem.error_um(i) + eval.deviations_um(i) - problem.d0()(i);
    sum += r * r;
  }
  return problem.used.empty() ? 0.0 : std::sqrt(sum / problem.used.size());
}
// The sequential QPs of the search (RefineWithinMotionBound) over the first
// `directions` columns of the solve's V, each lightly damped
// (kSearchDampingShare of its singular value, never below that share of the
// weak-flank floor), fitting the noise-filtered error: e + (sum_i (1 - f_i)
// beta_i u_i) / sqrt(w) (the measured part of each direction shrunk as the
// filter did, what no direction reaches kept whole).
class SubspaceSearch {
 public:
  SubspaceSearch(const CorrectionOptions& options,
                 const CorrectionProblem& problem,
                 const LinearSolve& ls)
      : options_(options),
        problem_(problem),
        ls_(ls),
        filtered_(problem),
        t_lu_(problem.t_free) {
    Eigen::VectorXd removed = Eigen::VectorXd::Zero(ls.svd.u.rows());
    for (int i = 0; i < ls.svd.rank; ++i) {
      const double f = i < ls.filter.size() ? ls.filter(i) : 0.0;
      removed += (1.0 - f) * ls.beta(i) * ls.svd.u.col(i);
    }
    for (size_t r = 0; r < problem.used.size(); ++r) {
      const int i = problem.used[r];
      filtered_.error_um(i) += removed(r) / std::sqrt(problem.weights(i));
    }
  }

  // From the change `start`, at most `max_passes` passes, the last one that
  // lowers the cost by less than `stop_share` of it; the end point in
  // `searched`, its exact rms over the used points returned (infinity: a
  // used point lost).
  // Along the first `directions` of `svd` (the solve's, or the same A's
  // resolved further for the wide search).
  double Run(const Svd& svd,
             int directions,
             int max_passes,
             double stop_share,
             const Eigen::VectorXd& start,
             Eigen::VectorXd* searched) const {
    KeptSubspace subspace;
    subspace.k = directions;
    subspace.sigma1 = svd.sigma(0);
    subspace.ridge = 1e-12 * subspace.sigma1 * subspace.sigma1;
    subspace.vk = svd.v.leftCols(directions);
    subspace.tv = RowRunsTimes(problem_.t_map, subspace.vk);
    subspace.mu = (kSearchDampingShare * svd.sigma.head(directions))
                      .cwiseMax(kSearchDampingShare * ls_.rank_threshold);
    Eigen::VectorXd z = subspace.vk.transpose() * Coordinates(start);
    subspace.z = z;
    CorrectionOptions passes = options_;
    passes.max_num_iterations = max_passes;
    std::string not_converged;
    ModelEvaluation at_end;
    RefineWithinMotionBound(passes,
                            filtered_,
                            subspace,
                            &z,
                            searched,
                            &not_converged,
                            stop_share,
                            &at_end);
    return searched->size() == start.size() ? ExactRmsOf(problem_, at_end)
                                            : kInf;
  }

 private:
  // A change in the free coordinates: T_free^-1 change(free) (T maps the free
  // coordinates onto the free coefficients only, T_free is its square part).
  Eigen::VectorXd Coordinates(const Eigen::VectorXd& change) const {
    Eigen::VectorXd free_change(problem_.NumFree());
    for (int c = 0; c < problem_.NumFree(); ++c)
      free_change(c) = change(problem_.free[c]);
    return t_lu_.solve(free_change);
  }

  const CorrectionOptions& options_;
  const CorrectionProblem& problem_;
  const LinearSolve& ls_;
  CorrectionProblem filtered_;
  Eigen::PartialPivLU<Eigen::MatrixXd> t_lu_;
};

// The wide search: from the search's end point (`delta` where it lost a
// point) along the solve's directions down to kWideSearchShare of the weak-
// flank floor (with the per-direction filter, the solve's rank threshold), at
// most kWideSearchPasses passes; not where orders above the cubic are free.
// Those directions may lie below what the solve's SVD resolves
// (regularisation.h, ComputeSvd): there along the same A's Jacobi SVD. Where
// it predicts lower than *after, its answer replaces *searched, *after and
// *subspace_text.
void SearchWider(const CorrectionOptions& options,
                 const CorrectionProblem& problem,
                 const LinearSolve& ls,
                 const SubspaceSearch& search,
                 const Eigen::VectorXd& delta,
                 double* after,
                 Eigen::VectorXd* searched,
                 std::string* subspace_text) {
  if (OpensOrdersAboveCubic(options, problem.blocks)) return;
  const double floor_sigma = kWideSearchShare * ls.rank_threshold;
  Svd resolved;
  const Svd* svd = &ls.svd;
  if (ls.svd.resolved_down_to > floor_sigma) {
    resolved =
        ResolvedSvdOfWeightedSystem(problem, problem.used, ls.rank_threshold);
    svd = &resolved;
  }
  const int rank = ls.svd.rank;
  int wide = rank;
  while (wide < svd->sigma.size() && svd->sigma(wide) > 0.0 &&
         svd->sigma(wide) >= floor_sigma)
    ++wide;
  if (wide == rank) return;
  Eigen::VectorXd searched_wide;
  const double after_wide =
      search.Run(*svd,
                 wide,
                 std::min(kWideSearchPasses, options.max_num_iterations),
                 kWideSearchStopShare,
                 std::isfinite(*after) ? *searched : delta,
                 &searched_wide);
  if (!(after_wide < *after)) return;
  *after = after_wide;
  *searched = searched_wide;
  *subspace_text = std::to_string(wide) + " directions, " +
                   std::to_string(wide - rank) +
                   " of them under the weak-flank floor";
}

// An exact prediction for the summary: infinity is a lost point.
std::string PredictionText(double um) {
  return std::isfinite(um) ? FormatUm(um) + " um" : "inf (a used point lost)";
}

}  // namespace

double ExactRms(const CorrectionProblem& problem,
                const Eigen::VectorXd& delta) {
  ModelEvaluation eval;
  problem.model->Evaluate(problem.parameters + delta, false, &eval);
  return ExactRmsOf(problem, eval);
}

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
      kSearchNoiseShare * problem.signal_noise_um + kSearchNoiseMarginUm;
  const double linear_rms_um = Rms(linear, problem.used);
  if (linear_rms_um <= threshold) {
    summary->exact_search = "not run: the linear answer leaves " +
                            FormatUm(linear_rms_um) + " um, near the noise";
    return delta;
  }
  const double before = ExactRms(problem, delta);
  summary->exact_search_before_rms_um = before;
  if (std::isfinite(before) && before <= threshold) {
    summary->exact_search = "not run: the exact answer leaves " +
                            FormatUm(before) + " um, near the noise";
    return delta;
  }
  const int rank = ls.svd.rank;
  const SubspaceSearch search(options, problem, ls);
  Eigen::VectorXd searched;
  double after = search.Run(ls.svd,
                            rank,
                            options.max_num_iterations,
                            kBoundedStopRelative,
                            delta,
                            &searched);
  std::string subspace_text = std::to_string(rank) + " directions";
  SearchWider(
      options, problem, ls, search, delta, &after, &searched, &subspace_text);
  summary->exact_search_after_rms_um = after;
  if (after < (1.0 - kSearchGainShare) * before - kSearchGainMinUm) {
    summary->exact_search =
        "taken: the exact model at the linearisation point predicts " +
        PredictionText(after) + " against " + PredictionText(before) + " (" +
        subspace_text + ")";
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
