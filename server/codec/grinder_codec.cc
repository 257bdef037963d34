#include "server/codec/grinder_codec.h"

#include <cmath>
#include <map>

#include "engine/core/units.h"
#include "server/codec/machine_kind.h"

namespace gearloop {
namespace {

const char* kAxisNames[kNumAxes] = {"X", "Y", "Z", "A", "B", "C"};

}  // namespace

std::string ApiFieldPath(const std::string& engine_field) {
  static const std::map<std::string, std::string> kRenames = {
      {"gear.normal_pressure_angle_rad", "gear.normal_pressure_angle_deg"},
      {"gear.helix_angle_rad", "gear.helix_angle_deg"},
      {"grid.profile_begin", "grid.profile_range[0]"},
      {"grid.profile_end", "grid.profile_range[1]"},
      {"grid.lead_begin", "grid.lead_range[0]"},
      {"grid.lead_end", "grid.lead_range[1]"},
      {"wheel.cone_angle_rad", "settings.wheel.cone_angle_deg"},
      {"settings.wheel.cone_angle_rad", "settings.wheel.cone_angle_deg"},
  };
  const auto it = kRenames.find(engine_field);
  if (it != kRenames.end()) return it->second;
  // Any other angle (*_rad) of the engine is *_deg in the API; a rate per
  // radian (machine.traverse_mm_per_rad) is read as the client wrote it.
  const std::string suffix = "_rad";
  const std::string per_rad = "_per_rad";
  const bool is_rate =
      engine_field.size() > per_rad.size() &&
      engine_field.compare(
          engine_field.size() - per_rad.size(), per_rad.size(), per_rad) == 0;
  if (!is_rate && engine_field.size() > suffix.size() &&
      engine_field.compare(
          engine_field.size() - suffix.size(), suffix.size(), suffix) == 0) {
    return engine_field.substr(0, engine_field.size() - suffix.size()) + "_deg";
  }
  return engine_field;
}

namespace {

// Reads <path>.hand into the sign of the helix angle (MODEL.md §1: beta > 0 is
// a left-hand helix); a helical gear needs it.
bool ReadGearHand(const nlohmann::json& gear,
                  const std::string& path,
                  double helix_angle_deg,
                  double* sign,
                  ApiError* error) {
  std::string hand;
  bool hand_found = false;
  if (!ReadString(gear, path, "hand", false, &hand, error, &hand_found))
    return false;
  const std::string field = JoinPath(path, "hand");
  if (hand_found) {
    if (hand == "left") {
      *sign = 1.0;
    } else if (hand == "right") {
      *sign = -1.0;
    } else {
      *error = InvalidValue(field, field + " must be \"left\" or \"right\"");
      return false;
    }
  } else if (helix_angle_deg != 0.0) {
    *error = InvalidRequest(field,
                            "missing required field " + field +
                                " (a helical gear needs \"left\" or "
                                "\"right\")");
    return false;
  }
  return true;
}

// Reads the gear: teeth, module, angles, widths, radii and hand.
bool ReadGear(const nlohmann::json& request,
              GrindingSetup* s,
              ApiError* error) {
  return ReadGearData(
      request, "gear", /*radii_required=*/true, &s->gear, error);
}

}  // namespace

bool ReadGearData(const nlohmann::json& request,
                  const std::string& key,
                  bool radii_required,
                  GearData* out,
                  ApiError* error) {
  const nlohmann::json* gear = nullptr;
  if (!RequireObject(request, "", key.c_str(), /*required=*/true, &gear, error))
    return false;
  const std::string& path = key;
  if (!CheckKeys(*gear,
                 path,
                 {"teeth",
                  "normal_module_mm",
                  "normal_pressure_angle_deg",
                  "helix_angle_deg",
                  "hand",
                  "face_width_mm",
                  "tip_radius_mm",
                  "root_radius_mm"},
                 error))
    return false;
  long long teeth = 0;
  double pressure_angle_deg = 0.0;
  double helix_angle_deg = 0.0;
  if (!ReadInteger(*gear, path, "teeth", true, &teeth, error) ||
      !ReadNumber(*gear,
                  path,
                  "normal_module_mm",
                  true,
                  &out->normal_module_mm,
                  error) ||
      !ReadNumber(*gear,
                  path,
                  "normal_pressure_angle_deg",
                  true,
                  &pressure_angle_deg,
                  error) ||
      !ReadNumber(
          *gear, path, "helix_angle_deg", true, &helix_angle_deg, error) ||
      !ReadNumber(
          *gear, path, "face_width_mm", true, &out->face_width_mm, error) ||
      !ReadNumber(*gear,
                  path,
                  "tip_radius_mm",
                  radii_required,
                  &out->tip_radius_mm,
                  error) ||
      !ReadNumber(*gear,
                  path,
                  "root_radius_mm",
                  radii_required,
                  &out->root_radius_mm,
                  error)) {
    return false;
  }
  if (teeth < -1000000 || teeth > 1000000) {
    *error = InvalidValue(JoinPath(path, "teeth"),
                          JoinPath(path, "teeth") + " is out of range, got " +
                              std::to_string(teeth));
    return false;
  }
  out->teeth = static_cast<int>(teeth);
  if (helix_angle_deg < 0.0) {
    const std::string field = JoinPath(path, "helix_angle_deg");
    *error = InvalidValue(field,
                          field + " is unsigned (give the hand in " +
                              JoinPath(path, "hand") + "), got " +
                              nlohmann::json(helix_angle_deg).dump());
    return false;
  }
  double sign = 0.0;
  if (!ReadGearHand(*gear, path, helix_angle_deg, &sign, error)) return false;
  out->normal_pressure_angle_rad = pressure_angle_deg * kRadPerDeg;
  // MODEL.md §1: beta > 0 is a left-hand helix.
  out->helix_angle_rad = sign * helix_angle_deg * kRadPerDeg;
  return true;
}

namespace {

// Reads the wheel radius.
bool ReadWheel(const nlohmann::json& request,
               GrindingSetup* s,
               ApiError* error) {
  const nlohmann::json* wheel = nullptr;
  if (!RequireObject(request, "", "wheel", true, &wheel, error) ||
      !CheckKeys(*wheel, "wheel", {"radius_mm"}, error) ||
      !ReadNumber(
          *wheel, "wheel", "radius_mm", true, &s->wheel.radius_mm, error)) {
    return false;
  }
  return true;
}

// Reads the optional machine constants (flat-wheel grinders only).
bool ReadMachine(const nlohmann::json& request,
                 GrindingSetup* s,
                 ApiError* error) {
  const nlohmann::json* machine = nullptr;
  if (!RequireObject(request, "", "machine", false, &machine, error))
    return false;
  if (machine != nullptr) {
    if (!RequireFlatWheelGrinder(request, error)) return false;
    if (!CheckKeys(*machine,
                   "machine",
                   {"kind", "k1_mm", "k2_mm", "traverse_mm_per_rad"},
                   error) ||
        !ReadNumber(
            *machine, "machine", "k1_mm", false, &s->machine.k1_mm, error) ||
        !ReadNumber(
            *machine, "machine", "k2_mm", false, &s->machine.k2_mm, error) ||
        !ReadNumber(*machine,
                    "machine",
                    "traverse_mm_per_rad",
                    false,
                    &s->machine.traverse_mm_per_rad,
                    error)) {
      return false;
    }
  }
  return true;
}

// Reads the optional evaluation grid.
bool ReadGrid(const nlohmann::json& request,
              GrindingSetup* s,
              ApiError* error) {
  return ReadGridOptions(request, &s->grid, error);
}

}  // namespace

bool ReadGridOptions(const nlohmann::json& request,
                     GridOptions* grid_options,
                     ApiError* error) {
  const nlohmann::json* grid = nullptr;
  if (!RequireObject(request, "", "grid", false, &grid, error)) return false;
  if (grid != nullptr) {
    long long profile_points = grid_options->profile_points;
    long long lead_points = grid_options->lead_points;
    if (!CheckKeys(
            *grid,
            "grid",
            {"profile_points", "lead_points", "profile_range", "lead_range"},
            error) ||
        !ReadInteger(
            *grid, "grid", "profile_points", false, &profile_points, error) ||
        !ReadInteger(
            *grid, "grid", "lead_points", false, &lead_points, error) ||
        !ReadRange(*grid,
                   "grid",
                   "profile_range",
                   &grid_options->profile_begin,
                   &grid_options->profile_end,
                   error) ||
        !ReadRange(*grid,
                   "grid",
                   "lead_range",
                   &grid_options->lead_begin,
                   &grid_options->lead_end,
                   error)) {
      return false;
    }
    // Bounded before the narrowing; the engine checks the real limits.
    if (profile_points < 0 || profile_points > 10000) {
      *error = InvalidValue("grid.profile_points",
                            "grid.profile_points is out of range");
      return false;
    }
    if (lead_points < 0 || lead_points > 10000) {
      *error =
          InvalidValue("grid.lead_points", "grid.lead_points is out of range");
      return false;
    }
    grid_options->profile_points = static_cast<int>(profile_points);
    grid_options->lead_points = static_cast<int>(lead_points);
  }
  return true;
}

namespace {

// Reads the flank, right unless given.
bool ReadFlank(const nlohmann::json& request,
               GrindingSetup* s,
               ApiError* error) {
  std::string flank = "right";
  if (!ReadString(request, "", "flank", false, &flank, error)) return false;
  if (flank == "right") {
    s->flank = Flank::kRight;
  } else if (flank == "left") {
    s->flank = Flank::kLeft;
  } else {
    *error = InvalidValue("flank", "flank must be \"left\" or \"right\"");
    return false;
  }
  return true;
}

}  // namespace

bool ParseGrindingSetup(const nlohmann::json& request,
                        GrindingSetup* setup,
                        ApiError* error) {
  GrindingSetup s;
  if (!ReadGear(request, &s, error) || !ReadWheel(request, &s, error) ||
      !ReadMachine(request, &s, error) || !ReadGrid(request, &s, error) ||
      !ReadFlank(request, &s, error)) {
    return false;
  }

  ValidationIssue issue;
  if (!ValidateSetup(s, &issue)) {
    *error = InvalidValue(ApiFieldPath(issue.field), issue.message);
    return false;
  }
  *setup = s;
  return true;
}

bool ParseGearGridAndFlank(const nlohmann::json& request,
                           GearData* gear,
                           GridOptions* grid,
                           Flank* flank,
                           ApiError* error) {
  GrindingSetup s;
  if (!ReadGear(request, &s, error) || !ReadGrid(request, &s, error) ||
      !ReadFlank(request, &s, error)) {
    return false;
  }
  ValidationIssue issue;
  if (!ValidateGear(s.gear, &issue) || !ValidateGrid(s.grid, &issue)) {
    *error = InvalidValue(ApiFieldPath(issue.field), issue.message);
    return false;
  }
  *gear = s.gear;
  *grid = s.grid;
  *flank = s.flank;
  return true;
}

namespace {

// Reads the polynomial coefficients of the six axes; every axis is required
// and no other is allowed.
bool ReadAxes(const nlohmann::json& settings,
              const std::string& path,
              MachineSettings* s,
              ApiError* error) {
  const nlohmann::json* axes = nullptr;
  if (!RequireObject(settings, path, "axes", true, &axes, error)) return false;
  const std::string axes_path = JoinPath(path, "axes");
  for (int i = 0; i < kNumAxes; ++i) {
    const std::string field = JoinPath(axes_path, kAxisNames[i]);
    if (!axes->contains(kAxisNames[i])) {
      *error = InvalidRequest(field, "missing required field " + field);
      return false;
    }
    const nlohmann::json& coefficients = axes->at(kAxisNames[i]);
    if (!coefficients.is_array() || coefficients.empty() ||
        coefficients.size() > static_cast<size_t>(kCoefficientsPerAxis)) {
      *error = InvalidRequest(field,
                              field +
                                  " must be an array of 1 to 7 numbers "
                                  "(coefficient k multiplies roll^k)");
      return false;
    }
    for (size_t k = 0; k < coefficients.size(); ++k) {
      if (!NumberFromJson(coefficients[k],
                          field + "[" + std::to_string(k) + "]",
                          &s->axes[i][k],
                          error))
        return false;
      // A unit mistake, not a motion: more than 1e6 mm (or rad) from the
      // term at a roll of 0.1 rad. An order-6 correction over a roll range of
      // a few tenths of a radian has coefficients of 1e5-1e6 per um of motion
      // in rad^-6 (a plain least-squares job reached 1.3e6 for C's square).
      if (std::fabs(s->axes[i][k]) > 1e6 * std::pow(10.0, k)) {
        *error = InvalidValue(field + "[" + std::to_string(k) + "]",
                              "axis coefficient is implausibly large (beyond "
                              "1e6 x 10^k for the power k)");
        return false;
      }
    }
  }
  for (const auto& item : axes->items()) {
    bool known = false;
    for (const char* name : kAxisNames) known = known || item.key() == name;
    if (!known) {
      *error = InvalidRequest(
          JoinPath(axes_path, item.key()),
          "unknown axis " + item.key() + " (axes are X, Y, Z, A, B, C)");
      return false;
    }
  }
  return true;
}

// Reads the optional wheel shape: cone angle and parabola.
bool ReadWheelShape(const nlohmann::json& settings,
                    const std::string& path,
                    MachineSettings* s,
                    ApiError* error) {
  const nlohmann::json* wheel = nullptr;
  if (!RequireObject(settings, path, "wheel", false, &wheel, error))
    return false;
  if (wheel != nullptr) {
    const std::string wheel_path = JoinPath(path, "wheel");
    if (!CheckKeys(*wheel,
                   wheel_path,
                   {"cone_angle_deg",
                    "parabola_coefficient_per_mm",
                    "parabola_vertex_mm"},
                   error))
      return false;
    double cone_angle_deg = 0.0;
    if (!ReadNumber(*wheel,
                    wheel_path,
                    "cone_angle_deg",
                    false,
                    &cone_angle_deg,
                    error) ||
        !ReadNumber(*wheel,
                    wheel_path,
                    "parabola_coefficient_per_mm",
                    false,
                    &s->wheel.parabola_coefficient_per_mm,
                    error) ||
        !ReadNumber(*wheel,
                    wheel_path,
                    "parabola_vertex_mm",
                    false,
                    &s->wheel.parabola_vertex_mm,
                    error)) {
      return false;
    }
    if (std::fabs(cone_angle_deg) >= 45.0) {
      *error =
          InvalidValue(JoinPath(wheel_path, "cone_angle_deg"),
                       "the wheel cone angle must lie within (-45, 45) deg");
      return false;
    }
    if (std::fabs(s->wheel.parabola_coefficient_per_mm) > 1.0) {
      *error =
          InvalidValue(JoinPath(wheel_path, "parabola_coefficient_per_mm"),
                       "the parabola coefficient must lie within [-1, 1] 1/mm");
      return false;
    }
    if (std::fabs(s->wheel.parabola_vertex_mm) > 1e4) {
      *error = InvalidValue(JoinPath(wheel_path, "parabola_vertex_mm"),
                            "the parabola vertex must lie within 1e4 mm");
      return false;
    }
    s->wheel.cone_angle_rad = cone_angle_deg * kRadPerDeg;
  }
  return true;
}

}  // namespace

bool ParseMachineSettings(const nlohmann::json& settings,
                          const std::string& path,
                          MachineSettings* result,
                          ApiError* error) {
  if (!settings.is_object()) {
    *error = InvalidRequest(
        path, path + " must be an object, got " + TypeName(settings));
    return false;
  }
  MachineSettings s;
  if (!CheckKeys(settings, path, {"axes", "wheel"}, error) ||
      !ReadAxes(settings, path, &s, error) ||
      !ReadWheelShape(settings, path, &s, error))
    return false;
  *result = s;
  return true;
}

nlohmann::json MachineSettingsToJson(const MachineSettings& settings) {
  nlohmann::json axes = nlohmann::json::object();
  for (int i = 0; i < kNumAxes; ++i) {
    nlohmann::json coefficients = nlohmann::json::array();
    for (int k = 0; k < kCoefficientsPerAxis; ++k)
      coefficients.push_back(settings.axes[i][k]);
    axes[kAxisNames[i]] = coefficients;
  }
  return {{"axes", axes},
          {"wheel",
           {{"cone_angle_deg", settings.wheel.cone_angle_rad / kRadPerDeg},
            {"parabola_coefficient_per_mm",
             settings.wheel.parabola_coefficient_per_mm},
            {"parabola_vertex_mm", settings.wheel.parabola_vertex_mm}}}};
}

const char* FlankName(Flank flank) {
  return flank == Flank::kLeft ? "left" : "right";
}

std::string HandName(const GearData& gear) {
  if (gear.helix_angle_rad > 0.0) return "left";
  if (gear.helix_angle_rad < 0.0) return "right";
  return "";
}

nlohmann::json GearToJson(const GearData& gear) {
  nlohmann::json j = {
      {"teeth", gear.teeth},
      {"normal_module_mm", gear.normal_module_mm},
      {"normal_pressure_angle_deg",
       RoundTo1e9(gear.normal_pressure_angle_rad / kRadPerDeg)},
      {"helix_angle_deg",
       RoundTo1e9(std::fabs(gear.helix_angle_rad) / kRadPerDeg)},
      {"face_width_mm", gear.face_width_mm},
      {"tip_radius_mm", gear.tip_radius_mm},
      {"root_radius_mm", gear.root_radius_mm}};
  const std::string hand = HandName(gear);
  if (!hand.empty()) j["hand"] = hand;
  return j;
}

nlohmann::json EvaluationToJson(const FlankGrid& grid,
                                const ModelEvaluation& evaluation) {
  std::vector<bool> present(grid.NumPoints());
  nlohmann::json not_reached = nlohmann::json::array();
  nlohmann::json points = nlohmann::json::array();
  int reached = 0;
  for (int i = 0; i < grid.NumPoints(); ++i) {
    const FlankGridPoint& p = grid.points[i];
    present[i] = evaluation.status[i] == PointStatus::kOk;
    if (present[i]) {
      ++reached;
    } else {
      not_reached.push_back(
          {{"row", p.row},
           {"column", p.column},
           {"status", PointStatusName(evaluation.status[i])}});
    }
    points.push_back(
        {{"row", p.row},
         {"column", p.column},
         {"roll_length_mm", p.roll_length_mm},
         {"radius_mm", p.radius_mm},
         {"x_mm", p.x_mm},
         {"position_mm",
          {p.position_mm.x(), p.position_mm.y(), p.position_mm.z()}},
         {"normal", {p.normal.x(), p.normal.y(), p.normal.z()}}});
  }
  return {
      {"rows", grid.rows},
      {"columns", grid.columns},
      {"deviations_um",
       GridToJson(evaluation.deviations_um, present, grid.rows, grid.columns)},
      {"not_reached", not_reached},
      {"reached", reached},
      {"points", points}};
}

nlohmann::json NominalToJson(const GrindingSetup& setup,
                             const MachineSettings& nominal,
                             double roll_min_rad,
                             double roll_max_rad) {
  const GearData& g = setup.gear;
  return {{"settings", MachineSettingsToJson(nominal)},
          {"gear", GearToJson(g)},
          {"flank", FlankName(setup.flank)},
          {"pitch_radius_mm", g.PitchRadiusMm()},
          {"base_radius_mm", g.BaseRadiusMm()},
          {"transverse_pressure_angle_deg",
           g.TransversePressureAngleRad() * kDegPerRad},
          {"form_roll_length_mm", g.FormRollLengthMm()},
          {"tip_roll_length_mm", g.TipRollLengthMm()},
          {"roll_range_deg",
           {roll_min_rad * kDegPerRad, roll_max_rad * kDegPerRad}}};
}

namespace {

nlohmann::json SensitivitySummaryToJson(const SensitivitySummary& s) {
  nlohmann::json values = nlohmann::json::array();
  for (int i = 0; i < s.singular_values.size(); ++i)
    values.push_back(s.singular_values(i));
  return nlohmann::json{
      {"singular_values", values},
      {"rank", s.rank},
      {"condition_number",
       std::isfinite(s.condition_number) ? nlohmann::json(s.condition_number)
                                         : nlohmann::json(nullptr)}};
}

}  // namespace

nlohmann::json SensitivityToJson(const Eigen::MatrixXd& matrix,
                                 const SensitivitySummary& raw,
                                 const SensitivitySummary& normalised,
                                 const FlankGrid& grid,
                                 const ModelEvaluation& evaluation) {
  nlohmann::json rows = nlohmann::json::array();
  for (int i = 0; i < matrix.rows(); ++i) {
    nlohmann::json row = nlohmann::json::array();
    for (int j = 0; j < matrix.cols(); ++j) row.push_back(matrix(i, j));
    rows.push_back(row);
  }
  nlohmann::json names = nlohmann::json::array();
  nlohmann::json units = nlohmann::json::array();
  for (int j = 0; j < kNumGrinderParameters; ++j) {
    names.push_back(GrinderParameterName(j));
    std::string unit = j == kConeAngleIndex ? "deg" : GrinderParameterUnit(j);
    units.push_back("um/" + unit);
  }
  nlohmann::json answer = SensitivitySummaryToJson(raw);
  nlohmann::json evaluated = EvaluationToJson(grid, evaluation);
  answer["matrix"] = rows;
  answer["parameters"] = names;
  answer["units"] = units;
  answer["normalised"] = SensitivitySummaryToJson(normalised);
  answer["rows"] = grid.rows * grid.columns;
  answer["columns"] = kNumGrinderParameters;
  answer["not_reached"] = evaluated["not_reached"];
  return answer;
}

}  // namespace gearloop
