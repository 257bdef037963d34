#include "engine/simulation/measurement_simulator.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>

namespace gearloop {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

bool Contains(const std::vector<int>& v, int i) {
  return std::find(v.begin(), v.end(), i) != v.end();
}

}  // namespace

bool MeasurementSimulationOptions::IsValid(std::string* error) const {
  auto fail = [error](const char* message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (!(probe_noise_um >= 0.0) || !std::isfinite(probe_noise_um))
    return fail("probe_noise_um must be finite and >= 0");
  if (!(outlier_probability >= 0.0 && outlier_probability <= 1.0))
    return fail("outlier_probability must lie in [0, 1]");
  if (!(missing_probability >= 0.0 && missing_probability <= 1.0))
    return fail("missing_probability must lie in [0, 1]");
  if (!std::isfinite(outlier_size_um))
    return fail("outlier_size_um must be finite");
  if (teeth < 1) return fail("teeth must be >= 1");
  return true;
}

SimulatedMeasurement SimulateMeasurement(
    const MachineModel& model,
    const Eigen::VectorXd& commanded_parameters,
    const Eigen::VectorXd& hidden_errors,
    const MeasurementSimulationOptions& options) {
  SimulatedMeasurement out;
  const int n = model.NumPoints();
  ModelEvaluation eval;
  model.Evaluate(commanded_parameters + hidden_errors, false, &eval);
  out.status = eval.status;
  out.true_deviations_um = Eigen::VectorXd::Constant(n, kNaN);
  for (int i = 0; i < n; ++i) {
    if (eval.status[i] == PointStatus::kOk)
      out.true_deviations_um(i) = eval.deviations_um(i);
  }

  // One generator for everything, drawn in a fixed order: missing, then per
  // tooth noise and outliers, so a seed reproduces the same grid.
  std::mt19937_64 rng(options.seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::vector<bool> missing(n, false);
  for (int i = 0; i < n; ++i) {
    const bool draw = unit(rng) < options.missing_probability;
    missing[i] = draw || Contains(options.missing_points, i) ||
                 !std::isfinite(out.true_deviations_um(i));
  }
  std::vector<bool> outlier(n, false);
  for (int tooth = 0; tooth < options.teeth; ++tooth) {
    Eigen::VectorXd grid = Eigen::VectorXd::Constant(n, kNaN);
    for (int i = 0; i < n; ++i) {
      const double noise = options.probe_noise_um * gauss(rng);
      const bool random_outlier = unit(rng) < options.outlier_probability;
      const double sign = unit(rng) < 0.5 ? -1.0 : 1.0;
      if (missing[i]) continue;
      double value = out.true_deviations_um(i) + noise;
      if (random_outlier ||
          (tooth == 0 && Contains(options.outlier_points, i))) {
        value += sign * options.outlier_size_um;
        outlier[i] = true;
      }
      grid(i) = value;
    }
    out.teeth_um.push_back(grid);
  }
  out.measured_um =
      options.teeth == 1 ? out.teeth_um.front() : AverageTeeth(out.teeth_um);
  if (options.teeth == 1) out.teeth_um.clear();
  for (int i = 0; i < n; ++i) {
    if (missing[i]) out.missing_indices.push_back(i);
    if (outlier[i]) out.outlier_indices.push_back(i);
  }
  return out;
}

Eigen::VectorXd RandomHiddenErrors(
    const MachineModel& model,
    double roll_min_rad,
    double roll_max_rad,
    double block_size,
    int max_order,
    double wheel_size,
    std::uint64_t seed,
    const std::vector<std::string>& fixed_blocks) {
  const std::vector<ParameterBlock> blocks = model.ParameterBlocks();
  Eigen::VectorXd y = Eigen::VectorXd::Zero(model.NumParameters());
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  for (const ParameterBlock& b : blocks) {
    const bool fixed =
        std::find(fixed_blocks.begin(), fixed_blocks.end(), b.name) !=
        fixed_blocks.end();
    if (b.is_polynomial) {
      const int top = std::min(max_order, b.num_coefficients - 1);
      for (int k = 0; k <= top; ++k) {
        const double draw = gauss(rng);
        if (!fixed)
          y(b.first_index + k) = draw * block_size / std::sqrt(top + 1.0);
      }
    } else {
      for (int k = 0; k < b.num_coefficients; ++k) {
        const double draw = gauss(rng);
        if (!fixed) y(b.first_index + k) = draw * wheel_size;
      }
    }
  }
  return DeltaFromCorrectionCoordinates(blocks, y, roll_min_rad, roll_max_rad);
}

ClosedLoopResult SimulateClosedLoop(
    const MachineModel& model,
    const Eigen::VectorXd& initial_commanded_parameters,
    const Eigen::VectorXd& hidden_errors,
    const Eigen::VectorXd& target_um,
    const ClosedLoopOptions& options) {
  ClosedLoopResult result;
  Eigen::VectorXd commanded = initial_commanded_parameters;
  MeasurementSimulationOptions measurement = options.measurement;
  for (int part = 0; part <= options.corrections; ++part) {
    ClosedLoopIteration it;
    it.part = part;
    it.commanded_parameters = commanded;
    const SimulatedMeasurement cmm =
        SimulateMeasurement(model, commanded, hidden_errors, measurement);
    ++measurement.seed;
    it.true_error_um = cmm.true_deviations_um - target_um;
    it.measured_um = cmm.measured_um;
    double sum2 = 0.0, max_abs = 0.0, msum2 = 0.0;
    int count = 0, mcount = 0;
    for (int i = 0; i < it.true_error_um.size(); ++i) {
      if (std::isfinite(it.true_error_um(i))) {
        sum2 += it.true_error_um(i) * it.true_error_um(i);
        max_abs = std::max(max_abs, std::abs(it.true_error_um(i)));
        ++count;
      }
      const double m = cmm.measured_um(i) - target_um(i);
      if (std::isfinite(m)) {
        msum2 += m * m;
        ++mcount;
      }
    }
    // A part on which the wheel reaches no grid point has no error figure
    // (NaN), never 0.
    const double no_figure = std::numeric_limits<double>::quiet_NaN();
    it.true_rms_um = count > 0 ? std::sqrt(sum2 / count) : no_figure;
    it.true_max_um = count > 0 ? max_abs : no_figure;
    it.measured_rms_um = mcount > 0 ? std::sqrt(msum2 / mcount) : no_figure;
    if (part < options.corrections) {
      CorrectionInput input;
      input.model = &model;
      input.current_parameters = commanded;
      input.measured_um = cmm.measured_um;
      input.target_um = target_um;
      input.roll_min_rad = options.roll_min_rad;
      input.roll_max_rad = options.roll_max_rad;
      const CorrectionResult correction =
          ComputeCorrection(options.correction, input);
      it.correction = correction.summary;
      it.corrected = true;
      it.predicted_residual_um = correction.predicted_residual_um;
      it.predicted_change_um = correction.predicted_change_um;
      it.linearised_at = correction.linearised_at;
      result.iterations.push_back(it);
      if (!correction.summary.IsSolutionUsable()) {
        result.message = "correction " + std::to_string(part) +
                         " unusable: " + correction.summary.message;
        return result;
      }
      commanded = correction.parameters;
    } else {
      result.iterations.push_back(it);
    }
  }
  result.completed = true;
  return result;
}

}  // namespace gearloop
