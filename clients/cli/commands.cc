// clients/cli/commands.cc: one function per subcommand. Each reads its files, sends one or a few
// requests, and prints either a table for a person or (--json) the server's JSON for a script.
// Diagnostics go to stderr, results to stdout, so `gearloop show 7 --grid residual > r.csv`
// and `gearloop report 7 > job.html` work in pipelines.
#include "clients/cli/commands.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <thread>

#include <nlohmann/json.hpp>

#include "clients/cli/api_client.h"
#include "clients/cli/csv_grid.h"
#include "clients/cli/grid_files.h"
#include "clients/cli/report.h"

namespace gearloop {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

// --- Argument parsing ---------------------------------------------------------------------------

// The options one subcommand takes: names that take a value, and flags.
struct CommandSpec {
  const char* name;
  const char* usage;  // the full --help text
  std::set<std::string> valued;
  std::set<std::string> flags;
  int min_positional;
  int max_positional;
};

struct ParsedArgs {
  std::vector<std::string> positional;
  std::map<std::string, std::vector<std::string>> values;
  std::set<std::string> flags;

  bool Has(const std::string& name) const { return values.count(name) > 0 || flags.count(name) > 0; }
  std::string Value(const std::string& name, const std::string& fallback = "") const {
    auto it = values.find(name);
    return it == values.end() ? fallback : it->second.back();
  }
};

bool UsageError(const CommandSpec& spec, const std::string& message) {
  std::cerr << "gearloop " << spec.name << ": " << message << "\n"
            << "Try 'gearloop " << spec.name << " --help'.\n";
  return false;
}

// Accepts "--name value" and "--name=value". Returns false after printing a usage error.
bool ParseArgs(const CommandSpec& spec, const std::vector<std::string>& args, ParsedArgs* parsed) {
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& arg = args[i];
    if (arg.size() > 2 && arg.compare(0, 2, "--") == 0) {
      std::string name = arg;
      std::optional<std::string> inline_value;
      const size_t eq = arg.find('=');
      if (eq != std::string::npos) {
        name = arg.substr(0, eq);
        inline_value = arg.substr(eq + 1);
      }
      if (spec.valued.count(name)) {
        if (inline_value) {
          parsed->values[name].push_back(*inline_value);
        } else if (i + 1 < args.size()) {
          parsed->values[name].push_back(args[++i]);
        } else {
          return UsageError(spec, "option " + name + " needs a value");
        }
      } else if (spec.flags.count(name) && !inline_value) {
        parsed->flags.insert(name);
      } else {
        return UsageError(spec, "unknown option " + arg);
      }
    } else {
      parsed->positional.push_back(arg);
    }
  }
  const int n = static_cast<int>(parsed->positional.size());
  if (n < spec.min_positional) return UsageError(spec, "missing argument");
  if (n > spec.max_positional) return UsageError(spec, "unexpected argument '" + parsed->positional[n - 1] + "'");
  return true;
}

bool ParseCount(const std::string& text, long long min, long long max, long long* value) {
  if (text.empty()) return false;
  char* end = nullptr;
  const long long v = std::strtoll(text.c_str(), &end, 10);
  if (end != text.c_str() + text.size() || v < min || v > max) return false;
  *value = v;
  return true;
}

// --- Output ------------------------------------------------------------------------------------

std::string Fixed(const json& value, int digits = 3) {
  if (!value.is_number()) return "-";
  std::ostringstream out;
  out << std::fixed << std::setprecision(digits) << value.get<double>();
  return out.str();
}

std::string Text(const json& value) {
  if (value.is_string()) return value.get<std::string>();
  if (value.is_null()) return "-";
  return value.dump();
}

std::string Member(const json& object, const char* key) {
  if (!object.is_object() || !object.contains(key)) return "-";
  return Text(object[key]);
}

// A grid as a table with the tip at the top, the way the flank is drawn (and the dashboard
// shows it): profile rows down the side, lead columns across.
void PrintGrid(const std::string& title, const json& grid) {
  CsvGrid g;
  if (!JsonToCsvGrid(grid, &g)) return;
  std::cout << title << " [um] (tip at top, lead from x < 0 to x > 0)\n";
  std::cout << std::setw(11) << "";
  for (int c = 0; c < g.columns; ++c) std::cout << std::setw(8) << ("L" + std::to_string(c + 1));
  std::cout << "\n";
  for (int r = g.rows - 1; r >= 0; --r) {
    std::string label = "row " + std::to_string(r + 1);
    if (r == g.rows - 1) label += " tip";
    if (r == 0) label += " root";
    std::cout << std::left << std::setw(11) << label << std::right;
    for (int c = 0; c < g.columns; ++c) {
      const auto& v = g.at(r, c);
      std::ostringstream cell;
      if (v) {
        // No "-0.00": a value that rounds to zero prints as zero.
        cell << std::fixed << std::setprecision(2) << (std::fabs(*v) < 0.005 ? 0.0 : *v);
      } else {
        cell << "-";
      }
      std::cout << std::setw(8) << cell.str();
    }
    std::cout << "\n";
  }
}

void PrintJson(const json& value) { std::cout << value.dump(2) << "\n"; }

// Maps an answer to an exit code and prints its error. Returns -1 when the answer is fine.
int CheckAnswer(const ApiResponse& answer) {
  if (!answer.transport_error.empty()) {
    std::cerr << "gearloop: " << answer.transport_error << "\n";
    return kExitTransport;
  }
  if (answer.IsApiError()) {
    std::cerr << "gearloop: server refused the request: " << answer.ErrorText() << "\n";
    return kExitApiError;
  }
  if (!answer.ok() || !answer.body.is_object()) {
    std::cerr << "gearloop: unexpected answer " << answer.status << " from the server\n";
    return kExitTransport;
  }
  return -1;
}

int InputError(const std::string& message) {
  std::cerr << "gearloop: " << message << "\n";
  return kExitInput;
}

