// engine/simulation/measurement_simulator.h: the simulated gear measuring
// machine and the simulated closed loop of grinding, measuring and correcting
// (MODEL.md §8).
//
//   MeasurementSimulationOptions m;
//   m.probe_noise_um = 0.5;
//   m.seed = 7;
//   SimulatedMeasurement cmm = SimulateMeasurement(grinder, commanded,
//   hidden_errors, m);
//   // cmm.measured_um is what the solver sees; cmm.true_deviations_um is never
//   shown to it.
//
//   ClosedLoopOptions loop;                     // 3 corrections, default
//   solver ClosedLoopResult run = SimulateClosedLoop(grinder, commanded,
//   hidden_errors, target_um, loop);
//   // run.iterations[k].true_rms_um: the true flank error of part k against
//   the target
//
// Hidden machine errors are a perturbation of the parameter vector that the
// machine really runs with (commanded + hidden): axis offsets (coefficient 0 of
// an axis), drifts (coefficient 1), polynomial errors (higher coefficients) and
// wheel-profile errors (the scalar wheel parameters). The solver only ever sees
// the commanded parameters and the measured grid.
#ifndef GEARLOOP_ENGINE_SIMULATION_MEASUREMENT_SIMULATOR_H_
#define GEARLOOP_ENGINE_SIMULATION_MEASUREMENT_SIMULATOR_H_

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "engine/core/machine_model.h"
#include "engine/correction/correction.h"

namespace gearloop {

struct MeasurementSimulationOptions {
  // Standard deviation of the Gaussian probe noise added to every delivered
  // point [um] (>= 0).
  double probe_noise_um = 0.0;
  // Seed of the std::mt19937_64 that draws noise, outliers and missing points.
  std::uint64_t seed = 1;
  // Each delivered point is a gross outlier with this probability; an outlier
  // adds
  // +-outlier_size_um (random sign) to the reading.
  double outlier_probability = 0.0;
  double outlier_size_um = 20.0;
  // Points that are always outliers (row-major indices), in addition to the
  // random ones.
  std::vector<int> outlier_points;
  // Each point is missing (NaN) with this probability; plus these fixed
  // indices.
  double missing_probability = 0.0;
  std::vector<int> missing_points;
  // Number of teeth measured on the flank; each tooth gets its own noise. The
  // reported grid is AverageTeeth of them (engine/correction/correction.h); all
  // teeth carry the same machine error.
  int teeth = 1;

  bool IsValid(std::string* error) const;
};

struct SimulatedMeasurement {
  // The flank as really ground (commanded + hidden errors), without noise [um];
  // NaN where the wheel does not reach or the model does not converge.
  Eigen::VectorXd true_deviations_um;
  // The grid the measuring machine reports [um]: true + noise + outliers, NaN =
  // missing.
  Eigen::VectorXd measured_um;
  // Each tooth's grid when teeth > 1 (measured_um is their average).
  std::vector<Eigen::VectorXd> teeth_um;
  std::vector<int> outlier_indices;  // points that received a gross error
  std::vector<int> missing_indices;  // points reported as NaN
  std::vector<PointStatus> status;   // of the grinding model
};

// Grinds with commanded + hidden_errors in `model` and measures the result.
SimulatedMeasurement SimulateMeasurement(
    const MachineModel& model,
    const Eigen::VectorXd& commanded_parameters,
    const Eigen::VectorXd& hidden_errors,
    const MeasurementSimulationOptions& options);

// Random hidden machine errors: each polynomial block up to `max_order` gets
// orthonormal Legendre coordinates over the roll range (CorrectionCoordinates,
// engine/correction/correction.h) drawn from N(0, block_size^2 / (max_order +
// 1)), so that its expected correction size is block_size; scalar blocks get
// N(0, wheel_size^2) in their scale. Polynomial blocks named in `fixed_blocks`,
// and scalar ones too, get no error. Deterministic in `seed`.
Eigen::VectorXd RandomHiddenErrors(
    const MachineModel& model,
    double roll_min_rad,
    double roll_max_rad,
    double block_size,
    int max_order,
    double wheel_size,
    std::uint64_t seed,
    const std::vector<std::string>& fixed_blocks = {});

struct ClosedLoopOptions {
  // Number of corrections; the loop grinds corrections + 1 parts.
  int corrections = 3;
  // The measuring machine; its seed is advanced by one for every part measured.
  MeasurementSimulationOptions measurement;
  // The solver options used for every correction.
  CorrectionOptions correction;
  // Optional roll range for the solver (see CorrectionInput); empty range =
  // from the model.
  double roll_min_rad = 0.0;
  double roll_max_rad = 0.0;
};

struct ClosedLoopIteration {
  int part = 0;                          // 0 = ground with the initial settings
  Eigen::VectorXd commanded_parameters;  // what the machine was told
  Eigen::VectorXd
      true_error_um;  // true deviations - target (NaN where not reached)
  // What the measuring machine reported for this part [um], row-major, NaN =
  // missing (the mean of the teeth when several are measured): the grid the
  // correction was computed from.
  Eigen::VectorXd measured_um;
  double true_rms_um =
      0.0;  // over the reached points (NaN when none is reached)
  double true_max_um = 0.0;
  double measured_rms_um =
      0.0;  // of measured - target over the delivered points (NaN: none)
  CorrectionSummary
      correction;  // the correction computed from this part (not for the last)
  bool corrected = false;  // whether `correction` was computed
  // The correction's predicted grids (CorrectionResult), row-major [um]; empty
  // when not corrected.
  Eigen::VectorXd predicted_residual_um;
  Eigen::VectorXd predicted_change_um;
  // The parameters the correction was linearised at (CorrectionResult:
  // the estimated machine state, or the commanded settings); empty when not
  // corrected.
  Eigen::VectorXd linearised_at;
};

struct ClosedLoopResult {
  std::vector<ClosedLoopIteration> iterations;  // corrections + 1 parts
  bool completed =
      false;  // false when a correction was unusable (the loop stops there)
  std::string message;
};

// commanded -> grind with hidden errors -> measure -> correct -> ... (MODEL.md
// §8).
ClosedLoopResult SimulateClosedLoop(
    const MachineModel& model,
    const Eigen::VectorXd& initial_commanded_parameters,
    const Eigen::VectorXd& hidden_errors,
    const Eigen::VectorXd& target_um,
    const ClosedLoopOptions& options);

}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_SIMULATION_MEASUREMENT_SIMULATOR_H_
