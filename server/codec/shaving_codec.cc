#include "server/codec/shaving_codec.h"

#include <cmath>
#include <limits>
#include <vector>

#include "engine/core/units.h"
#include "server/codec/correction_codec.h"
#include "server/codec/grinder_codec.h"

namespace gearloop {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Puts `path` in front of the error's field (the request's own readers name
// fields relative to the shaving body).
bool Prefixed(const std::string& path, ApiError* error) {
  if (!path.empty())
    error->field = error->field.empty() ? path : JoinPath(path, error->field);
  return false;
}

// A gear whose absent radii (NaN after reading) are the standard ones.
bool ReadShavingGear(const nlohmann::json& body,
                     const char* key,
                     GearData* gear,
                     ApiError* error) {
  GearData read;
  read.tip_radius_mm = kNaN;
  read.root_radius_mm = kNaN;
  if (!ReadGearData(body, key, /*radii_required=*/false, &read, error))
    return false;
  GearData unset = read;
  unset.tip_radius_mm = 0.0;
  unset.root_radius_mm = 0.0;
  const GearData standard = WithStandardRadii(unset);
  if (std::isnan(read.tip_radius_mm))
    read.tip_radius_mm = standard.tip_radius_mm;
  if (std::isnan(read.root_radius_mm))
    read.root_radius_mm = standard.root_radius_mm;
  *gear = read;
  return true;
}

bool ReadDiagonalModification(const nlohmann::json& body,
                              DiagonalModification* m,
                              ApiError* error) {
  const nlohmann::json* object = nullptr;
  if (!RequireObject(body, "", "diagonal_modification", false, &object, error))
    return false;
  if (object == nullptr) return true;
  const std::string path = "diagonal_modification";
  long long exponent = m->exponent;
  if (!ReadNumber(*object, path, "root_um", false, &m->root_um, error) ||
      !ReadNumber(*object, path, "tip_um", false, &m->tip_um, error) ||
      !ReadNumber(*object, path, "root_band", false, &m->root_band, error) ||
      !ReadNumber(*object, path, "tip_band", false, &m->tip_band, error) ||
      !ReadInteger(*object, path, "exponent", false, &exponent, error) ||
      !ReadNumber(*object, path, "root_slope", false, &m->root_slope, error) ||
      !ReadNumber(*object, path, "tip_slope", false, &m->tip_slope, error)) {
    return false;
  }
  // Bounded before the narrowing; the engine says which values it takes.
  m->exponent =
      exponent < -1000 || exponent > 1000 ? 1000 : static_cast<int>(exponent);
  return true;
}

bool ReadWheelCheck(const nlohmann::json& body,
                    ShavingWheelCheck* check,
                    ApiError* error) {
  const nlohmann::json* object = nullptr;
  if (!RequireObject(body, "", "wheel_check", false, &object, error))
    return false;
  if (object == nullptr) return true;
  return ReadNumber(
             *object, "wheel_check", "h_s_mm", false, &check->h_s_mm, error) &&
         ReadNumber(*object,
                    "wheel_check",
                    "traverse_mm_per_rad",
                    false,
                    &check->traverse_mm_per_rad,
                    error);
}

nlohmann::json IndexList(const std::vector<GridIndex>& indices) {
  nlohmann::json list = nlohmann::json::array();
  for (const GridIndex& index : indices)
    list.push_back({index.row, index.column});
  return list;
}

nlohmann::json ContactsToJson(const ShavingResult& result) {
  nlohmann::json rows = nlohmann::json::array();
  for (int r = 0; r < result.rows; ++r) {
    nlohmann::json row = nlohmann::json::array();
    for (int c = 0; c < result.columns; ++c) {
      const size_t i = static_cast<size_t>(r * result.columns + c);
      if (i >= result.contacts.size() ||
          !std::isfinite(result.contacts[i].roll_length_mm)) {
        row.push_back(nullptr);
        continue;
      }
      const ShavingContact& contact = result.contacts[i];
      row.push_back({{"roll_length_mm", contact.roll_length_mm},
                     {"x_mm", contact.x_mm},
                     {"work_angle_rad", contact.work_angle_rad},
                     {"work_relief_um", FiniteOrNull(contact.work_relief_um)},
                     {"status", ShavingPointStatusName(result.status[i])}});
    }
    rows.push_back(std::move(row));
  }
  return rows;
}

// Strict input: the keys of a shaving request (at `path`: "" or
// "target.shaving") and of its diagonal modification and wheel check, named
// in full. The gears and the grid check their own.
bool CheckShavingKeys(const nlohmann::json& body,
                      const std::string& path,
                      ApiError* error) {
  const auto nested = [&](const char* key) {
    return body.contains(key) ? body.at(key) : nlohmann::json();
  };
  return CheckKeys(body,
                   path,
                   {"work_gear",
                    "cutter",
                    "centre_distance_mm",
                    "diagonal_modification",
                    "grid",
                    "wheel_check"},
                   error) &&
         CheckKeys(nested("diagonal_modification"),
                   JoinPath(path, "diagonal_modification"),
                   {"root_um",
                    "tip_um",
                    "root_band",
                    "tip_band",
                    "exponent",
                    "root_slope",
                    "tip_slope"},
                   error) &&
         CheckKeys(nested("wheel_check"),
                   JoinPath(path, "wheel_check"),
                   {"h_s_mm", "traverse_mm_per_rad"},
                   error);
}

}  // namespace

