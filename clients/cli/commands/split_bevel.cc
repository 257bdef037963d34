// clients/cli/commands/split_bevel.cc: split equal-base-circle bevel wheels
// milled on a head-head 5-axis machine (docs/split-bevel.md): `gearloop
// split-trajectory` (POST /api/v1/bevel/split-trajectory), and the summary
// `gearloop show` prints for such a job.
#include <algorithm>
#include <iomanip>
#include <iostream>
#include <limits>
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

// A numeric option and the request member it sets.
struct NumberOption {
  const char* option;
  const char* object;
  const char* key;
  bool integer;
};

constexpr NumberOption kNumberOptions[] = {
    {"--teeth", "gear", "teeth", true},
    {"--pitch-angle-deg", "gear", "pitch_angle_deg", false},
    {"--module-mm", "gear", "outer_transverse_module_mm", false},
    {"--cone-distance-mm", "gear", "outer_cone_distance_mm", false},
    {"--face-width-mm", "gear", "face_width_mm", false},
    {"--spiral-angle-deg", "gear", "mean_spiral_angle_deg", false},
    {"--pressure-angle-deg", "gear", "pressure_angle_deg", false},
    {"--tool-radius-mm", "tool", "radius_mm", false},
    {"--stock-mm", "tool", "stock_mm", false},
    {"--slot", "cut", "slot_index", true},
    {"--levels", "cut", "depth_levels", true},
    {"--steps", "cut", "steps", true},
    {"--chord-tolerance-mm", "cut", "chord_tolerance_mm", false},
    {"--feed", "cut", "feed_mm_per_min", false},
    {"--pivot-mm", "machine", "pivot_length_mm", false},
};

json& Object(json* body, const char* object) {
  if (!body->contains(object) || !(*body)[object].is_object())
    (*body)[object] = json::object();
  return (*body)[object];
}

// The options that set request members (over REQUEST.json's). Returns -1, or
// the usage exit code after printing the reason.
int ApplyOptions(const ParsedArgs& args, json* body) {
  for (const NumberOption& o : kNumberOptions) {
    if (!args.Has(o.option)) continue;
    const std::string text = args.Value(o.option);
    long long integer = 0;
    double number = 0.0;
    if (o.integer ? !ParseCount(text, -1000000000, 1000000000, &integer)
                  : !ParseNumber(text, &number)) {
      std::cerr << "gearloop split-trajectory: " << o.option << " takes "
                << (o.integer ? "an integer" : "a number") << "\n";
      return kExitUsage;
    }
    Object(body, o.object)[o.key] = o.integer ? json(integer) : json(number);
  }
  if (args.Has("--hand")) Object(body, "gear")["hand"] = args.Value("--hand");
  if (args.Has("--from")) Object(body, "cut")["from"] = args.Value("--from");
  if (args.Has("--flanks")) {
    json flanks = json::array();
    std::stringstream list(args.Value("--flanks"));
    std::string flank;
    while (std::getline(list, flank, ',')) flanks.push_back(flank);
    Object(body, "cut")["flanks"] = flanks;
  }
  if (args.Has("--nc")) Object(body, "output")["nc"] = true;
  return -1;
}

// The smallest and largest value of `key` over the points of a pass.
std::string Range(const json& points, const char* key) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const json& p : points) {
    if (!p.is_object() || !p.contains(key) || !p[key].is_number()) continue;
    lo = std::min(lo, p[key].get<double>());
    hi = std::max(hi, p[key].get<double>());
  }
  if (lo > hi) return "-";
  return Fixed(lo, 3) + " .. " + Fixed(hi, 3);
}

}  // namespace

