// server/correction_codec.h: the correction request of POST /api/v1/corrections (also the
// items of a batch and the re-run of a replay) read from JSON into engine inputs, run, and the
// result written back as JSON plus the job record the history stores.
//
//   CorrectionRequest request;
//   ApiError error;
//   if (!ParseCorrectionRequest(body, &request, &error)) return RespondError(res, error);
//   CorrectionRun run;
//   if (!RunCorrection(request, &run, &error)) return RespondError(res, error);  // 422
//   // run.result_json, run.job (kind/links still to set), run.solve_seconds
//
// Request fields (API names):
//   gear, wheel, machine, grid, flank   the setup (ParseGrindingSetup)
//   settings                            the settings the measured part was ground with
//                                       (default: nominal)
//   measurement                         {"deviations_um": grid} (null = not delivered) or
//                                       {"teeth": [grid, ...]} (averaged point by point)
//   target                              {"deviations_um": grid} or {"modifications": [{kind,
//                                       amount_um, length_fraction, shape, ...}]}; default none
//   options                             solver options (CorrectionOptionsFromJson)
//   settings_source_job_id              the stored job whose corrected settings the measured
//                                       part was ground with (lineage); checked by the handler
#ifndef GEARLOOP_SERVER_CORRECTION_CODEC_H_
#define GEARLOOP_SERVER_CORRECTION_CODEC_H_

#include <cstdint>
#include <optional>
#include <string>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "engine/core/axis_motion.h"
#include "engine/correction/correction.h"
#include "engine/grinder/grinding_setup.h"
#include "engine/grinder/grinder_settings.h"
#include "server/codec/grinder_codec.h"
#include "storage/job_repository.h"

namespace gearloop {

struct CorrectionRequest {
  GrindingSetup setup;
  MachineSettings settings;
  Eigen::VectorXd measured_um;  // row-major, NaN = missing
  Eigen::VectorXd target_um;    // row-major
  CorrectionOptions options;
  std::optional<int64_t> settings_source_job_id;
};

// Reads and validates a whole correction request: 400 for shapes, 422 for values (with the
// field path), including options.IsValid.
bool ParseCorrectionRequest(const nlohmann::json& body, CorrectionRequest* request, ApiError* error);

// Reads "options" (an object, may be absent) into `options`, starting from the defaults.
// Fields: solver ("regularised" | "pso" | "lsq-plain"), mode ("next-part" | "rework"),
// default_max_order, max_order {block: order}, point_weights (grid), probe_noise_um,
// block_scales {block: scale}, min_flank_effect_um,
// max_num_iterations (<= 200), max_rework_passes (<= 20), outlier_threshold, outlier_min_um,
// max_outlier_fraction, pso_particles (<= 200), pso_generations (<= 2000; particles x generations x
// grid points <= 5e6 for the "pso" solver), pso_seed.
bool ParseCorrectionOptions(const nlohmann::json& body, int rows, int columns, CorrectionOptions* options,
                            ApiError* error);

// Reads "measurement" of `body`: {"deviations_um": grid} (null = not delivered, NaN in
// `measured_um`) or {"teeth": [grid, ...]} averaged point by point.
bool ParseCorrectionMeasurement(const nlohmann::json& body, int rows, int columns, Eigen::VectorXd* measured_um,
                                ApiError* error);

// Reads "target" of `body` (absent or null = no modification) into a row-major grid [um]:
// {"deviations_um": grid} or {"modifications": [{kind, amount_um, length_fraction, shape,
// second_amount_um, second_length_fraction, amount_gradient_um, second_amount_gradient_um}]}.
bool ParseCorrectionTarget(const nlohmann::json& body, const GrindingSetup& setup, int rows, int columns,
                           Eigen::VectorXd* target_um, ApiError* error);

// The solver's summary as the API reports it (status, residuals, rank, regularisation, sizes,
// outliers and missing points as {row, column}); `columns` is the grid's lead_points.
nlohmann::json CorrectionSummaryToJson(const CorrectionSummary& summary, int columns);

// The axis motion of a correction as the API reports it (engine/core/axis_motion.h): the change of
// each axis position at kAxisMotionSamples roll angles over the summary's roll range, with rms
// and max |.|, and the scalar (wheel) changes; units in the keys:
//   {"roll_rad": [...],
//    "axes": {"X": {"change_um": [...], "rms_um": r, "max_abs_um": m}, ..., "A": {"change_urad": ...}},
//    "wheel": {"cone_angle_rad": v, "parabola_coefficient_per_mm": v, "parabola_vertex_mm": v}}
nlohmann::json AxisMotionToJson(const AxisMotion& motion);
// The same for `delta` of a correction of `model` over the roll range of `summary`.
nlohmann::json CorrectionAxisMotionJson(const MachineModel& model, const Eigen::VectorXd& delta,
                                        const CorrectionSummary& summary);

struct CorrectionRun {
  CorrectionResult result;
  MachineSettings new_settings;
  nlohmann::json result_json;
  // Filled except id, created_utc, kind, request_json, server_version and the links.
  JobRecord job;
  double solve_seconds = 0.0;
};

// Builds the grinder, solves and renders. A solve the engine refuses as invalid input is a 422
// (false); a valid solve that does not converge is a normal run with its status.
bool RunCorrection(const CorrectionRequest& request, CorrectionRun* run, ApiError* error);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_CORRECTION_CODEC_H_
