// clients/cli/commands/corrections.cc: `gearloop submit` and `gearloop replay`,
// which compute a correction and store it as a job (POST /api/v1/corrections,
// /api/v1/corrections/ID/replay).
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

bool IsConverged(const json& answer) {
  if (!answer.contains("result") || !answer["result"].is_object()) return false;
  return answer["result"].value("status", "") == "converged";
}

// Sends a correction request; prints; exit code.
int SendCorrection(ApiClient* client,
                   const std::string& path,
                   const json& body,
                   const GlobalOptions& global) {
  const ApiResponse answer = client->Post(path, body);
  const int failure = CheckAnswer(answer);
  if (failure >= 0) return failure;
  if (global.json) {
    PrintJson(answer.body);
  } else {
    PrintCorrectionSummary(answer.body);
  }
  return IsConverged(answer.body) ? kExitOk : kExitNotConverged;
}

}  // namespace

const CommandSpec kSubmit{
    "submit",
    "usage: gearloop submit REQUEST.json MEASUREMENT.(csv|json) [options]\n\n"
    "Computes a correction for a measured flank and stores it as a job (POST "
    "/api/v1/corrections).\n"
    "REQUEST.json holds the setup: gear, wheel, machine, grid, flank, and "
    "optionally settings\n"
    "(what the part was ground with; default nominal), target and options. "
    "MEASUREMENT is a CSV\n"
    "grid (5 rows x 9 columns, row 1 = root side, empty or null = missing) or "
    "a JSON measurement\n"
    "file (clients/FORMATS.md). It replaces any measurement in "
    "REQUEST.json.\n\n"
    "options:\n"
    "  --target FILE         wanted topography: CSV grid (complete) or JSON "
    "{modifications:[...]}\n"
    "  --options FILE        JSON object of solver options, merged over "
    "REQUEST.json's\n"
    "  --settings-from ID    the part was ground with the corrected settings "
    "of job ID\n"
    "                        (they are fetched when REQUEST.json has no "
    "settings)\n"
    "  --residual-csv FILE   write the predicted residual grid as CSV\n"
    "  --settings-out FILE   write the new machine settings as JSON\n"
    "(trace of the part, each optional:)\n" +
        std::string(kTraceOptionsHelp) +
        "\nExit 0 converged, 5 stored but not converged, 3 refused (the "
        "message names the field).\n",
    {"--target",
     "--options",
     "--settings-from",
     "--residual-csv",
     "--settings-out",
     "--part-number",
     "--serial",
     "--teeth",
     "--measured-at",
     "--machine-id",
     "--file-name"},
    {},
    2,
    2};

int RunSubmit(const ParsedArgs& args,
              ApiClient* client,
              const GlobalOptions& global) {
  json request;
  int built = BuildCorrectionRequest(
      args.positional[0], args.positional[1], args, &request);
  if (built >= 0) return built;
  built = ApplyTraceOptions("submit", args, "", &request);
  if (built >= 0) return built;
  return SubmitCorrectionRequest(client, request, args, global);
}

int SubmitCorrectionRequest(ApiClient* client,
                            json request,
                            const ParsedArgs& args,
                            const GlobalOptions& global) {
  json source_settings;
  const int built = FillSourceSettings(client, &request, &source_settings);
  if (built >= 0) return built;
  const ApiResponse answer = client->Post("/api/v1/corrections", request);
  const int failure = CheckAnswer(answer);
  if (failure >= 0) return failure;
  const json& result =
      answer.body.contains("result") ? answer.body["result"] : json::object();
  std::string error;
  if (args.Has("--residual-csv") && result.contains("predicted_residual_um")) {
    CsvGrid grid;
    if (JsonToCsvGrid(result["predicted_residual_um"], &grid) &&
        !WriteTextFile(
            args.Value("--residual-csv"), FormatCsvGrid(grid, true), &error)) {
      return InputError(error);
    }
  }
  if (args.Has("--settings-out") && result.contains("settings")) {
    if (!WriteTextFile(args.Value("--settings-out"),
                       result["settings"].dump(2) + "\n",
                       &error))
      return InputError(error);
  }
  if (global.json) {
    PrintJson(answer.body);
  } else {
    PrintCorrectionSummary(answer.body);
  }
  return IsConverged(answer.body) ? kExitOk : kExitNotConverged;
}

const CommandSpec kReplay{
    "replay",
    "usage: gearloop replay ID [--options FILE] [--set NAME=VALUE ...] "
    "[--target FILE]\n\n"
    "Re-runs the stored measurement of job ID with changed options or target\n"
    "(POST /api/v1/corrections/ID/replay); the new job is linked to its "
    "parent.\n\n"
    "options:\n"
    "  --options FILE     JSON object merged over the stored options (null "
    "removes)\n"
    "  --set NAME=VALUE   one option; VALUE is read as JSON when it parses\n"
    "                     (--set solver=pso --set max_num_iterations=100)\n"
    "  --target FILE      a new target: CSV grid or JSON "
    "{modifications:[...]}\n",
    {"--options", "--set", "--target"},
    {},
    1,
    1};

int RunReplay(const ParsedArgs& args,
              ApiClient* client,
              const GlobalOptions& global) {
  long long id = 0;
  if (!ParseJobId(args.positional[0], &id)) {
    std::cerr << "gearloop replay: '" << args.positional[0]
              << "' is not a job id\n";
    return kExitUsage;
  }
  json changes = json::object();
  std::string error;
  if (args.Has("--options")) {
    json options;
    if (!ReadJsonFile(args.Value("--options"), &options, &error))
      return InputError(error);
    if (!options.is_object())
      return InputError(args.Value("--options") +
                        ": options must be a JSON object");
    changes["options"] = options;
  }
  auto set = args.values.find("--set");
  if (set != args.values.end()) {
    if (!changes.contains("options")) changes["options"] = json::object();
    for (const std::string& assignment : set->second) {
      const size_t eq = assignment.find('=');
      if (eq == std::string::npos || eq == 0) {
        std::cerr << "gearloop replay: --set takes NAME=VALUE, got '"
                  << assignment << "'\n";
        return kExitUsage;
      }
      const std::string text = assignment.substr(eq + 1);
      json value = json::parse(text, nullptr, /*allow_exceptions=*/false);
      if (value.is_discarded()) value = text;
      changes["options"][assignment.substr(0, eq)] = value;
    }
  }
  if (args.Has("--target")) {
    // The grid shape of the stored job decides how the CSV is read.
    const ApiResponse parent =
        client->Get("/api/v1/corrections/" + std::to_string(id));
    const int failure = CheckAnswer(parent);
    if (failure >= 0) return failure;
    int rows = 5;
    int columns = 9;
    GridShape(parent.body.value("request", json::object()), &rows, &columns);
    json target;
    if (!ReadTargetFile(args.Value("--target"), rows, columns, &target, &error))
      return InputError(error);
    changes["target"] = target;
  }
  return SendCorrection(client,
                        "/api/v1/corrections/" + std::to_string(id) + "/replay",
                        changes,
                        global);
}

}  // namespace cli_internal
}  // namespace gearloop