void PrintSplitTrajectory(const json& result) {
  const json derived = result.value("derived", json::object());
  std::cout << "base circle r_b "
            << Fixed(derived.value("base_radius_mm", json()))
            << " mm, normal module "
            << Fixed(derived.value("normal_module_mm", json()), 4)
            << " mm, cone distance "
            << Fixed(derived.value("inner_cone_distance_mm", json()), 2)
            << " .. "
            << Fixed(derived.value("outer_cone_distance_mm", json()), 2)
            << " mm, spiral angle "
            << Fixed(derived.value("inner_spiral_angle_deg", json())) << " .. "
            << Fixed(derived.value("outer_spiral_angle_deg", json()))
            << " deg\n";
  std::cout << std::right << std::setw(5) << "pass" << std::setw(9) << "flank"
            << std::setw(6) << "level" << std::setw(9) << "stations"
            << std::setw(22) << "A range [deg]" << std::setw(22)
            << "B range [deg]" << std::setw(16) << "max side dev"
            << "\n";
  int index = 0;
  for (const json& pass : result.value("passes", json::array())) {
    if (!pass.is_object()) continue;
    const json points = pass.value("points", json::array());
    const json deviation = pass.value("side_deviation_mm", json::object());
    std::cout << std::setw(5) << ++index << std::setw(9)
              << Member(pass, "flank") << std::setw(6) << Member(pass, "level")
              << std::setw(9)
              << pass.value("point_count",
                            static_cast<long long>(points.size()))
              << std::setw(22) << Range(points, "A_deg") << std::setw(22)
              << Range(points, "B_deg") << std::setw(13)
              << Fixed(deviation.value("max", json()), 4) << " mm"
              << "\n";
  }
}

const CommandSpec kSplitTrajectory{
    "split-trajectory",
    "usage: gearloop split-trajectory [REQUEST.json] [options]\n\n"
    "Computes the 5-axis flank-milling trajectory of one slot of a split "
    "equal-base-circle bevel\n"
    "wheel on a head-head machine (POST /api/v1/bevel/split-trajectory; "
    "docs/split-bevel.md),\n"
    "stores it as a job and prints per pass: flank, depth level, stations, the "
    "A and B ranges and\n"
    "the largest side deviation (positive = material left). REQUEST.json is a "
    "whole request\n"
    "{gear, tool, cut, machine, setup, output}; the options set its members "
    "(over the file's).\n\n"
    "options:\n"
    "  --teeth N  --pitch-angle-deg D  --module-mm M | --cone-distance-mm R\n"
    "  --face-width-mm B  --spiral-angle-deg D (mean)  --hand left|right  "
    "--pressure-angle-deg D\n"
    "  --tool-radius-mm R  --stock-mm S             the end mill\n"
    "  --slot K  --flanks convex,concave  --levels L  --steps N | "
    "--chord-tolerance-mm T\n"
    "  --from toe|heel  --feed F (mm/min)  --pivot-mm P\n"
    "  --nc FILE   write the NC program to FILE\n\n"
    "Exit 0 computed, 3 refused (the message names the field).\n",
    {"--teeth",
     "--pitch-angle-deg",
     "--module-mm",
     "--cone-distance-mm",
     "--face-width-mm",
     "--spiral-angle-deg",
     "--hand",
     "--pressure-angle-deg",
     "--tool-radius-mm",
     "--stock-mm",
     "--slot",
     "--flanks",
     "--levels",
     "--steps",
     "--chord-tolerance-mm",
     "--from",
     "--feed",
     "--pivot-mm",
     "--nc"},
    {},
    0,
    1};

int RunSplitTrajectory(const ParsedArgs& args,
                       ApiClient* client,
                       const GlobalOptions& global) {
  json body = json::object();
  if (!args.positional.empty()) {
    std::string error;
    if (!ReadJsonFile(args.positional[0], &body, &error))
      return InputError(error);
    if (!body.is_object())
      return InputError(args.positional[0] +
                        ": the request must be a JSON object");
  }
  const int bad = ApplyOptions(args, &body);
  if (bad >= 0) return bad;
  const ApiResponse answer =
      client->Post("/api/v1/bevel/split-trajectory", body);
  const int failure = CheckAnswer(answer);
  if (failure >= 0) return failure;
  std::string error;
  if (args.Has("--nc") &&
      !WriteTextFile(args.Value("--nc"),
                     answer.body.value("nc_program", std::string()),
                     &error)) {
    return InputError(error);
  }
  if (global.json) {
    PrintJson(answer.body);
    return kExitOk;
  }
  std::cout << "job " << Member(answer.body, "job_id")
            << " (split_trajectory), NC program at "
            << Member(answer.body, "nc_location") << "\n";
  PrintSplitTrajectory(answer.body);
  if (args.Has("--nc"))
    std::cout << "NC program written to " << args.Value("--nc") << "\n";
  return kExitOk;
}

}  // namespace cli_internal
}  // namespace gearloop
