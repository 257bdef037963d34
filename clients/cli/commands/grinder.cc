// clients/cli/commands/grinder.cc: the grinder model without a correction:
// `gearloop nominal` (POST /api/v1/nominal) and `gearloop evaluate` (POST
// /api/v1/evaluate).
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "clients/cli/command_util.h"
#include "clients/cli/commands/subcommands.h"
#include "clients/cli/csv_grid.h"
#include "clients/cli/grid_files.h"

namespace gearloop {
namespace cli_internal {
namespace {

using nlohmann::json;

// Axis coefficients as a table: one line per axis, one column per power of the
// roll angle.
void PrintSettings(const json& settings) {
  const json axes = settings.value("axes", json::object());
  std::cout << std::left << std::setw(9) << "axis" << std::right;
  for (int k = 0; k < 7; ++k)
    std::cout << std::setw(14) << ("phi^" + std::to_string(k));
  std::cout << "\n";
  for (const char* axis : {"X", "Y", "Z", "A", "B", "C"}) {
    const bool linear = axis[0] == 'X' || axis[0] == 'Y' || axis[0] == 'Z';
    std::cout << std::left << std::setw(9)
              << (std::string(axis) + (linear ? " [mm]" : " [rad]"))
              << std::right;
    const json coefficients = axes.value(axis, json::array());
    for (int k = 0; k < 7; ++k) {
      std::ostringstream cell;
      if (k < static_cast<int>(coefficients.size()) &&
          coefficients[k].is_number()) {
        cell << std::scientific << std::setprecision(5)
             << coefficients[k].get<double>();
      } else {
        cell << "0";
      }
      std::cout << std::setw(14) << cell.str();
    }
    std::cout << "\n";
  }
  const json wheel = settings.value("wheel", json::object());
  std::cout << "wheel: cone angle " << Member(wheel, "cone_angle_deg")
            << " deg, parabola " << Member(wheel, "parabola_coefficient_per_mm")
            << " /mm, vertex " << Member(wheel, "parabola_vertex_mm")
            << " mm\n";
}

}  // namespace

const CommandSpec kNominal{
    "nominal",
    "usage: gearloop nominal REQUEST.json [--settings-out FILE]\n\n"
    "Prints the nominal machine settings of the setup in REQUEST.json (gear, "
    "wheel,\n"
    "machine, flank; POST /api/v1/nominal): the settings that grind the exact\n"
    "involute helicoid, and the roll range. Other keys of the file (a "
    "correction's\n"
    "measurement, target, options) are left out.\n\n"
    "options:\n"
    "  --settings-out FILE   write the settings as JSON (input of `evaluate "
    "--settings`)\n",
    {"--settings-out"},
    {},
    1,
    1};

int RunNominal(const ParsedArgs& args,
               ApiClient* client,
               const GlobalOptions& global) {
  json request;
  std::string error;
  if (!ReadJsonFile(args.positional[0], &request, &error))
    return InputError(error);
  if (!request.is_object())
    return InputError(args.positional[0] +
                      ": the request must be a JSON object");
  const ApiResponse answer =
      client->Post("/api/v1/nominal", OnlyKeys(request, kGrinderSetupKeys));
  const int failure = CheckAnswer(answer);
  if (failure >= 0) return failure;
  if (args.Has("--settings-out") &&
      !WriteTextFile(
          args.Value("--settings-out"),
          answer.body.value("settings", json::object()).dump(2) + "\n",
          &error)) {
    return InputError(error);
  }
  if (global.json) {
    PrintJson(answer.body);
    return kExitOk;
  }
  PrintSettings(answer.body.value("settings", json::object()));
  const json roll = answer.body.value("roll_range_deg", json::array());
  if (roll.is_array() && roll.size() == 2) {
    std::cout << "roll range " << Fixed(roll[0]) << " .. " << Fixed(roll[1])
              << " deg, pitch radius "
              << Fixed(answer.body.value("pitch_radius_mm", json()))
              << " mm, base radius "
              << Fixed(answer.body.value("base_radius_mm", json())) << " mm\n";
  }
  return kExitOk;
}

const CommandSpec kEvaluate{
    "evaluate",
    "usage: gearloop evaluate REQUEST.json [--settings FILE] [--csv FILE]\n\n"
    "Grinds the flank of REQUEST.json's setup in the model with the given "
    "settings and prints its\n"
    "deviations from the involute on the grid (POST /api/v1/evaluate); points "
    "the wheel does not\n"
    "reach are shown as '-'. Only the setup (gear, wheel, machine, grid, "
    "flank, settings) is sent.\n\n"
    "options:\n"
    "  --settings FILE   machine settings JSON ({axes, wheel}, e.g. from "
    "`submit --settings-out`);\n"
    "                    default REQUEST.json's settings, else nominal\n"
    "  --csv FILE        write the grid as CSV\n",
    {"--settings", "--csv"},
    {},
    1,
    1};

int RunEvaluate(const ParsedArgs& args,
                ApiClient* client,
                const GlobalOptions& global) {
  json request;
  std::string error;
  if (!ReadJsonFile(args.positional[0], &request, &error))
    return InputError(error);
  if (!request.is_object())
    return InputError(args.positional[0] +
                      ": the request must be a JSON object");
  if (args.Has("--settings")) {
    json settings;
    if (!ReadJsonFile(args.Value("--settings"), &settings, &error))
      return InputError(error);
    if (settings.is_object() && settings.contains("settings"))
      settings = settings["settings"];
    request["settings"] = settings;
  }
  const ApiResponse answer =
      client->Post("/api/v1/evaluate", OnlyKeys(request, kGrinderSetupKeys));
  const int failure = CheckAnswer(answer);
  if (failure >= 0) return failure;
  const json grid = answer.body.value("deviations_um", json());
  if (args.Has("--csv")) {
    CsvGrid csv;
    if (!JsonToCsvGrid(grid, &csv)) {
      std::cerr << "gearloop evaluate: the answer holds no deviation grid\n";
      return kExitTransport;
    }
    if (!WriteTextFile(args.Value("--csv"), FormatCsvGrid(csv, true), &error))
      return InputError(error);
  }
  if (global.json) {
    PrintJson(answer.body);
    return kExitOk;
  }
  PrintGrid("deviations from the involute", grid);
  const json not_reached = answer.body.value("not_reached", json::array());
  if (not_reached.is_array() && !not_reached.empty()) {
    std::cout << not_reached.size() << " points not reached by the wheel\n";
  }
  return kExitOk;
}

}  // namespace cli_internal
}  // namespace gearloop
