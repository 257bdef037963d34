#include "server/codec/json_read.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>

namespace gearloop {

std::string TypeName(const nlohmann::json& value) {
  if (value.is_null()) return "null";
  if (value.is_boolean()) return "a boolean";
  if (value.is_number()) return "a number";
  if (value.is_string()) return "a string";
  if (value.is_array()) return "an array";
  return "an object";
}

bool NumberFromJson(const nlohmann::json& value,
                    const std::string& path,
                    double* out,
                    ApiError* error) {
  if (!value.is_number()) {
    *error = InvalidRequest(path,
                            path + " must be a number, got " + TypeName(value));
    return false;
  }
  const double number = value.get<double>();
  if (!std::isfinite(number)) {
    *error = InvalidValue(path, path + " must be a finite number");
    return false;
  }
  *out = number;
  return true;
}

namespace {

// Depth of nesting of arrays and objects, counted without parsing (strings
// skipped), so a hostile "[[[[..." never reaches the parser.
int JsonNestingDepth(const std::string& text) {
  int depth = 0;
  int max_depth = 0;
  bool in_string = false;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (c == '\\') {
        ++i;
      } else if (c == '"') {
        in_string = false;
      }
      continue;
    }
    if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      ++depth;
      if (depth > max_depth) max_depth = depth;
      if (max_depth > kMaxJsonDepth) return max_depth;
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
  return max_depth;
}

bool IntegerFromJson(const nlohmann::json& v,
                     const std::string& field,
                     long long* value,
                     ApiError* error) {
  if (v.is_number_integer()) {
    // Unsigned values above the signed range arrive as number_unsigned.
    if (v.is_number_unsigned() && v.get<unsigned long long>() > 1000000000ULL) {
      *error = InvalidValue(field, field + " is far too large");
      return false;
    }
    *value = v.get<long long>();
    return true;
  }
  if (v.is_number_float()) {
    const double d = v.get<double>();
    // 37.0 is 37; 37.5 is not a count.
    if (std::isfinite(d) && d == std::floor(d) && std::fabs(d) <= 1e9) {
      *value = static_cast<long long>(d);
      return true;
    }
    *error = InvalidRequest(field, field + " must be an integer");
    return false;
  }
  *error =
      InvalidRequest(field, field + " must be an integer, got " + TypeName(v));
  return false;
}

// Shared head of the Read* functions: sets *found (if given) to whether `key`
// is present; an absent optional field leaves the value at its default and
// succeeds, an absent required one fails with "missing required field". A
// present one goes to read_value(value, field).
template <typename ReadValue>
bool ReadField(const nlohmann::json& object,
               const std::string& path,
               const char* key,
               bool required,
               ApiError* error,
               bool* found,
               const ReadValue& read_value) {
  const std::string field = JoinPath(path, key);
  const bool present = object.contains(key);
  if (found != nullptr) *found = present;
  if (!present) {
    if (!required) return true;
    *error = InvalidRequest(field, "missing required field " + field);
    return false;
  }
  return read_value(object.at(key), field);
}

}  // namespace

bool ReadRange(const nlohmann::json& object,
               const std::string& path,
               const char* key,
               double* begin,
               double* end,
               ApiError* error) {
  const std::string field = JoinPath(path, key);
  if (!object.contains(key)) return true;  // defaults stay
  const nlohmann::json& value = object.at(key);
  if (!value.is_array() || value.size() != 2) {
    *error = InvalidRequest(
        field, field + " must be an array of two numbers [begin, end]");
    return false;
  }
  return NumberFromJson(value[0], field + "[0]", begin, error) &&
         NumberFromJson(value[1], field + "[1]", end, error);
}

bool RequireObject(const nlohmann::json& request,
                   const std::string& path,
                   const char* key,
                   bool required,
                   const nlohmann::json** out,
                   ApiError* error) {
  *out = nullptr;
  return ReadField(
      request,
      path,
      key,
      required,
      error,
      /*found=*/nullptr,
      [&](const nlohmann::json& value, const std::string& field) {
        if (!value.is_object()) {
          *error = InvalidRequest(
              field, field + " must be an object, got " + TypeName(value));
          return false;
        }
        *out = &value;
        return true;
      });
}