// The result's axis_motion as a small table: the change of each axis position at the 9 roll
// angles of the result's range (um for linear axes, urad for rotary ones), its rms and largest
// magnitude over the range, then the wheel-parameter changes. Nothing for a job stored without it.
void PrintAxisMotion(const json& result) {
  if (!result.contains("axis_motion") || !result["axis_motion"].is_object()) return;
  const json& motion = result["axis_motion"];
  const json roll = motion.value("roll_rad", json::array());
  const json axes = motion.value("axes", json::object());
  if (!roll.is_array() || roll.empty() || !axes.is_object()) return;
  constexpr double kDegPerRad = 180.0 / 3.14159265358979323846;
  std::cout << "axis motion of the correction over the roll range (change of the axis position)\n";
  std::cout << std::left << std::setw(11) << "roll [deg]" << std::right;
  for (const json& r : roll) std::cout << std::setw(9) << (r.is_number() ? Fixed(r.get<double>() * kDegPerRad, 2) : "-");
  std::cout << std::setw(10) << "rms" << std::setw(10) << "max |.|" << "\n";
  // Linear axes first, as the machine lists them; then any other axis the model has.
  std::vector<std::string> names;
  for (const char* name : {"X", "Y", "Z", "A", "B", "C"}) {
    if (axes.contains(name)) names.push_back(name);
  }
  for (const auto& item : axes.items()) {
    if (std::find(names.begin(), names.end(), item.key()) == names.end()) names.push_back(item.key());
  }
  for (const std::string& name : names) {
    const json& axis = axes[name];
    if (!axis.is_object()) continue;
    // The unit is in the keys: change_um / change_urad.
    std::string unit;
    for (const char* u : {"um", "urad"}) {
      if (axis.contains(std::string("change_") + u)) unit = u;
    }
    if (unit.empty()) continue;
    std::cout << std::left << std::setw(11) << (name + " [" + unit + "]") << std::right;
    for (const json& v : axis["change_" + unit]) std::cout << std::setw(9) << Fixed(v, 2);
    std::cout << std::setw(10) << Fixed(axis.value("rms_" + unit, json()), 2) << std::setw(10)
              << Fixed(axis.value("max_abs_" + unit, json()), 2) << "\n";
  }
  const json wheel = motion.value("wheel", json::object());
  if (wheel.is_object() && !wheel.empty()) {
    std::cout << "wheel change:";
    for (const auto& [key, value] : wheel.items()) {
      std::ostringstream number;
      if (value.is_number()) {
        number << std::setprecision(4) << value.get<double>();
      } else {
        number << "-";
      }
      std::cout << " " << key << " " << number.str();
    }
    std::cout << "\n";
  }
}

void PrintCorrectionSummary(const json& answer) {
  const json& result = answer.contains("result") ? answer["result"] : json::object();
  std::cout << "job " << Member(answer, "id") << " (" << Member(answer, "kind") << ")  status "
            << Member(result, "status");
  if (result.contains("message") && result["message"].is_string() && !result["message"].get<std::string>().empty()) {
    std::cout << " - " << result["message"].get<std::string>();
  }
  std::cout << "\n";
  if (answer.contains("parent_job_id") && !answer["parent_job_id"].is_null()) {
    std::cout << "  replay of job " << Text(answer["parent_job_id"]) << "\n";
  }
  if (answer.contains("settings_source_job_id") && !answer["settings_source_job_id"].is_null()) {
    std::cout << "  ground with the settings of job " << Text(answer["settings_source_job_id"]) << "\n";
  }
  std::cout << "  deviation before     rms " << Fixed(result.value("initial_rms_um", json())) << " um, max "
            << Fixed(result.value("initial_max_um", json())) << " um\n"
            << "  predicted residual   rms " << Fixed(result.value("residual_rms_um", json())) << " um, max "
            << Fixed(result.value("residual_max_um", json())) << " um\n"
            << "  best reachable       rms " << Fixed(result.value("best_reachable_rms_um", json())) << " um\n"
            << "  solver " << Member(result, "solver") << ", mode " << Member(result, "mode") << ", rank "
            << Member(result, "rank") << ", condition " << Fixed(result.value("condition_number", json()), 1)
            << ", " << Member(result, "iterations") << " iterations, " << Fixed(result.value("elapsed_ms", json()), 1)
            << " ms\n";
  if (result.contains("regularisation") && result["regularisation"].is_object()) {
    const json& reg = result["regularisation"];
    std::cout << "  regularisation " << Member(reg, "rule") << ", level " << Fixed(reg.value("level", json()), 4)
              << ", effective dof " << Fixed(reg.value("effective_dof", json()), 1) << "\n";
  }
  if (result.contains("machine_state") && result["machine_state"].is_object()) {
    const json& state = result["machine_state"];
    if (state.value("estimated", false)) {
      std::cout << "  linearised at the estimated machine state (size " << Fixed(state.value("size", json()), 1)
                << ", misfit rms " << Fixed(state.value("misfit_rms_um", json())) << " um)\n";
    } else {
      std::cout << "  linearised at the commanded settings\n";
    }
  }
  if (result.contains("missing") && result["missing"].is_array() && !result["missing"].empty()) {
    std::cout << "  " << result["missing"].size() << " missing points left out\n";
  }
  if (result.contains("outliers") && result["outliers"].is_array() && !result["outliers"].empty()) {
    std::cout << "  " << result["outliers"].size() << " points rejected as outliers\n";
  }
  if (result.contains("predicted_residual_um")) PrintGrid("predicted residual", result["predicted_residual_um"]);
  PrintAxisMotion(result);
}

bool IsConverged(const json& answer) {
  if (!answer.contains("result") || !answer["result"].is_object()) return false;
  return answer["result"].value("status", "") == "converged";
}

// Sends a correction request; prints; exit code.
int SendCorrection(ApiClient* client, const std::string& path, const json& body, const GlobalOptions& global) {
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

// A number in full ("0.5", "-3e-3"); false for anything else.
bool ParseNumber(const std::string& text, double* value) {
  if (text.empty()) return false;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size() || !std::isfinite(v)) return false;
  *value = v;
  return true;
}

// --seed N and --noise UM of a simulation scenario (simulate, bevel-closed-loop). Returns -1, or
// the usage exit code after printing the reason.
int ApplySeedAndNoise(const CommandSpec& spec, const ParsedArgs& args, json* scenario) {
  if (args.Has("--seed")) {
    long long seed = 0;
    if (!ParseCount(args.Value("--seed"), 0, (1LL << 53), &seed)) {
      std::cerr << "gearloop " << spec.name << ": --seed takes a non-negative integer\n";
      return kExitUsage;
    }
    (*scenario)["seed"] = seed;
  }
  if (args.Has("--noise")) {
    double noise = 0.0;
    if (!ParseNumber(args.Value("--noise"), &noise) || !(noise >= 0.0)) {
      std::cerr << "gearloop " << spec.name << ": --noise takes a non-negative number of um\n";
      return kExitUsage;
    }
    (*scenario)["noise_um"] = noise;
  }
  return -1;
}

// --corrections N and --store of a closed loop (closed-loop, bevel-closed-loop). Returns -1, or
// the usage exit code after printing the reason.
int ApplyCorrectionsAndStore(const CommandSpec& spec, const ParsedArgs& args, json* scenario) {
  if (args.Has("--corrections")) {
    long long n = 0;
    if (!ParseCount(args.Value("--corrections"), 1, 1000, &n)) {
      std::cerr << "gearloop " << spec.name << ": --corrections takes a positive integer\n";
      return kExitUsage;
    }
    (*scenario)["corrections"] = n;
  }
  if (args.Has("--store")) (*scenario)["store"] = true;
  return -1;
}

