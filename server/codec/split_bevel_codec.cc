#include "server/codec/split_bevel_codec.h"

#include <climits>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "engine/core/units.h"

namespace gearloop {
namespace {

// An optional number at `key`: stays empty when absent.
bool ReadOptional(const nlohmann::json& object,
                  const std::string& path,
                  const char* key,
                  std::optional<double>* out,
                  ApiError* error) {
  double value = 0.0;
  bool found = false;
  if (!ReadNumber(object, path, key, false, &value, error, &found))
    return false;
  if (found) *out = value;
  return true;
}

// An optional angle in degrees at `key`, kept in radians.
bool ReadOptionalAngle(const nlohmann::json& object,
                       const std::string& path,
                       const char* key,
                       std::optional<double>* out_rad,
                       ApiError* error) {
  std::optional<double> deg;
  if (!ReadOptional(object, path, key, &deg, error)) return false;
  if (deg) *out_rad = DegToRad(*deg);
  return true;
}

// An integer at `key` that must fit an int (the engine then checks its range).
bool ReadInt(const nlohmann::json& object,
             const std::string& path,
             const char* key,
             bool required,
             int* out,
             ApiError* error,
             bool* found = nullptr) {
  long long value = 0;
  bool present = false;
  if (!ReadInteger(object, path, key, required, &value, error, &present))
    return false;
  if (found != nullptr) *found = present;
  if (!present) return true;
  if (value < INT_MIN || value > INT_MAX) {
    const std::string field = JoinPath(path, key);
    *error = InvalidValue(field, field + " is out of range");
    return false;
  }
  *out = static_cast<int>(value);
  return true;
}

// A word of an enumeration: 422 naming the field when it is none of `words`.
bool ReadWord(const nlohmann::json& object,
              const std::string& path,
              const char* key,
              bool required,
              const std::vector<std::string>& words,
              std::string* out,
              ApiError* error,
              bool* found) {
  if (!ReadString(object, path, key, required, out, error, found)) return false;
  if (!*found) return true;
  for (const std::string& word : words)
    if (*out == word) return true;
  const std::string field = JoinPath(path, key);
  std::string list;
  for (const std::string& word : words)
    list += (list.empty() ? "\"" : " or \"") + word + "\"";
  *error = InvalidValue(field, field + " must be " + list);
  return false;
}

bool ParseGearSize(const nlohmann::json& gear,
                   SplitBevelGear* out,
                   ApiError* error) {
  return ReadOptional(gear,
                      "gear",
                      "outer_cone_distance_mm",
                      &out->outer_cone_distance_mm,
                      error) &&
         ReadOptional(gear,
                      "gear",
                      "outer_transverse_module_mm",
                      &out->outer_transverse_module_mm,
                      error) &&
         ReadNumber(
             gear, "gear", "face_width_mm", true, &out->face_width_mm, error) &&
         ReadOptionalAngle(gear,
                           "gear",
                           "mean_spiral_angle_deg",
                           &out->mean_spiral_angle_rad,
                           error) &&
         ReadOptionalAngle(gear,
                           "gear",
                           "outer_spiral_angle_deg",
                           &out->outer_spiral_angle_rad,
                           error);
}

bool ParseGear(const nlohmann::json& body,
               SplitBevelGear* out,
               ApiError* error) {
  const nlohmann::json* gear = nullptr;
  if (!RequireObject(body, "", "gear", true, &gear, error)) return false;
  double pitch_deg = 0.0, pressure_deg = 0.0;
  std::string hand;
  bool found = false;
  if (!CheckKeys(*gear,
                 "gear",
                 {"teeth",
                  "pitch_angle_deg",
                  "outer_cone_distance_mm",
                  "outer_transverse_module_mm",
                  "face_width_mm",
                  "mean_spiral_angle_deg",
                  "outer_spiral_angle_deg",
                  "hand",
                  "pressure_angle_deg",
                  "addendum_mm",
                  "dedendum_mm",
                  "slot_width_mm"},
                 error) ||
      !ReadInt(*gear, "gear", "teeth", true, &out->teeth, error) ||
      !ReadNumber(*gear, "gear", "pitch_angle_deg", true, &pitch_deg, error) ||
      !ParseGearSize(*gear, out, error) ||
      !ReadWord(*gear,
                "gear",
                "hand",
                true,
                {"left", "right"},
                &hand,
                error,
                &found) ||
      !ReadNumber(
          *gear, "gear", "pressure_angle_deg", true, &pressure_deg, error) ||
      !ReadOptional(*gear, "gear", "addendum_mm", &out->addendum_mm, error) ||
      !ReadOptional(*gear, "gear", "dedendum_mm", &out->dedendum_mm, error) ||
      !ReadOptional(*gear, "gear", "slot_width_mm", &out->slot_width_mm, error))
    return false;
  out->pitch_angle_rad = DegToRad(pitch_deg);
  out->pressure_angle_rad = DegToRad(pressure_deg);
  out->hand = hand == "left" ? SplitBevelHand::kLeft : SplitBevelHand::kRight;
  return true;
}

bool ParseTool(const nlohmann::json& body,
               SplitBevelTool* out,
               ApiError* error) {
  const nlohmann::json* tool = nullptr;
  return RequireObject(body, "", "tool", true, &tool, error) &&
         CheckKeys(*tool, "tool", {"radius_mm", "stock_mm"}, error) &&
         ReadNumber(*tool, "tool", "radius_mm", true, &out->radius_mm, error) &&
         ReadNumber(*tool, "tool", "stock_mm", false, &out->stock_mm, error);
}

// cut.flanks: an array of "convex" / "concave" (the engine refuses an empty
// list and repeats).
bool ParseFlanks(const nlohmann::json& cut,
                 std::vector<SplitBevelFlank>* out,
                 ApiError* error) {
  if (!cut.contains("flanks")) return true;
  const nlohmann::json& flanks = cut.at("flanks");
  if (!flanks.is_array()) {
    *error = InvalidRequest("cut.flanks",
                            "cut.flanks must be an array of \"convex\" and "
                            "\"concave\"");
    return false;
  }
  out->clear();
  for (size_t i = 0; i < flanks.size(); ++i) {
    const std::string field = "cut.flanks[" + std::to_string(i) + "]";
    if (!flanks[i].is_string()) {
      *error = InvalidRequest(field, field + " must be a string");
      return false;
    }
    const std::string word = flanks[i].get<std::string>();
    if (word != "convex" && word != "concave") {
      *error =
          InvalidValue(field, field + " must be \"convex\" or \"concave\"");
      return false;
    }
    out->push_back(word == "convex" ? SplitBevelFlank::kConvex
                                    : SplitBevelFlank::kConcave);
  }
  return true;
}

bool ParseCut(const nlohmann::json& body, SplitBevelCut* out, ApiError* error) {
  const nlohmann::json* cut = nullptr;
  if (!RequireObject(body, "", "cut", false, &cut, error)) return false;
  if (cut == nullptr) return true;
  int steps = 0;
  bool has_steps = false, has_from = false;
  std::string from;
  if (!CheckKeys(*cut,
                 "cut",
                 {"slot_index",
                  "flanks",
                  "depth_levels",
                  "steps",
                  "chord_tolerance_mm",
                  "from",
                  "feed_mm_per_min"},
                 error) ||
      !ReadInt(*cut, "cut", "slot_index", false, &out->slot_index, error) ||
      !ParseFlanks(*cut, &out->flanks, error) ||
      !ReadInt(*cut, "cut", "depth_levels", false, &out->depth_levels, error) ||
      !ReadInt(*cut, "cut", "steps", false, &steps, error, &has_steps) ||
      !ReadOptional(
          *cut, "cut", "chord_tolerance_mm", &out->chord_tolerance_mm, error) ||
      !ReadWord(*cut,
                "cut",
                "from",
                false,
                {"toe", "heel"},
                &from,
                error,
                &has_from) ||
      !ReadNumber(
          *cut, "cut", "feed_mm_per_min", false, &out->feed_mm_per_min, error))
    return false;
  if (has_steps) out->steps = steps;
  if (has_from && from == "heel") out->from = SplitBevelStart::kHeel;
  return true;
}

bool ParseMachine(const nlohmann::json& body,
                  SplitBevelMachine* out,
                  ApiError* error) {
  const nlohmann::json* machine = nullptr;
  if (!RequireObject(body, "", "machine", false, &machine, error)) return false;
  if (machine == nullptr) return true;
  HeadLimits& limits = out->limits;
  double a_min = RadToDeg(limits.a_min_rad), a_max = RadToDeg(limits.a_max_rad);
  double b_min = RadToDeg(limits.b_min_rad), b_max = RadToDeg(limits.b_max_rad);
  if (!CheckKeys(*machine,
                 "machine",
                 {"pivot_length_mm", "a_limits_deg", "b_limits_deg"},
                 error) ||
      !ReadNumber(*machine,
                  "machine",
                  "pivot_length_mm",
                  false,
                  &out->pivot_length_mm,
                  error) ||
      !ReadRange(*machine, "machine", "a_limits_deg", &a_min, &a_max, error) ||
      !ReadRange(*machine, "machine", "b_limits_deg", &b_min, &b_max, error))
    return false;
  if (machine->contains("a_limits_deg")) {
    limits.a_min_rad = DegToRad(a_min);
    limits.a_max_rad = DegToRad(a_max);
  }
  if (machine->contains("b_limits_deg")) {
    limits.b_min_rad = DegToRad(b_min);
    limits.b_max_rad = DegToRad(b_max);
  }
  return true;
}

bool ParseSetup(const nlohmann::json& body,
                SplitBevelSetup* out,
                ApiError* error) {
  const nlohmann::json* setup = nullptr;
  if (!RequireObject(body, "", "setup", false, &setup, error)) return false;
  if (setup == nullptr) return true;
  if (!CheckKeys(*setup,
                 "setup",
                 {"apex_mm", "segment_mid_deg", "segment_angle_deg"},
                 error))
    return false;
  if (setup->contains("apex_mm")) {
    const nlohmann::json& apex = setup->at("apex_mm");
    if (!apex.is_array() || apex.size() != 3) {
      *error = InvalidRequest("setup.apex_mm",
                              "setup.apex_mm must be an array of three numbers "
                              "[x, y, z]");
      return false;
    }
    for (int i = 0; i < 3; ++i) {
      if (!NumberFromJson(apex[i],
                          "setup.apex_mm[" + std::to_string(i) + "]",
                          &out->apex_mm[i],
                          error))
        return false;
    }
  }
  return ReadOptionalAngle(*setup,
                           "setup",
                           "segment_mid_deg",
                           &out->segment_mid_rad,
                           error) &&
         ReadOptionalAngle(*setup,
                           "setup",
                           "segment_angle_deg",
                           &out->segment_angle_rad,
                           error);
}

bool ParseOutput(const nlohmann::json& body, bool* nc, ApiError* error) {
  const nlohmann::json* output = nullptr;
  if (!RequireObject(body, "", "output", false, &output, error)) return false;
  return output == nullptr ||
         (CheckKeys(*output, "output", {"nc"}, error) &&
          ReadBool(*output, "output", "nc", false, nc, error));
}

}  // namespace

bool ParseSplitBevelRequest(const nlohmann::json& body,
                            SplitBevelRequest* request,
                            ApiError* error) {
  return ParseGear(body, &request->gear, error) &&
         ParseTool(body, &request->tool, error) &&
         ParseCut(body, &request->cut, error) &&
         ParseMachine(body, &request->machine, error) &&
         ParseSetup(body, &request->setup, error) &&
         ParseOutput(body, &request->nc_program, error);
}

bool CheckSplitBevelRequest(const SplitBevelRequest& request, ApiError* error) {
  std::string field, message;
  if (request.IsValid(&field, &message)) return true;
  *error = InvalidValue(field, message);
  return false;
}

ApiError SplitBevelResultError(const SplitBevelResult& result) {
  return InvalidValue(result.field, result.message);
}

std::string SplitBevelJobFlank(const SplitBevelRequest& request) {
  if (request.cut.flanks.size() == 1)
    return SplitBevelFlankName(request.cut.flanks[0]);
  return "both";
}

}  // namespace gearloop
