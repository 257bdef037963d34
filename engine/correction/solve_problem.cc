// One prepared correction problem solved (solve_problem.h).
#include "engine/correction/solve_problem.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <utility>

#include "engine/core/units.h"
#include "engine/correction/baseline_solvers.h"
#include "engine/correction/exact_search.h"
#include "engine/correction/machine_state.h"
#include "engine/correction/outliers.h"
#include "engine/correction/prediction_band.h"
#include "engine/correction/refinement.h"
#include "engine/correction/regularisation.h"
#include "engine/correction/rework_qp.h"
#include "engine/correction/safe_step.h"

namespace gearloop {
namespace correction_internal {
namespace {

// The rms over the used points of the error the linear model predicts after
// delta, e + S delta.
double LinearPredictionRms(const CorrectionProblem& problem,
                           const Eigen::VectorXd& delta) {
  const Eigen::VectorXd r = problem.error_um + problem.jacobian_um * delta;
  return Rms(r, problem.used);
}

// Rank, spectrum, best reachable and initial error of the linear solve on the
// final rows (every solver reports them).
void ReportLinearSolve(const CorrectionProblem& problem,
                       const LinearSolve& ls,
                       CorrectionSummary* summary) {
  summary->singular_values = ls.svd.sigma;
  summary->rank = ls.svd.rank;
  summary->condition_number =
      ls.svd.rank > 0 ? ls.svd.sigma(0) / ls.svd.sigma(ls.svd.rank - 1) : kInf;
  Eigen::VectorXd best_um = Eigen::VectorXd::Zero(problem.num_points);
  for (size_t r = 0; r < problem.used.size(); ++r) {
    best_um(problem.used[r]) =
        ls.best(r) / std::sqrt(problem.weights(problem.used[r]));
  }
  summary->best_reachable_rms_um = Rms(best_um, problem.used);
  summary->initial_rms_um = Rms(problem.error_um, problem.used);
  summary->initial_max_um = MaxAbs(problem.error_um, problem.used);
}

// Steps 3-4 of the regularised solver in the kept subspace of `ls`: the
// Tikhonov answer (through the QP with bounds or in rework mode), then the
// rework passes or the exact-model refinement.
Eigen::VectorXd SolveRegularised(const CorrectionOptions& options,
                                 const CorrectionProblem& problem,
                                 const LinearSolve& ls,
                                 CorrectionSummary* summary,
                                 std::string* not_converged) {
  summary->rule = problem.rule;
  summary->signal_filter_used = problem.signal_noise_um > 0.0;
  summary->regularisation_level = ls.lambda;
  summary->effective_dof = ls.dof;
  summary->truncation_rank = ls.k;
  const KeptSubspace subspace = KeepSubspace(ls, problem.t_map);
  const bool rework = problem.mode == CorrectionMode::kRework;
  Eigen::VectorXd z = subspace.z;
  const bool beyond_motion_bound =
      subspace.k > 0 && !WithinMotionBound(problem, subspace, z);
  if (subspace.k > 0 && (rework || problem.has_bounds || beyond_motion_bound)) {
    Eigen::VectorXd z_new;
    if (SolveLinearisedQp(problem,
                          subspace,
                          problem.jacobian_um,
                          Eigen::VectorXd::Zero(problem.num_points),
                          Eigen::VectorXd::Zero(subspace.k),
                          &z_new)) {
      z = z_new;
    } else {
      *not_converged = "the constrained linear problem failed";
    }
  }
  Eigen::VectorXd delta = subspace.tv * z;
  // A change the measurement could not even see is not worth a move; nor a
  // correction along fewer than kNoEffectiveDirectionDof effective directions
  // (a part measured as noise alone: the filter's 3e-8 directions move the
  // flank by 1e-11 um, and whether the safe step finds that better than none
  // was the contacts' last bits, and with it the answer's status and the
  // order choice). The state fit keeps its own: its test reads its figures.
  const bool negligible =
      !rework &&
      ((!problem.machine_state_fit && ls.dof < kNoEffectiveDirectionDof) ||
       (problem.signal_noise_um > 0.0 &&
        Rms(problem.jacobian_um * delta, problem.used) <
            kNegligibleChangeShare * problem.signal_noise_um));
  if (negligible) {
    delta.setZero();
    summary->effective_dof = 0.0;
  }
  summary->linear_residual_rms_um = LinearPredictionRms(problem, delta);
  if (subspace.k == 0 || negligible) {
    // Nothing above the noise: no change.
  } else if (rework) {
    summary->iterations =
        RunReworkPasses(options, problem, subspace, &z, &delta, not_converged);
  } else if ((beyond_motion_bound || options.signal_filter) &&
             !problem.has_bounds && options.max_num_iterations > 0) {
    summary->iterations = RefineWithinMotionBound(
        options, problem, subspace, &z, &delta, not_converged);
  } else if (options.max_num_iterations > 0) {
    RefineOnExactModel(
        options, problem, subspace, z, &delta, summary, not_converged);
  }
  return delta;
}

// The regularised answer, then the exact search from it; `*regularised` gets
// the regularised answer where the search replaced it (empty otherwise).
Eigen::VectorXd SolveAndSearch(const CorrectionOptions& options,
                               const CorrectionProblem& problem,
                               const LinearSolve& ls,
                               CorrectionSummary* summary,
                               std::string* not_converged,
                               Eigen::VectorXd* regularised) {
  Eigen::VectorXd delta =
      SolveRegularised(options, problem, ls, summary, not_converged);
  *regularised = delta;
  delta = SearchOnExactModel(options, problem, ls, delta, summary);
  if (delta == *regularised) regularised->resize(0);
  return delta;
}

// Whether every grid point is measured and reached by the model at the
// linearisation point and at the commanded settings
// (HoldTheBoundWhereTheContactsGo asks it: where the part lacks points, the
// model's contacts there are unmeasured, and an answer that moves the contacts
// far is left to the safe step's shortening).
bool EveryPointMeasuredAndReached(const CorrectionProblem& problem) {
  if (!problem.measured_um.allFinite()) return false;
  const bool has_commanded =
      static_cast<int>(problem.commanded_status.size()) == problem.num_points;
  for (int i = 0; i < problem.num_points; ++i) {
    if (problem.evaluation.status[i] != PointStatus::kOk) return false;
    if (has_commanded && problem.commanded_status[i] != PointStatus::kOk)
      return false;
  }
  return true;
}

// The solve's motion bound held where the answer moves the next part's
// contacts as well: where an answer with orders 4-6 moves an axis beyond its
// bound at roll angles outside the roll range that its own contacts reach
// (MotionRowsWhereTheNextContactsGo), those angles join the motion rows and
// the problem is solved again, at most kContactRangeSolves times, where every
// grid point is measured and reached (EveryPointMeasuredAndReached: asked
// where the part lacked points as well, 3 rounds of 39 000 on 65 seeds came
// out worse, each regrinding rows the part lacked, and one more on the
// common points where the commanded settings did not reach 9 measured
// points), and only where the answer is predicted below the bar the order
// choice sets (options.orders_above_cubic_bar_um: an every-order answer no
// lower than the cubic answer's prediction less the margin is not taken
// anyway; solving those again cost 0.7-1 ms per correction on average, seed
// 2026, one thread); summary->motion_bound_beyond_roll_range says where and
// how often. The safe step would otherwise only shorten such an answer:
// robustness benchmark, seed 2026, scenario 167 (z 89, a root relief and an
// 18 um lead crowning, sigma 0.21 um): the every-order answer predicted 0.36
// um, its contacts ran past the roll range where orders 4-6 grow, and half of
// it (0.63 um) lost to the cubic answer in every round; the loop ended at 0.75
// um where the true state reaches 0.22. Now orders 4-6 answer in round 1 and
// the loop ends at 0.34 um. Full reference, seeds 2026, 7, 1, 4, 11
// (BENCHMARKS.md, "The motion bound where the next contacts go"): within 1.2 x
// best + noise 954 -> 965 of 1000, rounds worse unchanged (1 of 3000); quick
// count, 65 seeds: within 12 852 -> 12 874 of 13 000, the same 27 worse rounds
// of 39 000.
constexpr int kContactRangeSolves = 2;
Eigen::VectorXd HoldTheBoundWhereTheContactsGo(const CorrectionOptions& options,
                                               CorrectionProblem* problem,
                                               const LinearSolve& ls,
                                               Eigen::VectorXd delta,
                                               CorrectionSummary* summary,
                                               std::string* not_converged,
                                               Eigen::VectorXd* regularised) {
  if (!EveryPointMeasuredAndReached(*problem)) return delta;
  const double bar_um = options.orders_above_cubic_bar_um;
  double lo_rad = problem->roll_min_rad, hi_rad = problem->roll_max_rad;
  int solves = 0;
  for (; solves < kContactRangeSolves; ++solves) {
    // Asked of the change the safe step will check (scaled into the bound
    // over the roll range): the same model evaluations, kept in the memo.
    SafeStepOutcome scaled;
    const Eigen::VectorXd step =
        BoundAxisMotion(options, *problem, delta, &scaled);
    double lo = kNaN, hi = kNaN;
    const Eigen::MatrixXd rows =
        MotionRowsWhereTheNextContactsGo(options, *problem, step, &lo, &hi);
    if (rows.rows() == 0) break;
    // Solving again adds a bound: an answer predicted no lower than the bar
    // the order choice set (the cubic answer's prediction less the margin)
    // will not win by it.
    if (std::isfinite(bar_um) && !(ExactRms(*problem, step) < bar_um)) break;
    lo_rad = std::min(lo_rad, lo);
    hi_rad = std::max(hi_rad, hi);
    Eigen::MatrixXd joined(problem->motion_rows.rows() + rows.rows(),
                           problem->motion_rows.cols());
    joined << problem->motion_rows, rows;
    problem->motion_rows = std::move(joined);
    not_converged->clear();
    delta = SolveAndSearch(
        options, *problem, ls, summary, not_converged, regularised);
  }
  if (solves > 0) {
    char text[200];
    std::snprintf(text,
                  sizeof(text),
                  "held over %.2f..%.2f deg of roll, where the answer moved "
                  "the next part's contacts beyond the roll range (solved "
                  "again %d time(s))",
                  lo_rad * kDegPerRad,
                  hi_rad * kDegPerRad,
                  solves);
    summary->motion_bound_beyond_roll_range = text;
  }
  return delta;
}

// The exact prediction at the new parameters: change and residual per point,
// their rms and max over the used points, the correction size, and the status.
// `at_new_parameters`: the model there when the caller has it (the safe
// step's kept fraction, or the linearisation point for no change), else null.
void PredictExactly(const CorrectionOptions& options,
                    const CorrectionProblem& problem,
                    const Eigen::VectorXd& delta,
                    std::string not_converged,
                    const ModelEvaluation* at_new_parameters,
                    CorrectionResult* result) {
  CorrectionSummary& summary = result->summary;
  const int n = problem.num_points;
  result->delta = delta;
  result->parameters = problem.parameters + delta;
  ModelEvaluation evaluated;
  if (at_new_parameters == nullptr)
    problem.model->Evaluate(result->parameters, false, &evaluated);
  const ModelEvaluation& eval1 =
      at_new_parameters != nullptr ? *at_new_parameters : evaluated;
  result->predicted_change_um = Eigen::VectorXd::Constant(n, kNaN);
  result->predicted_residual_um = Eigen::VectorXd::Constant(n, kNaN);
  int lost = 0;
  summary.max_added_material_um = 0.0;
  for (int i = 0; i < n; ++i) {
    if (problem.evaluation.status[i] != PointStatus::kOk) continue;
    if (eval1.status[i] != PointStatus::kOk) {
      ++lost;
      continue;
    }
    result->predicted_change_um(i) = eval1.deviations_um(i) - problem.d0()(i);
    summary.max_added_material_um =
        std::max(summary.max_added_material_um, result->predicted_change_um(i));
    if (std::isfinite(problem.error_um(i))) {
      result->predicted_residual_um(i) =
          problem.error_um(i) + result->predicted_change_um(i);
    }
  }
  // With no change the part stays as measured, also where the model has no
  // contact (the safe step keeps the settings for those points).
  if (delta.isZero(0.0)) {
    for (int i : problem.measured_not_reached) {
      result->predicted_change_um(i) = 0.0;
      result->predicted_residual_um(i) = problem.error_um(i);
    }
  }
  std::vector<int> predicted_used;
  for (int i : PredictedPoints(problem))
    if (std::isfinite(result->predicted_residual_um(i)))
      predicted_used.push_back(i);
  summary.residual_rms_um = Rms(result->predicted_residual_um, predicted_used);
  summary.residual_max_um =
      MaxAbs(result->predicted_residual_um, predicted_used);
  summary.correction_size = CorrectionSize(problem.blocks,
                                           delta,
                                           problem.roll_min_rad,
                                           problem.roll_max_rad,
                                           options.block_scales,
                                           &summary.block_sizes);
  if (lost > 0 && not_converged.empty()) {
    not_converged = std::to_string(lost) +
                    " grid point(s) are not reached by the corrected settings";
  }
  if (problem.mode == CorrectionMode::kRework &&
      options.solver == CorrectionSolver::kRegularised &&
      summary.max_added_material_um > options.rework_tolerance_um &&
      not_converged.empty()) {
    not_converged = "rework: the correction still adds material at some point";
  }
  summary.status = not_converged.empty() ? CorrectionStatus::kConverged
                                         : CorrectionStatus::kNotConverged;
  summary.message = not_converged;
}

// The safe step of the regularised solver (safe_step.h): the motion bound,
// then the largest fraction of the change whose exact prediction at the
// linearisation point (the estimated machine state, or the commanded
// parameters) is better than keeping the current settings.
Eigen::VectorXd MakeStepSafe(const CorrectionOptions& options,
                             const CorrectionProblem& problem,
                             const Eigen::VectorXd& delta,
                             CorrectionSummary* summary,
                             std::string* no_safe_improvement,
                             SafeStepOutcome* outcome) {
  Eigen::VectorXd step = BoundAxisMotion(options, problem, delta, outcome);
  if (delta.isZero(0.0) && summary->truncation_rank > 0) {
    // Directions there were, but nothing above the noise along them: no
    // change asked for, nothing to check (with no direction at all, rank 0,
    // the check below says that no fraction makes a better part).
    outcome->current_rms_um = CurrentPartRms(problem);
    outcome->predicted_rms_um = outcome->current_rms_um;
  } else {
    step = ChooseSafeStep(options, problem, step, outcome);
    DropNegligibleStep(problem, &step, outcome);
  }
  summary->safe_step_checked = true;
  summary->motion_scale = outcome->motion_scale;
  summary->step_fraction = outcome->step_fraction;
  summary->safe_step_current_rms_um = outcome->current_rms_um;
  summary->safe_step_predicted_rms_um = outcome->predicted_rms_um;
  summary->safe_step_state_spread_um = outcome->state_spread_um;
  summary->safe_step_wheel_parabola = outcome->wheel_parabola;
  const bool part_kept = outcome->improved && outcome->step_fraction > 0.0 &&
                         outcome->step_fraction < 1.0;
  summary->safe_step_shortened = part_kept ? outcome->shortened : "";
  if (!outcome->improved) *no_safe_improvement = outcome->message;
  return step;
}

// The exact search's answer refused by the safe step (no fraction of it is
// predicted better than the current part): the regularised answer it replaced
// goes through the safe step instead and, where a fraction of it is safe, is
// answered; the search's outcome says so. A search answer rests on the exact
// model's curvature at the linearisation point, and where none of it is safe
// the regularised answer may still be: robustness benchmark, seed 47,
// scenario 113 (z 144, a 3.9 um tip relief, the root rows not measured): the
// searched answer was refused in rounds 1 and 2 and the part stayed at
// 51.0 um; the regularised answer, predicted 1.01 um, made 0.76 um and the
// loop ended at 0.146 um. Quick count, 50 seeds x 200 scenarios (BENCHMARKS.md,
// "The regularised answer where the search's is refused"): rounds worse
// unchanged (18 of 30 000), within 1.2 x best + noise 9888 -> 9891 of 10 000;
// 10 final parts better by more than 5 %, 4 worse.
// Where it is, `*delta` becomes its safe step; otherwise the search's refusal
// stands and `*delta`, `*summary`, `*no_safe_improvement` and `*outcome` are
// left as they are.
void TakeRegularisedAnswerWhereTheSearchsIsRefused(
    const CorrectionOptions& options,
    const CorrectionProblem& problem,
    const Eigen::VectorXd& regularised,
    Eigen::VectorXd* delta,
    CorrectionSummary* summary,
    std::string* no_safe_improvement,
    SafeStepOutcome* outcome) {
  CorrectionSummary regularised_summary = *summary;
  std::string regularised_refusal;
  SafeStepOutcome regularised_outcome;
  const Eigen::VectorXd step = MakeStepSafe(options,
                                            problem,
                                            regularised,
                                            &regularised_summary,
                                            &regularised_refusal,
                                            &regularised_outcome);
  if (!regularised_outcome.improved) return;
  const std::string taken = "taken: ";
  std::string searched = summary->exact_search;
  if (searched.rfind(taken, 0) == 0) searched.erase(0, taken.size());
  *summary = std::move(regularised_summary);
  summary->exact_search =
      "refused by the safe step (no fraction of the search's answer is "
      "predicted better than the current part; the regularised answer went "
      "through the safe step instead): " +
      searched;
  no_safe_improvement->clear();
  *outcome = std::move(regularised_outcome);
  *delta = step;
}

}  // namespace

CorrectionResult SolveProblem(const CorrectionOptions& options,
                              CorrectionProblem problem,
                              const CorrectionResult* state) {
  CorrectionResult result;
  result.linearised_at = problem.parameters;
  CorrectionSummary& summary = result.summary;
  summary.solver = options.solver;
  summary.mode = problem.mode;
  ReportProblem(problem, &summary);
  // The outlier test's first fit on the points it leaves has the SVD the
  // solve needs (the same A): made once.
  Svd svd_at_used;
  if (options.outlier_threshold > 0.0 &&
      options.solver == CorrectionSolver::kRegularised) {
    RemoveGrossOutliers(options, &problem, &summary, &svd_at_used);
  }
  const LinearSolve ls =
      SolveRegularisedLinear(options,
                             problem,
                             problem.used,
                             svd_at_used.u.rows() > 0 ? &svd_at_used : nullptr);
  ReportLinearSolve(problem, ls, &summary);
  std::string not_converged;
  Eigen::VectorXd delta;
  Eigen::VectorXd regularised;  // the regularised answer the search replaced
  switch (options.solver) {
    case CorrectionSolver::kRegularised:
      delta = SolveAndSearch(
          options, problem, ls, &summary, &not_converged, &regularised);
      if (options.safe_step)
        delta = HoldTheBoundWhereTheContactsGo(options,
                                               &problem,
                                               ls,
                                               std::move(delta),
                                               &summary,
                                               &not_converged,
                                               &regularised);
      break;
    case CorrectionSolver::kPlainLeastSquares:
      delta = SolvePlainLeastSquares(problem);
      summary.linear_residual_rms_um = LinearPredictionRms(problem, delta);
      break;
    case CorrectionSolver::kParticleSwarm:
      delta = SolveParticleSwarm(options, problem);
      summary.iterations = options.pso_generations;
      summary.linear_residual_rms_um = LinearPredictionRms(problem, delta);
      break;
  }
  std::string no_safe_improvement;
  SafeStepOutcome outcome;
  if (options.safe_step && options.solver == CorrectionSolver::kRegularised) {
    delta = MakeStepSafe(
        options, problem, delta, &summary, &no_safe_improvement, &outcome);
    if (!outcome.improved && regularised.size() > 0) {
      TakeRegularisedAnswerWhereTheSearchsIsRefused(options,
                                                    problem,
                                                    regularised,
                                                    &delta,
                                                    &summary,
                                                    &no_safe_improvement,
                                                    &outcome);
    }
  }
  const ModelEvaluation* at_new_parameters =
      outcome.has_evaluation ? &outcome.evaluation
      : delta.isZero(0.0)    ? &problem.evaluation
                             : nullptr;
  PredictExactly(
      options, problem, delta, not_converged, at_new_parameters, &result);
  if (!no_safe_improvement.empty()) {
    summary.status = CorrectionStatus::kNoSafeImprovement;
    summary.message = no_safe_improvement;
  }
  if (state != nullptr) ReportMachineState(*state, &summary);
  EstimatePredictionBand(problem, &result);
  return result;
}

}  // namespace correction_internal
}  // namespace gearloop
