// clients/cli/command_util.cc: the helpers of command_util.h. Diagnostics go to
// stderr, results to stdout.
#include "clients/cli/command_util.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <utility>

#include "clients/cli/csv_grid.h"
#include "clients/cli/grid_files.h"

namespace gearloop {
namespace cli_internal {
namespace {

using nlohmann::json;

// The result's axis_motion as a small table: the change of each axis position
// at the 9 roll angles of the result's range (um for linear axes, urad for
// rotary ones), its rms and largest magnitude over the range, then the
// wheel-parameter changes. Nothing for a job stored without it.
void PrintAxisMotion(const json& result) {
  if (!result.contains("axis_motion") || !result["axis_motion"].is_object())
    return;
  const json& motion = result["axis_motion"];
  const json roll = motion.value("roll_rad", json::array());
  const json axes = motion.value("axes", json::object());
  if (!roll.is_array() || roll.empty() || !axes.is_object()) return;
  constexpr double kDegPerRad = 180.0 / 3.14159265358979323846;
  std::cout << "axis motion of the correction over the roll range (change of "
               "the axis position)\n";
  std::cout << std::left << std::setw(11) << "roll [deg]" << std::right;
  for (const json& r : roll)
    std::cout << std::setw(9)
              << (r.is_number() ? Fixed(r.get<double>() * kDegPerRad, 2) : "-");
  std::cout << std::setw(10) << "rms" << std::setw(10) << "max |.|"
            << "\n";
  // Linear axes first, as the machine lists them; then any other axis the model
  // has.
  std::vector<std::string> names;
  for (const char* name : {"X", "Y", "Z", "A", "B", "C"}) {
    if (axes.contains(name)) names.push_back(name);
  }
  for (const auto& item : axes.items()) {
    if (std::find(names.begin(), names.end(), item.key()) == names.end())
      names.push_back(item.key());
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
    std::cout << std::left << std::setw(11) << (name + " [" + unit + "]")
              << std::right;
    for (const json& v : axis["change_" + unit])
      std::cout << std::setw(9) << Fixed(v, 2);
    std::cout << std::setw(10) << Fixed(axis.value("rms_" + unit, json()), 2)
              << std::setw(10)
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

}  // namespace

// --- Arguments
// -----------------------------------------------------------------------------------

bool ParseCount(const std::string& text,
                long long min,
                long long max,
                long long* value) {
  if (text.empty()) return false;
  char* end = nullptr;
  const long long v = std::strtoll(text.c_str(), &end, 10);
  if (end != text.c_str() + text.size() || v < min || v > max) return false;
  *value = v;
  return true;
}

bool ParseNumber(const std::string& text, double* value) {
  if (text.empty()) return false;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size() || !std::isfinite(v)) return false;
  *value = v;
  return true;
}

bool ParseJobId(const std::string& text, long long* id) {
  return ParseCount(text, 1, (1LL << 53), id);
}

// --- Output
// --------------------------------------------------------------------------------------

std::string Fixed(const json& value, int digits) {
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

json OnlyKeys(const json& object, const std::vector<std::string>& keys) {
  json kept = json::object();
  for (const std::string& key : keys) {
    if (object.is_object() && object.contains(key)) kept[key] = object[key];
  }
  return kept;
}

const std::vector<std::string> kGrinderSetupKeys = {
    "gear", "wheel", "machine", "grid", "flank", "settings"};

std::string Member(const json& object, const char* key) {
  if (!object.is_object() || !object.contains(key)) return "-";
  return Text(object[key]);
}

void PrintGrid(const std::string& title, const json& grid) {
  CsvGrid g;
  if (!JsonToCsvGrid(grid, &g)) return;
  std::cout << title << " [um] (tip at top, lead from x < 0 to x > 0)\n";
  std::cout << std::setw(11) << "";
  for (int c = 0; c < g.columns; ++c)
    std::cout << std::setw(8) << ("L" + std::to_string(c + 1));
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
        cell << std::fixed << std::setprecision(2)
             << (std::fabs(*v) < 0.005 ? 0.0 : *v);
      } else {
        cell << "-";
      }
      std::cout << std::setw(8) << cell.str();
    }
    std::cout << "\n";
  }
}

void PrintJson(const json& value) { std::cout << value.dump(2) << "\n"; }

int CheckAnswer(const ApiResponse& answer) {
  if (!answer.transport_error.empty()) {
    std::cerr << "gearloop: " << answer.transport_error << "\n";
    return kExitTransport;
  }
  if (answer.IsApiError()) {
    std::cerr << "gearloop: server refused the request: " << answer.ErrorText()
              << "\n";
    return kExitApiError;
  }
  if (!answer.ok() || !answer.body.is_object()) {
    std::cerr << "gearloop: unexpected answer " << answer.status
              << " from the server\n";
    return kExitTransport;
  }
  return -1;
}

int InputError(const std::string& message) {
  std::cerr << "gearloop: " << message << "\n";
  return kExitInput;
}

int PrintOrWriteText(const ParsedArgs& args, const std::string& text) {
  if (!args.Has("--output")) {
    std::cout << text;
    return kExitOk;
  }
  std::string error;
  if (!WriteTextFile(args.Value("--output"), text, &error))
    return InputError(error);
  std::cerr << "wrote " << args.Value("--output") << "\n";
  return kExitOk;
}

// --- Corrections
// ---------------------------------------------------------------------------------

const char* const kTraceOptionsHelp =
    "  --part-number P          trace: the part number (stored, filterable)\n"
    "  --serial S               trace: the serial number\n"
    "  --teeth 1,10,19          trace: the measured tooth numbers\n"
    "  --measured-at TIME       trace: ISO-8601 time of the measurement\n"
    "  --machine-id M           trace: the machine the part was made on\n"
    "  --file-name F            trace: the measuring file (default: its "
    "name)\n";

int ApplyTraceOptions(const std::string& command,
                      const ParsedArgs& args,
                      const std::string& machine_file_path,
                      json* request) {
  json trace = request->contains("trace") && (*request)["trace"].is_object()
                   ? (*request)["trace"]
                   : json::object();
  const std::pair<const char*, const char*> texts[] = {
      {"--part-number", "part_number"},
      {"--serial", "serial"},
      {"--measured-at", "measured_at"},
      {"--machine-id", "machine_id"},
      {"--file-name", "file_name"}};
  for (const auto& [option, key] : texts) {
    if (args.Has(option)) trace[key] = args.Value(option);
  }
  if (!machine_file_path.empty() && !trace.contains("file_name")) {
    const size_t slash = machine_file_path.find_last_of('/');
    trace["file_name"] = slash == std::string::npos
                             ? machine_file_path
                             : machine_file_path.substr(slash + 1);
  }
  if (args.Has("--teeth")) {
    json teeth = json::array();
    std::stringstream list(args.Value("--teeth"));
    std::string item;
    while (std::getline(list, item, ',')) {
      long long tooth = 0;
      if (!ParseCount(item, 1, 100000, &tooth)) {
        std::cerr << "gearloop " << command
                  << ": --teeth takes tooth numbers >= 1 separated by commas, "
                     "got '"
                  << args.Value("--teeth") << "'\n";
        return kExitUsage;
      }
      teeth.push_back(tooth);
    }
    trace["teeth"] = teeth;
  }
  if (!trace.empty()) (*request)["trace"] = trace;
  return -1;
}

std::string VerdictCell(const json& result) {
  if (!result.contains("verdict") || !result["verdict"].is_object()) return "-";
  const json& verdict = result["verdict"];
  const auto one = [&verdict](const char* part) {
    return verdict.value(part, json::object()).value("verdict", "?");
  };
  return one("measured") + "/" + one("predicted");
}

// The tolerance and the verdicts of a result with a tolerance.
void PrintVerdict(const json& result) {
  if (!result.contains("verdict") || !result["verdict"].is_object()) return;
  const json& verdict = result["verdict"];
  const json tolerance = verdict.value("tolerance", json::object());
  std::string limits;
  if (tolerance.contains("rms_um"))
    limits += "rms " + Fixed(tolerance["rms_um"], 2) + " um";
  if (tolerance.contains("max_um"))
    limits += std::string(limits.empty() ? "" : ", ") + "max " +
              Fixed(tolerance["max_um"], 2) + " um";
  if (tolerance.contains("iso_class"))
    limits += std::string(limits.empty() ? "" : ", ") + "ISO 1328-1 class " +
              Text(tolerance["iso_class"]);
  std::cout << "  tolerance            " << limits << "\n";
  for (const char* part : {"measured", "predicted"}) {
    const json v = verdict.value(part, json::object());
    std::string failed;
    for (const json& name : v.value("failed", json::array()))
      failed += (failed.empty() ? "" : ", ") + Text(name);
    std::cout << "  verdict " << std::left << std::setw(13) << part
              << std::right << v.value("verdict", "?")
              << (failed.empty() ? "" : "  (misses " + failed + ")") << "\n";
  }
}

// The reach block of a job that missed its tolerance: per target
// modification the share the machine makes and what would make the rest.
void PrintReach(const json& result) {
  const json reach = result.value("reach", json());
  if (!reach.is_object()) return;
  for (const json& c : reach.value("components", json::array())) {
    const json modification = c.value("modification", json::object());
    const json share = c.value("reachable_share", json());
    std::cout << "  reach " << Member(modification, "kind") << " "
              << (share.is_number()
                      ? Fixed(json(100.0 * share.get<double>()), 1)
                      : std::string("-"))
              << " % made\n";
    const json remedy = c.value("remedy", json());
    if (remedy.is_object())
      std::cout << "    -> " << Member(remedy, "message") << "\n";
  }
}

// How sure the prediction is, and why the safe step kept less than the whole
// change where it did (absent on jobs stored before them).
void PrintPredictionBand(const json& result) {
  const json band = result.value("prediction_band", json());
  if (band.is_object() &&
      band.value("expected_true_rms_um", json()).is_number()) {
    const json two = band.value("true_rms_2sigma_um", json());
    const bool pair = two.is_array() && two.size() == 2;
    std::cout << "  next part true rms   "
              << Fixed(band.value("expected_true_rms_um", json()))
              << " um, 2 sigma " << Fixed(pair ? two[0] : json()) << ".."
              << Fixed(pair ? two[1] : json()) << " um (noise "
              << Fixed(band.value("noise_sigma_um", json())) << " um "
              << (band.value("noise_stated", false) ? "stated" : "estimated");
    const json stated = band.value("stated_noise_um", json());
    if (stated.is_number())
      std::cout << " from the measurement's scatter; " << Fixed(stated)
                << " um stated is contradicted";
    const json probe = band.value("noise_read_as_probe_um", json());
    if (band.value("misfit_read_as_flank", false) && probe.is_number())
      std::cout << " from a misfit, more than a probe scatters: the expected "
                   "value counts all but "
                << Fixed(probe) << " um of it as flank the next part keeps";
    std::cout << ")\n";
  }
  const json safe_step = result.value("safe_step", json());
  const json shortened = safe_step.is_object()
                             ? safe_step.value("shortened_because", json())
                             : json();
  if (shortened.is_string() && !shortened.get<std::string>().empty()) {
    std::cout << "  safe step kept "
              << Text(safe_step.value("step_fraction", json()))
              << " of the change: the whole change "
              << shortened.get<std::string>() << "\n";
  }
  const json parabola = safe_step.is_object()
                            ? safe_step.value("wheel_parabola", json())
                            : json();
  if (parabola.is_object()) {
    std::cout << "  wheel parabola       ";
    if (parabola.value("source", "") == "measurement")
      std::cout << Fixed(parabola.value("estimate_flank_um", json())) << " +- "
                << Fixed(parabola.value("sd_flank_um", json()))
                << " um rms of flank as the measurement shows it\n";
    else
      std::cout << Fixed(parabola.value("hedged_flank_um", json()))
                << " um rms of flank assumed (noise not known)\n";
  }
}

void PrintCorrectionSummary(const json& answer) {
  const json& result =
      answer.contains("result") ? answer["result"] : json::object();
  std::cout << "job " << Member(answer, "id") << " (" << Member(answer, "kind")
            << ")  status " << Member(result, "status");
  if (result.contains("message") && result["message"].is_string() &&
      !result["message"].get<std::string>().empty()) {
    std::cout << " - " << result["message"].get<std::string>();
  }
  std::cout << "\n";
  if (answer.contains("parent_job_id") && !answer["parent_job_id"].is_null()) {
    std::cout << "  replay of job " << Text(answer["parent_job_id"]) << "\n";
  }
  if (answer.contains("settings_source_job_id") &&
      !answer["settings_source_job_id"].is_null()) {
    std::cout << "  ground with the settings of job "
              << Text(answer["settings_source_job_id"]) << "\n";
  }
  std::cout << "  deviation before     rms "
            << Fixed(result.value("initial_rms_um", json())) << " um, max "
            << Fixed(result.value("initial_max_um", json())) << " um\n"
            << "  predicted residual   rms "
            << Fixed(result.value("residual_rms_um", json())) << " um, max "
            << Fixed(result.value("residual_max_um", json())) << " um\n"
            << "  best reachable       rms "
            << Fixed(result.value("best_reachable_rms_um", json())) << " um\n";
  PrintPredictionBand(result);
  if (result.contains("iso1328") && result["iso1328"].is_object()) {
    // ISO 1328-1 overall class of the measured part (against the target)
    // and of the predicted next part.
    const json& iso = result["iso1328"];
    const auto overall = [&iso](const char* which) {
      const json& quality = iso.value(which, json::object());
      return quality.contains("classes") && quality["classes"].is_object()
                 ? Text(quality["classes"].value("overall", json()))
                 : std::string("-");
    };
    std::cout << "  ISO 1328-1 class     " << overall("target_relative")
              << " measured, " << overall("predicted") << " predicted\n";
  }
  PrintVerdict(result);
  PrintReach(result);
  std::cout << "  solver " << Member(result, "solver") << ", mode "
            << Member(result, "mode") << ", rank " << Member(result, "rank")
            << ", condition "
            << Fixed(result.value("condition_number", json()), 1) << ", "
            << Member(result, "iterations") << " iterations, "
            << Fixed(result.value("elapsed_ms", json()), 1) << " ms\n";
  if (result.contains("regularisation") &&
      result["regularisation"].is_object()) {
    const json& reg = result["regularisation"];
    std::cout << "  regularisation " << Member(reg, "rule") << ", level "
              << Fixed(reg.value("level", json()), 4) << ", effective dof "
              << Fixed(reg.value("effective_dof", json()), 1) << "\n";
  }
  if (result.contains("machine_state") && result["machine_state"].is_object()) {
    const json& state = result["machine_state"];
    if (state.value("estimated", false)) {
      std::cout << "  linearised at the estimated machine state (size "
                << Fixed(state.value("size", json()), 1) << ", misfit rms "
                << Fixed(state.value("misfit_rms_um", json())) << " um)\n";
    } else {
      std::cout << "  linearised at the commanded settings\n";
    }
  }
  // The exact-model search (absent on jobs stored before it, '' for solvers
  // without it): what it did and, when it ran, its two exact predictions.
  const json search = result.value("exact_search", json());
  const json outcome =
      search.is_object() ? search.value("outcome", json()) : json();
  if (outcome.is_string() && !outcome.get<std::string>().empty()) {
    std::cout << "  exact-model search " << outcome.get<std::string>() << "\n";
    const json regularised =
        search.value("regularised_predicted_rms_um", json());
    const json searched = search.value("searched_predicted_rms_um", json());
    if (regularised.is_number() || searched.is_number())
      std::cout << "    exact-model rms " << Fixed(regularised)
                << " um regularised, " << Fixed(searched) << " um searched\n";
  }
  if (result.contains("missing") && result["missing"].is_array() &&
      !result["missing"].empty()) {
    std::cout << "  " << result["missing"].size()
              << " missing points left out\n";
  }
  if (result.contains("outliers") && result["outliers"].is_array() &&
      !result["outliers"].empty()) {
    std::cout << "  " << result["outliers"].size()
              << " points rejected as outliers\n";
  }
  if (result.contains("predicted_residual_um"))
    PrintGrid("predicted residual", result["predicted_residual_um"]);
  PrintAxisMotion(result);
}

int BuildCorrectionRequest(const std::string& request_path,
                           const std::string& measurement_path,
                           const ParsedArgs& args,
                           json* request) {
  std::string error;
  if (!ReadJsonFile(request_path, request, &error)) return InputError(error);
  if (!request->is_object())
    return InputError(request_path + ": the request must be a JSON object");
  int rows = 5;
  int columns = 9;
  GridShape(*request, &rows, &columns);
  if (!measurement_path.empty()) {
    json measurement;
    if (!ReadMeasurementFile(
            measurement_path, rows, columns, &measurement, &error))
      return InputError(error);
    (*request)["measurement"] = measurement;
  }
  if (args.Has("--target")) {
    json target;
    if (!ReadTargetFile(args.Value("--target"), rows, columns, &target, &error))
      return InputError(error);
    (*request)["target"] = target;
  }
  if (args.Has("--options")) {
    json options;
    if (!ReadJsonFile(args.Value("--options"), &options, &error))
      return InputError(error);
    if (!options.is_object())
      return InputError(args.Value("--options") +
                        ": options must be a JSON object");
    if (!request->contains("options") || !(*request)["options"].is_object())
      (*request)["options"] = json::object();
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

int FillSourceSettings(ApiClient* client, json* request, json* cache) {
  if (!request->contains("settings_source_job_id") ||
      request->contains("settings"))
    return -1;
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

// --- Simulations
// ---------------------------------------------------------------------------------

int ApplySeedAndNoise(const CommandSpec& spec,
                      const ParsedArgs& args,
                      json* scenario) {
  if (args.Has("--seed")) {
    long long seed = 0;
    if (!ParseCount(args.Value("--seed"), 0, (1LL << 53), &seed)) {
      std::cerr << "gearloop " << spec.name
                << ": --seed takes a non-negative integer\n";
      return kExitUsage;
    }
    (*scenario)["seed"] = seed;
  }
  if (args.Has("--noise")) {
    double noise = 0.0;
    if (!ParseNumber(args.Value("--noise"), &noise) || !(noise >= 0.0)) {
      std::cerr << "gearloop " << spec.name
                << ": --noise takes a non-negative number of um\n";
      return kExitUsage;
    }
    (*scenario)["noise_um"] = noise;
  }
  return -1;
}

int ApplyCorrectionsAndStore(const CommandSpec& spec,
                             const ParsedArgs& args,
                             json* scenario) {
  if (args.Has("--corrections")) {
    long long n = 0;
    if (!ParseCount(args.Value("--corrections"), 1, 1000, &n)) {
      std::cerr << "gearloop " << spec.name
                << ": --corrections takes a positive integer\n";
      return kExitUsage;
    }
    (*scenario)["corrections"] = n;
  }
  if (args.Has("--store")) (*scenario)["store"] = true;
  return -1;
}

// True when the last part of a closed loop deviates more from the target (true
// rms, else measured rms) than the part made before any correction; says so
// on stderr.
bool LoopDiverged(const json& loop, bool quiet) {
  const json iterations = loop.value("iterations", json::array());
  if (iterations.size() < 2) return false;
  const auto rms = [](const json& it) {
    const json value =
        it.contains("true_rms_um") && it["true_rms_um"].is_number()
            ? it["true_rms_um"]
            : it.value("measured_rms_um", json());
    return value.is_number() ? value.get<double>() : std::nan("");
  };
  const double first = rms(iterations.front());
  const double last = rms(iterations.back());
  if (!(last > first)) return false;
  if (!quiet) {
    std::cerr << "gearloop: the loop diverged: part "
              << Member(iterations.back(), "part") << " deviates "
              << Fixed(json(last)) << " um rms from the target, part "
              << Member(iterations.front(), "part") << " " << Fixed(json(first))
              << " um; check the solver options and the machine setup\n";
  }
  return true;
}

int SendClosedLoop(ApiClient* client,
                   const json& scenario,
                   const char* made,
                   const GlobalOptions& global) {
  const ApiResponse answer =
      client->Post("/api/v1/simulations/closed-loop", scenario);
  const int failure = CheckAnswer(answer);
  if (failure >= 0) return failure;
  if (global.json) {
    PrintJson(answer.body);
  } else {
    std::cout << std::setw(5) << "part" << std::setw(12) << "true rms"
              << std::setw(12) << "true max" << std::setw(14) << "measured rms"
              << std::setw(15) << "correction" << std::setw(6) << "job"
              << "\n";
    for (const json& it : answer.body.value("iterations", json::array())) {
      std::string correction = "-";
      if (it.contains("correction") && it["correction"].is_object()) {
        correction = it["correction"].value("status", "yes");
      }
      std::cout << std::setw(5) << Member(it, "part") << std::setw(12)
                << Fixed(it.value("true_rms_um", json())) << std::setw(12)
                << Fixed(it.value("true_max_um", json())) << std::setw(14)
                << Fixed(it.value("measured_rms_um", json())) << std::setw(15)
                << correction << std::setw(6) << Member(it, "job_id") << "\n";
    }
    std::cout << "(deviations from the target in um; part 0 is " << made
              << " before any correction)\n";
    const std::string note = answer.body.value("message", "");
    if (!note.empty()) std::cout << note << "\n";
  }
  const json completed = answer.body.value("completed", json(true));
  if (completed.is_boolean() && !completed.get<bool>())
    return kExitNotConverged;
  return LoopDiverged(answer.body, global.json) ? kExitNotConverged : kExitOk;
}

}  // namespace cli_internal
}  // namespace gearloop
