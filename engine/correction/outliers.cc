// The gross-outlier test of the correction (outliers.h).
#include "engine/correction/outliers.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace gearloop {
namespace correction_internal {
namespace {

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const size_t n = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + n, v.end());
  double m = v[n];
  if (v.size() % 2 == 0) {
    m = 0.5 * (m + *std::max_element(v.begin(), v.begin() + n));
  }
  return m;
}

// Huber's tuning constant (95 % efficiency under Gaussian noise) and the
// reweighting passes of the robust fit.
constexpr double kHuberK = 1.345;
constexpr int kRobustPasses = 5;
// The Huber passes stop when no weight moves by more than this share of its
// full weight.
constexpr double kRobustWeightTolerance = 1e-3;

// The isolation of each grid point in `x` (NaN where unknown): the least
// distance of x_i from what its neighbours predict to first order along a line
// through it (row, column and both diagonals): the mean of the two
// neighbours on either side, or on one side the linear extrapolation 2 x_a -
// x_b from the next two. A smooth field's gradient is no isolation (a
// single neighbour's value would be). NaN unless at least kIsolationLines
// lines give a prediction: one line across a region the measurement mostly
// lacks is no corroboration (robustness benchmark, seed 11, scenario 111: a
// root-row point of a 12-tooth gear with both row neighbours missing, 11 um off
// the one diagonal's extrapolation and real).
constexpr int kIsolationLines = 2;

std::vector<double> Isolation(const Eigen::VectorXd& x, int rows, int columns) {
  const auto at = [&](int r, int c) {
    return r < 0 || c < 0 || r >= rows || c >= columns ? kNaN
                                                       : x(r * columns + c);
  };
  std::vector<double> isolation(x.size(), kNaN);
  for (int i = 0; i < x.size(); ++i) {
    if (!std::isfinite(x(i))) continue;
    const int row = i / columns, col = i % columns;
    double least = kInf;
    int lines = 0;
    for (const auto& [dr, dc] :
         {std::pair<int, int>{0, 1}, {1, 0}, {1, 1}, {1, -1}}) {
      const double predicted[3] = {
          0.5 * (at(row - dr, col - dc) + at(row + dr, col + dc)),
          2.0 * at(row - dr, col - dc) - at(row - 2 * dr, col - 2 * dc),
          2.0 * at(row + dr, col + dc) - at(row + 2 * dr, col + 2 * dc)};
      bool line = false;
      for (double p : predicted) {
        if (!std::isfinite(p)) continue;
        least = std::min(least, std::abs(x(i) - p));
        line = true;
      }
      lines += line ? 1 : 0;
    }
    if (lines >= kIsolationLines) isolation[i] = least;
  }
  return isolation;
}

// The limit beyond which a point of `isolation` (Isolation) stands alone:
// max(outlier_threshold x 1.4826 x the median isolation of the points where
// it is known, outlier_min_um); infinity where none is known.
double IsolationLimit(const CorrectionOptions& options,
                      const std::vector<double>& isolation) {
  std::vector<double> finite;
  for (double v : isolation)
    if (std::isfinite(v)) finite.push_back(v);
  if (finite.empty()) return kInf;
  std::nth_element(
      finite.begin(), finite.begin() + finite.size() / 2, finite.end());
  const double spread_um = 1.4826 * finite[finite.size() / 2];
  return std::max(options.outlier_threshold * spread_um,
                  options.outlier_min_um);
}

