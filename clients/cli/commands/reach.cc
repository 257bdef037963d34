// clients/cli/commands/reach.cc: `gearloop reach REQUEST.json`, the share of a
// target the machine configuration can make, before anything is ground (POST
// /api/v1/targets/reach).
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "clients/cli/command_util.h"
#include "clients/cli/commands/subcommands.h"

namespace gearloop {
namespace cli_internal {
namespace {

using nlohmann::json;

std::string Percent(const json& share) {
  if (!share.is_number()) return "-";
  std::ostringstream out;
  out << std::fixed << std::setprecision(1) << 100.0 * share.get<double>()
      << " %";
  return out.str();
}

void PrintReachRow(const std::string& name, const json& reach) {
  std::cout << std::left << std::setw(34) << name << std::right << std::setw(11)
            << Fixed(reach.value("target_rms_um", json())) << std::setw(15)
            << Fixed(reach.value("unreachable_rms_um", json())) << std::setw(10)
            << Percent(reach.value("reachable_share", json())) << "\n";
}

// "X to order 6 74.5 %" of remedy.higher_order.
std::string OrderText(const json& higher) {
  if (!higher.is_object()) return "";
  return Member(higher, "axis") + " to order " +
         Text(higher.value("order", json())) + " " +
         Percent(higher.value("reachable_share", json()));
}

std::string ShareOf(const json& remedy, const char* key) {
  const json block = remedy.value(key, json());
  return block.is_object() ? Percent(block.value("reachable_share", json()))
                           : std::string();
}

// The line under a component that is not made whole: the remedy the server
// computed, then what else it tried.
void PrintRemedy(const json& remedy) {
  if (!remedy.is_object()) return;
  const std::string kind = Member(remedy, "kind");
  const json higher = remedy.value("higher_order", json());
  std::string line = "  -> ";
  if (kind == "higher_order") {
    line += "open axis " + OrderText(higher);
  } else if (kind == "wheel_profile") {
    line +=
        "free the wheel profile (parabola) " + ShareOf(remedy, "wheel_profile");
  } else if (kind == "wheel_traverse") {
    line += "wheel traverse along the lead (outside the model)";
  } else {
    line += "no remedy in the model";
  }
  std::string tried;
  if (kind != "higher_order" && higher.is_object())
    tried += "best axis " + OrderText(higher);
  if (kind != "wheel_profile" &&
      remedy.value("wheel_profile", json()).is_object())
    tried += (tried.empty() ? "" : ", ") + std::string("wheel profile ") +
             ShareOf(remedy, "wheel_profile");
  if (remedy.value("wheel_traverse", json()).is_object())
    tried += (tried.empty() ? "" : ", ") + std::string("traverse C_s ") +
             ShareOf(remedy, "wheel_traverse");
  if (!tried.empty()) line += "; tried: " + tried;
  std::cout << line << "\n";
}

// "lead_crowning 10 um" for a modification.
std::string ModificationName(const json& modification) {
  std::string name = Member(modification, "kind");
  if (modification.contains("amount_um"))
    name += " " + Text(modification["amount_um"]) + " um";
  return name;
}

}  // namespace

const CommandSpec kReach{
    "reach",
    "usage: gearloop reach REQUEST.json [--target FILE] [--options FILE]\n\n"
    "Tells, before anything is ground, how much of the target the machine "
    "configuration of\n"
    "REQUEST.json can make (POST /api/v1/targets/reach): for each target "
    "modification and for all\n"
    "together, the target's rms, the rms no correction at the allowed orders "
    "can make, and the\n"
    "share of the target made; then the same with every axis free to order "
    "6.\n"
    "Under each modification not made whole, the remedy the server computed "
    "(a higher order\n"
    "on a named axis, the wheel profile freed, or the wheel traverse along "
    "the lead) and the\n"
    "share each would reach.\n\n"
    "options:\n"
    "  --target FILE    JSON {modifications:[...]} replacing REQUEST.json's "
    "target\n"
    "  --options FILE   JSON object of solver options, merged over "
    "REQUEST.json's\n\n"
    "Exit 0 when every modification can be made whole (share >= 99 %), 5 "
    "when some cannot.\n",
    {"--target", "--options"},
    {},
    1,
    1};

int RunReach(const ParsedArgs& args,
             ApiClient* client,
             const GlobalOptions& global) {
  json request;
  const int built =
      BuildCorrectionRequest(args.positional[0], "", args, &request);
  if (built >= 0) return built;
  request.erase("measurement");
  const ApiResponse answer = client->Post("/api/v1/targets/reach", request);
  const int failure = CheckAnswer(answer);
  if (failure >= 0) return failure;
  bool whole = true;
  for (const json& c : answer.body.value("components", json::array())) {
    const json share = c.value("reachable_share", json());
    whole = whole && share.is_number() && share.get<double>() >= 0.99;
  }
  if (global.json) {
    PrintJson(answer.body);
    return whole ? kExitOk : kExitNotConverged;
  }
  std::cout << std::left << std::setw(34) << "target" << std::right
            << std::setw(11) << "rms um" << std::setw(15) << "not made um"
            << std::setw(10) << "made"
            << "\n";
  for (const json& c : answer.body.value("components", json::array())) {
    PrintReachRow(ModificationName(c.value("modification", json())), c);
    PrintRemedy(c.value("remedy", json()));
  }
  const json combined = answer.body.value("combined", json());
  PrintReachRow("all together", combined);
  // Every axis at order 6 is a row of its own only where the options hold an
  // axis lower (by default every order is open and it is the row above).
  const json highest = answer.body.value("with_highest_orders", json());
  if (highest.is_object() && !highest.value("same_as_combined", false))
    PrintReachRow("all together, every axis to order 6", highest);
  if (!whole) {
    std::cout << "part of the target is out of reach of this machine "
                 "configuration; the -> lines say\n"
                 "what would make the rest (computed by the server: an axis "
                 "held below order 6 opened higher,\n"
                 "the wheel profile freed, the traverse C_s); --json gives "
                 "the remedies in full\n";
  }
  return whole ? kExitOk : kExitNotConverged;
}

}  // namespace cli_internal
}  // namespace gearloop
