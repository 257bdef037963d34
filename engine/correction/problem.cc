// The correction problem of one request, built once (problem.h). The averaging
// of several teeth lives here only: the machine-state estimate reads its mean
// count from the problem.
#include "engine/correction/problem.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "engine/correction/legendre_coordinates.h"
#include "engine/correction/outliers.h"
#include "engine/correction/regularisation.h"

namespace gearloop {
namespace correction_internal {
namespace {

// The roll range of the request, else the span of the contact roll angles of
// the reached points together with the model's nominal roll range (a
// correction shifts the contacts along the roll, by a quarter of the range
// after a work-rotation offset, while the machine keeps rolling over the
// programmed range: the motion is bounded over both) ([-1, 1] when they span
// nothing).
void ChooseRollRange(const CorrectionInput& input,
                     const ModelEvaluation& evaluation,
                     int n,
                     double* roll_min,
                     double* roll_max) {
  *roll_min = input.roll_min_rad;
  *roll_max = input.roll_max_rad;
  if (*roll_min < *roll_max) return;
  *roll_min = kInf;
  *roll_max = -kInf;
  double nominal_min = 0.0, nominal_max = 0.0;
  if (input.model->NominalRollRange(&nominal_min, &nominal_max)) {
    *roll_min = nominal_min;
    *roll_max = nominal_max;
  }
  for (int i = 0; i < n; ++i) {
    if (evaluation.status[i] == PointStatus::kOk &&
        std::isfinite(evaluation.contact_roll_rad[i])) {
      *roll_min = std::min(*roll_min, evaluation.contact_roll_rad[i]);
      *roll_max = std::max(*roll_max, evaluation.contact_roll_rad[i]);
    }
  }
  if (!(*roll_min < *roll_max)) {
    *roll_min = -1.0;
    *roll_max = 1.0;
  }
}

// The coefficients that may change: orders 0..max order of each block
// (max_order, else default_max_order clamped to the block's degree; scalar
// blocks free unless named -1, or fixed unless named when fixed_by_default).
int FreeOrder(const CorrectionOptions& options, const ParameterBlock& b) {
  int order = b.is_polynomial
                  ? std::min(options.default_max_order, b.num_coefficients - 1)
                  : (b.fixed_by_default ? -1 : 0);
  const auto it = options.max_order.find(b.name);
  if (it != options.max_order.end())
    order = std::min(it->second, b.num_coefficients - 1);
  return order;
}

bool SelectFreeParameters(const CorrectionOptions& options,
                          const std::vector<ParameterBlock>& blocks,
                          std::vector<int>* free,
                          std::string* error) {
  for (const ParameterBlock& b : blocks) {
    const int order = FreeOrder(options, b);
    for (int k = 0; k <= order; ++k) free->push_back(b.first_index + k);
  }
  for (const auto& [name, order] : options.max_order) {
    (void)order;
    bool known = false;
    for (const ParameterBlock& b : blocks) known = known || b.name == name;
    if (!known) {
      *error = "max_order names an unknown parameter block '" + name + "'";
      return false;
    }
  }
  return true;
}

// The smoothness weight of Legendre order k of an axis: how much faster than a
// cubic it accelerates the axis at the ends of the roll range, P_k''(1) /
// P_3''(1) = (k-1) k (k+1) (k+2) / 360, and 1 up to order 3. A coordinate of
// order k is divided by it, so one unit of the regularised size buys as much
// end acceleration in every order: orders 4, 5, 6 cost 3, 7 and 14 times
// their motion. Orders 0-3 (the default freedom) are unchanged.
double SmoothnessWeight(const ParameterBlock& block, int index) {
  if (!block.is_polynomial) return 1.0;
  const double k = index - block.first_index;
  if (k <= 3.0) return 1.0;
  return (k - 1.0) * k * (k + 1.0) * (k + 2.0) / 360.0;
}

// T over the free coordinates and its rows `free`, each column divided by its
// smoothness weight. Orders 0..K of a Legendre block touch only monomials
// 0..K, so restricting columns and rows to `free` is exact.
void BuildCoordinates(const CorrectionOptions& options, CorrectionProblem* p) {
  const int np = p->num_parameters, nf = p->NumFree();
  const Eigen::MatrixXd t_full = CoordinateMap(
      p->blocks, np, p->roll_min_rad, p->roll_max_rad, options.block_scales);
  p->t_map = Eigen::MatrixXd::Zero(np, nf);
  p->t_free.resize(nf, nf);
  for (int c = 0; c < nf; ++c) {
    const int j = p->free[c];
    double weight = 1.0;
    for (const ParameterBlock& b : p->blocks) {
      if (j >= b.first_index && j < b.first_index + b.num_coefficients)
        weight = SmoothnessWeight(b, j);
    }
    p->t_map.col(c) = t_full.col(j) / weight;
    for (int r = 0; r < nf; ++r)
      p->t_free(r, c) = t_full(p->free[r], j) / weight;
  }
}

void SetBounds(const CorrectionOptions& options, CorrectionProblem* p) {
  const int np = p->num_parameters;
  p->has_bounds = false;
  p->lower = Eigen::VectorXd::Constant(np, -kInf);
  p->upper = Eigen::VectorXd::Constant(np, kInf);
  if (options.lower_delta.size() == np) {
    p->lower = options.lower_delta;
    p->upper = options.upper_delta;
    for (int j : p->free)
      p->has_bounds = p->has_bounds || std::isfinite(p->lower(j)) ||
                      std::isfinite(p->upper(j));
  }
}

}  // namespace

std::string ValidateCorrectionInput(const CorrectionOptions& options,
                                    const CorrectionInput& input) {
  std::string error;
  if (!options.IsValid(&error)) return error;
  if (input.model == nullptr) return "no machine model";
  const int np = input.model->NumParameters();
  const int n = input.model->NumPoints();
  if (input.current_parameters.size() != np ||
      !input.current_parameters.allFinite()) {
    return "current_parameters must hold " + std::to_string(np) +
           " finite values";
  }
  if (!input.measured_teeth_um.empty()) {
    for (size_t t = 0; t < input.measured_teeth_um.size(); ++t) {
      if (input.measured_teeth_um[t].size() != n) {
        return "measured_teeth_um[" + std::to_string(t) + "] must hold " +
               std::to_string(n) + " values";
      }
    }
  } else if (input.measured_um.size() != n) {
    return "measured_um must hold " + std::to_string(n) + " values";
  }
  if (input.target_um.size() != n)
    return "target_um must hold " + std::to_string(n) + " values";
  if (options.point_weights.size() != 0 && options.point_weights.size() != n) {
    return "point_weights must be empty or hold " + std::to_string(n) +
           " values";
  }
  if (options.lower_delta.size() != 0 && options.lower_delta.size() != np) {
    return "bounds must be empty or hold " + std::to_string(np) + " values";
  }
  if (input.jacobian_um.size() != 0 &&
      (input.jacobian_um.rows() != n || input.jacobian_um.cols() != np)) {
    return "jacobian_um must be " + std::to_string(n) + " x " +
           std::to_string(np);
  }
  return "";
}

MeasuredFlank AverageMeasurement(const CorrectionOptions& options,
                                 const CorrectionInput& input) {
  const int n = input.model->NumPoints();
  MeasuredFlank flank;
  flank.measured_um = input.measured_um;
  flank.noise_share = Eigen::VectorXd::Ones(n);
  if (input.measured_teeth_um.empty()) return flank;
  Eigen::VectorXi counts;
  std::vector<Eigen::VectorXd> teeth = input.measured_teeth_um;
  if (options.outlier_threshold > 0.0 &&
      options.solver == CorrectionSolver::kRegularised) {
    flank.tooth_outliers = DropToothOutliers({options.outlier_threshold,
                                              options.outlier_min_um,
                                              options.probe_noise_um},
                                             &teeth);
  }
  flank.measured_um = AverageTeeth(teeth, &counts);
  double count_sum = 0.0;
  int delivered = 0;
  for (int i = 0; i < n; ++i) {
    flank.noise_share(i) = counts(i) > 0 ? 1.0 / counts(i) : 1.0;
    if (counts(i) > 0) {
      count_sum += counts(i);
      ++delivered;
    }
  }
  if (delivered > 0) flank.mean_teeth_averaged = count_sum / delivered;
  return flank;
}

void SelectPoints(CorrectionProblem* p) {
  p->reached.clear();
  p->used.clear();
  p->missing.clear();
  p->measured_not_reached.clear();
  for (int i = 0; i < p->num_points; ++i) {
    const bool ok = p->evaluation.status[i] == PointStatus::kOk;
    const bool measured = std::isfinite(p->error_um(i)) && p->weights(i) > 0.0;
    if (ok) p->reached.push_back(i);
    if (ok && measured) {
      p->used.push_back(i);
    } else {
      p->missing.push_back(i);
      if (measured) p->measured_not_reached.push_back(i);
    }
  }
}

void LineariseAt(const Eigen::VectorXd& parameters,
                 const Eigen::MatrixXd& given_jacobian,
                 CorrectionProblem* p) {
  p->parameters = parameters;
  p->model->Evaluate(parameters, given_jacobian.size() == 0, &p->evaluation);
  p->jacobian_um =
      given_jacobian.size() != 0 ? given_jacobian : p->evaluation.jacobian_um;
  SelectPoints(p);
  if (p->t_map.size() != 0) p->st = TimesColumnRuns(p->jacobian_um, p->t_map);
}

bool PrepareCorrectionProblem(const CorrectionOptions& options,
                              const CorrectionInput& input,
                              CorrectionProblem* p,
                              CorrectionSummary* summary,
                              std::string* error) {
  p->model = input.model;
  p->svd_memo = std::make_shared<SvdMemo>();
  p->blocks = input.model->ParameterBlocks();
  p->num_parameters = input.model->NumParameters();
  p->num_points = input.model->NumPoints();
  const int n = p->num_points;
  p->mode = options.mode;
  p->rule = ChooseRegularisationRule(options);
  p->probe_noise_um = options.probe_noise_um;
  const MeasuredFlank flank = AverageMeasurement(options, input);
  p->measured_um = flank.measured_um;
  p->error_um = flank.measured_um - input.target_um;  // NaN where missing
  p->target_um = input.target_um;
  p->noise_share = flank.noise_share;
  p->mean_teeth_averaged = flank.mean_teeth_averaged;
  p->tooth_outliers = flank.tooth_outliers;
  p->weights = options.point_weights.size() == n ? options.point_weights
                                                 : Eigen::VectorXd::Ones(n);

  LineariseAt(input.current_parameters, input.jacobian_um, p);
  p->commanded_parameters = input.current_parameters;
  p->commanded_deviations_um = p->evaluation.deviations_um;
  p->commanded_status = p->evaluation.status;
  ChooseRollRange(input, p->evaluation, n, &p->roll_min_rad, &p->roll_max_rad);
  summary->roll_min_rad = p->roll_min_rad;
  summary->roll_max_rad = p->roll_max_rad;
  summary->missing_indices = p->missing;
  if (p->used.empty()) {
    // With no point used, every measured point is one the model does not
    // reach (SelectPoints).
    const int measured = static_cast<int>(p->measured_not_reached.size());
    const int not_reached = static_cast<int>(std::count_if(
        p->measured_not_reached.begin(),
        p->measured_not_reached.end(),
        [p](int i) {
          return p->evaluation.status[i] == PointStatus::kNotReached;
        }));
    const int not_converged = measured - not_reached;
    if (measured == 0) {
      *error =
          "no usable grid point: every point is missing or has zero weight";
    } else {
      *error =
          "no usable grid point: the model at the current settings has "
          "no contact at any of the " +
          std::to_string(measured) + " measured grid point(s) (" +
          std::to_string(not_reached) + " not reached by the wheel, " +
          std::to_string(not_converged) +
          " with no envelope point found); check the settings against "
          "the machine and the grid against the flank";
    }
    return false;
  }
  if (!SelectFreeParameters(options, p->blocks, &p->free, error)) return false;
  summary->num_free_parameters = p->NumFree();
  summary->num_points_used = static_cast<int>(p->used.size());
  if (p->free.empty()) {
    *error = "no parameter is free to change";
    return false;
  }
  BuildCoordinates(options, p);
  p->st = TimesColumnRuns(p->jacobian_um, p->t_map);  // n x nf
  SetBounds(options, p);
  p->motion_rows = RelativeMotionRows(options, *p, kMotionBoundSamples);
  return true;
}

namespace {

// The motion bound of `block` (options.max_axis_motion_mm / _rad), 0 where
// it has none (not a polynomial, or a unit without a bound).
double MotionBoundOf(const CorrectionOptions& options,
                     const ParameterBlock& block) {
  if (!block.is_polynomial) return 0.0;
  const double bound = block.unit == "mm"    ? options.max_axis_motion_mm
                       : block.unit == "rad" ? options.max_axis_motion_rad
                                             : 0.0;
  return bound > 0.0 ? bound : 0.0;
}

// The first and last index of the run of `v` from its first nonzero entry to
// its last (first > last: no nonzero entry).
template <typename Vector>
std::pair<int, int> NonzeroSpan(const Vector& v) {
  int first = 0, last = static_cast<int>(v.size()) - 1;
  while (first <= last && v(first) == 0.0) ++first;
  while (last >= first && v(last) == 0.0) --last;
  return {first, last};
}

}  // namespace

Eigen::MatrixXd TimesColumnRuns(const Eigen::MatrixXd& left,
                                const Eigen::MatrixXd& right) {
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(left.rows(), right.cols());
  // No column of `left` to take (an empty block is no column to offset).
  if (left.rows() == 0 || left.cols() == 0) return out;
  for (int j = 0; j < right.cols(); ++j) {
    const auto [first, last] = NonzeroSpan(right.col(j));
    for (int r = first; r <= last; ++r) out.col(j) += left.col(r) * right(r, j);
  }
  return out;
}

Eigen::MatrixXd RowRunsTimes(const Eigen::MatrixXd& left,
                             const Eigen::MatrixXd& right) {
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(left.rows(), right.cols());
  // No row of `right` to take (no kept direction: right is np x 0).
  if (right.rows() == 0 || right.cols() == 0) return out;
  for (int i = 0; i < left.rows(); ++i) {
    const auto [first, last] = NonzeroSpan(left.row(i));
    for (int c = first; c <= last; ++c) out.row(i) += left(i, c) * right.row(c);
  }
  return out;
}

Eigen::MatrixXd MotionRowsAt(const CorrectionOptions& options,
                             const CorrectionProblem& problem,
                             const std::vector<double>& rolls_rad) {
  // Filled in place: the safe step and the state test ask for these rows at
  // every answer (a row vector allocated per block and roll was 3-4 % of a
  // correction's CPU, BENCHMARKS.md "The correction's CPU at the median").
  int num_rows = 0;
  for (const ParameterBlock& block : problem.blocks)
    if (MotionBoundOf(options, block) > 0.0)
      num_rows += static_cast<int>(rolls_rad.size());
  Eigen::MatrixXd m = Eigen::MatrixXd::Zero(num_rows, problem.num_parameters);
  int r = 0;
  for (const ParameterBlock& block : problem.blocks) {
    const double bound = MotionBoundOf(options, block);
    if (!(bound > 0.0)) continue;
    for (const double phi : rolls_rad) {
      double power = 1.0;
      for (int k = 0; k < block.num_coefficients; ++k, power *= phi)
        m(r, block.first_index + k) = power / bound;
      ++r;
    }
  }
  return m;
}

double LargestRelativeMotion(const CorrectionOptions& options,
                             const CorrectionProblem& problem,
                             const std::vector<double>& rolls_rad,
                             const Eigen::VectorXd& delta) {
  // MotionRowsAt's rows times delta, row by row without the matrix (each
  // entry made as there and summed in the columns' order).
  double largest = 0.0;
  for (const ParameterBlock& block : problem.blocks) {
    const double bound = MotionBoundOf(options, block);
    if (!(bound > 0.0)) continue;
    for (const double phi : rolls_rad) {
      double power = 1.0, motion = 0.0;
      for (int k = 0; k < block.num_coefficients; ++k, power *= phi)
        motion += (power / bound) * delta(block.first_index + k);
      largest = std::max(largest, std::abs(motion));
    }
  }
  return largest;
}

double LargestRelativeMotionOverRollRange(const CorrectionOptions& options,
                                          const CorrectionProblem& problem,
                                          int samples,
                                          const Eigen::VectorXd& delta) {
  // Golden-section steps on a bracket of two sample spacings: 0.618^48 of it
  // (below 1e-9 of the roll range at 41 samples).
  constexpr int kGoldenSteps = 48;
  const double golden = 0.5 * (std::sqrt(5.0) - 1.0);
  const std::vector<double> rolls_rad = RollSamples(problem, samples);
  const int n = static_cast<int>(rolls_rad.size());
  double largest = 0.0;
  for (const ParameterBlock& block : problem.blocks) {
    const double bound = MotionBoundOf(options, block);
    if (!(bound > 0.0)) continue;
    const auto motion = [&](double phi) {
      double power = 1.0, sum = 0.0;
      for (int k = 0; k < block.num_coefficients; ++k, power *= phi)
        sum += (power / bound) * delta(block.first_index + k);
      return std::abs(sum);
    };
    std::vector<double> at(n);
    for (int s = 0; s < n; ++s) {
      at[s] = motion(rolls_rad[s]);
      largest = std::max(largest, at[s]);
    }
    // Each sample at least as large as its neighbours brackets a maximum of
    // |motion| between them (an end sample: between it and its one
    // neighbour, where the motion may rise from the end and fall again
    // before the next sample); a polynomial of order <= 6 has at most 5
    // turning points, and 41 samples leave one per bracket.
    for (int s = 0; s < n; ++s) {
      const bool above_before = s == 0 || at[s] >= at[s - 1];
      const bool above_after = s + 1 == n || at[s] >= at[s + 1];
      if (!(above_before && above_after)) continue;
      double lo = rolls_rad[std::max(s - 1, 0)];
      double hi = rolls_rad[std::min(s + 1, n - 1)];
      double a = hi - golden * (hi - lo), b = lo + golden * (hi - lo);
      double fa = motion(a), fb = motion(b);
      for (int step = 0; step < kGoldenSteps; ++step) {
        if (fa >= fb) {
          hi = b;
          b = a;
          fb = fa;
          a = hi - golden * (hi - lo);
          fa = motion(a);
        } else {
          lo = a;
          a = b;
          fa = fb;
          b = lo + golden * (hi - lo);
          fb = motion(b);
        }
      }
      largest = std::max(largest, std::max(fa, fb));
    }
  }
  return largest;
}

std::vector<double> RollSamples(const CorrectionProblem& problem, int samples) {
  std::vector<double> rolls_rad(samples);
  for (int s = 0; s < samples; ++s) {
    rolls_rad[s] =
        problem.roll_min_rad +
        (problem.roll_max_rad - problem.roll_min_rad) * s / (samples - 1.0);
  }
  return rolls_rad;
}

Eigen::MatrixXd RelativeMotionRows(const CorrectionOptions& options,
                                   const CorrectionProblem& problem,
                                   int samples) {
  return MotionRowsAt(options, problem, RollSamples(problem, samples));
}

CorrectionProblem RelinearisedAt(const CorrectionProblem& problem,
                                 const Eigen::VectorXd& parameters) {
  CorrectionProblem p = problem;
  LineariseAt(parameters, Eigen::MatrixXd(), &p);
  return p;
}

namespace {

// CorrectionSummary::error_neighbour_ratio of `problem`'s error.
double ErrorNeighbourRatio(const CorrectionProblem& problem) {
  if (problem.model == nullptr) return kNaN;
  const int rows = problem.model->GridRows();
  const int columns = problem.model->GridColumns();
  if (rows * columns != problem.num_points) return kNaN;
  std::vector<bool> used(problem.num_points, false);
  double sum = 0.0;
  int finite = 0;
  for (int i : problem.used) {
    used[i] = std::isfinite(problem.error_um(i));
    if (!used[i]) continue;
    sum += problem.error_um(i);
    ++finite;
  }
  const double mean = sum / std::max(1, finite);
  double variance = 0.0, difference2 = 0.0;
  int count = 0, pairs = 0;
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < columns; ++c) {
      const int i = r * columns + c;
      if (!used[i]) continue;
      const double e = problem.error_um(i);
      variance += (e - mean) * (e - mean);
      ++count;
      for (const int j :
           {c + 1 < columns ? i + 1 : -1, r + 1 < rows ? i + columns : -1}) {
        if (j < 0 || !used[j]) continue;
        const double d = e - problem.error_um(j);
        difference2 += d * d;
        ++pairs;
      }
    }
  }
  variance /= std::max(1, count);
  if (pairs < 2 || !(variance > 0.0)) return kNaN;
  return difference2 / pairs / (2.0 * variance);
}

}  // namespace