// Per point of `used`, whether it stands alone in the measured machine error
// m - d(commanded) (the points `used` only; ProbeSpikes' field): beyond
// IsolationLimit of what its neighbours predict (Isolation), or not known
// there. A probe's spike stands alone there; a point next to one does not,
// though the fit's residual there may be the larger: at a grid corner
// (leverage 0.9) the fit bends toward the spike and leaves its row neighbours
// the larger misfit (robustness benchmark, seed 777, bevel scenario 47: a
// -13.2 um spike at row 0, column 8 kept, its two neighbours dropped, and the
// state fit took the spike for the machine: 0.075 -> 2.34 um).
std::vector<bool> StandAlone(const CorrectionOptions& options,
                             const CorrectionProblem& problem,
                             const std::vector<int>& used) {
  std::vector<bool> alone(used.size(), true);
  const int rows = problem.model->GridRows();
  const int columns = problem.model->GridColumns();
  // The real measurement: the state fit's problem has it as its target
  // (MachineStateProblem).
  const Eigen::VectorXd& measured_um =
      problem.machine_state_fit ? problem.target_um : problem.measured_um;
  const Eigen::VectorXd& commanded_um = problem.commanded_deviations_um;
  if (rows <= 0 || columns <= 0 || rows * columns != problem.num_points ||
      measured_um.size() != problem.num_points ||
      commanded_um.size() != problem.num_points)
    return alone;
  Eigen::VectorXd machine_error_um =
      Eigen::VectorXd::Constant(problem.num_points, kNaN);
  for (int i : used) machine_error_um(i) = measured_um(i) - commanded_um(i);
  const std::vector<double> isolation =
      Isolation(machine_error_um, rows, columns);
  const double limit_um = IsolationLimit(options, isolation);
  for (size_t r = 0; r < used.size(); ++r) {
    const double v = isolation[used[r]];
    alone[r] = !std::isfinite(v) || v > limit_um;
  }
  return alone;
}

}  // namespace

RobustFit RobustLinearFit(const CorrectionOptions& options,
                          CorrectionProblem* problem,
                          const std::vector<int>& used,
                          Svd* svd_at_weights) {
  // The passes reweight `problem` in place (a copy of the whole problem per
  // fit was 0.75 % of a correction's instructions) and give it back as it
  // came: its weights and signal_noise_um are restored below.
  const Eigen::VectorXd weights = problem->weights;
  const double signal_noise_um = problem->signal_noise_um;
  CorrectionProblem& weighted = *problem;
  // The isolation test looks at the directions a smooth machine error takes,
  // one Tikhonov level over those above min_flank_effect_um: the weak
  // directions the per-direction filter may follow have a lone point's shape,
  // and would fit the very outlier the test looks for.
  weighted.signal_noise_um = 0.0;
  const LinearSolve ls = SolveRegularisedLinear(options, weighted, used);
  if (svd_at_weights != nullptr) *svd_at_weights = ls.svd;
  // The passes refit along the first fit's directions at its level, a QR each
  // (an SVD each was 81 % of the correction's SVDs, 4.9 per robust fit, on
  // the robustness benchmark, seed 2026, default options).
  const Eigen::MatrixXd directions = ls.svd.v.leftCols(ls.k);
  Eigen::VectorXd residual = ls.residual;
  for (int pass = 0; pass < kRobustPasses && !used.empty(); ++pass) {
    std::vector<double> size(used.size());
    for (size_t r = 0; r < used.size(); ++r)
      size[r] = std::abs(residual(r) / std::sqrt(weighted.weights(used[r])));
    const double scale = std::max(1.4826 * Median(size),
                                  std::max(weighted.probe_noise_um, 1e-3));
    double largest_change = 0.0;
    for (size_t r = 0; r < used.size(); ++r) {
      const int i = used[r];
      const double w =
          weights(i) *
          std::min(1.0, kHuberK * scale / std::max(size[r], 1e-12));
      if (weights(i) > 0.0)
        largest_change = std::max(
            largest_change, std::abs(w - weighted.weights(i)) / weights(i));
      weighted.weights(i) = w;
    }
    // Weights settled: one more pass would not move the fit.
    if (pass > 0 && largest_change < kRobustWeightTolerance) break;
    if (pass + 1 < kRobustPasses) {
      residual = TikhonovFitAlong(weighted, used, directions, ls.lambda, false)
                     .residual;
    }
  }
  // The fit at the last weights, with its hat matrix.
  const SubspaceFit fit =
      TikhonovFitAlong(weighted, used, directions, ls.lambda, true);
  RobustFit robust{fit.residual, fit.leverage, weighted.weights};
  problem->weights = weights;
  problem->signal_noise_um = signal_noise_um;
  return robust;
}

