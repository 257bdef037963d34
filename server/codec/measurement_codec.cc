#include "server/codec/measurement_codec.h"

#include <cmath>
#include <limits>
#include <utility>

#include "server/codec/correction_codec.h"
#include "server/codec/grinder_codec.h"

namespace gearloop {
namespace {

// Reads "datum_face" ("x_negative" | "x_positive"), absent = the file's own.
bool ReadDatumFace(const nlohmann::json& object,
                   const std::string& path,
                   std::optional<DatumFace>* datum_face,
                   ApiError* error) {
  std::string name;
  bool found = false;
  if (!ReadString(object, path, "datum_face", false, &name, error, &found))
    return false;
  if (!found) return true;
  if (name == "x_negative") {
    *datum_face = DatumFace::kXNegative;
  } else if (name == "x_positive") {
    *datum_face = DatumFace::kXPositive;
  } else {
    const std::string field = JoinPath(path, "datum_face");
    *error = InvalidValue(field,
                          field + " must be \"x_negative\" or \"x_positive\"");
    return false;
  }
  return true;
}

// Reads "sign_factors": each of the four factors +1 or -1 (default +1).
bool ReadSignFactors(const nlohmann::json& object,
                     const std::string& path,
                     TraceSignFactors* sign,
                     ApiError* error) {
  const nlohmann::json* factors = nullptr;
  if (!RequireObject(object, path, "sign_factors", false, &factors, error))
    return false;
  if (factors == nullptr) return true;
  const std::string factors_path = JoinPath(path, "sign_factors");
  if (!CheckKeys(*factors,
                 factors_path,
                 {"profile_right", "profile_left", "helix_right", "helix_left"},
                 error))
    return false;
  const std::pair<const char*, double*> keys[] = {
      {"profile_right", &sign->profile_right},
      {"profile_left", &sign->profile_left},
      {"helix_right", &sign->helix_right},
      {"helix_left", &sign->helix_left}};
  for (const auto& [key, value] : keys) {
    if (!ReadNumber(*factors, factors_path, key, false, value, error))
      return false;
    if (*value != 1.0 && *value != -1.0) {
      const std::string field = JoinPath(factors_path, key);
      *error = InvalidValue(field, field + " must be 1 or -1");
      return false;
    }
  }
  return true;
}

nlohmann::json PointList(const std::vector<GridPointIndex>& points) {
  nlohmann::json list = nlohmann::json::array();
  for (const GridPointIndex& p : points)
    list.push_back({{"row", p.row}, {"column", p.column}});
  return list;
}

nlohmann::json ClassOrNull(const std::optional<int>& value) {
  return value ? nlohmann::json(*value) : nlohmann::json(nullptr);
}

}  // namespace

bool ParseMeasurementFileRequest(const nlohmann::json& object,
                                 const std::string& path,
                                 MeasurementFileRequest* file,
                                 ApiError* error) {
  MeasurementFileRequest f;
  long long tooth = 0;
  if (!ReadString(object, path, "format", true, &f.format, error) ||
      !ReadString(object, path, "content", true, &f.content, error) ||
      !ReadInteger(object, path, "tooth", false, &tooth, error) ||
      !ReadDatumFace(object, path, &f.datum_face, error) ||
      !ReadSignFactors(object, path, &f.sign, error)) {
    return false;
  }
  if (f.format != "mka" && f.format != "gde") {
    const std::string field = JoinPath(path, "format");
    *error = InvalidValue(field, field + " must be \"mka\" or \"gde\"");
    return false;
  }
  if (tooth < 0 || tooth > 100000) {
    const std::string field = JoinPath(path, "tooth");
    *error = InvalidValue(field,
                          field +
                              " must be a tooth number >= 1 (or 0 for the "
                              "mean of all teeth), got " +
                              std::to_string(tooth));
    return false;
  }
  f.tooth = static_cast<int>(tooth);
  *file = std::move(f);
  return true;
}

bool ParseMeasurementImportRequest(const nlohmann::json& body,
                                   MeasurementImportRequest* request,
                                   ApiError* error) {
  if (!body.is_object()) {
    *error = InvalidRequest("", "the request body must be a JSON object");
    return false;
  }
  MeasurementImportRequest r;
  if (!ParseGearGridAndFlank(body, &r.gear, &r.grid, &r.flank, error) ||
      !ParseMeasurementFileRequest(body, "", &r.file, error)) {
    return false;
  }
  *request = std::move(r);
  return true;
}

bool HasMeasurementFile(const nlohmann::json& body) {
  return body.is_object() && body.contains("measurement") &&
         body.at("measurement").is_object() &&
         body.at("measurement").contains("file");
}

nlohmann::json FlankFiguresToJson(const FlankFigures& f) {
  return {
      {"profile_evaluation_length_mm",
       FiniteOrNull(f.profile_evaluation_length_mm)},
      {"helix_evaluation_length_mm",
       FiniteOrNull(f.helix_evaluation_length_mm)},
      {"profile_grid_extent_mm", FiniteOrNull(f.profile_grid_extent_mm)},
      {"helix_grid_extent_mm", FiniteOrNull(f.helix_grid_extent_mm)},
      {"fHa_mean", FiniteOrNull(f.fHa_mean)},
      {"fHa_mean_grid", FiniteOrNull(f.fHa_mean_grid)},
      {"fHa_max_abs", FiniteOrNull(f.fHa_max_abs)},
      {"fHa_max_abs_grid", FiniteOrNull(f.fHa_max_abs_grid)},
      {"ffa_max_abs", FiniteOrNull(f.ffa_max_abs)},
      {"Fa_max_abs", FiniteOrNull(f.Fa_max_abs)},
      {"Ca_mean", FiniteOrNull(f.Ca_mean)},
      {"Ca_mean_grid", FiniteOrNull(f.Ca_mean_grid)},
      {"fHb_mean", FiniteOrNull(f.fHb_mean)},
      {"fHb_mean_grid", FiniteOrNull(f.fHb_mean_grid)},
      {"fHb_max_abs", FiniteOrNull(f.fHb_max_abs)},
      {"fHb_max_abs_grid", FiniteOrNull(f.fHb_max_abs_grid)},
      {"ffb_max_abs", FiniteOrNull(f.ffb_max_abs)},
      {"Fb_max_abs", FiniteOrNull(f.Fb_max_abs)},
      {"Cb_mean", FiniteOrNull(f.Cb_mean)},
      {"Cb_mean_grid", FiniteOrNull(f.Cb_mean_grid)},
      {"twist_alpha", FiniteOrNull(f.twist_alpha)},
      {"twist_alpha_grid", FiniteOrNull(f.twist_alpha_grid)},
      {"twist_beta", FiniteOrNull(f.twist_beta)},
      {"twist_beta_grid", FiniteOrNull(f.twist_beta_grid)},
  };
}

nlohmann::json AccuracyClassesToJson(const AccuracyClasses& c) {
  return {{"fHa", ClassOrNull(c.fHa)},
          {"ffa", ClassOrNull(c.ffa)},
          {"Fa", ClassOrNull(c.Fa)},
          {"fHb", ClassOrNull(c.fHb)},
          {"ffb", ClassOrNull(c.ffb)},
          {"Fb", ClassOrNull(c.Fb)},
          {"overall", ClassOrNull(c.overall)}};
}

nlohmann::json FlankQualityToJson(const FlankFigures& figures,
                                  const AccuracyClasses& classes) {
  if (!figures.ok) {
    return {{"figures", nullptr},
            {"classes", nullptr},
            {"message", figures.message}};
  }
  return {{"figures", FlankFiguresToJson(figures)},
          {"classes", AccuracyClassesToJson(classes)}};
}

nlohmann::json MeasurementImportToJson(
    const TraceGridResult& grid,
    const FlankFigures& figures,
    const AccuracyClasses& classes,
    const std::vector<std::string>& warnings) {
  nlohmann::json teeth = nlohmann::json::array();
  for (int t : grid.teeth) teeth.push_back(t);
  return {
      {"deviations_um",
       GridToJson(grid.deviations_um, {}, grid.rows, grid.columns)},
      {"figures", FlankFiguresToJson(figures)},
      {"classes", AccuracyClassesToJson(classes)},
      {"warnings", warnings},
      {"not_measured", PointList(grid.not_measured)},
      {"teeth", teeth},
      {"tooth_spread_um",
       grid.tooth_spread_um.size() == grid.rows * grid.columns
           ? GridToJson(grid.tooth_spread_um, {}, grid.rows, grid.columns)
           : nlohmann::json(nullptr)},
      {"max_crossing_mismatch_um", FiniteOrNull(grid.max_crossing_mismatch_um)},
      {"profile_traces", grid.profile_traces},
      {"helix_traces", grid.helix_traces},
  };
}

}  // namespace gearloop
