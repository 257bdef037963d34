#include "server/codec/simulation_codec.h"

#include <cmath>
#include <limits>
#include <string>

#include "engine/core/units.h"
#include "engine/grinder/grinder_settings.h"
#include "server/codec/correction_codec.h"
#include "server/codec/grinder_codec.h"

namespace gearloop {
namespace {
const char* kAxisNames[kNumAxes] = {"X", "Y", "Z", "A", "B", "C"};

// Reads hidden_errors.axes: per axis, up to 7 coefficients.
bool ReadHiddenAxisErrors(const nlohmann::json& axes,
                          Eigen::VectorXd* errors,
                          ApiError* error) {
  if (!axes.is_object()) {
    *error = InvalidRequest(
        "hidden_errors.axes",
        "hidden_errors.axes must be an object of axis -> coefficients");
    return false;
  }
  for (const auto& item : axes.items()) {
    int axis = -1;
    for (int i = 0; i < kNumAxes; ++i) {
      if (item.key() == kAxisNames[i]) axis = i;
    }
    const std::string field = "hidden_errors.axes." + item.key();
    if (axis < 0) {
      *error = InvalidRequest(
          field, "unknown axis " + item.key() + " (axes are X, Y, Z, A, B, C)");
      return false;
    }
    const nlohmann::json& coefficients = item.value();
    if (!coefficients.is_array() ||
        coefficients.size() > static_cast<size_t>(kCoefficientsPerAxis)) {
      *error = InvalidRequest(field,
                              field + " must be an array of at most 7 numbers");
      return false;
    }
    for (size_t k = 0; k < coefficients.size(); ++k) {
      if (!ReadCoefficient(coefficients[k],
                           field + "[" + std::to_string(k) + "]",
                           /*max_abs=*/1e3,
                           "finite and at most 1e3 in size",
                           &(*errors)(ParameterIndex(static_cast<Axis>(axis),
                                                     static_cast<int>(k))),
                           error)) {
        return false;
      }
    }
  }
  return true;
}

// Reads hidden_errors.wheel: cone angle and parabola.
bool ReadHiddenWheelErrors(const nlohmann::json& wheel,
                           Eigen::VectorXd* errors,
                           ApiError* error) {
  if (!wheel.is_object()) {
    *error = InvalidRequest("hidden_errors.wheel",
                            "hidden_errors.wheel must be an object");
    return false;
  }
  double cone_deg = 0.0, parabola = 0.0, vertex = 0.0;
  if (!CheckKeys(wheel,
                 "hidden_errors.wheel",
                 {"cone_angle_deg",
                  "parabola_coefficient_per_mm",
                  "parabola_vertex_mm"},
                 error) ||
      !ReadNumber(wheel,
                  "hidden_errors.wheel",
                  "cone_angle_deg",
                  false,
                  &cone_deg,
                  error) ||
      !ReadNumber(wheel,
                  "hidden_errors.wheel",
                  "parabola_coefficient_per_mm",
                  false,
                  &parabola,
                  error) ||
      !ReadNumber(wheel,
                  "hidden_errors.wheel",
                  "parabola_vertex_mm",
                  false,
                  &vertex,
                  error)) {
    return false;
  }
  if (std::fabs(cone_deg) > 10.0 || std::fabs(parabola) > 1.0 ||
      std::fabs(vertex) > 1e3) {
    *error = InvalidValue("hidden_errors.wheel",
                          "hidden wheel errors are implausibly large");
    return false;
  }
  (*errors)(kConeAngleIndex) = cone_deg * kRadPerDeg;
  (*errors)(kParabolaCoefficientIndex) = parabola;
  (*errors)(kParabolaVertexIndex) = vertex;
  return true;
}

}  // namespace

// Hidden errors given coefficient by coefficient; every part optional.
bool ParseGrinderHiddenErrors(const nlohmann::json& value,
                              Eigen::VectorXd* errors,
                              ApiError* error) {
  const std::string path = "hidden_errors";
  errors->setZero(kNumGrinderParameters);
  if (!value.is_object()) {
    *error = InvalidRequest(
        path,
        "hidden_errors must be an object {\"axes\": {...}, \"wheel\": {...}}");
    return false;
  }
  if (!CheckKeys(value, path, {"axes", "wheel"}, error)) return false;
  if (value.contains("axes") &&
      !ReadHiddenAxisErrors(value.at("axes"), errors, error))
    return false;
  if (value.contains("wheel") &&
      !ReadHiddenWheelErrors(value.at("wheel"), errors, error))
    return false;
  return true;
}

bool ParseRandomHiddenErrors(const nlohmann::json& value,
                             RandomHiddenErrorsRequest* request,
                             ApiError* error) {
  const std::string path = "random_hidden_errors";
  if (!value.is_object()) {
    *error = InvalidRequest(
        path,
        path + " must be an object {block_size, max_order, wheel_size, seed}");
    return false;
  }
  double block_size = 1.0, wheel_size = 0.0;
  long long max_order = 2, seed = 1;
  if (!CheckKeys(
          value,
          path,
          {"block_size", "max_order", "wheel_size", "seed", "fixed_blocks"},
          error) ||
      !ReadNumber(value, path, "block_size", false, &block_size, error) ||
      !ReadInteger(value, path, "max_order", false, &max_order, error) ||
      !ReadNumber(value, path, "wheel_size", false, &wheel_size, error) ||
      !ReadInteger(value, path, "seed", false, &seed, error)) {
    return false;
  }
  if (block_size < 0.0 || block_size > 1e4) {
    *error =
        InvalidValue(path + ".block_size", "block_size must lie in [0, 1e4]");
    return false;
  }
  if (wheel_size < 0.0 || wheel_size > 1e3) {
    *error =
        InvalidValue(path + ".wheel_size", "wheel_size must lie in [0, 1e3]");
    return false;
  }
  if (max_order < 0 || max_order > kAxisPolynomialDegree) {
    *error = InvalidValue(path + ".max_order", "max_order must lie in [0, 6]");
    return false;
  }
  if (seed < 0) {
    *error = InvalidValue(path + ".seed", "seed must not be negative");
    return false;
  }
  std::vector<std::string> fixed;
  if (value.contains("fixed_blocks")) {
    const nlohmann::json& list = value.at("fixed_blocks");
    if (!list.is_array()) {
      *error = InvalidRequest(path + ".fixed_blocks",
                              "fixed_blocks must be an array of block names");
      return false;
    }
    for (const nlohmann::json& name : list) {
      if (!name.is_string()) {
        *error = InvalidRequest(path + ".fixed_blocks",
                                "fixed_blocks must be an array of block names");
        return false;
      }
      fixed.push_back(name.get<std::string>());
    }
  }
  request->block_size = block_size;
  request->max_order = static_cast<int>(max_order);
  request->wheel_size = wheel_size;
  request->seed = static_cast<std::uint64_t>(seed);
  request->fixed_blocks = fixed;
  return true;
}

namespace {

bool ParsePointList(const nlohmann::json& body,
                    const char* key,
                    int rows,
                    int columns,
                    std::vector<int>* indices,
                    ApiError* error) {
  if (!body.contains(key)) return true;
  const nlohmann::json& list = body.at(key);
  if (!list.is_array()) {
    *error = InvalidRequest(
        key, std::string(key) + " must be an array of [row, column] pairs");
    return false;
  }
  for (size_t i = 0; i < list.size(); ++i) {
    const std::string field = std::string(key) + "[" + std::to_string(i) + "]";
    const nlohmann::json& pair = list[i];
    if (!pair.is_array() || pair.size() != 2 || !pair[0].is_number_integer() ||
        !pair[1].is_number_integer()) {
      *error = InvalidRequest(
          field, field + " must be a [row, column] pair of integers");
      return false;
    }
    const long long row = pair[0].get<long long>();
    const long long column = pair[1].get<long long>();
    if (row < 0 || row >= rows || column < 0 || column >= columns) {
      *error = InvalidValue(field, field + " lies outside the grid");
      return false;
    }
    indices->push_back(static_cast<int>(row * columns + column));
  }
  return true;
}

nlohmann::json PointsJson(const std::vector<int>& indices, int columns) {
  nlohmann::json list = nlohmann::json::array();
  for (int i : indices)
    list.push_back({{"row", i / columns}, {"column", i % columns}});
  return list;
}

}  // namespace

bool ParseMeasurementSimulation(const nlohmann::json& body,
                                bool with_point_lists,
                                int rows,
                                int columns,
                                MeasurementSimulationOptions* measurement,
                                ApiError* error) {
  MeasurementSimulationOptions& m = *measurement;
  long long seed = 1, teeth = 1;
  if (!ReadNumber(body, "", "noise_um", false, &m.probe_noise_um, error) ||
      !ReadInteger(body, "", "seed", false, &seed, error) ||
      !ReadNumber(body,
                  "",
                  "outlier_probability",
                  false,
                  &m.outlier_probability,
                  error) ||
      !ReadNumber(
          body, "", "outlier_size_um", false, &m.outlier_size_um, error) ||
      !ReadNumber(body,
                  "",
                  "missing_probability",
                  false,
                  &m.missing_probability,
                  error) ||
      !ReadInteger(body, "", "teeth", false, &teeth, error)) {
    return false;
  }
  if (with_point_lists &&
      (!ParsePointList(
           body, "outlier_points", rows, columns, &m.outlier_points, error) ||
       !ParsePointList(
           body, "missing_points", rows, columns, &m.missing_points, error))) {
    return false;
  }
  if (seed < 0) {
    *error = InvalidValue("seed", "seed must not be negative");
    return false;
  }
  if (teeth < 1 || teeth > 50) {
    *error =
        InvalidValue("teeth", "teeth (measured per flank) must lie in [1, 50]");
    return false;
  }
  // ReadNumber lets only finite numbers through; written so that a NaN would
  // fail too.
  if (!(m.probe_noise_um >= 0.0 && m.probe_noise_um <= 1e3)) {
    *error = InvalidValue("noise_um", "noise_um must lie in [0, 1000]");
    return false;
  }
  if (!(std::fabs(m.outlier_size_um) <= 1e4)) {
    *error =
        InvalidValue("outlier_size_um", "outlier_size_um must lie within 1e4");
    return false;
  }
  m.seed = static_cast<std::uint64_t>(seed);
  m.teeth = static_cast<int>(teeth);
  std::string message;
  if (!m.IsValid(&message)) {
    // The simulator's messages name the C++ field; the API names are the same
    // but for noise.
    std::string field = message.substr(0, message.find(' '));
    if (field == "probe_noise_um") field = "noise_um";
    *error = InvalidValue(field, message);
    return false;
  }
  return true;
}

nlohmann::json SimulatedMeasurementToJson(const SimulatedMeasurement& cmm,
                                          int rows,
                                          int columns) {
  nlohmann::json not_reached = nlohmann::json::array();
  for (size_t i = 0; i < cmm.status.size(); ++i) {
    if (cmm.status[i] != PointStatus::kOk) {
      not_reached.push_back({{"row", static_cast<int>(i) / columns},
                             {"column", static_cast<int>(i) % columns},
                             {"status", PointStatusName(cmm.status[i])}});
    }
  }
  nlohmann::json answer = {
      {"measurement",
       {{"deviations_um", GridToJson(cmm.measured_um, {}, rows, columns)}}},
      {"true_deviations_um",
       GridToJson(cmm.true_deviations_um, {}, rows, columns)},
      {"outliers", PointsJson(cmm.outlier_indices, columns)},
      {"missing", PointsJson(cmm.missing_indices, columns)},
      {"not_reached", not_reached}};
  if (cmm.teeth_um.size() > 1) {
    nlohmann::json teeth = nlohmann::json::array();
    for (const Eigen::VectorXd& tooth : cmm.teeth_um)
      teeth.push_back(GridToJson(tooth, {}, rows, columns));
    answer["measurement"]["teeth"] = teeth;
  }
  return answer;
}

bool ParseClosedLoop(const nlohmann::json& body,
                     int rows,
                     int columns,
                     ClosedLoopOptions* loop,
                     nlohmann::json* options_body,
                     ApiError* error) {
  long long corrections = 3;
  if (!ReadInteger(body, "", "corrections", false, &corrections, error))
    return false;
  if (corrections < 1 || corrections > 20) {
    *error = InvalidValue("corrections", "corrections must lie in [1, 20]");
    return false;
  }
  // The solver knows the probe's noise unless told otherwise.
  *options_body =
      body.contains("options") ? body.at("options") : nlohmann::json::object();
  if (options_body->is_object() && !options_body->contains("probe_noise_um")) {
    (*options_body)["probe_noise_um"] = loop->measurement.probe_noise_um;
  }
  loop->corrections = static_cast<int>(corrections);
  return ParseCorrectionOptions(
      {{"options", *options_body}}, rows, columns, &loop->correction, error);
}

nlohmann::json ClosedLoopIterationToJson(const ClosedLoopIteration& it,
                                         const std::string& parameters_key,
                                         const nlohmann::json& commanded,
                                         int rows,
                                         int columns) {
  return {{"part", it.part},
          {parameters_key, commanded},
          {"true_rms_um", FiniteOrNull(it.true_rms_um)},
          {"true_max_um", FiniteOrNull(it.true_max_um)},
          {"measured_rms_um", FiniteOrNull(it.measured_rms_um)},
          {"true_error_um", GridToJson(it.true_error_um, {}, rows, columns)},
          {"correction",
           it.corrected ? CorrectionSummaryToJson(it.correction, columns)
                        : nlohmann::json(nullptr)}};
}

}  // namespace gearloop