std::vector<double> StandardisedResiduals(const RobustFit& fit,
                                          const std::vector<int>& used) {
  std::vector<double> loo(used.size());
  for (size_t r = 0; r < used.size(); ++r) {
    loo[r] = fit.residual(r) / std::sqrt(fit.weights(used[r])) /
             std::sqrt(std::max(1.0 - fit.leverage(r), 1e-6));
  }
  return loo;
}

int FindGrossOutlier(const std::vector<double>& loo,
                     const std::vector<int>& used,
                     int grid_rows,
                     int grid_columns,
                     const OutlierTest& test,
                     const std::vector<bool>& alone) {
  if (loo.empty()) return -1;
  const double med = Median(loo);
  std::vector<double> dev(loo.size());
  for (size_t r = 0; r < loo.size(); ++r) dev[r] = std::abs(loo[r] - med);
  const double spread = 1.4826 * Median(dev);
  const double limit = std::max(
      test.threshold * std::max(spread, std::max(test.probe_noise_um, 0.0)),
      test.min_um);
  // A gross outlier is an isolated point: it must also stand out from its grid
  // neighbours along every line through it (row, column and both diagonals; the
  // mean of the one or two neighbours on the line). A target the model cannot
  // follow (a tip, root or end relief, a diagonal band) leaves a misfit shared
  // along some line, and that is not an outlier.
  std::vector<int> position(static_cast<size_t>(grid_rows) * grid_columns, -1);
  for (size_t r = 0; r < used.size(); ++r)
    position[used[r]] = static_cast<int>(r);
  std::vector<double> isolation(loo.size(), 0.0);
  for (size_t r = 0; r < used.size(); ++r) {
    const int row = used[r] / grid_columns, col = used[r] % grid_columns;
    double least = dev[r];
    for (const auto& [dr, dc] :
         {std::pair<int, int>{0, 1}, {1, 0}, {1, 1}, {1, -1}}) {
      double sum = 0.0;
      int count = 0;
      for (int sign : {-1, 1}) {
        const int rr = row + sign * dr, cc = col + sign * dc;
        if (rr < 0 || cc < 0 || rr >= grid_rows || cc >= grid_columns) continue;
        const int q = position[rr * grid_columns + cc];
        if (q >= 0) {
          sum += loo[q];
          ++count;
        }
      }
      if (count > 0) least = std::min(least, std::abs(loo[r] - sum / count));
    }
    isolation[r] = least;
  }
  // The most isolated point beyond the limit, of those `alone` says stand
  // alone where any of them does.
  int worst = -1, worst_alone = -1;
  for (size_t r = 0; r < loo.size(); ++r) {
    if (!(isolation[r] > limit)) continue;
    if (worst < 0 || isolation[r] > isolation[worst])
      worst = static_cast<int>(r);
    if ((r >= alone.size() || alone[r]) &&
        (worst_alone < 0 || isolation[r] > isolation[worst_alone]))
      worst_alone = static_cast<int>(r);
  }
  return worst_alone >= 0 ? worst_alone : worst;
}

