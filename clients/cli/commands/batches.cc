// clients/cli/commands/batches.cc: `gearloop batch`, every measurement file of a folder as one
// batch of corrections (POST /api/v1/batches), followed until the server is done.
#include "clients/cli/commands/subcommands.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "clients/cli/command_util.h"
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
  std::cerr << "\r[" << std::string(filled, '#') << std::string(width - filled, '.') << "] " << finished << "/"
            << total << " done";
  if (failed > 0) std::cerr << ", " << failed << " failed";
  std::cerr << (final_line ? "\n" : "   ") << std::flush;
}

}  // namespace

const CommandSpec kBatch{
    "batch",
    "usage: gearloop batch REQUEST.json FOLDER [options]\n\n"
    "Sends every measurement file in FOLDER (*.csv and *.json, in name order) as one batch of\n"
    "corrections with the setup of REQUEST.json (POST /api/v1/batches), shows a progress bar\n"
    "while the server works (GET /api/v1/batches/ID), then a summary table per file.\n\n"
    "options:\n"
    "  --target FILE     the same target for every item (else REQUEST.json's)\n"
    "  --options FILE    solver options merged over REQUEST.json's\n"
    "  --settings-from ID  every part was ground with the corrected settings of job ID\n"
    "  --no-wait         print the batch id and return at once\n"
    "  --poll-ms N       progress polling interval (default 250)\n\n"
    "Exit 0 all items converged, 5 some failed or did not converge, 4 a file is invalid\n"
    "(nothing is sent then).\n",
    {"--target", "--options", "--poll-ms", "--settings-from"},
    {"--no-wait"},
    2,
    2};

int RunBatch(const ParsedArgs& args, ApiClient* client, const GlobalOptions& global) {
  const std::string folder = args.positional[1];
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) return InputError(folder + ": not a folder");
  std::vector<std::string> files;
  for (const fs::directory_entry& entry : fs::directory_iterator(folder, ec)) {
    if (!entry.is_regular_file()) continue;
    const std::string path = entry.path().string();
    if (HasExtension(path, ".csv") || HasExtension(path, ".json")) files.push_back(path);
  }
  std::sort(files.begin(), files.end());
  if (files.empty()) return InputError(folder + ": no *.csv or *.json measurement files");

  json items = json::array();
  json source_settings;
  for (const std::string& file : files) {
    json request;
    int built = BuildCorrectionRequest(args.positional[0], file, args, &request);
    if (built >= 0) return built;
    built = FillSourceSettings(client, &request, &source_settings);
    if (built >= 0) return built;
    items.push_back(request);
  }
  const ApiResponse created = client->Post("/api/v1/batches", {{"items", items}});
  int failure = CheckAnswer(created);
  if (failure >= 0) return failure;
  const std::string batch_id = Text(created.body["id"]);
  if (args.Has("--no-wait")) {
    if (global.json) {
      PrintJson(created.body);
    } else {
      std::cout << "batch " << batch_id << " accepted with " << files.size() << " items\n";
    }
    return kExitOk;
  }
  long long poll_ms = 250;
  if (args.Has("--poll-ms") && !ParseCount(args.Value("--poll-ms"), 10, 60000, &poll_ms)) {
    std::cerr << "gearloop batch: --poll-ms takes 10..60000\n";
    return kExitUsage;
  }
  const bool progress = !global.json && isatty(STDERR_FILENO);
  ApiResponse state;
  while (true) {
    state = client->Get("/api/v1/batches/" + batch_id);
    failure = CheckAnswer(state);
    if (failure >= 0) return failure;
    const int total = state.body.value("total", 0);
    const int done = state.body.value("done", 0);
    const int failed = state.body.value("failed", 0);
    const bool finished = state.body.value("status", "") != "running";
    if (progress) DrawProgress(done, failed, total, finished);
    if (finished) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(poll_ms));
  }
  // One row per file: its job's outcome or the reason the server refused it.
  json rows = json::array();
  bool all_good = true;
  for (const json& item : state.body.value("items", json::array())) {
    const int index = item.value("index", -1);
    json row = {{"file", index >= 0 && index < static_cast<int>(files.size()) ? files[index] : "?"},
                {"state", item.value("state", "")}};
    if (item.contains("job_id")) {
      row["job_id"] = item["job_id"];
      const ApiResponse job = client->Get("/api/v1/corrections/" + Text(item["job_id"]));
      if (job.ok() && job.body.is_object()) {
        const json result = job.body.value("result", json::object());
        row["status"] = result.value("status", "");
        row["initial_rms_um"] = result.value("initial_rms_um", json());
        row["residual_rms_um"] = result.value("residual_rms_um", json());
        row["residual_max_um"] = result.value("residual_max_um", json());
        if (row["status"] != "converged") all_good = false;
      }
    } else {
      all_good = false;
      if (item.contains("error")) row["error"] = item["error"];
    }
    rows.push_back(row);
  }
  if (global.json) {
    PrintJson({{"batch", state.body}, {"summary", rows}});
  } else {
    std::cout << "batch " << batch_id << ": " << Member(state.body, "done") << " done, "
              << Member(state.body, "failed") << " failed of " << Member(state.body, "total") << "\n";
    std::cout << std::left << std::setw(28) << "file" << std::setw(6) << "job" << std::setw(15) << "status"
              << std::right << std::setw(11) << "before um" << std::setw(11) << "rms um" << std::setw(11)
              << "max um" << "\n";
    for (const json& row : rows) {
      std::string file = fs::path(row["file"].get<std::string>()).filename().string();
      if (file.size() > 27) file = file.substr(0, 24) + "...";
      std::cout << std::left << std::setw(28) << file << std::setw(6) << Member(row, "job_id");
      if (row.contains("error")) {
        std::cout << "failed: " << Member(row["error"], "code") << " at " << Member(row["error"], "field") << ": "
                  << Member(row["error"], "message") << "\n";
        continue;
      }
      std::cout << std::setw(15) << Member(row, "status") << std::right << std::setw(11)
                << Fixed(row.value("initial_rms_um", json())) << std::setw(11)
                << Fixed(row.value("residual_rms_um", json())) << std::setw(11)
                << Fixed(row.value("residual_max_um", json())) << "\n";
    }
  }
  return all_good ? kExitOk : kExitNotConverged;
}

}  // namespace cli_internal
}  // namespace gearloop
