// The prediction band of the correction (prediction_band.h).
#include "engine/correction/prediction_band.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "engine/correction/machine_state.h"

namespace gearloop {
namespace correction_internal {

double BandNoiseSigma(const CorrectionProblem& problem,
                      const CorrectionSummary& summary,
                      bool* stated) {
  *stated =
      problem.probe_noise_um > 0.0 && std::isnan(problem.stated_probe_noise_um);
  if (problem.probe_noise_um > 0.0) return problem.probe_noise_um;
  const double n = static_cast<double>(summary.num_points_used);
  if (summary.machine_state_estimated) {
    const double dof = summary.machine_state_dof;
    if (n > dof + 1.0)
      return summary.machine_state_misfit_rms_um * std::sqrt(n / (n - dof));
  }
  const double dof = summary.effective_dof;
  if (n > dof + 1.0)
    return summary.linear_residual_rms_um * std::sqrt(n / (n - dof));
  return 0.0;
}

namespace {

// The mean square over every point the next part has: `measured2` (the mean
// square over the n measured points) and, at the points not `measured` with
// a target, r = flank_um(i) - t where the model grinds them (flank_um(i)
// finite); the total count in `*all`.
template <class Flank>
double MeanSquareOverAll(const CorrectionProblem& problem,
                         const std::vector<bool>& measured,
                         double measured2,
                         double n,
                         Flank flank_um,
                         double* all) {
  double others2 = 0.0;
  int others = 0;
  for (int i = 0; i < problem.num_points; ++i) {
    const double flank = measured[i] ? kNaN : flank_um(i);
    if (!std::isfinite(flank) || !std::isfinite(problem.target_um(i))) continue;
    const double r = flank - problem.target_um(i);
    others2 += r * r;
    ++others;
  }
  *all = n + others;
  return (measured2 * n + others2) / *all;
}

// The next part's mean square over the points it has (MeanSquareOverAll) and
// its sd; and, where the model grinds points the measurement lacks, the same
// without them (the reading in which they stay unground: a point the
// measurement lacks is most often one the machine did not reach, and the
// model that grinds it is the one that did not foresee that), NaN otherwise.
// Outliers count in both: the part has them.
struct MeanSquareReadings {
  double all2 = 0.0, sd2 = 0.0;
  double unground2 = kNaN, unground_sd2 = kNaN;
};

template <class Flank>
MeanSquareReadings ReadingsOverAll(const CorrectionProblem& problem,
                                   const std::vector<bool>& measured,
                                   double measured2,
                                   double n,
                                   double sd2_times_n,
                                   Flank flank_um) {
  MeanSquareReadings readings;
  double all = 0.0;
  readings.all2 =
      MeanSquareOverAll(problem, measured, measured2, n, flank_um, &all);
  readings.sd2 = sd2_times_n / all;
  if (problem.measured_um.size() != problem.num_points) return readings;
  std::vector<bool> skipped = measured;
  for (int i = 0; i < problem.num_points; ++i)
    if (!std::isfinite(problem.measured_um(i))) skipped[i] = true;
  double with_measurement = 0.0;
  const double unground2 = MeanSquareOverAll(
      problem, skipped, measured2, n, flank_um, &with_measurement);
  if (with_measurement < all) {
    readings.unground2 = unground2;
    readings.unground_sd2 = sd2_times_n / with_measurement;
  }
  return readings;
}

// The next part's mean square true residual as the model at the commanded
// settings predicts it after the step (problem linearised at an estimated
// state): on the `predicted` points e + the change there (the state's
// prediction where the commanded model has no contact before or after), less
// `noise_bias2`; on the other points it grinds after the step, its flank
// (ReadingsOverAll; the sd of the mean square is `sd2_times_n` over the
// points counted). False when linearised at the commanded settings (nothing
// else to say).
bool CommandedEndPrediction(const CorrectionProblem& problem,
                            const CorrectionResult& result,
                            const std::vector<int>& predicted,
                            const std::vector<bool>& measured,
                            double noise_bias2,
                            double sd2_times_n,
                            MeanSquareReadings* readings) {
  if (!problem.AtEstimatedState() ||
      problem.commanded_status.size() !=
          static_cast<size_t>(problem.num_points))
    return false;
  ModelEvaluation after;
  const bool moved = !result.delta.isZero(0.0);
  if (moved)
    problem.model->Evaluate(
        problem.commanded_parameters + result.delta, false, &after);
  const Eigen::VectorXd& after_um =
      moved ? after.deviations_um : problem.commanded_deviations_um;
  const std::vector<PointStatus>& after_status =
      moved ? after.status : problem.commanded_status;
  double measured2 = 0.0;
  for (int i : predicted) {
    double r = result.predicted_residual_um(i);
    if (problem.commanded_status[i] == PointStatus::kOk &&
        after_status[i] == PointStatus::kOk)
      r = problem.error_um(i) + after_um(i) -
          problem.commanded_deviations_um(i);
    measured2 += r * r;
  }
  const double n = static_cast<double>(predicted.size());
  *readings = ReadingsOverAll(
      problem,
      measured,
      std::max(0.0, measured2 / n - noise_bias2),
      n,
      sd2_times_n,
      [&](int i) {
        return after_status[i] == PointStatus::kOk ? after_um(i) : kNaN;
      });
  return true;
}

// The bands of the next part's true rms at a mean noise variance
// `mean_variance` over the `predicted` points (prediction_band.h): the
// expected mean square and, for k = 1, 2, the low and high ends' squares.
struct TrueRmsBands {
  double expected2 = 0.0;
  double low2[2] = {0.0, 0.0};
  double high2[2] = {0.0, 0.0};
};

// Widens `bands` to reach over a reading of the next part's mean square
// `mean2` with sd `sd2`.
void ReachOver(double mean2, double sd2, TrueRmsBands* bands) {
  for (int k = 1; k <= 2; ++k) {
    bands->low2[k - 1] =
        std::min(bands->low2[k - 1], std::max(0.0, mean2 - k * sd2));
    bands->high2[k - 1] = std::max(bands->high2[k - 1], mean2 + k * sd2);
  }
}

TrueRmsBands BandsAtNoise(const CorrectionProblem& problem,
                          const CorrectionResult& result,
                          const std::vector<int>& predicted,
                          const ModelEvaluation* after_step,
                          double mean_variance) {
  const CorrectionSummary& summary = result.summary;
  TrueRmsBands bands;
  const double n = static_cast<double>(predicted.size());
  const double kept = summary.safe_step_checked
                          ? summary.motion_scale * summary.step_fraction
                          : 1.0;
  const double dof = std::min(kept * summary.effective_dof, n);
  const double pred2 = summary.residual_rms_um * summary.residual_rms_um;
  const double expected2 =
      std::max(0.0, pred2 - mean_variance * (1.0 - 2.0 * dof / n));
  double change2 = 0.0;
  for (int i : predicted)
    if (std::isfinite(result.predicted_change_um(i)))
      change2 += result.predicted_change_um(i) * result.predicted_change_um(i);
  change2 /= n;
  const double model2 = kModelShareOfChange * kModelShareOfChange * change2;
  const double sd2 = std::sqrt(4.0 * (mean_variance / n + model2) * pred2 +
                               2.0 * mean_variance * mean_variance / n);
  // The points the model grinds after the step that the prediction has no
  // measurement of (unmeasured, outliers) count at the model's flank: the
  // true part has them. Those the measurement lacks may stay unground: the
  // band reaches over that reading too.
  std::vector<bool> measured(problem.num_points, false);
  for (int i : predicted) measured[i] = true;
  // The model's flank after the step: d0 + the change where it grinds the
  // point before the step too, its evaluation after the step where only
  // there (a row the part lacks, ground again).
  const auto flank_after = [&](int i) {
    if (std::isfinite(result.predicted_change_um(i)))
      return result.predicted_change_um(i) + problem.d0()(i);
    if (after_step != nullptr &&
        problem.evaluation.status[i] != PointStatus::kOk &&
        after_step->status[i] == PointStatus::kOk)
      return after_step->deviations_um(i);
    return kNaN;
  };
  const MeanSquareReadings readings =
      ReadingsOverAll(problem, measured, expected2, n, sd2 * n, flank_after);
  bands.expected2 = readings.all2;
  for (int k = 1; k <= 2; ++k) {
    bands.low2[k - 1] = std::max(0.0, readings.all2 - k * readings.sd2);
    bands.high2[k - 1] = readings.all2 + k * readings.sd2;
  }
  if (std::isfinite(readings.unground2))
    ReachOver(readings.unground2, readings.unground_sd2, &bands);
  // Linearised at an estimated state: the same step on the model at the
  // commanded settings, the other end of what the machine may be running,
  // predicts the part too; the band reaches over both.
  MeanSquareReadings commanded;
  if (CommandedEndPrediction(problem,
                             result,
                             predicted,
                             measured,
                             mean_variance * (1.0 - 2.0 * dof / n),
                             sd2 * n,
                             &commanded)) {
    ReachOver(commanded.all2, commanded.sd2, &bands);
    if (std::isfinite(commanded.unground2))
      ReachOver(commanded.unground2, commanded.unground_sd2, &bands);
  }
  return bands;
}

}  // namespace

void EstimatePredictionBand(const CorrectionProblem& problem,
                            CorrectionResult* result) {
  CorrectionSummary& summary = result->summary;
  PredictionBand& band = summary.prediction_band;
  band.noise_sigma_um = BandNoiseSigma(problem, summary, &band.noise_stated);
  band.stated_noise_um = problem.stated_probe_noise_um;
  const int points = problem.num_points;
  result->predicted_residual_sigma_um = Eigen::VectorXd::Constant(points, kNaN);
  std::vector<int> predicted;
  for (int i : PredictedPoints(problem))
    if (std::isfinite(result->predicted_residual_um(i))) predicted.push_back(i);
  double mean_variance = 0.0;
  for (int i : predicted) {
    // A stated sigma (or the scatter that replaced it) is one tooth's; an
    // estimated one is already that of the mean the solver saw.
    const double share =
        problem.probe_noise_um > 0.0 ? problem.noise_share(i) : 1.0;
    const double sigma_i = band.noise_sigma_um * std::sqrt(share);
    result->predicted_residual_sigma_um(i) = sigma_i;
    mean_variance += sigma_i * sigma_i;
  }
  if (predicted.empty()) return;
  mean_variance /= static_cast<double>(predicted.size());
  // Where the model has points without a contact at the linearisation point,
  // the step may grind them: the model after the step (the exact
  // prediction's evaluation, from the correction's memo).
  ModelEvaluation after_step;
  const ModelEvaluation* after = nullptr;
  const bool some_unground = std::any_of(
      problem.evaluation.status.begin(),
      problem.evaluation.status.end(),
      [](PointStatus status) { return status != PointStatus::kOk; });
  if (some_unground && problem.model != nullptr &&
      problem.evaluation.status.size() ==
          static_cast<size_t>(problem.num_points) &&
      result->parameters.size() == problem.num_parameters) {
    problem.model->Evaluate(result->parameters, false, &after_step);
    if (after_step.status.size() == static_cast<size_t>(problem.num_points))
      after = &after_step;
  }
  TrueRmsBands bands =
      BandsAtNoise(problem, *result, predicted, after, mean_variance);
  // A noise estimated from a misfit (the state's, or the correction's own
  // where no state was estimated) above what a probe scatters
  // (kStateNoiseCeilingUm) may be flank the model cannot explain, which the
  // next part keeps (seed 11, scenario 138: 3.9 um left, the part stays at
  // 4.02 um; held-out seed 304 with every hidden error x3, scenario 33: half
  // the grid unground and the rest at +-200 um, no change answered, a misfit
  // of 98 um read as noise made the expected true rms 0.72 um), or
  // measurement the part does not have, outliers the test kept (seed 22,
  // scenario 70: a part of 1.13 um measured at 5.49): the bands reach over
  // both readings, the excess as noise and as flank, and the expected value
  // is the second's, the part no better than the model explains it.
  // Robustness benchmark, quick count, 80 tuned seeds: of the 379 rounds
  // whose expected value this changes, achieved / expected median 2.40 ->
  // 1.06 and 90th percentile 2 460 -> 1.38, inside the 2-sigma band 229 ->
  // 365; 2-sigma coverage of all rounds 98.64 -> 98.92 % (BENCHMARKS.md,
  // "The expected value over a misfit").
  const double ceiling_um = kStateNoiseCeilingUm;
  if (!(problem.probe_noise_um > 0.0) && band.noise_sigma_um > ceiling_um) {
    const double share = ceiling_um / band.noise_sigma_um;
    const TrueRmsBands as_flank = BandsAtNoise(
        problem, *result, predicted, after, mean_variance * share * share);
    bands.expected2 = as_flank.expected2;
    band.misfit_read_as_flank = true;
    band.noise_read_as_probe_um = ceiling_um;
    for (int k = 0; k < 2; ++k) {
      bands.low2[k] = std::min(bands.low2[k], as_flank.low2[k]);
      bands.high2[k] = std::max(bands.high2[k], as_flank.high2[k]);
    }
  }
  band.expected_true_rms_um = std::sqrt(bands.expected2);
  for (int k = 0; k < 2; ++k) {
    band.true_rms_low_um[k] = std::sqrt(bands.low2[k]);
    band.true_rms_high_um[k] = std::sqrt(bands.high2[k]);
  }
}

}  // namespace correction_internal
}  // namespace gearloop
