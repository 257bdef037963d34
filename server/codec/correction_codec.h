// server/codec/correction_codec.h: the machine-independent part of a correction
// request (POST /api/v1/corrections, the items of a batch, the re-run of a
// replay) read from JSON, and the solver's summary and axis motion written
// back. Pure mapping: no solve, no model evaluation, no job record
// (server/services/correction_service.h runs and stores).
//
//   CorrectionRequest request;
//   ApiError error;
//   if (!ParseCorrectionRequest(body, rows, columns,
//   /*target_modifications_allowed=*/true, &request,
//                               &error)) {
//     return RespondError(res, error);
//   }
//
// Request fields (API names), besides the machine's own
// (server/services/machine_family.h):
//   measurement             {"deviations_um": grid} (null = not delivered) or
//   {"teeth": [grid,
//                           ...]} (several teeth of the flank, averaged by the
//                           engine)
//   target                  {"deviations_um": grid} or {"modifications":
//   [{kind, amount_um,
//                           length_fraction, shape, ...}]}; default none
//   options                 solver options (ParseCorrectionOptions)
//   settings_source_job_id  the stored job whose corrected settings the
//   measured part was ground
//                           with (lineage); its existence is checked by the
//                           service
#ifndef GEARLOOP_SERVER_CODEC_CORRECTION_CODEC_H_
#define GEARLOOP_SERVER_CODEC_CORRECTION_CODEC_H_

#include <Eigen/Core>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "engine/core/axis_motion.h"
#include "engine/correction/correction.h"
#include "engine/grinder/target_modification.h"
#include "engine/shaving/cutter_target.h"
#include "server/codec/json_read.h"

namespace gearloop {

struct CorrectionRequest {
  // One measured grid (row-major, NaN = missing), or several teeth of the flank
  // (then measured_um is empty and the engine averages them:
  // CorrectionInput::measured_teeth_um).
  Eigen::VectorXd measured_um;
  std::vector<Eigen::VectorXd> measured_teeth_um;
  // The target [um], row-major; zero when the target is given as modifications,
  // which the machine family evaluates on its flank.
  Eigen::VectorXd target_um;
  std::optional<std::vector<TargetModification>> target_modifications;
  // target {"shaving": {...}} (SHAVING.md, flat-wheel grinder): the shaving
  // request as read, not yet validated (the service fits it to the machine's
  // gear and grid, then validates and resolves it into target_um).
  std::optional<ShavingInput> target_shaving;
  bool target_shaving_grid_given = false;
  // target.stock_target_um beside "shaving": the target resolved before (the
  // server writes it into the stored request), row-major, with the points the
  // work gear generates (false = null, weight 0). Used as is: nothing is
  // recomputed.
  std::optional<Eigen::VectorXd> target_shaving_resolved_um;
  std::vector<bool> target_shaving_generated;
  CorrectionOptions options;
  std::optional<int64_t> settings_source_job_id;
};

// A measured or target deviation larger than this is taken for a unit mistake
// (a grid in nm where the API speaks um): 422 naming the entry, unless the
// request says "allow_large_deviations": true.
constexpr double kMaxPlausibleDeviationUm = 500.0;

// Reads measurement, target, options and settings_source_job_id on a rows x
// columns grid: 400 for shapes, 422 for values (with the field path), including
// options.IsValid. Without `target_modifications_allowed` (a family without
// involute modifications) a target with "modifications" is a 422.
bool ParseCorrectionRequest(const nlohmann::json& body,
                            int rows,
                            int columns,
                            bool target_modifications_allowed,
                            CorrectionRequest* request,
                            ApiError* error);

// Reads "options" (an object, may be absent) into `options`, starting from the
// defaults. Fields: solver ("regularised" | "pso" | "lsq-plain"), mode
// ("next-part" | "rework"), default_max_order, max_order {block: order},
// point_weights (grid), probe_noise_um, block_scales {block: scale},
// min_flank_effect_um, max_num_iterations (<= 200), max_rework_passes (<= 20),
// outlier_threshold, outlier_min_um, max_outlier_fraction, pso_particles (<=
// 200), pso_generations (<= 2000; particles x generations x grid points <= 5e6
// for the "pso" solver), pso_seed.
bool ParseCorrectionOptions(const nlohmann::json& body,
                            int rows,
                            int columns,
                            CorrectionOptions* options,
                            ApiError* error);

// Reads "measurement" of `body`: {"deviations_um": grid} into `measured_um`
// (null = not delivered, NaN) or {"teeth": [grid, ...]} into
// `measured_teeth_um` (one grid per tooth).
bool ParseCorrectionMeasurement(const nlohmann::json& body,
                                int rows,
                                int columns,
                                Eigen::VectorXd* measured_um,
                                std::vector<Eigen::VectorXd>* measured_teeth_um,
                                ApiError* error);

// Reads "target" of `body` (absent or null = no modification) into a row-major
// grid [um]:
// {"deviations_um": grid}, or {"modifications": [{kind, amount_um,
// length_fraction, shape, second_amount_um, second_length_fraction,
// amount_gradient_um, second_amount_gradient_um}]} into `modifications` (each
// validated; `target_um` is then zero). A {"shaving": ...} target is a 422
// here: only a correction resolves it (ParseShavingTarget and the service).
bool ParseCorrectionTarget(
    const nlohmann::json& body,
    int rows,
    int columns,
    Eigen::VectorXd* target_um,
    std::optional<std::vector<TargetModification>>* modifications,
    ApiError* error);

// Reads target {"shaving": {...}, "stock_target_um": grid (optional)} of
// `body` into request->target_shaving (codec/shaving_codec.h; fields
// "target.shaving.*") and, when given, the resolved grid (nulls allowed) into
// target_shaving_resolved_um / target_shaving_generated. Absent: nothing set.
bool ParseShavingTarget(const nlohmann::json& body,
                        int rows,
                        int columns,
                        CorrectionRequest* request,
                        ApiError* error);

// True when body.target is an object holding "shaving".
bool HasShavingTarget(const nlohmann::json& body);

// True when body.target is an object holding "modifications".
bool HasTargetModifications(const nlohmann::json& body);

// Reads settings_source_job_id (absent or null = none; an id >= 1 otherwise).
bool ParseSettingsSourceJobId(const nlohmann::json& body,
                              std::optional<int64_t>* id,
                              ApiError* error);

// The solver's summary as the API reports it (status, residuals, rank,
// regularisation, sizes, outliers and missing points as {row, column});
// `columns` is the grid's lead_points.
nlohmann::json CorrectionSummaryToJson(const CorrectionSummary& summary,
                                       int columns);

// The axis motion of a correction as the API reports it
// (engine/core/axis_motion.h): the change of each axis position at
// kAxisMotionSamples roll angles over the summary's roll range, with rms and
// max |.|, and the scalar (wheel) changes; units in the keys:
//   {"roll_rad": [...],
//    "axes": {"X": {"change_um": [...], "rms_um": r, "max_abs_um": m}, ...,
//    "A": {"change_urad": ...}}, "wheel": {"cone_angle_rad": v,
//    "parabola_coefficient_per_mm": v, "parabola_vertex_mm": v}}
nlohmann::json AxisMotionToJson(const AxisMotion& motion);

// `value`, or null when it is not finite (JSON has no NaN).
nlohmann::json FiniteOrNull(double value);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_CODEC_CORRECTION_CODEC_H_