std::string JoinPath(const std::string& path, const std::string& key) {
  return path.empty() ? key : path + "." + key;
}

ApiError InvalidRequest(const std::string& field, const std::string& message) {
  return ApiError{400, "invalid_request", message, field};
}

ApiError InvalidValue(const std::string& field, const std::string& message) {
  return ApiError{422, "invalid_value", message, field};
}

nlohmann::json ErrorBody(const ApiError& error) {
  return {{"error",
           {{"code", error.code},
            {"message", error.message},
            {"field", error.field}}}};
}

bool ParseJsonBody(const std::string& text,
                   nlohmann::json* body,
                   ApiError* error) {
  if (JsonNestingDepth(text) > kMaxJsonDepth) {
    *error = ApiError{400,
                      "invalid_json",
                      "the body nests arrays or objects deeper than " +
                          std::to_string(kMaxJsonDepth) + " levels",
                      ""};
    return false;
  }
  // Parse without exceptions; nlohmann refuses NaN, Infinity and invalid UTF-8
  // in strings.
  nlohmann::json parsed =
      nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (parsed.is_discarded()) {
    // Parse again with exceptions only for the message (position of the fault).
    std::string message = "the body is not valid JSON";
    try {
      nlohmann::json unused = nlohmann::json::parse(text);
      (void)unused;
    } catch (const nlohmann::json::exception& e) {
      message += std::string(": ") + e.what();
    }
    *error = ApiError{400, "invalid_json", message, ""};
    return false;
  }
  if (!parsed.is_object()) {
    *error = InvalidRequest(
        "", "the body must be a JSON object, got " + TypeName(parsed));
    return false;
  }
  *body = std::move(parsed);
  return true;
}

bool ReadNumber(const nlohmann::json& object,
                const std::string& path,
                const char* key,
                bool required,
                double* value,
                ApiError* error,
                bool* found) {
  return ReadField(object,
                   path,
                   key,
                   required,
                   error,
                   found,
                   [&](const nlohmann::json& v, const std::string& field) {
                     return NumberFromJson(v, field, value, error);
                   });
}

bool ReadInteger(const nlohmann::json& object,
                 const std::string& path,
                 const char* key,
                 bool required,
                 long long* value,
                 ApiError* error,
                 bool* found) {
  return ReadField(object,
                   path,
                   key,
                   required,
                   error,
                   found,
                   [&](const nlohmann::json& v, const std::string& field) {
                     return IntegerFromJson(v, field, value, error);
                   });
}

bool ReadString(const nlohmann::json& object,
                const std::string& path,
                const char* key,
                bool required,
                std::string* value,
                ApiError* error,
                bool* found) {
  return ReadField(object,
                   path,
                   key,
                   required,
                   error,
                   found,
                   [&](const nlohmann::json& v, const std::string& field) {
                     if (!v.is_string()) {
                       *error = InvalidRequest(
                           field,
                           field + " must be a string, got " + TypeName(v));
                       return false;
                     }
                     *value = v.get<std::string>();
                     return true;
                   });
}

bool ReadBool(const nlohmann::json& object,
              const std::string& path,
              const char* key,
              bool required,
              bool* value,
              ApiError* error,
              bool* found) {
  return ReadField(
      object,
      path,
      key,
      required,
      error,
      found,
      [&](const nlohmann::json& v, const std::string& field) {
        if (!v.is_boolean()) {
          *error = InvalidRequest(
              field, field + " must be true or false, got " + TypeName(v));
          return false;
        }
        *value = v.get<bool>();
        return true;
      });
}

bool ReadCoefficient(const nlohmann::json& value,
                     const std::string& entry,
                     double max_abs,
                     const std::string& requirement,
                     double* coefficient,
                     ApiError* error) {
  if (!value.is_number()) {
    *error = InvalidRequest(entry, entry + " must be a number");
    return false;
  }
  const double v = value.get<double>();
  if (!std::isfinite(v) || std::fabs(v) > max_abs) {
    *error = InvalidValue(entry, entry + " must be " + requirement);
    return false;
  }
  *coefficient = v;
  return true;
}

