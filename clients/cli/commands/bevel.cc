// clients/cli/commands/bevel.cc: spiral-bevel pinions on the free-form
// generator (docs/bevel-machines.md): `gearloop bevel-convert` (POST
// /api/v1/bevel/conversions) and `gearloop bevel-closed-loop` (POST
// /api/v1/simulations/closed-loop).
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "clients/cli/command_util.h"
#include "clients/cli/commands/subcommands.h"
#include "clients/cli/grid_files.h"

namespace gearloop {
namespace cli_internal {
namespace {

using nlohmann::json;

constexpr const char* kBevelMachineKind = "free-form-bevel-generator";

// The pinion flank of a bevel command, in `body["job"]`: JOB.json when given (a
// bare job {side, published | cutter, machine, blank, grid}, or a whole request
// body with a "job" member, whose other members are kept), else the published
// pinion (Tang 2011). --side picks or overrides the flank. Returns -1, or an
// exit code after printing the reason.
int ReadBevelJob(const CommandSpec& spec, const ParsedArgs& args, json* body) {
  *body = json::object();
  if (!args.positional.empty()) {
    json file;
    std::string error;
    if (!ReadJsonFile(args.positional[0], &file, &error))
      return InputError(error);
    if (!file.is_object())
      return InputError(args.positional[0] +
                        ": the pinion job must be a JSON object");
    if (file.contains("job")) {
      *body = file;
    } else {
      (*body)["job"] = file;
    }
    if (!(*body)["job"].is_object())
      return InputError(args.positional[0] + ": \"job\" must be a JSON object");
  } else {
    (*body)["job"] = {{"side", "concave"}, {"published", true}};
  }
  if (args.Has("--side")) {
    const std::string side = args.Value("--side");
    if (side != "convex" && side != "concave") {
      std::cerr << "gearloop " << spec.name
                << ": --side takes convex or concave\n";
      return kExitUsage;
    }
    (*body)["job"]["side"] = side;
  }
  return -1;
}

// --degree N and --max-flank-distance-um X into the request's options. Both may
// be given: the server refuses that and names the field. Returns -1, or the
// usage exit code after printing the reason.
int ApplyConversionOptions(const ParsedArgs& args, json* body) {
  if (args.Has("--degree")) {
    long long degree = 0;
    if (!ParseCount(args.Value("--degree"), -1000, 1000, &degree)) {
      std::cerr << "gearloop bevel-convert: --degree takes an integer\n";
      return kExitUsage;
    }
    if (!body->contains("options") || !(*body)["options"].is_object())
      (*body)["options"] = json::object();
    (*body)["options"]["polynomial_degree"] = degree;
  }
  if (args.Has("--max-flank-distance-um")) {
    double tolerance_um = 0.0;
    if (!ParseNumber(args.Value("--max-flank-distance-um"), &tolerance_um)) {
      std::cerr << "gearloop bevel-convert: --max-flank-distance-um takes a "
                   "number of um\n";
      return kExitUsage;
    }
    if (!body->contains("options") || !(*body)["options"].is_object())
      (*body)["options"] = json::object();
    (*body)["options"]["max_flank_distance_um"] = tolerance_um;
  }
  return -1;
}

// The largest and rms |fit - exact| of each axis polynomial. The server gives
// rad or mm (the unit is in the key); a person reads urad and um.
void PrintFitResidual(const json& answer) {
  std::cout << "fit residual |fit - exact| per axis\n"
            << std::left << std::setw(6) << "axis" << std::right
            << std::setw(12) << "max" << std::setw(12) << "rms"
            << "\n";
  for (const json& axis : answer.value("fit_residual", json::array())) {
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
    std::cout << std::left << std::setw(6) << Member(axis, "axis") << std::right
              << std::setw(12) << cell("max") << std::setw(12) << cell("rms")
              << " " << unit << "\n";
  }
}

// A conversion for a person: the flank and degree, the fit residual per axis,
// and the distance of the flank the fitted motions cut from the cradle flank.
// `body` is the request sent.
void PrintConversion(const json& body, const json& answer) {
  // The answer spells the whole summary out; whether it began as the published
  // one is the request's.
  const json job = answer.value("job", json::object());
  std::cout << "spiral bevel pinion, " << Member(job, "side") << " flank"
            << (body["job"].value("published", false)
                    ? " (published summary, Tang 2011)"
                    : "")
            << ": degree " << Member(answer, "degree");
  const json roll = answer.value("roll_range_deg", json::array());
  if (roll.is_array() && roll.size() == 2) {
    std::cout << ", cradle roll " << Fixed(roll[0]) << " .. " << Fixed(roll[1])
              << " deg";
  }
  std::cout << "\n";
  PrintFitResidual(answer);
  const json distance = answer.value("flank_distance", json::object());
  std::cout << "flank distance to the cradle flank: max "
            << Fixed(distance.value("max_um", json()), 4) << " um, rms "
            << Fixed(distance.value("rms_um", json()), 4) << " um ("
            << Member(distance, "points_found") << " of "
            << Member(distance, "points") << " grid points)\n";
}

}  // namespace

const CommandSpec kBevelConvert{
    "bevel-convert",
    "usage: gearloop bevel-convert [--degree N | --max-flank-distance-um X] "
    "[--side S] [JOB.json]\n\n"
    "Converts the cradle-type generator summary of a spiral-bevel pinion flank "
    "into free-form\n"
    "axis polynomials (POST /api/v1/bevel/conversions) and prints the degree, "
    "the fit residual\n"
    "of each axis (largest and rms |fit - exact| over the roll range) and how "
    "far the flank the\n"
    "fitted motions cut lies from the cradle flank on the grid. JOB.json is "
    "the pinion job\n"
    "({side, published} or {side, cutter, machine, blank, grid}; "
    "clients/FORMATS.md) or a whole\n"
    "conversion request {job, options}; without it, the published pinion (Tang "
    "2011).\n\n"
    "options:\n"
    "  --degree N                  degree of every axis polynomial (server: "
    "1..12, default 5)\n"
    "  --max-flank-distance-um X   instead, the smallest degree whose flank "
    "lies within X um\n"
    "  --side S                    convex | concave (default concave for the "
    "published pinion)\n"
    "  --motion-out FILE           write the axis polynomials as JSON (the "
    "\"motion\" of a scenario)\n\n"
    "Exit 0 converted, 3 refused (the message names the field).\n",
    {"--degree", "--max-flank-distance-um", "--side", "--motion-out"},
    {},
    0,
    1};

int RunBevelConvert(const ParsedArgs& args,
                    ApiClient* client,
                    const GlobalOptions& global) {
  json body;
  int bad = ReadBevelJob(kBevelConvert, args, &body);
  if (bad >= 0) return bad;
  bad = ApplyConversionOptions(args, &body);
  if (bad >= 0) return bad;
  const ApiResponse answer = client->Post("/api/v1/bevel/conversions", body);
  const int failure = CheckAnswer(answer);
  if (failure >= 0) return failure;
  std::string error;
  if (args.Has("--motion-out") &&
      !WriteTextFile(args.Value("--motion-out"),
                     answer.body.value("motion", json::object()).dump(2) + "\n",
                     &error)) {
    return InputError(error);
  }
  if (global.json) {
    PrintJson(answer.body);
    return kExitOk;
  }
  PrintConversion(body, answer.body);
  return kExitOk;
}

const CommandSpec kBevelClosedLoop{
    "bevel-closed-loop",
    "usage: gearloop bevel-closed-loop [JOB.json] [options]\n\n"
    "Runs a simulated closed loop of a spiral-bevel pinion on the free-form "
    "generator (POST\n"
    "/api/v1/simulations/closed-loop with machine.kind "
    "free-form-bevel-generator): cut with the\n"
    "commanded axis motions plus hidden axis errors, measure, correct the "
    "motions, cut again, N\n"
    "times; prints the true and measured deviation of each part. JOB.json is "
    "the pinion job (as\n"
    "for `bevel-convert`) or a whole bevel scenario {job, motion, "
    "hidden_errors, noise_um, seed,\n"
    "target, options, ...}; without it, the published pinion.\n\n"
    "options:\n"
    "  --error AXIS=C0[,C1,...]  hidden error of an axis polynomial, "
    "coefficient k of t^k\n"
    "                            (AXIS: A_rad, B_rad, X_mm, Y_mm, Z_mm; repeat "
    "for several axes),\n"
    "                            e.g. --error X_mm=0.008 --error A_rad=0,2e-5\n"
    "  --noise UM                probe noise (standard deviation, um)\n"
    "  --seed N                  the noise's seed\n"
    "  --corrections N           number of corrections (server: 1..20, default "
    "3)\n"
    "  --side S                  convex | concave (default concave for the "
    "published pinion)\n"
    "  --store                   keep each correction as a bevel job (see "
    "`gearloop show`)\n\n"
    "Exit 0 completed, 5 the loop stopped early, 3 refused (the message names "
    "the field).\n",
    {"--error", "--noise", "--seed", "--corrections", "--side"},
    {"--store"},
    0,
    1};

int RunBevelClosedLoop(const ParsedArgs& args,
                       ApiClient* client,
                       const GlobalOptions& global) {
  json scenario;
  int bad = ReadBevelJob(kBevelClosedLoop, args, &scenario);
  if (bad >= 0) return bad;
  scenario["machine"] = {{"kind", kBevelMachineKind}};
  auto errors = args.values.find("--error");
  if (errors != args.values.end()) {
    if (!scenario.contains("hidden_errors") ||
        !scenario["hidden_errors"].is_object()) {
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
        std::cerr << "gearloop bevel-closed-loop: --error takes "
                     "AXIS=C0[,C1,...] with numbers, got '"
                  << assignment << "'\n";
        return kExitUsage;
      }
      // The axis name is the server's to check: it names the field when it does
      // not know it.
      scenario["hidden_errors"][assignment.substr(0, eq)] = coefficients;
    }
  }
  bad = ApplySeedAndNoise(kBevelClosedLoop, args, &scenario);
  if (bad >= 0) return bad;
  bad = ApplyCorrectionsAndStore(kBevelClosedLoop, args, &scenario);
  if (bad >= 0) return bad;
  return SendClosedLoop(client, scenario, "cut", global);
}

}  // namespace cli_internal
}  // namespace gearloop

