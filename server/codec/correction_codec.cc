#include "server/codec/correction_codec.h"

#include <cmath>
#include <limits>
#include <map>
#include <vector>

#include "engine/core/units.h"
#include "server/codec/shaving_codec.h"
#include "server/codec/zero_correction.h"

namespace gearloop {
namespace {

bool ReadIntegerInRange(const nlohmann::json& object,
                        const std::string& path,
                        const char* key,
                        long long min,
                        long long max,
                        int* value,
                        ApiError* error) {
  long long v = *value;
  bool found = false;
  if (!ReadInteger(object, path, key, false, &v, error, &found)) return false;
  if (!found) return true;
  if (v < min || v > max) {
    const std::string field = JoinPath(path, key);
    *error = InvalidValue(field,
                          field + " must lie in [" + std::to_string(min) +
                              ", " + std::to_string(max) + "]");
    return false;
  }
  *value = static_cast<int>(v);
  return true;
}

bool ReadNamedMap(const nlohmann::json& object,
                  const std::string& path,
                  const char* key,
                  bool integers,
                  std::map<std::string, double>* out,
                  ApiError* error) {
  if (!object.contains(key)) return true;
  const std::string field = JoinPath(path, key);
  const nlohmann::json& value = object.at(key);
  if (!value.is_object()) {
    *error = InvalidRequest(
        field, field + " must be an object of block name -> number");
    return false;
  }
  for (const auto& item : value.items()) {
    const std::string item_field = JoinPath(field, item.key());
    if (!item.value().is_number() ||
        (integers && !item.value().is_number_integer())) {
      *error = InvalidRequest(item_field,
                              item_field + (integers ? " must be an integer"
                                                     : " must be a number"));
      return false;
    }
    const double number = item.value().get<double>();
    if (!std::isfinite(number)) {
      *error = InvalidValue(item_field, item_field + " must be finite");
      return false;
    }
    (*out)[item.key()] = number;
  }
  return true;
}

// A modification of more than a millimetre is a unit mistake, and an amount
// like 1e308 would only make the solve fail later.
bool CheckModificationAmounts(const TargetModification& modification,
                              const std::string& path,
                              ApiError* error) {
  const std::pair<const char*, double> amounts[] = {
      {"amount_um", modification.amount_um},
      {"second_amount_um", modification.second_amount_um},
      {"amount_gradient_um", modification.amount_gradient_um},
      {"second_amount_gradient_um", modification.second_amount_gradient_um}};
  for (const auto& [key, amount] : amounts) {
    if (std::abs(amount) <= 1000.0) continue;
    const std::string field = JoinPath(path, key);
    *error = InvalidValue(field, field + " must lie in [-1000, 1000] um");
    return false;
  }
  return true;
}

// The relief's "shape": "linear" (the default) or "parabolic".
bool ParseReliefShape(const nlohmann::json& value,
                      const std::string& path,
                      ReliefShape* shape,
                      ApiError* error) {
  std::string name = "linear";
  if (!ReadString(value, path, "shape", false, &name, error)) return false;
  if (name == "linear") {
    *shape = ReliefShape::kLinear;
  } else if (name == "parabolic") {
    *shape = ReliefShape::kParabolic;
  } else {
    *error = InvalidValue(JoinPath(path, "shape"),
                          "shape must be \"linear\" or \"parabolic\"");
    return false;
  }
  return true;
}

bool ParseModification(const nlohmann::json& value,
                       const std::string& path,
                       TargetModification* modification,
                       ApiError* error) {
  if (!value.is_object()) {
    *error = InvalidRequest(path,
                            path + " must be an object {kind, amount_um, ...}");
    return false;
  }
  std::string kind;
  if (!CheckKeys(value,
                 path,
                 {"kind",
                  "amount_um",
                  "length_fraction",
                  "shape",
                  "second_amount_um",
                  "second_length_fraction",
                  "amount_gradient_um",
                  "second_amount_gradient_um"},
                 error) ||
      !ReadString(value, path, "kind", true, &kind, error))
    return false;
  if (!ParseModificationKind(kind, &modification->kind)) {
    *error = InvalidValue(JoinPath(path, "kind"),
                          "unknown modification kind \"" + kind + "\"");
    return false;
  }
  const struct {
    const char* key;
    bool required;
    double* number;
  } numbers[] = {
      {"amount_um", true, &modification->amount_um},
      {"length_fraction", false, &modification->length_fraction},
      {"second_amount_um", false, &modification->second_amount_um},
      {"second_length_fraction", false, &modification->second_length_fraction},
      {"amount_gradient_um", false, &modification->amount_gradient_um},
      {"second_amount_gradient_um",
       false,
       &modification->second_amount_gradient_um}};
  for (const auto& number : numbers) {
    if (!ReadNumber(
            value, path, number.key, number.required, number.number, error))
      return false;
  }
  if (!ParseReliefShape(value, path, &modification->shape, error)) return false;
  if (!CheckModificationAmounts(*modification, path, error)) return false;
  ValidationIssue issue;
  if (!ValidateTargetModification(*modification, &issue)) {
    *error = InvalidValue(JoinPath(path, issue.field), issue.message);
    return false;
  }
  return true;
}

nlohmann::json PointList(const std::vector<int>& indices, int columns) {
  nlohmann::json list = nlohmann::json::array();
  for (int i : indices)
    list.push_back({{"row", i / columns}, {"column", i % columns}});
  return list;
}

// A unit as a key suffix, the API's way: "um" -> "_um", "1/mm" -> "_per_mm".
std::string UnitSuffix(const std::string& unit) {
  std::string suffix;
  for (size_t i = 0; i < unit.size(); ++i) {
    if (unit.compare(i, 2, "1/") == 0 && (i == 0 || unit[i - 1] == '/')) {
      suffix += "per_";
      ++i;
    } else if (unit[i] == '/') {
      suffix += "_per_";
    } else {
      suffix += unit[i];
    }
  }
  return "_" + suffix;
}

}  // namespace

nlohmann::json FiniteOrNull(double value) {
  return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json(nullptr);
}

nlohmann::json AxisMotionToJson(const AxisMotion& motion) {
  nlohmann::json roll = nlohmann::json::array();
  for (double r : motion.roll_rad) roll.push_back(FiniteOrNull(r));
  nlohmann::json axes = nlohmann::json::object();
  nlohmann::json wheel = nlohmann::json::object();
  for (const BlockMotion& b : motion.blocks) {
    const std::string suffix = UnitSuffix(b.unit);
    if (!b.is_polynomial) {
      wheel[b.name + suffix] =
          FiniteOrNull(b.change.empty() ? std::nan("") : b.change.front());
      continue;
    }
    nlohmann::json change = nlohmann::json::array();
    for (double v : b.change) change.push_back(FiniteOrNull(v));
    axes[b.name] = {{"change" + suffix, change},
                    {"rms" + suffix, FiniteOrNull(b.rms)},
                    {"max_abs" + suffix, FiniteOrNull(b.max_abs)}};
  }
  return {{"roll_rad", roll}, {"axes", axes}, {"wheel", wheel}};
}

// 422 naming the first entry of a rows x columns grid (row-major, NaN =
// absent) larger than kMaxPlausibleDeviationUm in size, unless allowed.
bool CheckDeviationSizes(const Eigen::VectorXd& grid,
                         const std::string& path,
                         int columns,
                         bool allow_large,
                         ApiError* error) {
  if (allow_large) return true;
  for (int i = 0; i < grid.size(); ++i) {
    if (!(std::abs(grid(i)) > kMaxPlausibleDeviationUm)) continue;
    const std::string field = path + "[" + std::to_string(i / columns) + "][" +
                              std::to_string(i % columns) + "]";
    *error = InvalidValue(
        field,
        field + " is " + nlohmann::json(grid(i)).dump() +
            " um: deviations beyond 500 um are refused as a unit mistake "
            "(nm for um?); send \"allow_large_deviations\": true if they "
            "are real");
    return false;
  }
  return true;
}

bool ReadAllowLargeDeviations(const nlohmann::json& body,
                              bool* allow,
                              ApiError* error) {
  *allow = false;
  return ReadBool(body, "", "allow_large_deviations", false, allow, error);
}

// The measurement: one grid, or several teeth handed to the engine as they are
// (it averages them and knows that an averaged point is less noisy).
bool ParseCorrectionMeasurement(const nlohmann::json& body,
                                int rows,
                                int columns,
                                Eigen::VectorXd* measured_um,
                                std::vector<Eigen::VectorXd>* measured_teeth_um,
                                ApiError* error) {
  if (!body.contains("measurement")) {
    *error =
        InvalidRequest("measurement", "missing required field measurement");
    return false;
  }
  const nlohmann::json& measurement = body.at("measurement");
  if (!measurement.is_object()) {
    *error = InvalidRequest(
        "measurement",
        "measurement must be an object {\"deviations_um\": grid}");
    return false;
  }
  bool allow_large = false;
  if (!ReadAllowLargeDeviations(body, &allow_large, error) ||
      !CheckKeys(measurement, "measurement", {"deviations_um", "teeth"}, error))
    return false;
  std::vector<bool> present;
  if (measurement.contains("deviations_um")) {
    if (!ParseGridValues(measurement.at("deviations_um"),
                         "measurement.deviations_um",
                         rows,
                         columns,
                         /*allow_null=*/true,
                         measured_um,
                         &present,
                         error)) {
      return false;
    }
    for (int i = 0; i < measured_um->size(); ++i) {
      if (!present[i])
        (*measured_um)(i) = std::numeric_limits<double>::quiet_NaN();
    }
    return CheckDeviationSizes(
        *measured_um, "measurement.deviations_um", columns, allow_large, error);
  }
  if (measurement.contains("teeth")) {
    const nlohmann::json& teeth = measurement.at("teeth");
    if (!teeth.is_array() || teeth.empty() || teeth.size() > 1000) {
      *error = InvalidRequest(
          "measurement.teeth",
          "measurement.teeth must be an array of 1 to 1000 grids");
      return false;
    }
    measured_teeth_um->clear();
    for (size_t t = 0; t < teeth.size(); ++t) {
      Eigen::VectorXd grid;
      const std::string path = "measurement.teeth[" + std::to_string(t) + "]";
      if (!ParseGridValues(
              teeth[t], path, rows, columns, true, &grid, &present, error))
        return false;
      for (int i = 0; i < grid.size(); ++i) {
        if (!present[i]) grid(i) = std::numeric_limits<double>::quiet_NaN();
      }
      if (!CheckDeviationSizes(grid, path, columns, allow_large, error))
        return false;
      measured_teeth_um->push_back(grid);
    }
    measured_um->resize(0);
    return true;
  }
  *error = InvalidRequest("measurement.deviations_um",
                          "missing required field measurement.deviations_um");
  return false;
}

bool HasShavingTarget(const nlohmann::json& body) {
  return body.contains("target") && body.at("target").is_object() &&
         body.at("target").contains("shaving");
}

bool ParseShavingTarget(const nlohmann::json& body,
                        int rows,
                        int columns,
                        CorrectionRequest* request,
                        ApiError* error) {
  if (!HasShavingTarget(body)) return true;
  const nlohmann::json& target = body.at("target");
  for (const auto& item : target.items()) {
    if (item.key() != "shaving" && item.key() != "stock_target_um") {
      *error =
          InvalidRequest(JoinPath("target", item.key()),
                         "a shaving target holds \"shaving\" (and the resolved "
                         "\"stock_target_um\" the server stores), not " +
                             item.key());
      return false;
    }
  }
  ShavingInput input;
  if (!ReadShavingInput(target.at("shaving"),
                        "target.shaving",
                        &input,
                        &request->target_shaving_grid_given,
                        error))
    return false;
  request->target_shaving = input;
  if (target.contains("stock_target_um")) {
    Eigen::VectorXd values;
    std::vector<bool> present;
    if (!ParseGridValues(target.at("stock_target_um"),
                         "target.stock_target_um",
                         rows,
                         columns,
                         /*allow_null=*/true,
                         &values,
                         &present,
                         error))
      return false;
    // The resolved target as a client may send it: the 500 um rule (null
    // points are absent).
    Eigen::VectorXd sized = values;
    for (int i = 0; i < sized.size(); ++i) {
      if (!present[i]) sized(i) = std::numeric_limits<double>::quiet_NaN();
    }
    bool allow_large = false;
    if (!ReadAllowLargeDeviations(body, &allow_large, error) ||
        !CheckDeviationSizes(
            sized, "target.stock_target_um", columns, allow_large, error))
      return false;
    request->target_shaving_resolved_um = values;
    request->target_shaving_generated = present;
  }
  return true;
}

bool HasTargetModifications(const nlohmann::json& body) {
  return body.contains("target") && body.at("target").is_object() &&
         body.at("target").contains("modifications");
}

bool ParseCorrectionTarget(
    const nlohmann::json& body,
    int rows,
    int columns,
    Eigen::VectorXd* target_um,
    std::optional<std::vector<TargetModification>>* modifications,
    ApiError* error) {
  target_um->setZero(rows * columns);
  if (!body.contains("target") || body.at("target").is_null()) return true;
  const nlohmann::json& target = body.at("target");
  if (!target.is_object()) {
    *error = InvalidRequest("target",
                            "target must be an object {\"deviations_um\": "
                            "grid} or {\"modifications\": [...]}");
    return false;
  }
  if (!CheckKeys(target,
                 "target",
                 {"deviations_um", "modifications", "shaving"},
                 error))
    return false;
  if (target.contains("shaving")) {
    *error = InvalidValue("target.shaving",
                          "a shaving target is resolved by POST "
                          "/api/v1/corrections only; give its stock_target_um "
                          "as target.deviations_um here");
    return false;
  }
  if (target.contains("deviations_um")) {
    // A user target grid in um: the measurement's 500 um rule.
    std::vector<bool> present;
    bool allow_large = false;
    return ParseGridValues(target.at("deviations_um"),
                           "target.deviations_um",
                           rows,
                           columns,
                           /*allow_null=*/false,
                           target_um,
                           &present,
                           error) &&
           ReadAllowLargeDeviations(body, &allow_large, error) &&
           CheckDeviationSizes(
               *target_um, "target.deviations_um", columns, allow_large, error);
  }
  if (target.contains("modifications")) {
    const nlohmann::json& list = target.at("modifications");
    if (!list.is_array() || list.size() > 100) {
      *error = InvalidRequest(
          "target.modifications",
          "target.modifications must be an array of at most 100 modifications");
      return false;
    }
    std::vector<TargetModification> parsed(list.size());
    for (size_t i = 0; i < list.size(); ++i) {
      if (!ParseModification(list[i],
                             "target.modifications[" + std::to_string(i) + "]",
                             &parsed[i],
                             error)) {
        return false;
      }
    }
    *modifications = std::move(parsed);
    return true;
  }
  *error = InvalidRequest(
      "target", "target needs \"deviations_um\" or \"modifications\"");
  return false;
}

namespace {

// The answer's prediction_band (docs/correction-safety.md).
nlohmann::json PredictionBandJson(const PredictionBand& band) {
  return {{"noise_sigma_um", FiniteOrNull(band.noise_sigma_um)},
          {"noise_stated", band.noise_stated},
          {"stated_noise_um", FiniteOrNull(band.stated_noise_um)},
          {"misfit_read_as_flank", band.misfit_read_as_flank},
          {"noise_read_as_probe_um", FiniteOrNull(band.noise_read_as_probe_um)},
          {"expected_true_rms_um", FiniteOrNull(band.expected_true_rms_um)},
          {"true_rms_1sigma_um",
           {FiniteOrNull(band.true_rms_low_um[0]),
            FiniteOrNull(band.true_rms_high_um[0])}},
          {"true_rms_2sigma_um",
           {FiniteOrNull(band.true_rms_low_um[1]),
            FiniteOrNull(band.true_rms_high_um[1])}}};
}

// The wheel parabola the safe step hedged (docs/correction-safety.md): null
// where it was not asked (rework, the state fit, the parabola a free
// parameter).
nlohmann::json WheelParabolaJson(const WheelParabolaEvidence& parabola) {
  if (!parabola.asked) return nullptr;
  return {{"source", parabola.from_measurement ? "measurement" : "assumed"},
          {"estimate_flank_um", FiniteOrNull(parabola.estimate_flank_um)},
          {"sd_flank_um", FiniteOrNull(parabola.sd_flank_um)},
          {"hedged_flank_um", FiniteOrNull(parabola.hedged_flank_um)}};
}

// The answer's orders: which axis orders the correction uses and why.
nlohmann::json OrdersJson(const CorrectionSummary& s) {
  return {
      {"highest_moved", s.highest_order_moved},
      {"choice", s.order_choice},
      {"cubic_predicted_rms_um", FiniteOrNull(s.cubic_orders_predicted_rms_um)},
      {"all_predicted_rms_um", FiniteOrNull(s.all_orders_predicted_rms_um)},
      {"motion_bound_beyond_roll_range", s.motion_bound_beyond_roll_range}};
}

// The exact-model search's outcome and its two predictions.
nlohmann::json ExactSearchJson(const CorrectionSummary& s) {
  return {
      {"outcome", s.exact_search},
      {"regularised_predicted_rms_um",
       FiniteOrNull(s.exact_search_before_rms_um)},
      {"searched_predicted_rms_um", FiniteOrNull(s.exact_search_after_rms_um)}};
}

}  // namespace

nlohmann::json CorrectionSummaryToJson(const CorrectionSummary& s,
                                       int columns) {
  nlohmann::json block_sizes = nlohmann::json::object();
  for (const BlockCorrectionSize& block : s.block_sizes)
    block_sizes[block.name] = FiniteOrNull(block.size);
  nlohmann::json singular_values = nlohmann::json::array();
  for (int i = 0; i < s.singular_values.size(); ++i)
    singular_values.push_back(FiniteOrNull(s.singular_values(i)));
  nlohmann::json answer = {
      {"status", CorrectionStatusName(s.status)},
      {"message", s.message},
      {"initial_rms_um", FiniteOrNull(s.initial_rms_um)},
      {"initial_max_um", FiniteOrNull(s.initial_max_um)},
      {"error_neighbour_ratio", FiniteOrNull(s.error_neighbour_ratio)},
      {"residual_rms_um", FiniteOrNull(s.residual_rms_um)},
      {"residual_max_um", FiniteOrNull(s.residual_max_um)},
      {"linear_residual_rms_um", FiniteOrNull(s.linear_residual_rms_um)},
      {"best_reachable_rms_um", FiniteOrNull(s.best_reachable_rms_um)},
      {"max_added_material_um", FiniteOrNull(s.max_added_material_um)},
      {"rank", s.rank},
      {"condition_number", FiniteOrNull(s.condition_number)},
      {"singular_values", singular_values},
      {"regularisation",
       {{"rule", RegularisationRuleName(s.rule)},
        {"level", FiniteOrNull(s.regularisation_level)},
        {"effective_dof", FiniteOrNull(s.effective_dof)},
        {"truncation_rank", s.truncation_rank},
        {"filter", s.signal_filter_used ? "per-direction" : "tikhonov"}}},
      {"machine_state",
       {{"estimated", s.machine_state_estimated},
        {"size", FiniteOrNull(s.machine_state_size)},
        {"misfit_rms_um", FiniteOrNull(s.machine_state_misfit_rms_um)},
        {"test", s.machine_state_test},
        {"statistic", FiniteOrNull(s.machine_state_statistic)},
        {"threshold", FiniteOrNull(s.machine_state_threshold)},
        {"reason", s.machine_state_reason}}},
      {"prediction_band", PredictionBandJson(s.prediction_band)},
      {"safe_step",
       {{"checked", s.safe_step_checked},
        {"motion_scale", FiniteOrNull(s.motion_scale)},
        {"step_fraction", FiniteOrNull(s.step_fraction)},
        {"current_rms_um", FiniteOrNull(s.safe_step_current_rms_um)},
        {"predicted_rms_um", FiniteOrNull(s.safe_step_predicted_rms_um)},
        {"state_spread_um", FiniteOrNull(s.safe_step_state_spread_um)},
        {"wheel_parabola", WheelParabolaJson(s.safe_step_wheel_parabola)},
        {"shortened_because", s.safe_step_shortened}}},
      {"orders", OrdersJson(s)},
      {"exact_search", ExactSearchJson(s)},
      {"solver", CorrectionSolverName(s.solver)},
      {"mode", CorrectionModeName(s.mode)},
      {"iterations", s.iterations},
      {"elapsed_ms", s.elapsed_ms},
      {"points_used", s.num_points_used},
      {"free_parameters", s.num_free_parameters},
      {"roll_range_deg",
       {s.roll_min_rad * kDegPerRad, s.roll_max_rad * kDegPerRad}},
      {"correction_size", FiniteOrNull(s.correction_size)},
      {"block_sizes", block_sizes},
      {"outliers", PointList(s.outlier_indices, columns)},
      {"tooth_outliers", PointList(s.tooth_outlier_indices, columns)},
      {"missing", PointList(s.missing_indices, columns)},
      {"measured_not_reached",
       PointList(s.measured_not_reached_indices, columns)},
      {"measured_not_reached_max_um",
       FiniteOrNull(s.measured_not_reached_max_um)},
  };
  // A zero correction says why (server/codec/zero_correction.h).
  const nlohmann::json explain = ZeroCorrectionExplainJson(s);
  if (!explain.is_null()) {
    const std::string said = s.message;
    answer["message"] = explain["message"].get<std::string>() +
                        (said.empty() ? std::string() : " (" + said + ")");
    answer["explain"] = explain;
  }
  return answer;
}

namespace {

// Reads options.solver and options.mode.
bool ReadSolverAndMode(const nlohmann::json& j,
                       const std::string& path,
                       CorrectionOptions* o,
                       ApiError* error) {
  std::string solver;
  bool found = false;
  if (!ReadString(j, path, "solver", false, &solver, error, &found))
    return false;
  if (found && !ParseCorrectionSolver(solver, &o->solver)) {
    *error = InvalidValue(
        "options.solver",
        "options.solver must be \"regularised\", \"pso\" or \"lsq-plain\"");
    return false;
  }
  std::string mode;
  if (!ReadString(j, path, "mode", false, &mode, error, &found)) return false;
  if (found && !ParseCorrectionMode(mode, &o->mode)) {
    *error = InvalidValue("options.mode",
                          "options.mode must be \"next-part\" or \"rework\"");
    return false;
  }
  return true;
}

// Reads options.default_max_order, options.max_order and options.block_scales.
bool ReadBlockOptions(const nlohmann::json& j,
                      const std::string& path,
                      CorrectionOptions* o,
                      ApiError* error) {
  if (!ReadIntegerInRange(
          j, path, "default_max_order", -1, 6, &o->default_max_order, error))
    return false;
  std::map<std::string, double> orders;
  if (!ReadNamedMap(j, path, "max_order", /*integers=*/true, &orders, error))
    return false;
  for (const auto& [name, order] : orders) {
    if (order < -1 || order > 6) {
      *error = InvalidValue("options.max_order." + name,
                            "a maximum order lies in [-1, 6]");
      return false;
    }
    o->max_order[name] = static_cast<int>(order);
  }
  return ReadNamedMap(j, path, "block_scales", false, &o->block_scales, error);
}

// Reads options.point_weights, a grid of rows x columns.
bool ReadPointWeights(const nlohmann::json& j,
                      int rows,
                      int columns,
                      CorrectionOptions* o,
                      ApiError* error) {
  if (!j.contains("point_weights")) return true;
  std::vector<bool> present;
  return ParseGridValues(j.at("point_weights"),
                         "options.point_weights",
                         rows,
                         columns,
                         false,
                         &o->point_weights,
                         &present,
                         error);
}

// Reads options.probe_noise_um and options.regularisation_rule.
bool ReadNoiseOptions(const nlohmann::json& j,
                      const std::string& path,
                      CorrectionOptions* o,
                      ApiError* error) {
  // Absent: the probe noise is unknown and generalised cross-validation picks
  // the level.
  bool noise_found = false;
  if (!ReadNumber(j,
                  path,
                  "probe_noise_um",
                  false,
                  &o->probe_noise_um,
                  error,
                  &noise_found))
    return false;
  if (noise_found && !(o->probe_noise_um >= 0.0 && o->probe_noise_um <= 1e3)) {
    *error = InvalidValue("options.probe_noise_um",
                          "options.probe_noise_um must lie in [0, 1000] um");
    return false;
  }
  std::string rule;
  bool rule_found = false;
  if (!ReadString(
          j, path, "regularisation_rule", false, &rule, error, &rule_found))
    return false;
  if (rule_found) {
    if (rule != "upre" && rule != "discrepancy-principle") {
      *error = InvalidValue("options.regularisation_rule",
                            "options.regularisation_rule must be \"upre\" or "
                            "\"discrepancy-principle\" "
                            "(it applies when probe_noise_um > 0)");
      return false;
    }
    o->use_discrepancy_principle = rule == "discrepancy-principle";
  }
  return true;
}

// Reads the solver's limits: machine state, iterations, rework passes,
// outlier rejection and the particle swarm's size.
bool ReadSolverLimits(const nlohmann::json& j,
                      const std::string& path,
                      CorrectionOptions* o,
                      ApiError* error) {
  if (!ReadBool(j,
                path,
                "estimate_machine_state",
                false,
                &o->estimate_machine_state,
                error))
    return false;
  return ReadNumber(j,
                    path,
                    "min_flank_effect_um",
                    false,
                    &o->min_flank_effect_um,
                    error) &&
         ReadIntegerInRange(j,
                            path,
                            "max_num_iterations",
                            0,
                            200,
                            &o->max_num_iterations,
                            error) &&
         ReadIntegerInRange(j,
                            path,
                            "max_rework_passes",
                            0,
                            20,
                            &o->max_rework_passes,
                            error) &&
         ReadNumber(j,
                    path,
                    "rework_tolerance_um",
                    false,
                    &o->rework_tolerance_um,
                    error) &&
         ReadNumber(j,
                    path,
                    "outlier_threshold",
                    false,
                    &o->outlier_threshold,
                    error) &&
         ReadNumber(
             j, path, "outlier_min_um", false, &o->outlier_min_um, error) &&
         ReadNumber(j,
                    path,
                    "max_outlier_fraction",
                    false,
                    &o->max_outlier_fraction,
                    error) &&
         ReadIntegerInRange(
             j, path, "pso_particles", 1, 200, &o->pso_particles, error) &&
         ReadIntegerInRange(
             j, path, "pso_generations", 1, 2000, &o->pso_generations, error);
}

// Reads options.pso_seed, which must not be negative.
bool ReadPsoSeed(const nlohmann::json& j,
                 const std::string& path,
                 CorrectionOptions* o,
                 ApiError* error) {
  long long seed = static_cast<long long>(o->pso_seed);
  if (!ReadInteger(j, path, "pso_seed", false, &seed, error)) return false;
  if (seed < 0) {
    *error = InvalidValue("options.pso_seed",
                          "options.pso_seed must not be negative");
    return false;
  }
  o->pso_seed = static_cast<unsigned long long>(seed);
  return true;
}

// Reads the "options" object field by field, in the order the API reports
// the first invalid field.
bool ReadOptionsObject(const nlohmann::json& j,
                       int rows,
                       int columns,
                       CorrectionOptions* o,
                       ApiError* error) {
  const std::string path = "options";
  if (!j.is_object()) {
    *error = InvalidRequest(path, "options must be an object");
    return false;
  }
  static const std::vector<std::string> kOptionKeys = {"solver",
                                                       "mode",
                                                       "default_max_order",
                                                       "max_order",
                                                       "block_scales",
                                                       "point_weights",
                                                       "probe_noise_um",
                                                       "regularisation_rule",
                                                       "estimate_machine_state",
                                                       "min_flank_effect_um",
                                                       "max_num_iterations",
                                                       "max_rework_passes",
                                                       "rework_tolerance_um",
                                                       "outlier_threshold",
                                                       "outlier_min_um",
                                                       "max_outlier_fraction",
                                                       "pso_particles",
                                                       "pso_generations",
                                                       "pso_seed"};
  return CheckKeys(j, path, kOptionKeys, error) &&
         ReadSolverAndMode(j, path, o, error) &&
         ReadBlockOptions(j, path, o, error) &&
         ReadPointWeights(j, rows, columns, o, error) &&
         ReadNoiseOptions(j, path, o, error) &&
         ReadSolverLimits(j, path, o, error) && ReadPsoSeed(j, path, o, error);
}

}  // namespace

bool ParseCorrectionOptions(const nlohmann::json& body,
                            int rows,
                            int columns,
                            CorrectionOptions* options,
                            ApiError* error) {
  CorrectionOptions o;
  if (body.contains("options") && !body.at("options").is_null()) {
    if (!ReadOptionsObject(body.at("options"), rows, columns, &o, error))
      return false;
  }
  // The swarm's work grows with particles x generations x grid points; keep one
  // request from occupying a worker for long (the published 40 x 200 on 5 x 9
  // is 3.6e5; 5e6 takes ~0.3 s).
  const double swarm_work =
      static_cast<double>(o.pso_particles) * o.pso_generations * rows * columns;
  if (o.solver == CorrectionSolver::kParticleSwarm && swarm_work > 5e6) {
    *error = InvalidValue(
        "options.pso_generations",
        "pso_particles x pso_generations x grid points must stay below 5e6");
    return false;
  }
  std::string message;
  if (!o.IsValid(&message)) {
    *error = InvalidValue("options", message);
    return false;
  }
  *options = o;
  return true;
}

bool ParseSettingsSourceJobId(const nlohmann::json& body,
                              std::optional<int64_t>* id,
                              ApiError* error) {
  id->reset();
  if (!body.contains("settings_source_job_id") ||
      body.at("settings_source_job_id").is_null())
    return true;
  long long value = 0;
  if (!ReadInteger(body, "", "settings_source_job_id", true, &value, error))
    return false;
  if (value <= 0) {
    *error =
        InvalidValue("settings_source_job_id",
                     "settings_source_job_id must name a stored job (id >= 1)");
    return false;
  }
  *id = value;
  return true;
}

bool ParseCorrectionRequest(const nlohmann::json& body,
                            int rows,
                            int columns,
                            bool target_modifications_allowed,
                            CorrectionRequest* request,
                            ApiError* error) {
  CorrectionRequest r;
  if (!ParseCorrectionMeasurement(
          body, rows, columns, &r.measured_um, &r.measured_teeth_um, error))
    return false;
  if (!target_modifications_allowed && HasTargetModifications(body)) {
    *error = InvalidValue("target.modifications",
                          "target modifications are defined for the grinder's "
                          "involute flank; give a bevel target as "
                          "target.deviations_um");
    return false;
  }
  if (HasShavingTarget(body)) {
    r.target_um.setZero(rows * columns);
    if (!ParseShavingTarget(body, rows, columns, &r, error)) return false;
  } else if (!ParseCorrectionTarget(body,
                                    rows,
                                    columns,
                                    &r.target_um,
                                    &r.target_modifications,
                                    error)) {
    return false;
  }
  if (!ParseCorrectionOptions(body, rows, columns, &r.options, error) ||
      !ParseSettingsSourceJobId(body, &r.settings_source_job_id, error)) {
    return false;
  }
  *request = std::move(r);
  return true;
}

}  // namespace gearloop