bool ParseGridValues(const nlohmann::json& value,
                     const std::string& path,
                     int rows,
                     int columns,
                     bool allow_null,
                     Eigen::VectorXd* values,
                     std::vector<bool>* present,
                     ApiError* error) {
  if (!value.is_array() || static_cast<int>(value.size()) != rows) {
    *error =
        InvalidRequest(path,
                       path + " must be an array of " + std::to_string(rows) +
                           " rows (the grid's profile_points)");
    return false;
  }
  values->setZero(rows * columns);
  present->assign(rows * columns, true);
  for (int r = 0; r < rows; ++r) {
    const std::string row_path = path + "[" + std::to_string(r) + "]";
    const nlohmann::json& row = value[r];
    if (!row.is_array() || static_cast<int>(row.size()) != columns) {
      *error = InvalidRequest(row_path,
                              row_path + " must be an array of " +
                                  std::to_string(columns) +
                                  " numbers (the grid's lead_points)");
      return false;
    }
    for (int c = 0; c < columns; ++c) {
      const std::string entry_path = row_path + "[" + std::to_string(c) + "]";
      const nlohmann::json& entry = row[c];
      if (entry.is_null()) {
        if (!allow_null) {
          *error = InvalidRequest(entry_path,
                                  entry_path + " must be a number, got null");
          return false;
        }
        (*present)[r * columns + c] = false;
        continue;
      }
      double number = 0.0;
      if (!NumberFromJson(entry, entry_path, &number, error)) return false;
      if (std::fabs(number) > 1e6) {
        *error = InvalidValue(
            entry_path,
            entry_path +
                " is beyond 1 m of deviation; deviations are in micrometres");
        return false;
      }
      (*values)(r * columns + c) = number;
    }
  }
  return true;
}

nlohmann::json GridToJson(const Eigen::VectorXd& values,
                          const std::vector<bool>& present,
                          int rows,
                          int columns) {
  nlohmann::json grid = nlohmann::json::array();
  for (int r = 0; r < rows; ++r) {
    nlohmann::json row = nlohmann::json::array();
    for (int c = 0; c < columns; ++c) {
      const int i = r * columns + c;
      const bool ok = (present.empty() || present[i]) && i < values.size() &&
                      std::isfinite(values(i));
      row.push_back(ok ? nlohmann::json(values(i)) : nlohmann::json(nullptr));
    }
    grid.push_back(row);
  }
  return grid;
}

double RoundTo1e9(double value) { return std::round(value * 1e9) / 1e9; }

namespace {

size_t EditDistance(const std::string& a, const std::string& b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t above = row[j];
      row[j] = std::min({row[j] + 1,
                         row[j - 1] + 1,
                         diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

}  // namespace

std::string NearestName(const std::string& name,
                        const std::vector<std::string>& known) {
  if (name.size() > 64) return "";
  std::string best;
  size_t best_distance = std::max<size_t>(1, name.size() / 3) + 1;
  for (const std::string& candidate : known) {
    const size_t distance = EditDistance(name, candidate);
    if (distance < best_distance) {
      best_distance = distance;
      best = candidate;
    }
  }
  return best;
}

bool CheckKeys(const nlohmann::json& object,
               const std::string& path,
               const std::vector<std::string>& allowed,
               ApiError* error) {
  if (!object.is_object()) return true;
  for (const auto& item : object.items()) {
    if (std::find(allowed.begin(), allowed.end(), item.key()) != allowed.end())
      continue;
    const std::string field = JoinPath(path, item.key());
    std::string message = "unknown key " + field;
    const std::string nearest = NearestName(item.key(), allowed);
    if (!nearest.empty()) message += "; did you mean " + nearest + "?";
    *error = InvalidValue(field, message);
    return false;
  }
  return true;
}

}  // namespace gearloop