bool ReadShavingInput(const nlohmann::json& body,
                      const std::string& path,
                      ShavingInput* input,
                      bool* grid_given,
                      ApiError* error) {
  if (!body.is_object()) {
    *error = InvalidRequest(
        path,
        (path.empty() ? "the body" : path) + std::string(" must be an object"));
    return false;
  }
  ShavingInput in = *input;
  double centre_distance_mm = 0.0;
  bool centre_distance_given = false;
  if (!CheckShavingKeys(body, path, error)) return false;
  if (!ReadShavingGear(body, "work_gear", &in.work_gear, error) ||
      !ReadShavingGear(body, "cutter", &in.cutter, error) ||
      !ReadNumber(body,
                  "",
                  "centre_distance_mm",
                  false,
                  &centre_distance_mm,
                  error,
                  &centre_distance_given) ||
      !ReadDiagonalModification(body, &in.diagonal_modification, error) ||
      !ReadGridOptions(body, &in.grid, error) ||
      !ReadWheelCheck(body, &in.wheel_check, error)) {
    return Prefixed(path, error);
  }
  if (centre_distance_given) in.centre_distance_mm = centre_distance_mm;
  if (grid_given != nullptr)
    *grid_given = body.contains("grid") && !body.at("grid").is_null();
  *input = in;
  return true;
}

bool ValidateShavingInput(const ShavingInput& input,
                          const std::string& path,
                          ApiError* error) {
  ValidationIssue issue;
  if (input.IsValid(&issue)) return true;
  *error = InvalidValue(ApiFieldPath(issue.field), issue.message);
  return Prefixed(path, error);
}

bool ParseShavingInput(const nlohmann::json& body,
                       const std::string& path,
                       ShavingInput* input,
                       ApiError* error) {
  ShavingInput in;
  if (!ReadShavingInput(body, path, &in, nullptr, error) ||
      !ValidateShavingInput(in, path, error))
    return false;
  *input = in;
  return true;
}

bool CheckShavingResult(const ShavingResult& result,
                        const std::string& path,
                        ApiError* error) {
  if (result.summary.IsSolutionUsable()) return true;
  const std::string field =
      result.summary.field.empty() ? "grid" : result.summary.field;
  *error = InvalidValue(ApiFieldPath(field), result.summary.message);
  return Prefixed(path, error);
}

std::vector<bool> ShavingGeneratedPoints(const ShavingResult& result) {
  std::vector<bool> generated(result.status.size());
  for (size_t i = 0; i < result.status.size(); ++i)
    generated[i] = result.status[i] == ShavingPointStatus::kOk;
  return generated;
}

nlohmann::json ShavingResultToJson(const ShavingResult& result,
                                   double elapsed_ms) {
  const std::vector<bool> generated = ShavingGeneratedPoints(result);
  const int rows = result.rows;
  const int columns = result.columns;
  const ShavingSummary& s = result.summary;
  return {
      {"crossed_axes_angle_deg",
       RoundTo1e9(result.crossed_axes_angle_rad * kDegPerRad)},
      {"centre_distance_mm", result.centre_distance_mm},
      {"delta_s_um", GridToJson(result.delta_s_um, generated, rows, columns)},
      {"base_um", GridToJson(result.base_um, generated, rows, columns)},
      {"stock_target_um",
       GridToJson(result.stock_target_um, generated, rows, columns)},
      {"outside_work_flank", IndexList(result.outside_work_flank)},
      {"not_converged", IndexList(result.not_converged)},
      {"contacts", ContactsToJson(result)},
      {"contact_line_length_mm", result.contact_line_length_mm},
      {"wheel_radius_min_mm",
       {{"fixed", result.wheel.wheel_radius_min_fixed_mm},
        {"traversing", result.wheel.wheel_radius_min_traversing_mm}}},
      {"contact_line_fixed_mm", result.wheel.contact_line_fixed_mm},
      {"contact_line_traversing_mm", result.wheel.contact_line_traversing_mm},
      {"contact_angle_deg", result.wheel.contact_angle_rad * kDegPerRad},
      {"rows", rows},
      {"columns", columns},
      {"points", s.num_points},
      {"generated", s.num_solved},
      {"elapsed_ms", elapsed_ms},
  };
}

}  // namespace gearloop