// Sends a closed-loop scenario and prints one line per part (or the JSON). `made` says how a
// part comes about ("ground", "cut"). Exit 5 when the loop stopped early.
int RunClosedLoop(ApiClient* client, const json& scenario, const char* made, const GlobalOptions& global) {
  const ApiResponse answer = client->Post("/api/v1/simulations/closed-loop", scenario);
  const int failure = CheckAnswer(answer);
  if (failure >= 0) return failure;
  if (global.json) {
    PrintJson(answer.body);
  } else {
    std::cout << std::setw(5) << "part" << std::setw(12) << "true rms" << std::setw(12) << "true max" << std::setw(14)
              << "measured rms" << std::setw(15) << "correction" << std::setw(6) << "job" << "\n";
    for (const json& it : answer.body.value("iterations", json::array())) {
      std::string correction = "-";
      if (it.contains("correction") && it["correction"].is_object()) {
        correction = it["correction"].value("status", "yes");
      }
      std::cout << std::setw(5) << Member(it, "part") << std::setw(12) << Fixed(it.value("true_rms_um", json()))
                << std::setw(12) << Fixed(it.value("true_max_um", json())) << std::setw(14)
                << Fixed(it.value("measured_rms_um", json())) << std::setw(15) << correction << std::setw(6)
                << Member(it, "job_id") << "\n";
    }
    std::cout << "(deviations from the target in um; part 0 is " << made << " before any correction)\n";
    const std::string note = answer.body.value("message", "");
    if (!note.empty()) std::cout << note << "\n";
  }
  const json completed = answer.body.value("completed", json(true));
  return completed.is_boolean() && !completed.get<bool>() ? kExitNotConverged : kExitOk;
}

// --- Subcommands ---------------------------------------------------------------------------------

const CommandSpec kHealth{"health",
                          "usage: gearloop health\n\n"
                          "Asks the server whether it is up (GET /healthz) and prints its version.\n"
                          "Exit 0 when it answers \"ok\", 2 when it cannot be reached.\n",
                          {},
                          {},
                          0,
                          0};

int Health(const ParsedArgs&, ApiClient* client, const GlobalOptions& global) {
  const ApiResponse answer = client->Get("/healthz");
  const int failure = CheckAnswer(answer);
  if (failure >= 0) return failure;
  if (global.json) {
    PrintJson(answer.body);
  } else {
    std::cout << "server " << Member(answer.body, "status") << ", version " << Member(answer.body, "version") << "\n";
  }
  return answer.body.value("status", "") == "ok" ? kExitOk : kExitTransport;
}

const CommandSpec kSubmit{
    "submit",
    "usage: gearloop submit REQUEST.json MEASUREMENT.(csv|json) [options]\n\n"
    "Computes a correction for a measured flank and stores it as a job (POST /api/v1/corrections).\n"
    "REQUEST.json holds the setup: gear, wheel, machine, grid, flank, and optionally settings\n"
    "(what the part was ground with; default nominal), target and options. MEASUREMENT is a CSV\n"
    "grid (5 rows x 9 columns, row 1 = root side, empty or null = missing) or a JSON measurement\n"
    "file (clients/FORMATS.md). It replaces any measurement in REQUEST.json.\n\n"
    "options:\n"
    "  --target FILE         wanted topography: CSV grid (complete) or JSON {modifications:[...]}\n"
    "  --options FILE        JSON object of solver options, merged over REQUEST.json's\n"
    "  --settings-from ID    the part was ground with the corrected settings of job ID\n"
    "                        (they are fetched when REQUEST.json has no settings)\n"
    "  --residual-csv FILE   write the predicted residual grid as CSV\n"
    "  --settings-out FILE   write the new machine settings as JSON\n\n"
    "Exit 0 converged, 5 stored but not converged, 3 refused (the message names the field).\n",
    {"--target", "--options", "--settings-from", "--residual-csv", "--settings-out"},
    {},
    2,
    2};

// Builds a correction request from the files; returns -1 when done, or an exit code.
int BuildCorrectionRequest(const std::string& request_path,
                           const std::string& measurement_path,
                           const ParsedArgs& args,
                           json* request) {
  std::string error;
  if (!ReadJsonFile(request_path, request, &error)) return InputError(error);
  if (!request->is_object()) return InputError(request_path + ": the request must be a JSON object");
  int rows = 5;
  int columns = 9;
  GridShape(*request, &rows, &columns);
  json measurement;
  if (!ReadMeasurementFile(measurement_path, rows, columns, &measurement, &error)) return InputError(error);
  (*request)["measurement"] = measurement;
  if (args.Has("--target")) {
    json target;
    if (!ReadTargetFile(args.Value("--target"), rows, columns, &target, &error)) return InputError(error);
    (*request)["target"] = target;
  }
  if (args.Has("--options")) {
    json options;
    if (!ReadJsonFile(args.Value("--options"), &options, &error)) return InputError(error);
    if (!options.is_object()) return InputError(args.Value("--options") + ": options must be a JSON object");
    if (!request->contains("options") || !(*request)["options"].is_object()) (*request)["options"] = json::object();
    (*request)["options"].merge_patch(options);
  }
  if (args.Has("--settings-from")) {
    long long id = 0;
    if (!ParseCount(args.Value("--settings-from"), 1, (1LL << 53), &id)) {
      std::cerr << "gearloop submit: --settings-from takes a job id\n";
      return kExitUsage;
    }
    (*request)["settings_source_job_id"] = id;
  }
  return -1;
}

// With --settings-from ID and no "settings" in the request file, the part was ground with job
// ID's corrected settings: fetch them (once; `cache` keeps them for the items of a batch) so the
// server corrects from where the machine really was. Returns -1, or an exit code.
int FillSourceSettings(ApiClient* client, json* request, json* cache) {
  if (!request->contains("settings_source_job_id") || request->contains("settings")) return -1;
  if (cache->is_null()) {
    const std::string id = Text((*request)["settings_source_job_id"]);
    const ApiResponse source = client->Get("/api/v1/corrections/" + id);
    const int failure = CheckAnswer(source);
    if (failure >= 0) return failure;
    const json result = source.body.value("result", json::object());
    if (!result.contains("settings") || !result["settings"].is_object()) {
      std::cerr << "gearloop: job " << id << " holds no corrected settings\n";
      return kExitApiError;
    }
    *cache = result["settings"];
  }
  (*request)["settings"] = *cache;
  return -1;
}

int Submit(const ParsedArgs& args, ApiClient* client, const GlobalOptions& global) {
  json request;
  int built = BuildCorrectionRequest(args.positional[0], args.positional[1], args, &request);
  if (built >= 0) return built;
  json source_settings;
  built = FillSourceSettings(client, &request, &source_settings);
  if (built >= 0) return built;
  const ApiResponse answer = client->Post("/api/v1/corrections", request);
  const int failure = CheckAnswer(answer);
  if (failure >= 0) return failure;
  const json& result = answer.body.contains("result") ? answer.body["result"] : json::object();
  std::string error;
  if (args.Has("--residual-csv") && result.contains("predicted_residual_um")) {
    CsvGrid grid;
    if (JsonToCsvGrid(result["predicted_residual_um"], &grid) &&
        !WriteTextFile(args.Value("--residual-csv"), FormatCsvGrid(grid, true), &error)) {
      return InputError(error);
    }
  }
  if (args.Has("--settings-out") && result.contains("settings")) {
    if (!WriteTextFile(args.Value("--settings-out"), result["settings"].dump(2) + "\n", &error)) return InputError(error);
  }
  if (global.json) {
    PrintJson(answer.body);
  } else {
    PrintCorrectionSummary(answer.body);
  }
  return IsConverged(answer.body) ? kExitOk : kExitNotConverged;
}