void ReportProblem(const CorrectionProblem& problem,
                   CorrectionSummary* summary) {
  summary->error_neighbour_ratio = ErrorNeighbourRatio(problem);
  summary->roll_min_rad = problem.roll_min_rad;
  summary->roll_max_rad = problem.roll_max_rad;
  summary->missing_indices = problem.missing;
  summary->measured_not_reached_indices = problem.measured_not_reached;
  summary->measured_not_reached_max_um = kNaN;
  for (int i : problem.measured_not_reached) {
    const double e = std::abs(problem.error_um(i));
    if (!(summary->measured_not_reached_max_um >= e))
      summary->measured_not_reached_max_um = e;
  }
  summary->tooth_outlier_indices = problem.tooth_outliers;
  summary->num_free_parameters = problem.NumFree();
  summary->num_points_used = static_cast<int>(problem.used.size());
}

bool HoldsAnAxisBelowItsHighestOrder(
    const CorrectionOptions& options,
    const std::vector<ParameterBlock>& blocks) {
  for (const ParameterBlock& b : blocks) {
    if (!b.is_polynomial) continue;
    const int order = FreeOrder(options, b);
    if (order >= 0 && order < b.num_coefficients - 1) return true;
  }
  return false;
}

bool OpensOrdersAboveCubic(const CorrectionOptions& options,
                           const std::vector<ParameterBlock>& blocks) {
  for (const ParameterBlock& b : blocks)
    if (b.is_polynomial && FreeOrder(options, b) > kCubicOrder) return true;
  return false;
}

