// server/codec/grinder_codec.h: the flat-wheel grinder's request pieces (gear,
// wheel, machine, grid, flank, settings) read from JSON into engine types, and
// the grinder's answers written back. Pure mapping: the engine's own validation
// (ValidateSetup) is called, no model is evaluated.
//
//   GrindingSetup setup;
//   ApiError error;
//   if (!ParseGrindingSetup(body, &setup, &error)) return RespondError(res,
//   error);
//
// Units: the API carries angles of the gear and the wheel profile in DEGREES
// (the engine in radians), the helix angle unsigned with a hand ("left" -> beta
// > 0, MODEL.md §1), axis coefficients as the machine takes them (X, Y, Z in
// mm, A, B, C in rad, per rad^k of roll).
#ifndef GEARLOOP_SERVER_CODEC_GRINDER_CODEC_H_
#define GEARLOOP_SERVER_CODEC_GRINDER_CODEC_H_

#include <nlohmann/json.hpp>
#include <string>

#include "engine/core/machine_model.h"
#include "engine/core/sensitivity.h"
#include "engine/grinder/flank_grid.h"
#include "engine/grinder/grinder_settings.h"
#include "engine/grinder/grinding_setup.h"
#include "server/codec/json_read.h"

namespace gearloop {

// Reads "gear", "wheel", "machine" (optional, zeros), "grid" (optional,
// defaults), "flank" (optional, "right") from `request` and validates them with
// the engine (ValidateSetup); engine field names in the engine's issue are
// mapped to the API's (ApiFieldPath).
bool ParseGrindingSetup(const nlohmann::json& request,
                        GrindingSetup* setup,
                        ApiError* error);

// Reads "gear", "grid" (optional, defaults) and "flank" (optional, "right")
// without a wheel or machine (a measured gear: POST
// /api/v1/measurements/import), validated with ValidateGear and ValidateGrid.
bool ParseGearGridAndFlank(const nlohmann::json& request,
                           GearData* gear,
                           GridOptions* grid,
                           Flank* flank,
                           ApiError* error);
// Reads the gear object at request[key] (teeth, normal_module_mm,
// normal_pressure_angle_deg, helix_angle_deg unsigned with hand,
// face_width_mm, tip_radius_mm, root_radius_mm) into `gear`; error fields are
// "<key>.<name>". Without `radii_required` absent radii leave their members
// as they were (the caller's default). No validation beyond types.
bool ReadGearData(const nlohmann::json& request,
                  const std::string& key,
                  bool radii_required,
                  GearData* gear,
                  ApiError* error);

// Reads the optional "grid" of `request` (profile_points, lead_points,
// profile_range, lead_range) over the defaults already in `grid`; the engine
// validates it (ValidateGrid).
bool ReadGridOptions(const nlohmann::json& request,
                     GridOptions* grid,
                     ApiError* error);

// Reads settings {"axes": {"X": [..7], ..., "C": [..]}, "wheel": {...}} found
// at `path` (for error fields). Each axis takes 1..7 coefficients (missing
// higher orders are 0); "wheel" is optional (a flat wheel).
bool ParseMachineSettings(const nlohmann::json& settings,
                          const std::string& path,
                          MachineSettings* result,
                          ApiError* error);

// The settings in the API's shape (cone angle in degrees).
nlohmann::json MachineSettingsToJson(const MachineSettings& settings);

// Maps an engine field path ("gear.normal_pressure_angle_rad",
// "grid.profile_begin", "settings.wheel.cone_angle_rad") to the API's name for
// it ("gear.normal_pressure_angle_deg", "grid.profile_range[0]",
// "settings.wheel.cone_angle_deg"). Unknown paths pass unchanged.
std::string ApiFieldPath(const std::string& engine_field);

// The API's view of the gear data ("helix_angle_deg" unsigned + "hand").
nlohmann::json GearToJson(const GearData& gear);
// "left" / "right".
const char* FlankName(Flank flank);
// "left" for beta > 0, "right" for beta < 0, "" for a spur gear.
std::string HandName(const GearData& gear);

// The evaluation of `settings` on the grid: "deviations_um" (null where not
// reached), "not_reached" [{row, column, status}], "reached", and "points"
// [{row, column, roll_length_mm, radius_mm, x_mm, position_mm [3], normal [3]}]
// in row-major order.
nlohmann::json EvaluationToJson(const FlankGrid& grid,
                                const ModelEvaluation& evaluation);

// POST /api/v1/nominal's answer: the nominal settings, the gear, the flank, its
// radii and roll lengths and the roll range [deg] of the grid.
nlohmann::json NominalToJson(const GrindingSetup& setup,
                             const MachineSettings& nominal,
                             double roll_min_rad,
                             double roll_max_rad);

// POST /api/v1/sensitivity's answer: the Jacobian `matrix_um` (cone-angle
// column per degree, as the API quotes it), its parameter names and units, the
// raw and the column-normalised singular values, rank and condition number, its
// size, and the points not reached.
nlohmann::json SensitivityToJson(const Eigen::MatrixXd& matrix_um,
                                 const SensitivitySummary& raw,
                                 const SensitivitySummary& normalised,
                                 const FlankGrid& grid,
                                 const ModelEvaluation& evaluation);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_CODEC_GRINDER_CODEC_H_
