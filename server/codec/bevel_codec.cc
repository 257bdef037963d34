#include "server/codec/bevel_codec.h"

#include <cmath>
#include <limits>
#include <vector>

#include "engine/core/units.h"

namespace gearloop {
namespace {
// Bevel motion coefficients (and their hidden errors) may be any finite value.
const char* const kAxisKeys[kNumFreeFormAxes] = {
    "A_rad", "B_rad", "X_mm", "Y_mm", "Z_mm"};

// Engine field "machine.cradle_angle_rad" -> API
// "job.machine.cradle_angle_deg".
std::string ApiBevelField(const std::string& engine_field) {
  std::string field = engine_field;
  const std::string rad = "_rad";
  const bool is_rate =
      field.size() > 8 && field.compare(field.size() - 8, 8, "_per_rad") == 0;
  if (!is_rate && field.size() > rad.size() &&
      field.compare(field.size() - rad.size(), rad.size(), rad) == 0) {
    field = field.substr(0, field.size() - rad.size()) + "_deg";
  }
  return "job." + field;
}

// One numeric field of the job: `degrees` fields are read in degrees into
// radians.
struct JobField {
  const char* key;
  double* value;
  bool degrees;
  bool required_without_published;
};

// Strict input: the group's keys are its fields and `other_keys` (read by the
// caller).
bool ReadJobFields(const nlohmann::json& job,
                   const char* group,
                   bool published,
                   std::vector<JobField> fields,
                   ApiError* error,
                   const std::vector<std::string>& other_keys = {}) {
  const std::string path = std::string("job.") + group;
  const bool present = job.contains(group);
  if (present && !job.at(group).is_object()) {
    *error = InvalidRequest(path, path + " must be an object");
    return false;
  }
  const nlohmann::json empty = nlohmann::json::object();
  const nlohmann::json& object = present ? job.at(group) : empty;
  std::vector<std::string> keys = other_keys;
  for (const JobField& f : fields) keys.push_back(f.key);
  if (!CheckKeys(object, path, keys, error)) return false;
  for (const JobField& f : fields) {
    double v = 0.0;
    bool found = false;
    if (!ReadNumber(object,
                    path,
                    f.key,
                    !published && f.required_without_published,
                    &v,
                    error,
                    &found))
      return false;
    if (found) *f.value = f.degrees ? v * kRadPerDeg : v;
  }
  return true;
}

bool ReadIntField(const nlohmann::json& object,
                  const std::string& path,
                  const char* key,
                  int* value,
                  ApiError* error) {
  long long v = *value;
  bool found = false;
  if (!ReadInteger(object, path, key, false, &v, error, &found)) return false;
  if (found) {
    if (v < -1000000 || v > 1000000) {
      *error = InvalidValue(JoinPath(path, key),
                            JoinPath(path, key) + " is out of range");
      return false;
    }
    *value = static_cast<int>(v);
  }
  return true;
}

nlohmann::json EntryToJson(const AxisSensitivityEntry& e,
                           bool with_grid,
                           int rows,
                           int columns) {
  const bool angular = e.axis == "A" || e.axis == "B";
  nlohmann::json j = {
      {"parameter", e.parameter},
      {"axis", e.axis},
      {"order", e.order},
      {"error", e.error},
      {"error_unit",
       std::string(angular ? "rad" : "mm") +
           (e.order == 0 ? "" : "/rad^" + std::to_string(e.order))},
      {"max_abs_um", e.max_abs_um},
      {"mean_abs_um", e.mean_abs_um},
      {"rms_um", e.rms_um},
      {"min_um", e.min_um},
      {"max_um", e.max_um}};
  if (with_grid) {
    j["exact_max_abs_um"] = e.exact_max_abs_um;
    j["grid_um"] = GridToJson(e.grid_um, {}, rows, columns);
  }
  return j;
}

}  // namespace

nlohmann::json GridPointsToJson(const BevelFlankGrid& grid) {
  nlohmann::json points = nlohmann::json::array();
  for (const BevelGridPoint& p : grid.points) {
    points.push_back(
        {{"row", p.row},
         {"column", p.column},
         {"cone_distance_mm", p.cone_distance_mm},
         {"polar_angle_deg", p.polar_angle_rad * kDegPerRad},
         {"roll_deg", p.contact.roll_rad * kDegPerRad},
         {"blade_u_mm", p.contact.blade_u_mm},
         {"position_mm",
          {p.position_mm.x(), p.position_mm.y(), p.position_mm.z()}},
         {"normal", {p.normal.x(), p.normal.y(), p.normal.z()}}});
  }
  return points;
}

namespace {

// Reads job.side and job.published and starts the job from them: the
// published job of that side, or an empty one with the side's blade.
bool ReadJobSide(const nlohmann::json& j,
                 BevelPinionJob* job,
                 bool* published,
                 ApiError* error) {
  std::string side;
  if (!ReadString(j, "job", "side", true, &side, error)) return false;
  BevelFlankSide flank_side;
  if (side == "convex") {
    flank_side = BevelFlankSide::kConvex;
  } else if (side == "concave") {
    flank_side = BevelFlankSide::kConcave;
  } else {
    *error =
        InvalidValue("job.side", "job.side must be \"convex\" or \"concave\"");
    return false;
  }
  if (!ReadBool(j, "job", "published", false, published, error)) return false;
  if (*published) {
    *job = PublishedPinionJob(flank_side);
  } else {
    job->side = flank_side;
    // The convex side is cut by the inside blade, the concave side by the
    // outside blade (§1).
    job->cutter.blade = flank_side == BevelFlankSide::kConvex
                            ? BevelBlade::kInside
                            : BevelBlade::kOutside;
  }
  return true;
}

// Reads job.cutter and job.machine (all fields required unless published).
bool ReadCutterAndMachine(const nlohmann::json& j,
                          bool published,
                          BevelPinionJob* job,
                          ApiError* error) {
  CradleMachineSettings& m = job->machine;
  if (!ReadJobFields(
          j,
          "cutter",
          published,
          {{"point_radius_mm", &job->cutter.point_radius_mm, false, true},
           {"blade_angle_deg", &job->cutter.blade_angle_rad, true, true},
           {"edge_radius_mm", &job->cutter.edge_radius_mm, false, false}},
          error) ||
      !ReadJobFields(
          j,
          "machine",
          published,
          {{"blank_offset_mm", &m.blank_offset_mm, false, true},
           {"horizontal_offset_mm", &m.horizontal_offset_mm, false, true},
           {"sliding_base_mm", &m.sliding_base_mm, false, true},
           {"machine_root_angle_deg", &m.machine_root_angle_rad, true, true},
           {"eccentric_angle_deg", &m.eccentric_angle_rad, true, true},
           {"eccentric_mm", &m.eccentric_mm, false, false},
           {"cradle_angle_deg", &m.cradle_angle_rad, true, true},
           {"tilt_rotation_deg", &m.tilt_rotation_rad, true, true},
           {"tilt_axis_inclination_deg",
            &m.tilt_axis_inclination_rad,
            true,
            false},
           {"tilt_axis_mounting_deg", &m.tilt_axis_mounting_rad, true, false},
           {"ratio_of_roll", &m.ratio_of_roll, false, true}},
          error)) {
    return false;
  }
  return true;
}

// Reads job.blank and job.grid.
bool ReadBlankAndGrid(const nlohmann::json& j,
                      bool published,
                      BevelPinionJob* job,
                      ApiError* error) {
  if (!ReadJobFields(
          j,
          "blank",
          published,
          {{"outer_cone_distance_mm",
            &job->blank.outer_cone_distance_mm,
            false,
            true},
           {"inner_cone_distance_mm",
            &job->blank.inner_cone_distance_mm,
            false,
            true},
           {"face_angle_deg", &job->blank.face_angle_rad, true, true},
           {"root_angle_deg", &job->blank.root_angle_rad, true, true}},
          error) ||
      !ReadJobFields(j,
                     "grid",
                     true,
                     {{"profile_min_fraction",
                       &job->grid.profile_min_fraction,
                       false,
                       false},
                      {"profile_max_fraction",
                       &job->grid.profile_max_fraction,
                       false,
                       false},
                      {"lengthwise_min_fraction",
                       &job->grid.lengthwise_min_fraction,
                       false,
                       false},
                      {"lengthwise_max_fraction",
                       &job->grid.lengthwise_max_fraction,
                       false,
                       false}},
                     error,
                     {"profile_points", "lengthwise_points"})) {
    return false;
  }
  if (j.contains("grid")) {
    if (!ReadIntField(j.at("grid"),
                      "job.grid",
                      "profile_points",
                      &job->grid.profile_points,
                      error) ||
        !ReadIntField(j.at("grid"),
                      "job.grid",
                      "lengthwise_points",
                      &job->grid.lengthwise_points,
                      error)) {
      return false;
    }
  }
  return true;
}

}  // namespace

bool ParseBevelJob(const nlohmann::json& body,
                   BevelPinionJob* result,
                   ApiError* error) {
  if (!body.contains("job")) {
    *error = InvalidRequest("job", "missing required field job");
    return false;
  }
  const nlohmann::json& j = body.at("job");
  if (!j.is_object()) {
    *error = InvalidRequest("job",
                            "job must be an object {\"side\": \"convex\", "
                            "\"published\": true} or a summary");
    return false;
  }
  BevelPinionJob job;
  bool published = false;
  if (!CheckKeys(j,
                 "job",
                 {"side", "published", "cutter", "machine", "blank", "grid"},
                 error) ||
      !ReadJobSide(j, &job, &published, error) ||
      !ReadCutterAndMachine(j, published, &job, error) ||
      !ReadBlankAndGrid(j, published, &job, error))
    return false;
  std::string field, message;
  if (!job.IsValid(&field, &message)) {
    const std::string api_field = ApiBevelField(field);
    *error = InvalidValue(api_field, api_field + " " + message);
    return false;
  }
  *result = job;
  return true;
}

nlohmann::json BevelJobToJson(const BevelPinionJob& job) {
  const CradleMachineSettings& m = job.machine;
  return {
      {"side", BevelFlankSideName(job.side)},
      {"cutter",
       {{"point_radius_mm", job.cutter.point_radius_mm},
        {"blade_angle_deg",
         RoundTo1e9(job.cutter.blade_angle_rad * kDegPerRad)},
        {"edge_radius_mm", job.cutter.edge_radius_mm},
        {"blade",
         job.cutter.blade == BevelBlade::kInside ? "inside" : "outside"}}},
      {"machine",
       {{"blank_offset_mm", m.blank_offset_mm},
        {"horizontal_offset_mm", m.horizontal_offset_mm},
        {"sliding_base_mm", m.sliding_base_mm},
        {"machine_root_angle_deg",
         RoundTo1e9(m.machine_root_angle_rad * kDegPerRad)},
        {"eccentric_angle_deg", RoundTo1e9(m.eccentric_angle_rad * kDegPerRad)},
        {"eccentric_mm", m.eccentric_mm},
        {"cradle_angle_deg", RoundTo1e9(m.cradle_angle_rad * kDegPerRad)},
        {"tilt_rotation_deg", RoundTo1e9(m.tilt_rotation_rad * kDegPerRad)},
        {"tilt_axis_inclination_deg",
         RoundTo1e9(m.tilt_axis_inclination_rad * kDegPerRad)},
        {"tilt_axis_mounting_deg",
         RoundTo1e9(m.tilt_axis_mounting_rad * kDegPerRad)},
        {"ratio_of_roll", m.ratio_of_roll}}},
      {"blank",
       {{"outer_cone_distance_mm", job.blank.outer_cone_distance_mm},
        {"inner_cone_distance_mm", job.blank.inner_cone_distance_mm},
        {"face_angle_deg", RoundTo1e9(job.blank.face_angle_rad * kDegPerRad)},
        {"root_angle_deg", RoundTo1e9(job.blank.root_angle_rad * kDegPerRad)}}},
      {"grid",
       {{"profile_points", job.grid.profile_points},
        {"lengthwise_points", job.grid.lengthwise_points},
        {"profile_min_fraction", job.grid.profile_min_fraction},
        {"profile_max_fraction", job.grid.profile_max_fraction},
        {"lengthwise_min_fraction", job.grid.lengthwise_min_fraction},
        {"lengthwise_max_fraction", job.grid.lengthwise_max_fraction}}}};
}

bool ParseFreeFormMotion(const nlohmann::json& value,
                         const std::string& path,
                         FreeFormMotion* motion,
                         ApiError* error) {
  if (!value.is_object()) {
    *error = InvalidRequest(
        path,
        path + " must be an object {\"A_rad\": [...], ..., \"Z_mm\": [...]}");
    return false;
  }
  std::vector<std::vector<double>> axes(kNumFreeFormAxes + 1);
  const char* keys[kNumFreeFormAxes + 1] = {
      "A_rad", "B_rad", "X_mm", "Y_mm", "Z_mm", "C_rad"};
  // "degree" is in answers; an answer's motion may be sent back as it is.
  if (!CheckKeys(value,
                 path,
                 {"degree", "A_rad", "B_rad", "X_mm", "Y_mm", "Z_mm", "C_rad"},
                 error))
    return false;
  for (int i = 0; i <= kNumFreeFormAxes; ++i) {
    const std::string field = JoinPath(path, keys[i]);
    if (!value.contains(keys[i])) {
      if (i == kNumFreeFormAxes) continue;  // C is optional
      *error = InvalidRequest(field, "missing required field " + field);
      return false;
    }
    const nlohmann::json& list = value.at(keys[i]);
    if (!list.is_array() || list.empty() || list.size() > 13) {
      *error = InvalidRequest(
          field, field + " must be an array of 1 to 13 coefficients");
      return false;
    }
    for (size_t k = 0; k < list.size(); ++k) {
      double v = 0.0;
      // A machine's axis travels are metres at most: a coefficient beyond
      // 1e6 (mm or rad per rad^k) is a unit mistake, not a motion.
      if (!ReadCoefficient(list[k],
                           field + "[" + std::to_string(k) + "]",
                           /*max_abs=*/1e6,
                           "finite and at most 1e6 in size",
                           &v,
                           error))
        return false;
      axes[i].push_back(v);
    }
  }
  const size_t length = axes[0].size();
  for (int i = 1; i < kNumFreeFormAxes; ++i) {
    if (axes[i].size() != length) {
      const std::string field = JoinPath(path, kAxisKeys[i]);
      *error = InvalidRequest(field,
                              field + " must have as many coefficients as " +
                                  JoinPath(path, "A_rad") + " (" +
                                  std::to_string(length) + ")");
      return false;
    }
  }
  FreeFormMotion m = FreeFormMotion::Zero(static_cast<int>(length) - 1);
  for (int i = 0; i < kNumFreeFormAxes; ++i) {
    for (size_t k = 0; k < length; ++k) m.coefficients[i](k) = axes[i][k];
  }
  m.c_coefficients = Eigen::Map<const Eigen::VectorXd>(
      axes[kNumFreeFormAxes].data(),
      static_cast<Eigen::Index>(axes[kNumFreeFormAxes].size()));
  *motion = m;
  return true;
}

nlohmann::json FreeFormMotionToJson(const FreeFormMotion& motion) {
  nlohmann::json j = {{"degree", motion.degree}};
  for (int i = 0; i < kNumFreeFormAxes; ++i) {
    nlohmann::json list = nlohmann::json::array();
    for (int k = 0; k < motion.coefficients[i].size(); ++k)
      list.push_back(motion.coefficients[i](k));
    j[kAxisKeys[i]] = list;
  }
  if (motion.c_coefficients.size() > 0) {
    nlohmann::json list = nlohmann::json::array();
    for (int k = 0; k < motion.c_coefficients.size(); ++k)
      list.push_back(motion.c_coefficients(k));
    j["C_rad"] = list;
  }
  return j;
}

// The keys of a conversion's options (roll_margin_fraction: the share of the
// roll range added at each end, ConversionOptions).
const std::vector<std::string> kConversionOptionKeys = {"polynomial_degree",
                                                        "max_flank_distance_um",
                                                        "num_samples",
                                                        "num_check_samples",
                                                        "roll_margin_fraction"};

bool ParseConversionOptions(const nlohmann::json& body,
                            ConversionOptions* result,
                            ApiError* error) {
  ConversionOptions options;
  if (body.contains("options") && !body.at("options").is_null()) {
    const nlohmann::json& o = body.at("options");
    if (!o.is_object()) {
      *error = InvalidRequest("options", "options must be an object");
      return false;
    }
    bool degree_found = false, tolerance_found = false;
    long long degree = options.polynomial_degree;
    if (!CheckKeys(o, "options", kConversionOptionKeys, error) ||
        !ReadInteger(o,
                     "options",
                     "polynomial_degree",
                     false,
                     &degree,
                     error,
                     &degree_found) ||
        !ReadNumber(o,
                    "options",
                    "max_flank_distance_um",
                    false,
                    &options.max_flank_distance_um,
                    error,
                    &tolerance_found) ||
        !ReadIntField(
            o, "options", "num_samples", &options.num_samples, error) ||
        !ReadIntField(o,
                      "options",
                      "num_check_samples",
                      &options.num_check_samples,
                      error) ||
        !ReadNumber(o,
                    "options",
                    "roll_margin_fraction",
                    false,
                    &options.roll_margin_fraction,
                    error)) {
      return false;
    }
    if (degree_found && tolerance_found) {
      *error = InvalidValue("options.max_flank_distance_um",
                            "give options.polynomial_degree or "
                            "options.max_flank_distance_um, not both");
      return false;
    }
    if (degree_found && (degree < 1 || degree > 12)) {
      *error = InvalidValue("options.polynomial_degree",
                            "options.polynomial_degree must lie in [1, 12]");
      return false;
    }
    options.polynomial_degree = static_cast<int>(degree);
    options.choose_degree = tolerance_found;
    if (tolerance_found && !(options.max_flank_distance_um > 0.0)) {
      *error = InvalidValue("options.max_flank_distance_um",
                            "options.max_flank_distance_um must be > 0");
      return false;
    }
    // Each sample costs a Ceres polish; keep one request short.
    if (options.num_samples > 2000 || options.num_check_samples > 5000) {
      *error = InvalidValue("options.num_samples",
                            "at most 2000 fit samples and 5000 check samples");
      return false;
    }
  }
  std::string message;
  if (!options.IsValid(&message)) {
    *error = InvalidValue("options", message);
    return false;
  }
  *result = options;
  return true;
}

nlohmann::json ConversionToJson(const BevelPinionJob& job,
                                const ConversionResult& c) {
  nlohmann::json fit = nlohmann::json::array();
  for (const AxisFitReport& r : c.fit) {
    fit.push_back({{"axis", r.axis},
                   {"max_" + r.unit, r.max_residual},
                   {"rms_" + r.unit, r.rms_residual}});
  }
  return {{"job", BevelJobToJson(job)},
          {"degree", c.motion.degree},
          {"motion", FreeFormMotionToJson(c.motion)},
          {"roll_range_deg",
           {c.roll_min_rad * kDegPerRad, c.roll_max_rad * kDegPerRad}},
          {"fit_residual", fit},
          {"exact",
           {{"max_rotation_difference", c.exact_max_rotation_difference},
            {"max_translation_difference_mm",
             c.exact_max_translation_difference_mm},
            {"max_closed_form_residual", c.max_closed_form_residual},
            {"max_polished_residual", c.max_polished_residual}}},
          {"fitted",
           {{"max_rotation_difference", c.fitted_max_rotation_difference},
            {"max_translation_difference_mm",
             c.fitted_max_translation_difference_mm}}},
          {"flank_distance",
           {{"max_um", c.flank_max_distance_um},
            {"rms_um", c.flank_rms_distance_um},
            {"points_found", c.flank_points_found},
            {"points", c.grid.NumPoints()}}},
          {"rows", c.grid.rows},
          {"columns", c.grid.columns},
          {"points", GridPointsToJson(c.grid)}};
}

nlohmann::json BevelEvaluationToJson(const BevelPinionJob& job,
                                     const FreeFormMotion& motion,
                                     const BevelFlankGrid& grid,
                                     const ModelEvaluation& evaluation) {
  const int rows = grid.rows;
  const int columns = grid.columns;
  std::vector<bool> present(evaluation.status.size());
  nlohmann::json not_reached = nlohmann::json::array();
  int reached = 0;
  for (size_t i = 0; i < evaluation.status.size(); ++i) {
    present[i] = evaluation.status[i] == PointStatus::kOk;
    reached += present[i];
    if (!present[i]) {
      not_reached.push_back(
          {{"row", static_cast<int>(i) / columns},
           {"column", static_cast<int>(i) % columns},
           {"status", PointStatusName(evaluation.status[i])}});
    }
  }
  return {{"job", BevelJobToJson(job)},
          {"motion", FreeFormMotionToJson(motion)},
          {"rows", rows},
          {"columns", columns},
          {"deviations_um",
           GridToJson(evaluation.deviations_um, present, rows, columns)},
          {"not_reached", not_reached},
          {"reached", reached},
          {"points", GridPointsToJson(grid)}};
}

bool ParseAxisSensitivityOptions(const nlohmann::json& body,
                                 AxisSensitivityOptions* result,
                                 ApiError* error) {
  AxisSensitivityOptions options;
  if (body.contains("errors") && !body.at("errors").is_null()) {
    const nlohmann::json& e = body.at("errors");
    if (!e.is_object()) {
      *error = InvalidRequest("errors",
                              "errors must be an object {linear_error_mm, "
                              "angular_error_deg, exact}");
      return false;
    }
    double angular_deg = options.angular_error_rad * kDegPerRad;
    if (!CheckKeys(e,
                   "errors",
                   {"linear_error_mm", "angular_error_deg", "exact"},
                   error) ||
        !ReadNumber(e,
                    "errors",
                    "linear_error_mm",
                    false,
                    &options.linear_error_mm,
                    error) ||
        !ReadNumber(
            e, "errors", "angular_error_deg", false, &angular_deg, error) ||
        !ReadBool(e, "errors", "exact", false, &options.exact, error)) {
      return false;
    }
    if (!(options.linear_error_mm > 0.0 && options.linear_error_mm <= 10.0)) {
      *error = InvalidValue("errors.linear_error_mm",
                            "errors.linear_error_mm must lie in (0, 10] mm");
      return false;
    }
    if (!(angular_deg > 0.0 && angular_deg <= 10.0)) {
      *error = InvalidValue("errors.angular_error_deg",
                            "errors.angular_error_deg must lie in (0, 10] deg");
      return false;
    }
    options.angular_error_rad = angular_deg * kRadPerDeg;
  }
  std::string message;
  if (!options.IsValid(&message)) {
    *error = InvalidValue("errors", message);
    return false;
  }
  *result = options;
  return true;
}

nlohmann::json AxisSensitivityToJson(const BevelPinionJob& job,
                                     const FreeFormMotion& motion,
                                     const AxisSensitivityOptions& options,
                                     const AxisSensitivityTable& table,
                                     int rows,
                                     int columns) {
  nlohmann::json offsets = nlohmann::json::array();
  for (const AxisSensitivityEntry& e : table.offsets)
    offsets.push_back(EntryToJson(e, true, rows, columns));
  nlohmann::json coefficients = nlohmann::json::array();
  for (const AxisSensitivityEntry& e : table.coefficients)
    coefficients.push_back(EntryToJson(e, false, rows, columns));
  nlohmann::json offset_ranking = nlohmann::json::array();
  for (int i : table.offset_ranking)
    offset_ranking.push_back(table.offsets[i].axis);
  nlohmann::json coefficient_ranking = nlohmann::json::array();
  for (int i : table.coefficient_ranking)
    coefficient_ranking.push_back(table.coefficients[i].parameter);
  return {{"job", BevelJobToJson(job)},
          {"motion", FreeFormMotionToJson(motion)},
          {"errors",
           {{"linear_error_mm", options.linear_error_mm},
            {"angular_error_deg", options.angular_error_rad * kDegPerRad},
            {"exact", options.exact}}},
          {"rows", rows},
          {"columns", columns},
          {"offsets", offsets},
          {"coefficients", coefficients},
          {"offset_ranking", offset_ranking},
          {"coefficient_ranking", coefficient_ranking}};
}

bool ParseBevelHiddenErrors(const nlohmann::json& body,
                            int degree,
                            FreeFormMotion* hidden_out,
                            ApiError* error) {
  FreeFormMotion& hidden = *hidden_out;
  hidden = FreeFormMotion::Zero(degree);
  if (body.contains("hidden_errors") && !body.at("hidden_errors").is_null()) {
    const nlohmann::json& h = body.at("hidden_errors");
    if (!h.is_object()) {
      *error = InvalidRequest("hidden_errors",
                              "hidden_errors must be an object {\"A_rad\": "
                              "[...], ..., \"Z_mm\": [...]}");
      return false;
    }
    if (!CheckKeys(
            h,
            "hidden_errors",
            std::vector<std::string>(kAxisKeys, kAxisKeys + kNumFreeFormAxes),
            error))
      return false;
    for (const auto& item : h.items()) {
      int axis = 0;
      for (int i = 0; i < kNumFreeFormAxes; ++i) {
        if (item.key() == kAxisKeys[i]) axis = i;
      }
      const std::string field = JoinPath("hidden_errors", item.key());
      if (!item.value().is_array() ||
          item.value().size() > static_cast<size_t>(degree + 1)) {
        *error = InvalidRequest(field,
                                field + " must be an array of at most " +
                                    std::to_string(degree + 1) +
                                    " coefficients (the motion's degree + 1)");
        return false;
      }
      for (size_t k = 0; k < item.value().size(); ++k) {
        // As the grinder's hidden errors (simulation_codec.cc).
        if (!ReadCoefficient(item.value()[k],
                             field + "[" + std::to_string(k) + "]",
                             /*max_abs=*/1e3,
                             "finite and at most 1e3 in size",
                             &hidden.coefficients[axis](k),
                             error)) {
          return false;
        }
      }
    }
  }
  return true;
}

}  // namespace gearloop