int HighestOrderMoved(const std::vector<ParameterBlock>& blocks,
                      const Eigen::VectorXd& delta) {
  int highest = -1;
  for (const ParameterBlock& b : blocks) {
    if (!b.is_polynomial) continue;
    for (int k = b.num_coefficients - 1; k > highest; --k) {
      if (delta(b.first_index + k) != 0.0) {
        highest = k;
        break;
      }
    }
  }
  return highest;
}

bool UsesOrdersAboveCubic(const CorrectionProblem& problem,
                          const Eigen::VectorXd& delta) {
  return HighestOrderMoved(problem.blocks, delta) > kCubicOrder;
}

std::vector<int> PredictedPoints(const CorrectionProblem& problem) {
  std::vector<int> points = problem.used;
  points.insert(points.end(),
                problem.measured_not_reached.begin(),
                problem.measured_not_reached.end());
  return points;
}

double Rms(const Eigen::VectorXd& r, const std::vector<int>& idx) {
  if (idx.empty()) return 0.0;
  double s = 0.0;
  for (int i : idx) s += r(i) * r(i);
  return std::sqrt(s / idx.size());
}

std::string FormatUm(double um) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.3g", um);
  return text;
}

double MaxAbs(const Eigen::VectorXd& r, const std::vector<int>& idx) {
  double m = 0.0;
  for (int i : idx) m = std::max(m, std::abs(r(i)));
  return m;
}

}  // namespace correction_internal

Eigen::VectorXd AverageTeeth(const std::vector<Eigen::VectorXd>& teeth_um,
                             Eigen::VectorXi* counts) {
  const int n =
      teeth_um.empty() ? 0 : static_cast<int>(teeth_um.front().size());
  Eigen::VectorXd sum = Eigen::VectorXd::Zero(n);
  Eigen::VectorXi count = Eigen::VectorXi::Zero(n);
  for (const Eigen::VectorXd& tooth : teeth_um) {
    for (int i = 0; i < n && i < tooth.size(); ++i) {
      if (std::isfinite(tooth(i))) {
        sum(i) += tooth(i);
        ++count(i);
      }
    }
  }
  Eigen::VectorXd mean(n);
  for (int i = 0; i < n; ++i)
    mean(i) = count(i) > 0 ? sum(i) / count(i) : correction_internal::kNaN;
  if (counts != nullptr) *counts = count;
  return mean;
}

}  // namespace gearloop
