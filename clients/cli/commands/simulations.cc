// clients/cli/commands/simulations.cc: `gearloop simulate` and `gearloop
// closed-loop`, the simulated measuring machine and closed loop of a gear
// grinder (POST /api/v1/simulations/...).
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>

#include "clients/cli/command_util.h"
#include "clients/cli/commands/subcommands.h"
#include "clients/cli/csv_grid.h"
#include "clients/cli/grid_files.h"

namespace gearloop {
namespace cli_internal {
namespace {

using nlohmann::json;

}  // namespace

const CommandSpec kSimulate{
    "simulate",
    "usage: gearloop simulate SCENARIO.json [--csv FILE] [--seed N] [--noise "
    "UM]\n\n"
    "Simulates the measuring machine (POST /api/v1/simulations/measurement): "
    "the flank a machine\n"
    "with hidden errors grinds from the commanded settings, as the CMM reports "
    "it. SCENARIO.json\n"
    "holds the setup (gear, wheel, machine, grid, flank), settings, "
    "hidden_errors or\n"
    "random_hidden_errors, noise_um, seed, missing_probability, ...; a "
    "closed-loop\n"
    "scenario's corrections, target, options and store are left out.\n\n"
    "options:\n"
    "  --csv FILE     write the simulated measurement as a CSV grid (input for "
    "`submit`)\n"
    "  --seed N       override the seed\n"
    "  --noise UM     override noise_um\n",
    {"--csv", "--seed", "--noise"},
    {},
    1,
    1};

int RunSimulate(const ParsedArgs& args,
                ApiClient* client,
                const GlobalOptions& global) {
  json scenario;
  std::string error;
  if (!ReadJsonFile(args.positional[0], &scenario, &error))
    return InputError(error);
  if (!scenario.is_object())
    return InputError(args.positional[0] +
                      ": the scenario must be a JSON object");
  const int bad = ApplySeedAndNoise(kSimulate, args, &scenario);
  if (bad >= 0) return bad;
  // A closed-loop scenario's own keys (corrections, target, options, store)
  // are not the measurement's: left out.
  const std::vector<std::string> keys = {"gear",
                                         "wheel",
                                         "machine",
                                         "grid",
                                         "flank",
                                         "settings",
                                         "hidden_errors",
                                         "random_hidden_errors",
                                         "noise_um",
                                         "seed",
                                         "outlier_probability",
                                         "outlier_size_um",
                                         "missing_probability",
                                         "teeth",
                                         "outlier_points",
                                         "missing_points"};
  const ApiResponse answer =
      client->Post("/api/v1/simulations/measurement", OnlyKeys(scenario, keys));
  const int failure = CheckAnswer(answer);
  if (failure >= 0) return failure;
  json grid;
  if (answer.body.contains("measurement") &&
      answer.body["measurement"].is_object()) {
    grid = answer.body["measurement"].value("deviations_um", json());
  }
  if (args.Has("--csv")) {
    CsvGrid csv;
    if (!JsonToCsvGrid(grid, &csv)) {
      std::cerr << "gearloop simulate: the answer holds no measurement grid\n";
      return kExitTransport;
    }
    if (!WriteTextFile(args.Value("--csv"), FormatCsvGrid(csv, true), &error))
      return InputError(error);
  }
  if (global.json) {
    PrintJson(answer.body);
  } else {
    PrintGrid("simulated measurement", grid);
    if (answer.body.contains("missing") && answer.body["missing"].is_array()) {
      std::cout << answer.body["missing"].size() << " missing points, ";
    }
    if (answer.body.contains("outliers") &&
        answer.body["outliers"].is_array()) {
      std::cout << answer.body["outliers"].size() << " outliers";
    }
    std::cout << "\n";
  }
  return kExitOk;
}

const CommandSpec kClosedLoop{
    "closed-loop",
    "usage: gearloop closed-loop SCENARIO.json [--corrections N] [--store]\n\n"
    "Runs a simulated closed loop on the server (POST "
    "/api/v1/simulations/closed-loop): grind\n"
    "with hidden machine errors, measure, correct, grind again, N times; "
    "prints the true and\n"
    "measured deviation of each part. SCENARIO.json: as for `simulate`, plus "
    "target, options.\n\n"
    "options:\n"
    "  --corrections N   number of corrections (1..20)\n"
    "  --store           keep each correction as a job (linked revision after "
    "revision)\n",
    {"--corrections"},
    {"--store"},
    1,
    1};

int RunClosedLoop(const ParsedArgs& args,
                  ApiClient* client,
                  const GlobalOptions& global) {
  json scenario;
  std::string error;
  if (!ReadJsonFile(args.positional[0], &scenario, &error))
    return InputError(error);
  if (!scenario.is_object())
    return InputError(args.positional[0] +
                      ": the scenario must be a JSON object");
  const int bad = ApplyCorrectionsAndStore(kClosedLoop, args, &scenario);
  if (bad >= 0) return bad;
  return SendClosedLoop(client, scenario, "ground", global);
}

}  // namespace cli_internal
}  // namespace gearloop
