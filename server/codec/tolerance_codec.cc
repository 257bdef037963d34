#include "server/codec/tolerance_codec.h"

#include <cmath>
#include <cstdio>

namespace gearloop {
namespace {

constexpr double kMaxToleranceUm = 1000.0;
constexpr int kFinestIsoClass = 1;
constexpr int kCoarsestIsoClass = 11;

bool ReadLimitUm(const nlohmann::json& object,
                 const char* key,
                 std::optional<double>* limit,
                 ApiError* error) {
  double value = 0.0;
  bool found = false;
  if (!ReadNumber(object, "tolerance", key, false, &value, error, &found))
    return false;
  if (!found) return true;
  const std::string path = std::string("tolerance.") + key;
  if (!(value > 0.0 && value <= kMaxToleranceUm)) {
    *error = InvalidValue(path, path + " must be > 0 and at most 1000 um");
    return false;
  }
  *limit = value;
  return true;
}

std::string Um(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.2f um", value);
  return buffer;
}

}  // namespace

bool ParseTolerance(const nlohmann::json& body,
                    std::optional<Tolerance>* tolerance,
                    ApiError* error) {
  const nlohmann::json* object = nullptr;
  if (!RequireObject(body, "", "tolerance", false, &object, error))
    return false;
  if (object == nullptr) return true;
  for (const auto& item : object->items()) {
    if (item.key() != "rms_um" && item.key() != "max_um" &&
        item.key() != "iso_class") {
      *error = InvalidRequest(
          "tolerance." + item.key(),
          "tolerance." + item.key() +
              " is not a tolerance field (rms_um, max_um, iso_class)");
      return false;
    }
  }
  Tolerance t;
  if (!ReadLimitUm(*object, "rms_um", &t.rms_um, error) ||
      !ReadLimitUm(*object, "max_um", &t.max_um, error))
    return false;
  long long iso_class = 0;
  bool found = false;
  if (!ReadInteger(
          *object, "tolerance", "iso_class", false, &iso_class, error, &found))
    return false;
  if (found) {
    if (iso_class < kFinestIsoClass || iso_class > kCoarsestIsoClass) {
      *error = InvalidValue("tolerance.iso_class",
                            "tolerance.iso_class must be an ISO 1328-1 flank "
                            "tolerance class, 1 to 11");
      return false;
    }
    t.iso_class = static_cast<int>(iso_class);
  }
  if (!t.rms_um && !t.max_um && !t.iso_class) {
    *error = InvalidRequest(
        "tolerance",
        "tolerance needs at least one of rms_um, max_um, iso_class");
    return false;
  }
  *tolerance = t;
  return true;
}

nlohmann::json ToleranceToJson(const Tolerance& tolerance) {
  nlohmann::json j = nlohmann::json::object();
  if (tolerance.rms_um) j["rms_um"] = *tolerance.rms_um;
  if (tolerance.max_um) j["max_um"] = *tolerance.max_um;
  if (tolerance.iso_class) j["iso_class"] = *tolerance.iso_class;
  return j;
}

nlohmann::json PartVerdictJson(const Tolerance& tolerance,
                               const PartFigures& figures) {
  nlohmann::json failed = nlohmann::json::array();
  // Written so that NaN misses the limit.
  if (tolerance.rms_um && !(figures.rms_um <= *tolerance.rms_um))
    failed.push_back("rms_um");
  if (tolerance.max_um && !(figures.max_um <= *tolerance.max_um))
    failed.push_back("max_um");
  if (tolerance.iso_class &&
      !(figures.iso_class.is_number_integer() &&
        figures.iso_class.get<int>() <= *tolerance.iso_class))
    failed.push_back("iso_class");
  const auto finite = [](double v) {
    return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
  };
  return {{"verdict", failed.empty() ? "PASS" : "FAIL"},
          {"rms_um", finite(figures.rms_um)},
          {"max_um", finite(figures.max_um)},
          {"iso_class", figures.iso_class},
          {"failed", failed}};
}

std::string MissedLimitsText(const Tolerance& tolerance,
                             const nlohmann::json& verdict) {
  std::string text;
  for (const nlohmann::json& name : verdict.value("failed", nlohmann::json())) {
    std::string part;
    const nlohmann::json& value =
        verdict.value(name.get<std::string>(), nlohmann::json());
    if (name == "rms_um") {
      part = "rms " +
             (value.is_number() ? Um(value.get<double>()) : std::string("?")) +
             " > " + Um(*tolerance.rms_um);
    } else if (name == "max_um") {
      part = "max " +
             (value.is_number() ? Um(value.get<double>()) : std::string("?")) +
             " > " + Um(*tolerance.max_um);
    } else {
      part = "ISO 1328-1 class " +
             (value.is_number() ? value.dump() : std::string("> 11")) +
             " coarser than " + std::to_string(*tolerance.iso_class);
    }
    text += (text.empty() ? "" : ", ") + part;
  }
  return text;
}

}  // namespace gearloop
