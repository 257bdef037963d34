// clients/cli/commands/batches.cc: `gearloop batch`, every measurement file of
// a folder as one batch of corrections (POST /api/v1/batches), followed until
// the server is done.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "clients/cli/command_util.h"
#include "clients/cli/commands/subcommands.h"
#include "clients/cli/grid_files.h"

namespace gearloop {
namespace cli_internal {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

void DrawProgress(int done, int failed, int total, bool final_line) {
  const int width = 30;
  const int finished = done + failed;
  const int filled = total > 0 ? finished * width / total : width;
  std::cerr << "\r[" << std::string(filled, '#')
            << std::string(width - filled, '.') << "] " << finished << "/"
            << total << " done";
  if (failed > 0) std::cerr << ", " << failed << " failed";
  std::cerr << (final_line ? "\n" : "   ") << std::flush;
}

// The measurement files of `folder` (*.csv and *.json), in name order. Returns
// -1, or an exit code when the folder is missing or holds none.
int ListMeasurementFiles(const std::string& folder,
                         std::vector<std::string>* files) {
  std::error_code ec;
  if (!fs::is_directory(folder, ec))
    return InputError(folder + ": not a folder");
  for (const fs::directory_entry& entry : fs::directory_iterator(folder, ec)) {
    if (!entry.is_regular_file()) continue;
    const std::string path = entry.path().string();
    if (HasExtension(path, ".csv") || HasExtension(path, ".json"))
      files->push_back(path);
  }
  std::sort(files->begin(), files->end());
  if (files->empty())
    return InputError(folder + ": no *.csv or *.json measurement files");
  return -1;
}

// One correction request per file, every file read and checked before anything
// is sent. Returns -1, or an exit code.
int BuildBatchItems(const ParsedArgs& args,
                    const std::vector<std::string>& files,
                    ApiClient* client,
                    json* items) {
  json source_settings;
  for (const std::string& file : files) {
    json request;
    int built =
        BuildCorrectionRequest(args.positional[0], file, args, &request);
    if (built >= 0) return built;
    built = FillSourceSettings(client, &request, &source_settings);
    if (built >= 0) return built;
    items->push_back(request);
  }
  return -1;
}

// Polls the batch every `poll_ms` until the server has finished it, with a
// progress bar on stderr when `progress`. Returns -1 with the last answer in
// `state`, or an exit code.
int WaitForBatch(ApiClient* client,
                 const std::string& batch_id,
                 long long poll_ms,
                 bool progress,
                 ApiResponse* state) {
  while (true) {
    *state = client->Get("/api/v1/batches/" + batch_id);
    const int failure = CheckAnswer(*state);
    if (failure >= 0) return failure;
    const int total = state->body.value("total", 0);
    const int done = state->body.value("done", 0);
    const int failed = state->body.value("failed", 0);
    const bool finished = state->body.value("status", "") != "running";
    if (progress) DrawProgress(done, failed, total, finished);
    if (finished) return -1;
    std::this_thread::sleep_for(std::chrono::milliseconds(poll_ms));
  }
}

// One row per file: its job's outcome or the reason the server refused it.
// `all_good` turns false when an item failed or its job did not converge.
json SummariseBatchItems(ApiClient* client,
                         const json& batch,
                         const std::vector<std::string>& files,
                         bool* all_good) {
  json rows = json::array();
  for (const json& item : batch.value("items", json::array())) {
    const int index = item.value("index", -1);
    json row = {
        {"file",
         index >= 0 && index < static_cast<int>(files.size()) ? files[index]
                                                              : "?"},
        {"state", item.value("state", "")}};
    if (item.contains("job_id")) {
      row["job_id"] = item["job_id"];
      const ApiResponse job =
          client->Get("/api/v1/corrections/" + Text(item["job_id"]));
      if (job.ok() && job.body.is_object()) {
        const json result = job.body.value("result", json::object());
        row["status"] = result.value("status", "");
        row["initial_rms_um"] = result.value("initial_rms_um", json());
        row["residual_rms_um"] = result.value("residual_rms_um", json());
        row["residual_max_um"] = result.value("residual_max_um", json());
        row["verdict"] = VerdictCell(result);
        if (row["status"] != "converged") *all_good = false;
      }
    } else {
      *all_good = false;
      if (item.contains("error")) row["error"] = item["error"];
    }
    rows.push_back(row);
  }
  return rows;
}

// The batch's counts, then one line per file (the name cut to 27 characters).
void PrintBatchSummary(const std::string& batch_id,
                       const json& batch,
                       const json& rows) {
  std::cout << "batch " << batch_id << ": " << Member(batch, "done")
            << " done, " << Member(batch, "failed") << " failed of "
            << Member(batch, "total") << "\n";
  std::cout << std::left << std::setw(28) << "file" << std::setw(6) << "job"
            << std::setw(25) << "status" << std::right << std::setw(11)
            << "before um" << std::setw(11) << "rms um" << std::setw(11)
            << "max um"
            << "  verdict (measured/predicted)"
            << "\n";
  for (const json& row : rows) {
    std::string file =
        fs::path(row["file"].get<std::string>()).filename().string();
    if (file.size() > 27) file = file.substr(0, 24) + "...";
    std::cout << std::left << std::setw(28) << file << std::setw(6)
              << Member(row, "job_id");
    if (row.contains("error")) {
      std::cout << "failed: " << Member(row["error"], "code") << " at "
                << Member(row["error"], "field") << ": "
                << Member(row["error"], "message") << "\n";
      continue;
    }
    std::cout << std::setw(25) << Member(row, "status") << std::right
              << std::setw(11) << Fixed(row.value("initial_rms_um", json()))
              << std::setw(11) << Fixed(row.value("residual_rms_um", json()))
              << std::setw(11) << Fixed(row.value("residual_max_um", json()))
              << "  " << row.value("verdict", "-") << "\n";
  }
}

}  // namespace

const CommandSpec kBatch{
    "batch",
    "usage: gearloop batch REQUEST.json FOLDER [options]\n\n"
    "Sends every measurement file in FOLDER (*.csv and *.json, in name order) "
    "as one batch of\n"
    "corrections with the setup of REQUEST.json (POST /api/v1/batches), shows "
    "a progress bar\n"
    "while the server works (GET /api/v1/batches/ID), then a summary table per "
    "file.\n\n"
    "options:\n"
    "  --target FILE     the same target for every item (else REQUEST.json's)\n"
    "  --options FILE    solver options merged over REQUEST.json's\n"
    "  --settings-from ID  every part was ground with the corrected settings "
    "of job ID\n"
    "  --no-wait         print the batch id and return at once\n"
    "  --poll-ms N       progress polling interval (default 250)\n\n"
    "Exit 0 all items converged, 5 some failed or did not converge, 4 a file "
    "is invalid\n"
    "(nothing is sent then).\n",
    {"--target", "--options", "--poll-ms", "--settings-from"},
    {"--no-wait"},
    2,
    2};

int RunBatch(const ParsedArgs& args,
             ApiClient* client,
             const GlobalOptions& global) {
  std::vector<std::string> files;
  int failure = ListMeasurementFiles(args.positional[1], &files);
  if (failure >= 0) return failure;
  json items = json::array();
  failure = BuildBatchItems(args, files, client, &items);
  if (failure >= 0) return failure;
  const ApiResponse created =
      client->Post("/api/v1/batches", {{"items", items}});
  failure = CheckAnswer(created);
  if (failure >= 0) return failure;
  const std::string batch_id = Text(created.body["id"]);
  if (args.Has("--no-wait")) {
    if (global.json) {
      PrintJson(created.body);
    } else {
      std::cout << "batch " << batch_id << " accepted with " << files.size()
                << " items\n";
    }
    return kExitOk;
  }
  long long poll_ms = 250;
  if (args.Has("--poll-ms") &&
      !ParseCount(args.Value("--poll-ms"), 10, 60000, &poll_ms)) {
    std::cerr << "gearloop batch: --poll-ms takes 10..60000\n";
    return kExitUsage;
  }
  const bool progress = !global.json && isatty(STDERR_FILENO);
  ApiResponse state;
  failure = WaitForBatch(client, batch_id, poll_ms, progress, &state);
  if (failure >= 0) return failure;
  bool all_good = true;
  const json rows = SummariseBatchItems(client, state.body, files, &all_good);
  if (global.json) {
    PrintJson({{"batch", state.body}, {"summary", rows}});
  } else {
    PrintBatchSummary(batch_id, state.body, rows);
  }
  return all_good ? kExitOk : kExitNotConverged;
}

}  // namespace cli_internal
}  // namespace gearloop
