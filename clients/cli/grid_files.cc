// clients/cli/grid_files.cc: reading measurement and target files and the grids
// of stored jobs. JSON grids are checked here, before sending, so that a wrong
// file is reported with its own name and the place in it (exit 4), not as the
// server's field path in a request (exit 3).
#include "clients/cli/grid_files.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <vector>

namespace gearloop {

using nlohmann::json;
namespace fs = std::filesystem;

bool ReadTextFile(const std::string& path,
                  std::string* text,
                  std::string* error) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    *error = path + ": cannot open file";
    return false;
  }
  std::ostringstream buffer;
  buffer << in.rdbuf();
  *text = buffer.str();
  return true;
}

bool ReadJsonFile(const std::string& path, json* value, std::string* error) {
  std::string text;
  if (!ReadTextFile(path, &text, error)) return false;
  try {
    *value = json::parse(text);
  } catch (const json::parse_error& e) {
    // nlohmann's message already says "at line L, column C".
    *error = path + ": not valid JSON: " + e.what();
    return false;
  }
  return true;
}

bool HasExtension(const std::string& path, const char* extension) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) {
    return std::tolower(c);
  });
  return ext == extension;
}

json CsvGridToJson(const CsvGrid& grid) {
  json rows = json::array();
  for (int r = 0; r < grid.rows; ++r) {
    json row = json::array();
    for (int c = 0; c < grid.columns; ++c) {
      const auto& v = grid.at(r, c);
      row.push_back(v ? json(*v) : json(nullptr));
    }
    rows.push_back(row);
  }
  return rows;
}

// A JSON array of rows (numbers or null) into a CsvGrid; false when it is not
// one.
bool JsonToCsvGrid(const json& value, CsvGrid* grid) {
  if (!value.is_array() || value.empty() || !value[0].is_array()) return false;
  grid->rows = static_cast<int>(value.size());
  grid->columns = static_cast<int>(value[0].size());
  grid->values.clear();
  for (const json& row : value) {
    if (!row.is_array() || static_cast<int>(row.size()) != grid->columns)
      return false;
    for (const json& v : row) {
      if (v.is_number()) {
        grid->values.emplace_back(v.get<double>());
      } else if (v.is_null()) {
        grid->values.emplace_back(std::nullopt);
      } else {
        return false;
      }
    }
  }
  return true;
}

bool CheckJsonGrid(const json& value,
                   const std::string& path,
                   int rows,
                   int columns,
                   bool allow_null,
                   std::string* error) {
  if (!value.is_array()) {
    *error = path + " must be an array of " + std::to_string(rows) + " rows";
    return false;
  }
  if (static_cast<int>(value.size()) != rows) {
    *error = path + " has " + std::to_string(value.size()) +
             " rows, expected " + std::to_string(rows);
    return false;
  }
  for (int r = 0; r < rows; ++r) {
    const std::string row_path = path + "[" + std::to_string(r) + "]";
    const json& row = value[r];
    if (!row.is_array()) {
      *error = row_path + " must be an array of " + std::to_string(columns) +
               " values";
      return false;
    }
    if (static_cast<int>(row.size()) != columns) {
      *error = row_path + " has " + std::to_string(row.size()) +
               " entries, expected " + std::to_string(columns);
      return false;
    }
    for (int c = 0; c < columns; ++c) {
      const json& v = row[c];
      if (v.is_number() || (allow_null && v.is_null())) continue;
      *error = row_path + "[" + std::to_string(c) + "] is " +
               (v.is_null() ? "null" : v.dump()) +
               (allow_null
                    ? ", expected a number in um or null"
                    : ", expected a number in um (this grid must be complete)");
      return false;
    }
  }
  return true;
}

// The grid shape a request asks for (grid.profile_points x grid.lead_points,
// default 5 x 9).
void GridShape(const json& request, int* rows, int* columns) {
  *rows = 5;
  *columns = 9;
  if (request.is_object() && request.contains("grid") &&
      request["grid"].is_object()) {
    const json& grid = request["grid"];
    if (grid.contains("profile_points") &&
        grid["profile_points"].is_number_integer()) {
      *rows = grid["profile_points"].get<int>();
    }
    if (grid.contains("lead_points") &&
        grid["lead_points"].is_number_integer()) {
      *columns = grid["lead_points"].get<int>();
    }
  }
}

namespace {

// Reads a CSV grid file of rows x columns um values (clients/cli/csv_grid.h)
// into
// {"deviations_um": grid}; allow_missing: empty cells become null instead of an
// error.
bool ReadCsvGridFile(const std::string& path,
                     int rows,
                     int columns,
                     bool allow_missing,
                     json* out,
                     std::string* error) {
  std::string text;
  if (!ReadTextFile(path, &text, error)) return false;
  CsvGridOptions options;
  options.rows = rows;
  options.columns = columns;
  options.allow_missing = allow_missing;
  CsvGrid grid;
  CsvGridError csv_error;
  if (!ParseCsvGrid(text, options, &grid, &csv_error)) {
    *error = path + ": " + csv_error.ToString();
    return false;
  }
  *out = {{"deviations_um", CsvGridToJson(grid)}};
  return true;
}

}  // namespace