std::vector<int> DropToothOutliers(const OutlierTest& test,
                                   std::vector<Eigen::VectorXd>* teeth_um) {
  std::vector<int> dropped;
  if (teeth_um->size() < 2) return dropped;
  const int n = static_cast<int>(teeth_um->front().size());
  std::vector<double> medians(n, kNaN), spread;
  for (int i = 0; i < n; ++i) {
    std::vector<double> v;
    for (const Eigen::VectorXd& tooth : *teeth_um)
      if (i < tooth.size() && std::isfinite(tooth(i))) v.push_back(tooth(i));
    if (v.size() < 2) continue;
    medians[i] = Median(v);
    for (double x : v) spread.push_back(std::abs(x - medians[i]));
  }
  const double sigma =
      std::max(1.4826 * Median(spread), std::max(test.probe_noise_um, 0.0));
  const double limit = std::max(test.threshold * sigma, test.min_um);
  for (int i = 0; i < n; ++i) {
    if (std::isnan(medians[i])) continue;
    bool any = false;
    for (Eigen::VectorXd& tooth : *teeth_um) {
      if (i >= tooth.size() || !std::isfinite(tooth(i))) continue;
      const double off = std::abs(tooth(i) - medians[i]);
      // Two teeth are each |a - b| / 2 from their median: both go.
      if (off > limit) {
        tooth(i) = kNaN;
        any = true;
      }
    }
    if (any) dropped.push_back(i);
  }
  return dropped;
}

void RemoveGrossOutliers(const CorrectionOptions& options,
                         CorrectionProblem* problem,
                         CorrectionSummary* summary,
                         Svd* svd_at_used) {
  std::vector<int>& used = problem->used;
  const OutlierTest test{options.outlier_threshold,
                         options.outlier_min_um,
                         problem->probe_noise_um};
  // max_outlier_fraction of the usable points, those the state fit left out
  // counted.
  const int found_before =
      static_cast<int>(problem->outliers_found_before.size());
  const int max_drop =
      std::max(0,
               static_cast<int>(std::floor(options.max_outlier_fraction *
                                           (used.size() + found_before))) -
                   found_before);
  summary->outlier_indices.insert(summary->outlier_indices.end(),
                                  problem->outliers_found_before.begin(),
                                  problem->outliers_found_before.end());
  for (int drop = 0; drop < max_drop; ++drop) {
    Svd at_weights;
    const RobustFit fit = RobustLinearFit(options, problem, used, &at_weights);
    const int worst = FindGrossOutlier(StandardisedResiduals(fit, used),
                                       used,
                                       problem->model->GridRows(),
                                       problem->model->GridColumns(),
                                       test,
                                       StandAlone(options, *problem, used));
    if (worst < 0) {
      if (svd_at_used != nullptr) *svd_at_used = std::move(at_weights);
      break;
    }
    summary->outlier_indices.push_back(used[worst]);
    used.erase(used.begin() + worst);
  }
  std::sort(summary->outlier_indices.begin(), summary->outlier_indices.end());
  summary->num_points_used = static_cast<int>(used.size());
}

std::vector<int> ProbeSpikes(const CorrectionOptions& options,
                             const CorrectionInput& input,
                             const std::vector<int>& outliers) {
  std::vector<int> spikes;
  const int rows = input.model->GridRows();
  const int columns = input.model->GridColumns();
  if (outliers.empty() || rows <= 0 || columns <= 0 ||
      rows * columns != input.model->NumPoints())
    return spikes;
  const Eigen::VectorXd measured_um =
      AverageMeasurement(options, input).measured_um;
  ModelEvaluation commanded;
  input.model->Evaluate(input.current_parameters, false, &commanded);
  Eigen::VectorXd machine_error_um =
      Eigen::VectorXd::Constant(input.model->NumPoints(), kNaN);
  for (int i = 0; i < machine_error_um.size(); ++i) {
    if (i < measured_um.size() && commanded.status[i] == PointStatus::kOk)
      machine_error_um(i) = measured_um(i) - commanded.deviations_um(i);
  }
  const std::vector<double> isolation =
      Isolation(machine_error_um, rows, columns);
  const double limit_um = IsolationLimit(options, isolation);
  for (int i : outliers) {
    if (i >= 0 && i < static_cast<int>(isolation.size()) &&
        isolation[i] > limit_um)
      spikes.push_back(i);
  }
  return spikes;
}

}  // namespace correction_internal
}  // namespace gearloop
