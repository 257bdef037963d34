// server/codec/json_read.h: the typed JSON readers every codec of the HTTP API
// (API.md) is built from, the API's error body, and grids of numbers in both
// directions. Knows no machine family.
//
//   nlohmann::json body;
//   ApiError error;
//   double noise_um = 0.0;
//   if (!ParseJsonBody(req.body, &body, &error) || !ReadNumber(body, "",
//   "noise_um", false, &noise_um, &error)) {
//     return RespondError(res, error);   // {"error": {"code", "message",
//     "field"}}
//   }
//
// Errors follow the closed list of api/openapi.yaml:
//   400 invalid_json     the body is not JSON (or nests deeper than
//   kMaxJsonDepth) 400 invalid_request  JSON of the wrong shape: a missing
//   field, a wrong type, a wrong length 422 invalid_value    well-formed but
//   impossible: an impossible gear, a range the wrong way
// and "field" names the place with the API's own names
// ("gear.normal_pressure_angle_deg", "grid.profile_range[0]",
// "measurement.deviations_um[2][7]").
#ifndef GEARLOOP_SERVER_CODEC_JSON_READ_H_
#define GEARLOOP_SERVER_CODEC_JSON_READ_H_

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace gearloop {

struct ApiError {
  int status = 400;
  std::string code;     // one of the closed list in api/openapi.yaml
  std::string message;  // for a person: what is wrong, in gear terms
  std::string field;    // path into the request with API names; empty when not
                        // about a field
};

// {"error": {"code": ..., "message": ..., "field": ...}}
nlohmann::json ErrorBody(const ApiError& error);

// Bodies nesting arrays/objects deeper than this are refused (400) before
// parsing: no request of the API nests beyond 5, and a deep nest is an attack
// on the parser's stack.
constexpr int kMaxJsonDepth = 32;

// Parses `text` as a JSON object. 400 invalid_json when it is not JSON, 400
// invalid_request when it is JSON but not an object.
bool ParseJsonBody(const std::string& text,
                   nlohmann::json* body,
                   ApiError* error);

// Reads a rows x columns grid of numbers (array of rows) at `path`. When
// `allow_null`, null entries are allowed and marked false in `present` (their
// value is 0); otherwise they are a 400. Wrong shapes are a 400 naming the row
// or entry; non-finite numbers a 422.
bool ParseGridValues(const nlohmann::json& value,
                     const std::string& path,
                     int rows,
                     int columns,
                     bool allow_null,
                     Eigen::VectorXd* values,
                     std::vector<bool>* present,
                     ApiError* error);

// A row-major vector as an array of rows; entries with present[i] == false (or
// a non-finite value) become null. `present` may be empty (all present).
nlohmann::json GridToJson(const Eigen::VectorXd& values,
                          const std::vector<bool>& present,
                          int rows,
                          int columns);

// `value` rounded to 9 decimals: degrees converted back from radians read as
// typed (15, not 14.999999999999998).
double RoundTo1e9(double value);

// Small typed readers used by the handlers; each fills `error` and returns
// false on failure. A missing member is an error only when `required`; *found
// tells whether it was there.
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
// ("hidden_errors.X_mm[2]"): not a number is a 400 "<entry> must be a number";
// not finite, or larger than max_abs in size, is a 422 "<entry> must be
// <requirement>" (requirement says which: "finite", "finite and at most 1e3 in
// size").
bool ReadCoefficient(const nlohmann::json& value,
                     const std::string& entry,
                     double max_abs,
                     const std::string& requirement,
                     double* coefficient,
                     ApiError* error);
// "a number", "an array", ...: the JSON type of `value` for error messages.
std::string TypeName(const nlohmann::json& value);
// `value` (named `path` in errors) as a finite number: 400 when not a number,
// 422 when not finite.
bool NumberFromJson(const nlohmann::json& value,
                    const std::string& path,
                    double* out,
                    ApiError* error);
// Reads an optional [begin, end] pair of numbers at `key` (absent: *begin and
// *end stay).
bool ReadRange(const nlohmann::json& object,
               const std::string& path,
               const char* key,
               double* begin,
               double* end,
               ApiError* error);
// Points *out at the object at `key` (nullptr when absent and not `required`);
// a non-object is a 400.
bool RequireObject(const nlohmann::json& request,
                   const std::string& path,
                   const char* key,
                   bool required,
                   const nlohmann::json** out,
                   ApiError* error);
// `path` joined with `key` ("gear" + "teeth" -> "gear.teeth"; "" + "gear" ->
// "gear").
std::string JoinPath(const std::string& path, const std::string& key);

// The name of `known` nearest to `name` by edit distance (at most a third of
// its length, and at least 1 allowed), or "" when none is near.
std::string NearestName(const std::string& name,
                        const std::vector<std::string>& known);
// Strict input: every key of `object` (at `path`) must be one of `allowed`.
// An unknown key is a 422 naming it as the client wrote it, and the nearest
// known key ("unknown key options.default_max_ordr; did you mean
// default_max_order?").
bool CheckKeys(const nlohmann::json& object,
               const std::string& path,
               const std::vector<std::string>& allowed,
               ApiError* error);

ApiError InvalidRequest(const std::string& field,
                        const std::string& message);  // 400
ApiError InvalidValue(const std::string& field,
                      const std::string& message);  // 422

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_CODEC_JSON_READ_H_