const CommandSpec kList{"list",
                        "usage: gearloop list [options]\n\n"
                        "Lists stored jobs, newest first (GET /api/v1/corrections).\n\n"
                        "options:\n"
                        "  --limit N        jobs per page (default 20)\n"
                        "  --offset N       skip the N newest\n"
                        "  --kind K         correction | replay | batch_item | closed_loop\n"
                        "  --status S       converged | not_converged | ...\n"
                        "  --flank F        left | right (a gear), convex | concave (a bevel pinion)\n"
                        "  --teeth N        only gears with N teeth\n\n"
                        "columns: rms um is the predicted residual; parent N = a replay of job N,\n"
                        "<N = the part was ground with the corrected settings of job N.\n",
                        {"--limit", "--offset", "--kind", "--status", "--flank", "--teeth"},
                        {},
                        0,
                        0};

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

int List(const ParsedArgs& args, ApiClient* client, const GlobalOptions& global) {
  std::string query;
  for (const char* key : {"limit", "offset", "kind", "status", "flank", "teeth"}) {
    const std::string option = std::string("--") + key;
    if (!args.Has(option)) continue;
    query += (query.empty() ? "?" : "&") + std::string(key) + "=" + UrlEncode(args.Value(option));
  }
  const ApiResponse answer = client->Get("/api/v1/corrections" + query);
  const int failure = CheckAnswer(answer);
  if (failure >= 0) return failure;
  if (global.json) {
    PrintJson(answer.body);
    return kExitOk;
  }
  const json jobs = answer.body.value("jobs", json::array());
  std::cout << std::left << std::setw(6) << "id" << std::setw(26) << "created (UTC)" << std::setw(12) << "kind"
            << std::setw(15) << "status" << std::setw(14) << "gear" << std::setw(7) << "flank" << std::right
            << std::setw(10) << "rms um" << std::setw(8) << "parent" << "\n";
  for (const json& job : jobs) {
    std::string gear = "-";
    if (job.value("machine_kind", "") == "free-form-bevel-generator") {
      gear = "bevel pinion";  // a pinion flank carries no tooth count or module
    } else if (job.contains("gear") && job["gear"].is_object()) {
      gear = Member(job["gear"], "teeth") + "z m" + Member(job["gear"], "normal_module_mm");
    }
    std::string parent = "-";
    if (job.contains("parent_job_id") && !job["parent_job_id"].is_null()) parent = Text(job["parent_job_id"]);
    if (parent == "-" && job.contains("settings_source_job_id") && !job["settings_source_job_id"].is_null()) {
      parent = "<" + Text(job["settings_source_job_id"]);
    }
    std::cout << std::left << std::setw(6) << Member(job, "id") << std::setw(26) << Member(job, "created_utc")
              << std::setw(12) << Member(job, "kind") << std::setw(15) << Member(job, "status") << std::setw(14)
              << gear << std::setw(7) << Member(job, "flank") << std::right << std::setw(10)
              << Fixed(job.value("residual_rms_um", json())) << std::setw(8) << parent << "\n";
  }
  std::cout << jobs.size() << " of " << Member(answer.body, "total") << " jobs\n";
  return kExitOk;
}

const CommandSpec kShow{"show",
                        "usage: gearloop show ID [--grid NAME] [--header]\n\n"
                        "Shows one stored job (GET /api/v1/corrections/ID): the result summary and the\n"
                        "predicted residual. With --grid, prints only that grid as CSV instead:\n"
                        "  measured | target | residual | change\n"
                        "(--header adds the L1..L9 header line.)\n",
                        {"--grid"},
                        {"--header"},
                        1,
                        1};

bool ParseJobId(const std::string& text, long long* id) { return ParseCount(text, 1, (1LL << 53), id); }


int Show(const ParsedArgs& args, ApiClient* client, const GlobalOptions& global) {
  long long id = 0;
  if (!ParseJobId(args.positional[0], &id)) {
    std::cerr << "gearloop show: '" << args.positional[0] << "' is not a job id\n";
    return kExitUsage;
  }
  std::string grid_name = args.Value("--grid");
  if (!grid_name.empty() && grid_name != "measured" && grid_name != "target" && grid_name != "residual" &&
      grid_name != "change") {
    std::cerr << "gearloop show: --grid takes measured, target, residual or change\n";
    return kExitUsage;
  }
  const ApiResponse answer = client->Get("/api/v1/corrections/" + std::to_string(id));
  const int failure = CheckAnswer(answer);
  if (failure >= 0) return failure;
  const json& job = answer.body;
  const json result = job.value("result", json::object());
  if (!grid_name.empty()) {
    json grid;
    if (grid_name == "residual") grid = result.value("predicted_residual_um", json());
    if (grid_name == "change") grid = result.value("predicted_change_um", json());
    if (grid_name == "measured") grid = MeasuredGrid(job);
    if (grid_name == "target") grid = TargetGrid(job);
    CsvGrid csv;
    if (!JsonToCsvGrid(grid, &csv)) {
      std::cerr << "gearloop show: job " << id << " has no " << grid_name << " grid\n";
      return kExitApiError;
    }
    std::cout << FormatCsvGrid(csv, args.Has("--header"));
    return kExitOk;
  }
  if (global.json) {
    PrintJson(job);
    return kExitOk;
  }
  std::cout << "created " << Member(job, "created_utc") << ", server " << Member(job, "server_version") << "\n";
  const json request = job.value("request", json::object());
  if (request.contains("gear")) {
    const json& gear = request["gear"];
    std::cout << "gear " << Member(gear, "teeth") << " teeth, mn " << Member(gear, "normal_module_mm") << " mm, alpha "
              << Member(gear, "normal_pressure_angle_deg") << " deg, beta " << Member(gear, "helix_angle_deg")
              << " deg " << Member(gear, "hand") << ", flank " << Member(request, "flank") << "\n";
  }
  const bool bevel = request.contains("machine") && request["machine"].is_object() &&
                     request["machine"].value("kind", "") == "free-form-bevel-generator";
  if (bevel) {
    const json bevel_job = request.value("job", json::object());
    std::cout << "machine: free-form bevel generator, spiral bevel pinion, " << Member(bevel_job, "side")
              << " flank" << (bevel_job.value("published", false) ? " (published summary, Tang 2011)" : "")
              << "\n  grid rows root to face, columns toe to heel\n";
  }
  const json measured = MeasuredGrid(job);
  if (!measured.is_null()) PrintGrid("measured", measured);
  PrintCorrectionSummary(job);
  if (bevel && result.contains("motion") && result["motion"].is_object()) {
    // The corrected axis polynomials and their change: coefficient k multiplies t^k.
    const json& motion = result["motion"];
    const json delta = result.value("delta", json::object());
    std::cout << "corrected axis motions (coefficient k of t^k, t the roll in rad; change in brackets)\n";
    for (const char* axis : {"A_rad", "B_rad", "X_mm", "Y_mm", "Z_mm"}) {
      if (!motion.contains(axis) || !motion[axis].is_array()) continue;
      std::cout << "  " << std::left << std::setw(6) << axis << std::right;
      for (size_t k = 0; k < motion[axis].size(); ++k) {
        std::ostringstream cell;
        cell << std::setprecision(8) << motion[axis][k].get<double>();
        if (delta.contains(axis) && delta[axis].is_array() && k < delta[axis].size()) {
          cell << " (" << std::setprecision(3) << delta[axis][k].get<double>() << ")";
        }
        std::cout << " " << cell.str();
      }
      std::cout << "\n";
    }
  }
  return kExitOk;
}

