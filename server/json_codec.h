// server/json_codec.h: JSON <-> engine types for the HTTP API (API.md), and the API's error
// body. The only place where JSON field names meet engine field names.
//
//   nlohmann::json body;
//   ApiError error;
//   GrindingSetup setup;
//   if (!ParseJsonBody(req.body, &body, &error) || !ParseGrindingSetup(body, &setup, &error)) {
//     return RespondError(res, error);   // {"error": {"code", "message", "field"}}
//   }
//
// Units: the API carries angles of the gear and the wheel profile in DEGREES (the engine in
// radians), the helix angle unsigned with a hand ("left" -> beta > 0, MODEL.md §1), axis
// coefficients as the machine takes them (X, Y, Z in mm, A, B, C in rad, per rad^k of roll).
//
// Errors follow the closed list of api/openapi.yaml:
//   400 invalid_json     the body is not JSON (or nests deeper than kMaxJsonDepth)
//   400 invalid_request  JSON of the wrong shape: a missing field, a wrong type, a wrong length
//   422 invalid_value    well-formed but impossible: an impossible gear, a range the wrong way
// and "field" names the place with the API's own names ("gear.normal_pressure_angle_deg",
// "grid.profile_range[0]", "measurement.deviations_um[2][7]").
#ifndef GEARLOOP_SERVER_JSON_CODEC_H_
#define GEARLOOP_SERVER_JSON_CODEC_H_

#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "engine/grinder/flank_grid.h"
#include "engine/grinder/grinding_setup.h"
#include "engine/core/machine_model.h"
#include "engine/grinder/grinder_settings.h"

namespace gearloop {

struct ApiError {
  int status = 400;
  std::string code;     // one of the closed list in api/openapi.yaml
  std::string message;  // for a person: what is wrong, in gear terms
  std::string field;    // path into the request with API names; empty when not about a field
};

// {"error": {"code": ..., "message": ..., "field": ...}}
nlohmann::json ErrorBody(const ApiError& error);

// Bodies nesting arrays/objects deeper than this are refused (400) before parsing: no request
// of the API nests beyond 5, and a deep nest is an attack on the parser's stack.
constexpr int kMaxJsonDepth = 32;

// Parses `text` as a JSON object. 400 invalid_json when it is not JSON, 400 invalid_request
// when it is JSON but not an object.
bool ParseJsonBody(const std::string& text, nlohmann::json* body, ApiError* error);

// Reads "gear", "wheel", "machine" (optional, zeros), "grid" (optional, defaults), "flank"
// (optional, "right") from `request` and validates them with the engine (ValidateSetup);
// engine field names in the engine's issue are mapped to the API's (ApiFieldPath).
bool ParseGrindingSetup(const nlohmann::json& request, GrindingSetup* setup, ApiError* error);

// Reads settings {"axes": {"X": [..7], ..., "C": [..]}, "wheel": {...}} found at `path` (for
// error fields). Each axis takes 1..7 coefficients (missing higher orders are 0); "wheel" is
// optional (a flat wheel).
bool ParseMachineSettings(const nlohmann::json& settings,
                          const std::string& path,
                          MachineSettings* result,
                          ApiError* error);

// The settings in the API's shape (cone angle in degrees).
nlohmann::json MachineSettingsToJson(const MachineSettings& settings);

// Maps an engine field path ("gear.normal_pressure_angle_rad", "grid.profile_begin",
// "settings.wheel.cone_angle_rad") to the API's name for it ("gear.normal_pressure_angle_deg",
// "grid.profile_range[0]", "settings.wheel.cone_angle_deg"). Unknown paths pass unchanged.
std::string ApiFieldPath(const std::string& engine_field);

// Reads a rows x columns grid of numbers (array of rows) at `path`. When `allow_null`, null
// entries are allowed and marked false in `present` (their value is 0); otherwise they are a
// 400. Wrong shapes are a 400 naming the row or entry; non-finite numbers a 422.
bool ParseGridValues(const nlohmann::json& value,
                     const std::string& path,
                     int rows,
                     int columns,
                     bool allow_null,
                     Eigen::VectorXd* values,
                     std::vector<bool>* present,
                     ApiError* error);

// A row-major vector as an array of rows; entries with present[i] == false (or a non-finite
// value) become null. `present` may be empty (all present).
nlohmann::json GridToJson(const Eigen::VectorXd& values, const std::vector<bool>& present, int rows, int columns);

// The API's view of the gear data ("helix_angle_deg" unsigned + "hand").
nlohmann::json GearToJson(const GearData& gear);
// `value` rounded to 9 decimals: degrees converted back from radians read as typed (15, not
// 14.999999999999998).
double RoundTo1e9(double value);
// "left" / "right".
const char* FlankName(Flank flank);
// "left" for beta > 0, "right" for beta < 0, "" for a spur gear.
std::string HandName(const GearData& gear);

// The evaluation of `settings` on the grid: "deviations_um" (null where not reached),
// "not_reached" [{row, column, status}], "reached", and "points" [{row, column,
// roll_length_mm, radius_mm, x_mm, position_mm [3], normal [3]}] in row-major order.
nlohmann::json EvaluationToJson(const FlankGrid& grid, const ModelEvaluation& evaluation);

// Small typed readers used by the handlers; each fills `error` and returns false on failure.
// A missing member is an error only when `required`; *found tells whether it was there.
bool ReadNumber(const nlohmann::json& object,
                const std::string& path,
                const char* key,
                bool required,
                double* value,
                ApiError* error,
                bool* found = nullptr);
bool ReadInteger(const nlohmann::json& object,
                 const std::string& path,
                 const char* key,
                 bool required,
                 long long* value,
                 ApiError* error,
                 bool* found = nullptr);
bool ReadString(const nlohmann::json& object,
                const std::string& path,
                const char* key,
                bool required,
                std::string* value,
                ApiError* error,
                bool* found = nullptr);
bool ReadBool(const nlohmann::json& object,
              const std::string& path,
              const char* key,
              bool required,
              bool* value,
              ApiError* error,
              bool* found = nullptr);
// One coefficient of a polynomial given as a JSON array, `entry` naming it
// ("hidden_errors.X_mm[2]"): not a number is a 400 "<entry> must be a number"; not finite, or
// larger than max_abs in size, is a 422 "<entry> must be <requirement>" (requirement says
// which: "finite", "finite and at most 1e3 in size").
bool ReadCoefficient(const nlohmann::json& value,
                     const std::string& entry,
                     double max_abs,
                     const std::string& requirement,
                     double* coefficient,
                     ApiError* error);
// `path` joined with `key` ("gear" + "teeth" -> "gear.teeth"; "" + "gear" -> "gear").
std::string JoinPath(const std::string& path, const std::string& key);

ApiError InvalidRequest(const std::string& field, const std::string& message);  // 400
ApiError InvalidValue(const std::string& field, const std::string& message);    // 422

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_JSON_CODEC_H_