// Reads a measurement file into the API's measurement object.
//   *.csv   one grid (clients/cli/csv_grid.h)
//   *.json  {"deviations_um": grid} or {"teeth": [grid, ...]}, or either inside
//   "measurement"
//           (clients/FORMATS.md); other members (part, tooth, machine, ...) are
//           ignored
bool ReadMeasurementFile(const std::string& path,
                         int rows,
                         int columns,
                         json* measurement,
                         std::string* error) {
  if (HasExtension(path, ".csv")) {
    return ReadCsvGridFile(
        path, rows, columns, /*allow_missing=*/true, measurement, error);
  }
  json file;
  if (!ReadJsonFile(path, &file, error)) return false;
  if (file.is_object() && file.contains("measurement"))
    file = file["measurement"];
  if (file.is_array()) file = {{"deviations_um", file}};
  if (!file.is_object() ||
      (!file.contains("deviations_um") && !file.contains("teeth"))) {
    *error = path + ": a measurement file holds \"deviations_um\" (a grid of " +
             std::to_string(rows) + " rows x " + std::to_string(columns) +
             " um values, null = missing) or \"teeth\" (a list of such grids)";
    return false;
  }
  json out = json::object();
  if (file.contains("deviations_um")) {
    if (!CheckJsonGrid(file["deviations_um"],
                       path + ": deviations_um",
                       rows,
                       columns,
                       /*allow_null=*/true,
                       error)) {
      return false;
    }
    out["deviations_um"] = file["deviations_um"];
  }
  if (file.contains("teeth")) {
    const json& teeth = file["teeth"];
    if (!teeth.is_array() || teeth.empty()) {
      *error = path + ": teeth must be a non-empty list of grids";
      return false;
    }
    for (size_t i = 0; i < teeth.size(); ++i) {
      if (!CheckJsonGrid(teeth[i],
                         path + ": teeth[" + std::to_string(i) + "]",
                         rows,
                         columns,
                         true,
                         error)) {
        return false;
      }
    }
    out["teeth"] = teeth;
  }
  *measurement = out;
  return true;
}

// A target file: a complete grid (*.csv or JSON {"deviations_um"}) or JSON
// {"modifications"}.
bool ReadTargetFile(const std::string& path,
                    int rows,
                    int columns,
                    json* target,
                    std::string* error) {
  if (HasExtension(path, ".csv")) {
    return ReadCsvGridFile(
        path, rows, columns, /*allow_missing=*/false, target, error);
  }
  json file;
  if (!ReadJsonFile(path, &file, error)) return false;
  if (file.is_object() && file.contains("target")) file = file["target"];
  if (file.is_array()) file = {{"modifications", file}};
  if (!file.is_object() ||
      (!file.contains("deviations_um") && !file.contains("modifications"))) {
    *error = path +
             ": a target file holds \"deviations_um\" (a complete grid) or "
             "\"modifications\" (a list)";
    return false;
  }
  if (file.contains("deviations_um") && !CheckJsonGrid(file["deviations_um"],
                                                       path + ": deviations_um",
                                                       rows,
                                                       columns,
                                                       /*allow_null=*/false,
                                                       error)) {
    return false;
  }
  *target = file;
  return true;
}

bool WriteTextFile(const std::string& path,
                   const std::string& text,
                   std::string* error) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  if (!out) {
    *error = path + ": cannot write file";
    return false;
  }
  return true;
}

// The measured grid of a stored job: the result's copy (what the solver used),
// else, for a job stored before the server sent it, the request's grid or the
// point-by-point mean of its teeth.
json MeasuredGrid(const json& job) {
  const json result = job.value("result", json::object());
  if (result.contains("measured_um")) return result["measured_um"];
  const json request = job.value("request", json::object());
  const json measurement = request.value("measurement", json::object());
  if (measurement.contains("deviations_um"))
    return measurement["deviations_um"];
  if (!measurement.contains("teeth") || !measurement["teeth"].is_array())
    return json();
  CsvGrid sum;
  std::vector<int> count;
  for (const json& tooth : measurement["teeth"]) {
    CsvGrid grid;
    if (!JsonToCsvGrid(tooth, &grid)) return json();
    if (sum.values.empty()) {
      sum = grid;
      for (auto& v : sum.values)
        v = v ? std::optional<double>(0.0) : std::nullopt;
      count.assign(sum.values.size(), 0);
    }
    if (grid.values.size() != sum.values.size()) return json();
    for (size_t i = 0; i < grid.values.size(); ++i) {
      if (!grid.values[i]) continue;
      sum.values[i] = sum.values[i].value_or(0.0) + *grid.values[i];
      ++count[i];
    }
  }
  for (size_t i = 0; i < sum.values.size(); ++i) {
    if (count[i] > 0) {
      sum.values[i] = *sum.values[i] / count[i];
    } else {
      sum.values[i] = std::nullopt;
    }
  }
  return CsvGridToJson(sum);
}

// The target grid: the result's copy, else (a job stored before the server sent
// it) the request's own grid, or zeros when there was no target. A target given
// as modifications is evaluated by the server only; an older job without
// target_um then has no target grid here.
json TargetGrid(const json& job) {
  const json result = job.value("result", json::object());
  if (result.contains("target_um")) return result["target_um"];
  const json request = job.value("request", json::object());
  const json target = request.value("target", json());
  if (target.is_object() && target.contains("deviations_um"))
    return target["deviations_um"];
  if (!target.is_null()) return json();
  CsvGrid measured;
  if (!JsonToCsvGrid(MeasuredGrid(job), &measured)) return json();
  for (auto& v : measured.values)
    v = 0.0;  // no target: the designed flank is the exact involute
  return CsvGridToJson(measured);
}

}  // namespace gearloop