const CommandSpec kReplay{"replay",
                          "usage: gearloop replay ID [--options FILE] [--set NAME=VALUE ...] [--target FILE]\n\n"
                          "Re-runs the stored measurement of job ID with changed options or target\n"
                          "(POST /api/v1/corrections/ID/replay); the new job is linked to its parent.\n\n"
                          "options:\n"
                          "  --options FILE     JSON object merged over the stored options (null removes)\n"
                          "  --set NAME=VALUE   one option; VALUE is read as JSON when it parses\n"
                          "                     (--set solver=pso --set max_num_iterations=100)\n"
                          "  --target FILE      a new target: CSV grid or JSON {modifications:[...]}\n",
                          {"--options", "--set", "--target"},
                          {},
                          1,
                          1};

int Replay(const ParsedArgs& args, ApiClient* client, const GlobalOptions& global) {
  long long id = 0;
  if (!ParseJobId(args.positional[0], &id)) {
    std::cerr << "gearloop replay: '" << args.positional[0] << "' is not a job id\n";
    return kExitUsage;
  }
  json changes = json::object();
  std::string error;
  if (args.Has("--options")) {
    json options;
    if (!ReadJsonFile(args.Value("--options"), &options, &error)) return InputError(error);
    if (!options.is_object()) return InputError(args.Value("--options") + ": options must be a JSON object");
    changes["options"] = options;
  }
  auto set = args.values.find("--set");
  if (set != args.values.end()) {
    if (!changes.contains("options")) changes["options"] = json::object();
    for (const std::string& assignment : set->second) {
      const size_t eq = assignment.find('=');
      if (eq == std::string::npos || eq == 0) {
        std::cerr << "gearloop replay: --set takes NAME=VALUE, got '" << assignment << "'\n";
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
    const ApiResponse parent = client->Get("/api/v1/corrections/" + std::to_string(id));
    const int failure = CheckAnswer(parent);
    if (failure >= 0) return failure;
    int rows = 5;
    int columns = 9;
    GridShape(parent.body.value("request", json::object()), &rows, &columns);
    json target;
    if (!ReadTargetFile(args.Value("--target"), rows, columns, &target, &error)) return InputError(error);
    changes["target"] = target;
  }
  return SendCorrection(client, "/api/v1/corrections/" + std::to_string(id) + "/replay", changes, global);
}

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

void DrawProgress(int done, int failed, int total, bool final_line) {
  const int width = 30;
  const int finished = done + failed;
  const int filled = total > 0 ? finished * width / total : width;
  std::cerr << "\r[" << std::string(filled, '#') << std::string(width - filled, '.') << "] " << finished << "/"
            << total << " done";
  if (failed > 0) std::cerr << ", " << failed << " failed";
  std::cerr << (final_line ? "\n" : "   ") << std::flush;
}

int Batch(const ParsedArgs& args, ApiClient* client, const GlobalOptions& global) {
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

const CommandSpec kSimulate{
    "simulate",
    "usage: gearloop simulate SCENARIO.json [--csv FILE] [--seed N] [--noise UM]\n\n"
    "Simulates the measuring machine (POST /api/v1/simulations/measurement): the flank a machine\n"
    "with hidden errors grinds from the commanded settings, as the CMM reports it. SCENARIO.json\n"
    "holds the setup (gear, wheel, machine, grid, flank), settings, hidden_errors or\n"
    "random_hidden_errors, noise_um, seed, missing_probability, ...\n\n"
    "options:\n"
    "  --csv FILE     write the simulated measurement as a CSV grid (input for `submit`)\n"
    "  --seed N       override the seed\n"
    "  --noise UM     override noise_um\n",
    {"--csv", "--seed", "--noise"},
    {},
    1,
    1};

int Simulate(const ParsedArgs& args, ApiClient* client, const GlobalOptions& global) {
  json scenario;
  std::string error;
  if (!ReadJsonFile(args.positional[0], &scenario, &error)) return InputError(error);
  if (!scenario.is_object()) return InputError(args.positional[0] + ": the scenario must be a JSON object");
  const int bad = ApplySeedAndNoise(kSimulate, args, &scenario);
  if (bad >= 0) return bad;
  const ApiResponse answer = client->Post("/api/v1/simulations/measurement", scenario);
  const int failure = CheckAnswer(answer);
  if (failure >= 0) return failure;
  json grid;
  if (answer.body.contains("measurement") && answer.body["measurement"].is_object()) {
    grid = answer.body["measurement"].value("deviations_um", json());
  }
  if (args.Has("--csv")) {
    CsvGrid csv;
    if (!JsonToCsvGrid(grid, &csv)) {
      std::cerr << "gearloop simulate: the answer holds no measurement grid\n";
      return kExitTransport;
    }
    if (!WriteTextFile(args.Value("--csv"), FormatCsvGrid(csv, true), &error)) return InputError(error);
  }
  if (global.json) {
    PrintJson(answer.body);
  } else {
    PrintGrid("simulated measurement", grid);
    if (answer.body.contains("missing") && answer.body["missing"].is_array()) {
      std::cout << answer.body["missing"].size() << " missing points, ";
    }
    if (answer.body.contains("outliers") && answer.body["outliers"].is_array()) {
      std::cout << answer.body["outliers"].size() << " outliers";
    }
    std::cout << "\n";
  }
  return kExitOk;
}

const CommandSpec kClosedLoop{
    "closed-loop",
    "usage: gearloop closed-loop SCENARIO.json [--corrections N] [--store]\n\n"
    "Runs a simulated closed loop on the server (POST /api/v1/simulations/closed-loop): grind\n"
    "with hidden machine errors, measure, correct, grind again, N times; prints the true and\n"
    "measured deviation of each part. SCENARIO.json: as for `simulate`, plus target, options.\n\n"
    "options:\n"
    "  --corrections N   number of corrections (1..20)\n"
    "  --store           keep each correction as a job (linked revision after revision)\n",
    {"--corrections"},
    {"--store"},
    1,
    1};

int ClosedLoop(const ParsedArgs& args, ApiClient* client, const GlobalOptions& global) {
  json scenario;
  std::string error;
  if (!ReadJsonFile(args.positional[0], &scenario, &error)) return InputError(error);
  if (!scenario.is_object()) return InputError(args.positional[0] + ": the scenario must be a JSON object");
  const int bad = ApplyCorrectionsAndStore(kClosedLoop, args, &scenario);
  if (bad >= 0) return bad;
  return RunClosedLoop(client, scenario, "ground", global);
}

// --- Spiral-bevel pinions (docs/bevel-machines.md) --------------------------------------------

constexpr const char* kBevelMachineKind = "free-form-bevel-generator";

// The pinion flank of a bevel command, in `body["job"]`: JOB.json when given (a bare job
// {side, published | cutter, machine, blank, grid}, or a whole request body with a "job"
// member, whose other members are kept), else the published pinion (Tang 2011). --side picks
// or overrides the flank. Returns -1, or an exit code after printing the reason.
int ReadBevelJob(const CommandSpec& spec, const ParsedArgs& args, json* body) {
  *body = json::object();
  if (!args.positional.empty()) {
    json file;
    std::string error;
    if (!ReadJsonFile(args.positional[0], &file, &error)) return InputError(error);
    if (!file.is_object()) return InputError(args.positional[0] + ": the pinion job must be a JSON object");
    if (file.contains("job")) {
      *body = file;
    } else {
      (*body)["job"] = file;
    }
    if (!(*body)["job"].is_object()) return InputError(args.positional[0] + ": \"job\" must be a JSON object");
  } else {
    (*body)["job"] = {{"side", "concave"}, {"published", true}};
  }
  if (args.Has("--side")) {
    const std::string side = args.Value("--side");
    if (side != "convex" && side != "concave") {
      std::cerr << "gearloop " << spec.name << ": --side takes convex or concave\n";
      return kExitUsage;
    }
    (*body)["job"]["side"] = side;
  }
  return -1;
}

const CommandSpec kBevelConvert{
    "bevel-convert",
    "usage: gearloop bevel-convert [--degree N | --max-flank-distance-um X] [--side S] [JOB.json]\n\n"
    "Converts the cradle-type generator summary of a spiral-bevel pinion flank into free-form\n"
    "axis polynomials (POST /api/v1/bevel/conversions) and prints the degree, the fit residual\n"
    "of each axis (largest and rms |fit - exact| over the roll range) and how far the flank the\n"
    "fitted motions cut lies from the cradle flank on the grid. JOB.json is the pinion job\n"
    "({side, published} or {side, cutter, machine, blank, grid}; clients/FORMATS.md) or a whole\n"
    "conversion request {job, options}; without it, the published pinion (Tang 2011).\n\n"
    "options:\n"
    "  --degree N                  degree of every axis polynomial (server: 1..12, default 5)\n"
    "  --max-flank-distance-um X   instead, the smallest degree whose flank lies within X um\n"
    "  --side S                    convex | concave (default concave for the published pinion)\n"
    "  --motion-out FILE           write the axis polynomials as JSON (the \"motion\" of a scenario)\n\n"
    "Exit 0 converted, 3 refused (the message names the field).\n",
    {"--degree", "--max-flank-distance-um", "--side", "--motion-out"},
    {},
    0,
    1};

int BevelConvert(const ParsedArgs& args, ApiClient* client, const GlobalOptions& global) {
  json body;
  int bad = ReadBevelJob(kBevelConvert, args, &body);
  if (bad >= 0) return bad;
  // Both may be given: the server refuses that and names the field.
  if (args.Has("--degree")) {
    long long degree = 0;
    if (!ParseCount(args.Value("--degree"), -1000, 1000, &degree)) {
      std::cerr << "gearloop bevel-convert: --degree takes an integer\n";
      return kExitUsage;
    }
    if (!body.contains("options") || !body["options"].is_object()) body["options"] = json::object();
    body["options"]["polynomial_degree"] = degree;
  }
  if (args.Has("--max-flank-distance-um")) {
    double tolerance_um = 0.0;
    if (!ParseNumber(args.Value("--max-flank-distance-um"), &tolerance_um)) {
      std::cerr << "gearloop bevel-convert: --max-flank-distance-um takes a number of um\n";
      return kExitUsage;
    }
    if (!body.contains("options") || !body["options"].is_object()) body["options"] = json::object();
    body["options"]["max_flank_distance_um"] = tolerance_um;
  }
  const ApiResponse answer = client->Post("/api/v1/bevel/conversions", body);
  const int failure = CheckAnswer(answer);
  if (failure >= 0) return failure;
  std::string error;
  if (args.Has("--motion-out") &&
      !WriteTextFile(args.Value("--motion-out"), answer.body.value("motion", json::object()).dump(2) + "\n", &error)) {
    return InputError(error);
  }
  if (global.json) {
    PrintJson(answer.body);
    return kExitOk;
  }
  // The answer spells the whole summary out; whether it began as the published one is the request's.
  const json job = answer.body.value("job", json::object());
  std::cout << "spiral bevel pinion, " << Member(job, "side") << " flank"
            << (body["job"].value("published", false) ? " (published summary, Tang 2011)" : "") << ": degree "
            << Member(answer.body, "degree");
  const json roll = answer.body.value("roll_range_deg", json::array());
  if (roll.is_array() && roll.size() == 2) {
    std::cout << ", cradle roll " << Fixed(roll[0]) << " .. " << Fixed(roll[1]) << " deg";
  }
  std::cout << "\n";
  // The server gives rad or mm (the unit is in the key); a person reads urad and um.
  std::cout << "fit residual |fit - exact| per axis\n"
            << std::left << std::setw(6) << "axis" << std::right << std::setw(12) << "max" << std::setw(12) << "rms"
            << "\n";
  for (const json& axis : answer.body.value("fit_residual", json::array())) {
    if (!axis.is_object()) continue;
    std::string unit;
    double scale = 1.0;
    std::string key;
    if (axis.contains("max_rad")) {
      key = "rad";
      unit = "urad";
      scale = 1e6;
    } else if (axis.contains("max_mm")) {
      key = "mm";
      unit = "um";
      scale = 1e3;
    } else {
      continue;
    }
    auto cell = [&](const char* stat) {
      const json value = axis.value(std::string(stat) + "_" + key, json());
      if (!value.is_number()) return std::string("-");
      std::ostringstream out;
      out << std::setprecision(3) << value.get<double>() * scale;
      return out.str();
    };
    std::cout << std::left << std::setw(6) << Member(axis, "axis") << std::right << std::setw(12) << cell("max")
              << std::setw(12) << cell("rms") << " " << unit << "\n";
  }
  const json distance = answer.body.value("flank_distance", json::object());
  std::cout << "flank distance to the cradle flank: max " << Fixed(distance.value("max_um", json()), 4) << " um, rms "
            << Fixed(distance.value("rms_um", json()), 4) << " um (" << Member(distance, "points_found") << " of "
            << Member(distance, "points") << " grid points)\n";
  return kExitOk;
}

const CommandSpec kBevelClosedLoop{
    "bevel-closed-loop",
    "usage: gearloop bevel-closed-loop [JOB.json] [options]\n\n"
    "Runs a simulated closed loop of a spiral-bevel pinion on the free-form generator (POST\n"
    "/api/v1/simulations/closed-loop with machine.kind free-form-bevel-generator): cut with the\n"
    "commanded axis motions plus hidden axis errors, measure, correct the motions, cut again, N\n"
    "times; prints the true and measured deviation of each part. JOB.json is the pinion job (as\n"
    "for `bevel-convert`) or a whole bevel scenario {job, motion, hidden_errors, noise_um, seed,\n"
    "target, options, ...}; without it, the published pinion.\n\n"
    "options:\n"
    "  --error AXIS=C0[,C1,...]  hidden error of an axis polynomial, coefficient k of t^k\n"
    "                            (AXIS: A_rad, B_rad, X_mm, Y_mm, Z_mm; repeat for several axes),\n"
    "                            e.g. --error X_mm=0.008 --error A_rad=0,2e-5\n"
    "  --noise UM                probe noise (standard deviation, um)\n"
    "  --seed N                  the noise's seed\n"
    "  --corrections N           number of corrections (server: 1..20, default 3)\n"
    "  --side S                  convex | concave (default concave for the published pinion)\n"
    "  --store                   keep each correction as a bevel job (see `gearloop show`)\n\n"
    "Exit 0 completed, 5 the loop stopped early, 3 refused (the message names the field).\n",
    {"--error", "--noise", "--seed", "--corrections", "--side"},
    {"--store"},
    0,
    1};

int BevelClosedLoop(const ParsedArgs& args, ApiClient* client, const GlobalOptions& global) {
  json scenario;
  int bad = ReadBevelJob(kBevelClosedLoop, args, &scenario);
  if (bad >= 0) return bad;
  scenario["machine"] = {{"kind", kBevelMachineKind}};
  auto errors = args.values.find("--error");
  if (errors != args.values.end()) {
    if (!scenario.contains("hidden_errors") || !scenario["hidden_errors"].is_object()) {
      scenario["hidden_errors"] = json::object();
    }
    for (const std::string& assignment : errors->second) {
      const size_t eq = assignment.find('=');
      json coefficients = json::array();
      bool good = eq != std::string::npos && eq > 0;
      std::string rest = good ? assignment.substr(eq + 1) : "";
      while (good) {
        const size_t comma = rest.find(',');
        double value = 0.0;
        good = ParseNumber(rest.substr(0, comma), &value);
        if (good) coefficients.push_back(value);
        if (comma == std::string::npos) break;
        rest = rest.substr(comma + 1);
      }
      if (!good) {
        std::cerr << "gearloop bevel-closed-loop: --error takes AXIS=C0[,C1,...] with numbers, got '" << assignment
                  << "'\n";
        return kExitUsage;
      }
      // The axis name is the server's to check: it names the field when it does not know it.
      scenario["hidden_errors"][assignment.substr(0, eq)] = coefficients;
    }
  }
  bad = ApplySeedAndNoise(kBevelClosedLoop, args, &scenario);
  if (bad >= 0) return bad;
  bad = ApplyCorrectionsAndStore(kBevelClosedLoop, args, &scenario);
  if (bad >= 0) return bad;
  return RunClosedLoop(client, scenario, "cut", global);
}

const CommandSpec kNominal{"nominal",
                           "usage: gearloop nominal REQUEST.json [--settings-out FILE]\n\n"
                           "Prints the nominal machine settings of the setup in REQUEST.json (gear, wheel,\n"
                           "machine, flank; POST /api/v1/nominal): the settings that grind the exact\n"
                           "involute helicoid, and the roll range.\n\n"
                           "options:\n"
                           "  --settings-out FILE   write the settings as JSON (input of `evaluate --settings`)\n",
                           {"--settings-out"},
                           {},
                           1,
                           1};

// Axis coefficients as a table: one line per axis, one column per power of the roll angle.
void PrintSettings(const json& settings) {
  const json axes = settings.value("axes", json::object());
  std::cout << std::left << std::setw(9) << "axis" << std::right;
  for (int k = 0; k < 7; ++k) std::cout << std::setw(14) << ("phi^" + std::to_string(k));
  std::cout << "\n";
  for (const char* axis : {"X", "Y", "Z", "A", "B", "C"}) {
    const bool linear = axis[0] == 'X' || axis[0] == 'Y' || axis[0] == 'Z';
    std::cout << std::left << std::setw(9) << (std::string(axis) + (linear ? " [mm]" : " [rad]")) << std::right;
    const json coefficients = axes.value(axis, json::array());
    for (int k = 0; k < 7; ++k) {
      std::ostringstream cell;
      if (k < static_cast<int>(coefficients.size()) && coefficients[k].is_number()) {
        cell << std::scientific << std::setprecision(5) << coefficients[k].get<double>();
      } else {
        cell << "0";
      }
      std::cout << std::setw(14) << cell.str();
    }
    std::cout << "\n";
  }
  const json wheel = settings.value("wheel", json::object());
  std::cout << "wheel: cone angle " << Member(wheel, "cone_angle_deg") << " deg, parabola "
            << Member(wheel, "parabola_coefficient_per_mm") << " /mm, vertex " << Member(wheel, "parabola_vertex_mm")
            << " mm\n";
}

int Nominal(const ParsedArgs& args, ApiClient* client, const GlobalOptions& global) {
  json request;
  std::string error;
  if (!ReadJsonFile(args.positional[0], &request, &error)) return InputError(error);
  if (!request.is_object()) return InputError(args.positional[0] + ": the request must be a JSON object");
  const ApiResponse answer = client->Post("/api/v1/nominal", request);
  const int failure = CheckAnswer(answer);
  if (failure >= 0) return failure;
  if (args.Has("--settings-out") &&
      !WriteTextFile(args.Value("--settings-out"), answer.body.value("settings", json::object()).dump(2) + "\n",
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
    std::cout << "roll range " << Fixed(roll[0]) << " .. " << Fixed(roll[1]) << " deg, pitch radius "
              << Fixed(answer.body.value("pitch_radius_mm", json())) << " mm, base radius "
              << Fixed(answer.body.value("base_radius_mm", json())) << " mm\n";
  }
  return kExitOk;
}

const CommandSpec kEvaluate{
    "evaluate",
    "usage: gearloop evaluate REQUEST.json [--settings FILE] [--csv FILE]\n\n"
    "Grinds the flank of REQUEST.json's setup in the model with the given settings and prints its\n"
    "deviations from the involute on the grid (POST /api/v1/evaluate); points the wheel does not\n"
    "reach are shown as '-'.\n\n"
    "options:\n"
    "  --settings FILE   machine settings JSON ({axes, wheel}, e.g. from `submit --settings-out`);\n"
    "                    default REQUEST.json's settings, else nominal\n"
    "  --csv FILE        write the grid as CSV\n",
    {"--settings", "--csv"},
    {},
    1,
    1};

int Evaluate(const ParsedArgs& args, ApiClient* client, const GlobalOptions& global) {
  json request;
  std::string error;
  if (!ReadJsonFile(args.positional[0], &request, &error)) return InputError(error);
  if (!request.is_object()) return InputError(args.positional[0] + ": the request must be a JSON object");
  if (args.Has("--settings")) {
    json settings;
    if (!ReadJsonFile(args.Value("--settings"), &settings, &error)) return InputError(error);
    if (settings.is_object() && settings.contains("settings")) settings = settings["settings"];
    request["settings"] = settings;
  }
  const ApiResponse answer = client->Post("/api/v1/evaluate", request);
  const int failure = CheckAnswer(answer);
  if (failure >= 0) return failure;
  const json grid = answer.body.value("deviations_um", json());
  if (args.Has("--csv")) {
    CsvGrid csv;
    if (!JsonToCsvGrid(grid, &csv)) {
      std::cerr << "gearloop evaluate: the answer holds no deviation grid\n";
      return kExitTransport;
    }
    if (!WriteTextFile(args.Value("--csv"), FormatCsvGrid(csv, true), &error)) return InputError(error);
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

const CommandSpec kReport{"report",
                          "usage: gearloop report ID [-o FILE]\n\n"
                          "Writes a self-contained printable HTML report of job ID (measured, target and\n"
                          "predicted residual topographies, axis corrections over the roll range, the\n"
                          "convergence along its lineage) to stdout or FILE. No network needed to view it.\n",
                          {"--output"},
                          {},
                          1,
                          1};

int Report(const ParsedArgs& args, ApiClient* client, const GlobalOptions&) {
  long long id = 0;
  if (!ParseJobId(args.positional[0], &id)) {
    std::cerr << "gearloop report: '" << args.positional[0] << "' is not a job id\n";
    return kExitUsage;
  }
  const ApiResponse job = client->Get("/api/v1/corrections/" + std::to_string(id));
  int failure = CheckAnswer(job);
  if (failure >= 0) return failure;
  // The lineage gives the convergence plot; an older server without the route still gets a
  // report, with this job alone.
  json lineage = json::array({job.body});
  const ApiResponse chain = client->Get("/api/v1/corrections/" + std::to_string(id) + "/lineage");
  if (chain.ok() && chain.body.is_object() && chain.body.contains("jobs") && chain.body["jobs"].is_array()) {
    // The lineage lists summaries; the plot needs each job's measured rms, so fetch the last 20.
    json full = json::array();
    const json& jobs = chain.body["jobs"];
    for (size_t i = jobs.size() > 20 ? jobs.size() - 20 : 0; i < jobs.size(); ++i) {
      const ApiResponse one = client->Get("/api/v1/corrections/" + Text(jobs[i].value("id", json())));
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
  if (args.Has("--output")) {
    if (!WriteTextFile(args.Value("--output"), html, &error)) return InputError(error);
    std::cerr << "wrote " << args.Value("--output") << "\n";
  } else {
    std::cout << html;
  }
  return kExitOk;
}

struct Command {
  const CommandSpec* spec;
  int (*run)(const ParsedArgs&, ApiClient*, const GlobalOptions&);
  const char* summary;
};

const std::vector<Command>& Commands() {
  static const std::vector<Command> commands = {
      {&kSubmit, Submit, "compute and store a correction from a request and a measurement file"},
      {&kList, List, "list stored jobs, newest first"},
      {&kShow, Show, "show one job, or export one of its grids as CSV"},
      {&kReplay, Replay, "re-run a stored measurement with changed options or target"},
      {&kBatch, Batch, "correct every measurement file of a folder as one batch"},
      {&kSimulate, Simulate, "simulate a CMM measurement of a machine with hidden errors"},
      {&kClosedLoop, ClosedLoop, "simulate grind-measure-correct loops"},
      {&kBevelConvert, BevelConvert, "convert a bevel pinion's cradle summary to free-form axis motions"},
      {&kBevelClosedLoop, BevelClosedLoop, "simulate cut-measure-correct loops of a bevel pinion"},
      {&kReport, Report, "write a printable HTML report of a job"},
      {&kNominal, Nominal, "print the nominal machine settings of a setup"},
      {&kEvaluate, Evaluate, "print the flank that given settings grind, on the grid"},
      {&kHealth, Health, "check that the server is up"},
  };
  return commands;
}

}  // namespace

std::string MainHelp() {
  std::ostringstream out;
  out << "usage: gearloop [--server URL] [--token T] [--json] [--timeout S] COMMAND [ARGS]\n\n"
         "Command-line client of the gearloop server: closed-loop correction of gear grinding.\n\n"
         "commands:\n";
  for (const Command& c : Commands()) out << "  " << std::left << std::setw(19) << c.spec->name << c.summary << "\n";
  out << "\nglobal options (anywhere on the line):\n"
         "  --server URL   server base URL (default $GEARLOOP_SERVER or http://127.0.0.1:8080)\n"
         "  --token T      send \"Authorization: Bearer T\" (default $GEARLOOP_TOKEN)\n"
         "  --json         print the server's JSON instead of tables\n"
         "  --timeout S    seconds for connecting and each read (default 120)\n"
         "  --help         this text; `gearloop COMMAND --help` for a command\n"
         "  --version      the client's version\n\n"
         "exit codes:\n"
         "  0  done, and the outcome is good\n"
         "  1  wrong arguments or options\n"
         "  2  server not reachable, timed out, answered 5xx or not the API\n"
         "  3  the server refused the request (4xx; the message names the field)\n"
         "  4  a local file could not be read or is invalid (the message names line and column)\n"
         "  5  done, but a correction did not converge or batch items failed\n\n"
         "files: CSV grids and JSON measurement files are described in clients/FORMATS.md.\n";
  return out.str();
}

int RunCommand(const std::string& name, const std::vector<std::string>& args, const GlobalOptions& global) {
  for (const Command& command : Commands()) {
    if (name != command.spec->name) continue;
    // "-o" is the short form of --output (report).
    std::vector<std::string> expanded;
    for (const std::string& arg : args) {
      if (arg == "--help" || arg == "-h") {
        std::cout << command.spec->usage;
        return kExitOk;
      }
      expanded.push_back(arg == "-o" ? "--output" : arg);
    }
    ParsedArgs parsed;
    if (!ParseArgs(*command.spec, expanded, &parsed)) return kExitUsage;
    ApiClient client(global.server, global.token, global.timeout_seconds);
    std::string error;
    if (!client.IsValid(&error)) {
      std::cerr << "gearloop: " << error << "\n";
      return kExitUsage;
    }
    return command.run(parsed, &client, global);
  }
  std::cerr << "gearloop: unknown command '" << name << "'\nTry 'gearloop --help'.\n";
  return kExitUsage;
}

}  // namespace gearloop
