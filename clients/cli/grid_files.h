// clients/cli/grid_files.h: the files the command-line client reads and writes
// (clients/FORMATS.md) turned into the API's JSON: measurement files (CSV grid
// or JSON), target files, and the grids of a stored job. Every refusal names
// the file and the place in it.
//
//   nlohmann::json measurement;
//   std::string error;
//   if (!ReadMeasurementFile("part7.csv", 5, 9, &measurement, &error)) {
//     std::cerr << error << "\n";   // "part7.csv: line 6, column 3: '0.6x' is
//     not a number ..."
//   }
//   request["measurement"] = measurement;   // {"deviations_um": [[...], ...]}
#ifndef GEARLOOP_CLIENTS_CLI_GRID_FILES_H_
#define GEARLOOP_CLIENTS_CLI_GRID_FILES_H_

#include <nlohmann/json.hpp>
#include <string>

#include "clients/cli/csv_grid.h"

namespace gearloop {

// Whole-file reads and writes; false with "<path>: <reason>" in `error`.
bool ReadTextFile(const std::string& path,
                  std::string* text,
                  std::string* error);
bool WriteTextFile(const std::string& path,
                   const std::string& text,
                   std::string* error);
// A JSON file; parse errors carry nlohmann's "at line L, column C".
bool ReadJsonFile(const std::string& path,
                  nlohmann::json* value,
                  std::string* error);
// True when `path` ends in `extension` (".csv"), in any case.
bool HasExtension(const std::string& path, const char* extension);

// A CsvGrid as the API's array of rows (null = missing), and back.
// JsonToCsvGrid is false when `value` is not a non-empty rectangular array of
// rows of numbers and nulls.
nlohmann::json CsvGridToJson(const CsvGrid& grid);
bool JsonToCsvGrid(const nlohmann::json& value, CsvGrid* grid);

// Checks that `value` (found at `path`, e.g. "part7.json: deviations_um") is a
// rows x columns grid of numbers, and of nulls when `allow_null`. The error
// names the row or entry: "part7.json: deviations_um[2] has 8 entries, expected
// 9".
bool CheckJsonGrid(const nlohmann::json& value,
                   const std::string& path,
                   int rows,
                   int columns,
                   bool allow_null,
                   std::string* error);

// The grid shape a correction request asks for: grid.profile_points x
// grid.lead_points, by default 5 x 9 (MODEL.md §4).
void GridShape(const nlohmann::json& request, int* rows, int* columns);

// A measurement file as the API's measurement object:
//   *.csv   one grid (csv_grid.h)              -> {"deviations_um": grid}
//   *.json  {"deviations_um": grid} or {"teeth": [grid, ...]}, either possibly
//   inside
//           "measurement", or a bare array of rows; other members (part, tooth,
//           ...) are dropped
bool ReadMeasurementFile(const std::string& path,
                         int rows,
                         int columns,
                         nlohmann::json* measurement,
                         std::string* error);

// A target file: a complete CSV grid, or JSON {"deviations_um"} /
// {"modifications": [...]} (possibly inside "target"), or a bare list of
// modifications.
bool ReadTargetFile(const std::string& path,
                    int rows,
                    int columns,
                    nlohmann::json* target,
                    std::string* error);

// The grids of a stored job (the answer of GET /api/v1/corrections/{id}); null
// when unknown.
//   MeasuredGrid: result.measured_um (the grid the solver used), else, for a
//   job stored before
//                 the server sent it, the request's grid or the point-by-point
//                 mean of its teeth.
//   TargetGrid:   result.target_um, else the request's target grid, zeros when
//   the request had
//                 no target, null for an older job whose target was given as
//                 modifications (the grid is the server's to evaluate; it is
//                 not rebuilt from the other grids).
nlohmann::json MeasuredGrid(const nlohmann::json& job);
nlohmann::json TargetGrid(const nlohmann::json& job);

}  // namespace gearloop

#endif  // GEARLOOP_CLIENTS_CLI_GRID_FILES_H_
