// clients/cli/commands/history.cc: the stored jobs: `gearloop list`, `gearloop
// show` and `gearloop report` (GET /api/v1/corrections, /api/v1/corrections/ID
// and its lineage).
#include <cctype>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <utility>

#include "clients/cli/command_util.h"
#include "clients/cli/commands/subcommands.h"
#include "clients/cli/csv_grid.h"
#include "clients/cli/grid_files.h"
#include "clients/cli/report.h"

namespace gearloop {
namespace cli_internal {
namespace {

using nlohmann::json;

std::string UrlEncode(const std::string& text) {
  static const char* kHex = "0123456789ABCDEF";
  std::string out;
  for (unsigned char c : text) {
    if (std::isalnum(c) || c == '-' || c == '_' || c == '.' || c == '~') {
      out += static_cast<char>(c);
    } else {
      out += '%';
      out += kHex[c >> 4];
      out += kHex[c & 15];
    }
  }
  return out;
}

// `gearloop show ID --grid NAME`: the job's grid NAME (measured, target,
// residual, change) as CSV. Exit 3 when the job has no such grid.
int PrintJobGrid(long long id,
                 const json& job,
                 const std::string& grid_name,
                 bool header) {
  const json result = job.value("result", json::object());
  json grid;
  if (grid_name == "residual")
    grid = result.value("predicted_residual_um", json());
  if (grid_name == "change") grid = result.value("predicted_change_um", json());
  if (grid_name == "measured") grid = MeasuredGrid(job);
  if (grid_name == "target") grid = TargetGrid(job);
  CsvGrid csv;
  if (!JsonToCsvGrid(grid, &csv)) {
    std::cerr << "gearloop show: job " << id << " has no " << grid_name
              << " grid\n";
    return kExitApiError;
  }
  std::cout << FormatCsvGrid(csv, header);
  return kExitOk;
}

// The gear and flank of a stored request, or the bevel machine and pinion
// flank. True for a bevel pinion job.
bool PrintJobSetup(const json& request) {
  if (request.contains("gear")) {
    const json& gear = request["gear"];
    std::cout << "gear " << Member(gear, "teeth") << " teeth, mn "
              << Member(gear, "normal_module_mm") << " mm, alpha "
              << Member(gear, "normal_pressure_angle_deg") << " deg, beta "
              << Member(gear, "helix_angle_deg") << " deg "
              << Member(gear, "hand") << ", flank " << Member(request, "flank")
              << "\n";
  }
  const bool bevel =
      request.contains("machine") && request["machine"].is_object() &&
      request["machine"].value("kind", "") == "free-form-bevel-generator";
  if (bevel) {
    const json bevel_job = request.value("job", json::object());
    std::cout << "machine: free-form bevel generator, spiral bevel pinion, "
              << Member(bevel_job, "side") << " flank"
              << (bevel_job.value("published", false)
                      ? " (published summary, Tang 2011)"
                      : "")
              << "\n  grid rows root to face, columns toe to heel\n";
  }
  return bevel;
}

// The corrected axis polynomials of a bevel job and their change: coefficient k
// multiplies t^k.
void PrintBevelMotion(const json& result) {
  const json& motion = result["motion"];
  const json delta = result.value("delta", json::object());
  std::cout << "corrected axis motions (coefficient k of t^k, t the roll in "
               "rad; change in brackets)\n";
  for (const char* axis : {"A_rad", "B_rad", "X_mm", "Y_mm", "Z_mm"}) {
    if (!motion.contains(axis) || !motion[axis].is_array()) continue;
    std::cout << "  " << std::left << std::setw(6) << axis << std::right;
    for (size_t k = 0; k < motion[axis].size(); ++k) {
      std::ostringstream cell;
      cell << std::setprecision(8) << motion[axis][k].get<double>();
      if (delta.contains(axis) && delta[axis].is_array() &&
          k < delta[axis].size()) {
        cell << " (" << std::setprecision(3) << delta[axis][k].get<double>()
             << ")";
      }
      std::cout << " " << cell.str();
    }
    std::cout << "\n";
  }
}

// The trace of a job in one line: "part 4711-A, serial S1, teeth 1 10, ...";
// empty when the job carries none.
std::string TraceLine(const json& job) {
  if (!job.contains("trace") || !job["trace"].is_object()) return "";
  const json& trace = job["trace"];
  const std::pair<const char*, const char*> fields[] = {
      {"part_number", "part"},
      {"serial", "serial"},
      {"teeth", "teeth"},
      {"measured_at", "measured"},
      {"file_name", "file"},
      {"machine_id", "machine"},
      {"batch_id", "batch"},
      {"submitted_by", "submitted by"}};
  std::string line;
  for (const auto& [key, label] : fields) {
    if (!trace.contains(key)) continue;
    std::string value;
    if (trace[key].is_array()) {
      for (const json& tooth : trace[key])
        value += (value.empty() ? "" : " ") + Text(tooth);
    } else {
      value = Text(trace[key]);
    }
    line += (line.empty() ? "" : ", ") + std::string(label) + " " + value;
  }
  return line;
}

// The list's part column: "4711-A/S1", "4711-A", "/S1" or "-".
std::string PartCell(const json& job) {
  const json trace = job.value("trace", json::object());
  const std::string part = trace.value("part_number", "");
  const std::string serial = trace.value("serial", "");
  if (part.empty() && serial.empty()) return "-";
  return serial.empty() ? part : part + "/" + serial;
}

// The list's query options and their query parameters.
const std::pair<const char*, const char*> kListQuery[] = {
    {"--limit", "limit"},
    {"--offset", "offset"},
    {"--kind", "kind"},
    {"--status", "status"},
    {"--flank", "flank"},
    {"--teeth", "teeth"},
    {"--part-number", "part_number"},
    {"--serial", "serial"},
    {"--tooth", "tooth"},
    {"--machine-id", "machine_id"},
    {"--batch", "batch_id"},
    {"--submitted-by", "submitted_by"},
    {"--file-name", "file_name"}};

}  // namespace

const CommandSpec kList{
    "list",
    "usage: gearloop list [options]\n\n"
    "Lists stored jobs, newest first (GET /api/v1/corrections).\n\n"
    "options:\n"
    "  --limit N        jobs per page (default 20)\n"
    "  --offset N       skip the N newest\n"
    "  --kind K         correction | replay | batch_item | closed_loop\n"
    "  --status S       converged | not_converged | ...\n"
    "  --flank F        left | right (a gear), convex | concave (a bevel "
    "pinion)\n"
    "  --teeth N        only gears with N teeth\n"
    "  --part-number P  only jobs of part number P (the request's trace)\n"
    "  --serial S       only jobs of serial number S\n"
    "  --tooth N        only jobs that measured tooth N\n"
    "  --machine-id M   only parts of machine M\n"
    "  --batch N        only the jobs of batch N\n"
    "  --submitted-by T only jobs submitted with the token named T\n"
    "  --file-name F    only jobs of measuring file F\n\n"
    "columns: rms um is the predicted residual; parent N = a replay of job N,\n"
    "<N = the part was ground with the corrected settings of job N; part is\n"
    "part number/serial.\n",
    {"--limit",
     "--offset",
     "--kind",
     "--status",
     "--flank",
     "--teeth",
     "--part-number",
     "--serial",
     "--tooth",
     "--machine-id",
     "--batch",
     "--submitted-by",
     "--file-name"},
    {},
    0,
    0};

int RunList(const ParsedArgs& args,
            ApiClient* client,
            const GlobalOptions& global) {
  std::string query;
  for (const auto& [option, key] : kListQuery) {
    if (!args.Has(option)) continue;
    query += (query.empty() ? "?" : "&") + std::string(key) + "=" +
             UrlEncode(args.Value(option));
  }
  const ApiResponse answer = client->Get("/api/v1/corrections" + query);
  const int failure = CheckAnswer(answer);
  if (failure >= 0) return failure;
  if (global.json) {
    PrintJson(answer.body);
    return kExitOk;
  }
  const json jobs = answer.body.value("jobs", json::array());
  std::cout << std::left << std::setw(6) << "id" << std::setw(26)
            << "created (UTC)" << std::setw(17) << "kind" << std::setw(25)
            << "status" << std::setw(14) << "gear" << std::setw(7) << "flank"
            << std::right << std::setw(10) << "rms um" << std::setw(8)
            << "parent"
            << "  part"
            << "\n";
  for (const json& job : jobs) {
    std::string gear = "-";
    if (job.value("machine_kind", "") == "free-form-bevel-generator") {
      gear = "bevel pinion";  // a pinion flank carries no tooth count or module
    } else if (job.value("machine_kind", "") == "head-head-5-axis-mill" &&
               job.contains("gear") && job["gear"].is_object()) {
      // A split bevel wheel: its (constant) normal module, rounded.
      gear = Member(job["gear"], "teeth") + "z mn" +
             Fixed(job["gear"].value("normal_module_mm", json()), 3);
    } else if (job.contains("gear") && job["gear"].is_object()) {
      gear = Member(job["gear"], "teeth") + "z m" +
             Member(job["gear"], "normal_module_mm");
    }
    std::string parent = "-";
    if (job.contains("parent_job_id") && !job["parent_job_id"].is_null())
      parent = Text(job["parent_job_id"]);
    if (parent == "-" && job.contains("settings_source_job_id") &&
        !job["settings_source_job_id"].is_null()) {
      parent = "<" + Text(job["settings_source_job_id"]);
    }
    std::cout << std::left << std::setw(6) << Member(job, "id") << std::setw(26)
              << Member(job, "created_utc") << std::setw(17)
              << Member(job, "kind") << std::setw(25) << Member(job, "status")
              << std::setw(14) << gear << std::setw(7) << Member(job, "flank")
              << std::right << std::setw(10)
              << Fixed(job.value("residual_rms_um", json())) << std::setw(8)
              << parent << "  " << PartCell(job) << "\n";
  }
  std::cout << jobs.size() << " of " << Member(answer.body, "total")
            << " jobs\n";
  return kExitOk;
}

const CommandSpec kShow{
    "show",
    "usage: gearloop show ID [--grid NAME] [--header]\n\n"
    "Shows one stored job (GET /api/v1/corrections/ID): the result summary and "
    "the\n"
    "predicted residual. With --grid, prints only that grid as CSV instead:\n"
    "  measured | target | residual | change\n"
    "(--header adds the L1..L9 header line.)\n",
    {"--grid"},
    {"--header"},
    1,
    1};

int RunShow(const ParsedArgs& args,
            ApiClient* client,
            const GlobalOptions& global) {
  long long id = 0;
  if (!ParseJobId(args.positional[0], &id)) {
    std::cerr << "gearloop show: '" << args.positional[0]
              << "' is not a job id\n";
    return kExitUsage;
  }
  std::string grid_name = args.Value("--grid");
  if (!grid_name.empty() && grid_name != "measured" && grid_name != "target" &&
      grid_name != "residual" && grid_name != "change") {
    std::cerr
        << "gearloop show: --grid takes measured, target, residual or change\n";
    return kExitUsage;
  }
  const ApiResponse answer =
      client->Get("/api/v1/corrections/" + std::to_string(id));
  const int failure = CheckAnswer(answer);
  if (failure >= 0) return failure;
  const json& job = answer.body;
  if (!grid_name.empty())
    return PrintJobGrid(id, job, grid_name, args.Has("--header"));
  if (global.json) {
    PrintJson(job);
    return kExitOk;
  }
  std::cout << "created " << Member(job, "created_utc") << ", server "
            << Member(job, "server_version") << "\n";
  const std::string trace = TraceLine(job);
  if (!trace.empty()) std::cout << trace << "\n";
  if (job.value("kind", std::string()) == "split_trajectory") {
    std::cout << "job " << Member(job, "id")
              << " (split_trajectory), NC program at /api/v1/bevel/"
                 "split-trajectory/"
              << Member(job, "id") << "/nc\n";
    // The server computes a stored trajectory's points again; when it cannot,
    // the table has no A/B ranges and this says why.
    const json note = job.value("points_recomputed", json::object());
    if (note.contains("error"))
      std::cout << "points not computed again: " << Member(note, "error")
                << "\n";
    PrintSplitTrajectory(job.value("result", json::object()));
    return kExitOk;
  }
  const bool bevel = PrintJobSetup(job.value("request", json::object()));
  const json measured = MeasuredGrid(job);
  if (!measured.is_null()) PrintGrid("measured", measured);
  PrintCorrectionSummary(job);
  const json result = job.value("result", json::object());
  if (bevel && result.contains("motion") && result["motion"].is_object())
    PrintBevelMotion(result);
  return kExitOk;
}

const CommandSpec kLineage{
    "lineage",
    "usage: gearloop lineage ID\n\n"
    "Lists the settings lineage of job ID (GET "
    "/api/v1/corrections/ID/lineage): "
    "the jobs whose\n"
    "corrected settings the part was ground with, back to the first "
    "measurement, then every job\n"
    "ground with settings descending from ID; oldest first, ID marked *.\n\n"
    "columns: rms um is the predicted residual; from N = ground with the "
    "settings of job N.\n",
    {},
    {},
    1,
    1};

int RunLineage(const ParsedArgs& args,
               ApiClient* client,
               const GlobalOptions& global) {
  long long id = 0;
  if (!ParseJobId(args.positional[0], &id)) {
    std::cerr << "gearloop lineage: '" << args.positional[0]
              << "' is not a job id\n";
    return kExitUsage;
  }
  const ApiResponse answer =
      client->Get("/api/v1/corrections/" + std::to_string(id) + "/lineage");
  const int failure = CheckAnswer(answer);
  if (failure >= 0) return failure;
  if (global.json) {
    PrintJson(answer.body);
    return kExitOk;
  }
  const json jobs = answer.body.value("jobs", json::array());
  std::cout << std::left << std::setw(8) << "id" << std::setw(26)
            << "created (UTC)" << std::setw(12) << "kind" << std::setw(25)
            << "status" << std::right << std::setw(10) << "rms um"
            << std::setw(8) << "from"
            << "  part\n";
  for (const json& job : jobs) {
    const std::string mark =
        job.value("id", json()) == json(id) ? std::string("*") : "";
    std::cout << std::left << std::setw(8) << Member(job, "id") + mark
              << std::setw(26) << Member(job, "created_utc") << std::setw(12)
              << Member(job, "kind") << std::setw(25) << Member(job, "status")
              << std::right << std::setw(10)
              << Fixed(job.value("residual_rms_um", json())) << std::setw(8)
              << Member(job, "settings_source_job_id") << "  " << PartCell(job)
              << "\n";
  }
  std::cout << jobs.size() << " jobs in the lineage of job " << id << "\n";
  return kExitOk;
}

const CommandSpec kReport{"report",
                          "usage: gearloop report ID [-o FILE]\n\n"
                          "Writes a self-contained printable HTML report of "
                          "job ID (measured, target and\n"
                          "predicted residual topographies, axis corrections "
                          "over the roll range, the\n"
                          "convergence along its lineage) to stdout or FILE. "
                          "No network needed to view it.\n",
                          {"--output"},
                          {},
                          1,
                          1};

int RunReport(const ParsedArgs& args, ApiClient* client, const GlobalOptions&) {
  long long id = 0;
  if (!ParseJobId(args.positional[0], &id)) {
    std::cerr << "gearloop report: '" << args.positional[0]
              << "' is not a job id\n";
    return kExitUsage;
  }
  const ApiResponse job =
      client->Get("/api/v1/corrections/" + std::to_string(id));
  int failure = CheckAnswer(job);
  if (failure >= 0) return failure;
  // The lineage gives the convergence plot; an older server without the route
  // still gets a report, with this job alone.
  json lineage = json::array({job.body});
  const ApiResponse chain =
      client->Get("/api/v1/corrections/" + std::to_string(id) + "/lineage");
  if (chain.ok() && chain.body.is_object() && chain.body.contains("jobs") &&
      chain.body["jobs"].is_array()) {
    // The lineage lists summaries; the plot needs each job's measured rms, so
    // fetch the last 20.
    json full = json::array();
    const json& jobs = chain.body["jobs"];
    for (size_t i = jobs.size() > 20 ? jobs.size() - 20 : 0; i < jobs.size();
         ++i) {
      const ApiResponse one = client->Get("/api/v1/corrections/" +
                                          Text(jobs[i].value("id", json())));
      if (one.ok() && one.body.is_object()) full.push_back(one.body);
    }
    if (!full.empty()) lineage = full;
  }
  std::string html;
  std::string error;
  if (!RenderJobReport(job.body, lineage, &html, &error)) {
    std::cerr << "gearloop report: " << error << "\n";
    return kExitInput;
  }
  return PrintOrWriteText(args, html);
}

}  // namespace cli_internal
}  // namespace gearloop
