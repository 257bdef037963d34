// clients/cli/commands/health.cc: `gearloop health` (GET /healthz).
#include <iostream>

#include "clients/cli/command_util.h"
#include "clients/cli/commands/subcommands.h"

namespace gearloop {
namespace cli_internal {

const CommandSpec kHealth{
    "health",
    "usage: gearloop health\n\n"
    "Asks the server whether it is up (GET /healthz) and prints its version.\n"
    "Exit 0 when it answers \"ok\", 2 when it cannot be reached.\n",
    {},
    {},
    0,
    0};

int RunHealth(const ParsedArgs&,
              ApiClient* client,
              const GlobalOptions& global) {
  const ApiResponse answer = client->Get("/healthz");
  const int failure = CheckAnswer(answer);
  if (failure >= 0) return failure;
  if (global.json) {
    PrintJson(answer.body);
  } else {
    std::cout << "server " << Member(answer.body, "status") << ", version "
              << Member(answer.body, "version") << "\n";
  }
  return answer.body.value("status", "") == "ok" ? kExitOk : kExitTransport;
}

}  // namespace cli_internal
}  // namespace gearloop
