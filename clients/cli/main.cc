// clients/cli/main.cc: `gearloop`, the command-line client of the gearloop
// server.
//
//   gearloop submit request.json part7.csv --target target.json
//   gearloop list --limit 5
//   gearloop --json show 12 | jq .result.residual_rms_um
//
// Global options may stand anywhere on the line; everything else goes to the
// subcommand (commands.h). Exit codes are listed by `gearloop --help`.
#include <cstdlib>
#include <iostream>
#include <string>
#include <vector>

#include "clients/cli/commands.h"

namespace {

constexpr const char* kClientVersion = "0.1.0";

bool TakeValue(const std::vector<std::string>& args,
               size_t* i,
               const std::string& name,
               std::string* value) {
  const std::string& arg = args[*i];
  if (arg.rfind(name + "=", 0) == 0) {
    *value = arg.substr(name.size() + 1);
    return true;
  }
  if (arg != name) return false;
  if (*i + 1 >= args.size()) {
    std::cerr << "gearloop: option " << name << " needs a value\n";
    std::exit(gearloop::kExitUsage);
  }
  *value = args[++*i];
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  using gearloop::GlobalOptions;
  GlobalOptions global;
  if (const char* server = std::getenv("GEARLOOP_SERVER");
      server != nullptr && *server != '\0') {
    global.server = server;
  }
  if (const char* token = std::getenv("GEARLOOP_TOKEN"); token != nullptr)
    global.token = token;

  const std::vector<std::string> args(argv + 1, argv + argc);
  std::string command;
  std::vector<std::string> rest;
  bool help = false;
  for (size_t i = 0; i < args.size(); ++i) {
    std::string value;
    if (TakeValue(args, &i, "--server", &value)) {
      global.server = value;
    } else if (TakeValue(args, &i, "--token", &value)) {
      global.token = value;
    } else if (TakeValue(args, &i, "--timeout", &value)) {
      char* end = nullptr;
      const long seconds = std::strtol(value.c_str(), &end, 10);
      if (value.empty() || *end != '\0' || seconds < 1 || seconds > 86400) {
        std::cerr << "gearloop: --timeout takes 1..86400 seconds\n";
        return gearloop::kExitUsage;
      }
      global.timeout_seconds = static_cast<int>(seconds);
    } else if (args[i] == "--json") {
      global.json = true;
    } else if (args[i] == "--version") {
      std::cout << "gearloop " << kClientVersion << "\n";
      return gearloop::kExitOk;
    } else if (command.empty() &&
               (args[i] == "--help" || args[i] == "-h" || args[i] == "help")) {
      help = true;
    } else if (command.empty() && !args[i].empty() && args[i][0] != '-') {
      command = args[i];
    } else {
      rest.push_back(args[i]);
    }
  }
  if (help && command.empty()) {
    std::cout << gearloop::MainHelp();
    return gearloop::kExitOk;
  }
  if (help) rest.push_back("--help");  // "gearloop help submit"
  if (command.empty()) {
    std::cerr << gearloop::MainHelp();
    return gearloop::kExitUsage;
  }
  return gearloop::RunCommand(command, rest, global);
}