namespace gearloop {
namespace cli_internal {
namespace {

// One ranked row: the parameter (or axis), its offset and the flank error it
// causes.
void PrintSensitivityRow(int rank, const std::string& name, const json& row) {
  std::ostringstream offset;
  const json error = row.value("error", json());
  if (error.is_number()) offset << std::setprecision(4) << error.get<double>();
  std::cout << std::setw(4) << rank << "  " << std::left << std::setw(10)
            << name << std::right << std::setw(12)
            << (error.is_number() ? offset.str() : "-") << " " << std::left
            << std::setw(11) << Member(row, "error_unit") << std::right
            << std::setw(12) << Fixed(row.value("max_abs_um", json()))
            << std::setw(12) << Fixed(row.value("rms_um", json())) << "\n";
}

// The rows of `items` named by `ranking` (key `key`), the first `top` of them.
void PrintRanking(const json& answer,
                  const char* items_key,
                  const char* ranking_key,
                  const char* key,
                  int top) {
  const json items = answer.value(items_key, json::array());
  int rank = 0;
  for (const json& name : answer.value(ranking_key, json::array())) {
    if (rank >= top) break;
    for (const json& row : items) {
      if (row.value(key, json()) != name) continue;
      PrintSensitivityRow(++rank, Text(name), row);
      break;
    }
  }
}

}  // namespace

const CommandSpec kBevelSensitivity{
    "bevel-sensitivity",
    "usage: gearloop bevel-sensitivity [JOB.json] [options]\n\n"
    "Ranks the free-form generator's axes of a spiral-bevel pinion flank by "
    "the flank error an\n"
    "error of each causes (POST /api/v1/bevel/axis-sensitivity): first a "
    "constant offset of each\n"
    "axis, then every polynomial coefficient, largest rms flank error first. "
    "JOB.json as for\n"
    "`bevel-convert`; without it, the published pinion.\n\n"
    "options:\n"
    "  --side S                 convex | concave\n"
    "  --linear-error-mm E      offset of X, Y, Z (server default 0.01)\n"
    "  --angular-error-deg E    offset of A, B (server default 0.01)\n"
    "  --top N                  coefficients listed (default 10)\n\n"
    "Exit 0 done, 3 refused (the message names the field).\n",
    {"--side", "--linear-error-mm", "--angular-error-deg", "--top"},
    {},
    0,
    1};

int RunBevelSensitivity(const ParsedArgs& args,
                        ApiClient* client,
                        const GlobalOptions& global) {
  json body;
  int bad = ReadBevelJob(kBevelSensitivity, args, &body);
  if (bad >= 0) return bad;
  for (const char* option : {"--linear-error-mm", "--angular-error-deg"}) {
    if (!args.Has(option)) continue;
    double value = 0.0;
    if (!ParseNumber(args.Value(option), &value)) {
      std::cerr << "gearloop bevel-sensitivity: " << option
                << " takes a number\n";
      return kExitUsage;
    }
    const std::string key = std::string(option).substr(2);
    body["errors"][key == "linear-error-mm" ? "linear_error_mm"
                                            : "angular_error_deg"] = value;
  }
  long long top = 10;
  if (args.Has("--top") && !ParseCount(args.Value("--top"), 1, 1000, &top)) {
    std::cerr << "gearloop bevel-sensitivity: --top takes 1 to 1000\n";
    return kExitUsage;
  }
  const ApiResponse answer =
      client->Post("/api/v1/bevel/axis-sensitivity", body);
  const int failure = CheckAnswer(answer);
  if (failure >= 0) return failure;
  if (global.json) {
    PrintJson(answer.body);
    return kExitOk;
  }
  std::cout << "flank error of each axis offset, largest first (um)\n"
            << "rank  axis            offset unit          max |dev|         "
               "rms\n";
  PrintRanking(answer.body, "offsets", "offset_ranking", "axis", 1000);
  std::cout << "\nflank error of each coefficient (k of t^k), largest first "
               "(um)\n"
            << "rank  parameter       offset unit          max |dev|         "
               "rms\n";
  PrintRanking(answer.body,
               "coefficients",
               "coefficient_ranking",
               "parameter",
               static_cast<int>(top));
  return kExitOk;
}

}  // namespace cli_internal
}  // namespace gearloop
