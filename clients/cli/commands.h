// clients/cli/commands.h: the subcommands of the `gearloop` command-line client
// and the exit codes scripts rely on. main.cc reads the global options and
// dispatches here.
//
//   GlobalOptions global;                 // --server, --token, --json,
//   --timeout int code = RunCommand("list", {"--limit", "5"}, global);
#ifndef GEARLOOP_CLIENTS_CLI_COMMANDS_H_
#define GEARLOOP_CLIENTS_CLI_COMMANDS_H_

#include <string>
#include <vector>

namespace gearloop {

// Exit codes (also printed by `gearloop --help`).
enum ExitCode : int {
  kExitOk = 0,     // done, and the outcome is good
  kExitUsage = 1,  // wrong arguments or options
  kExitTransport =
      2,  // server not reachable, timed out, 5xx or not speaking the API
  kExitApiError = 3,  // the server answered an API error (4xx: invalid request,
                      // not found, ...)
  kExitInput =
      4,  // a local file could not be read or is not a valid CSV/JSON file
  kExitNotConverged =
      5,  // done, but a correction did not converge or batch items failed
};

struct GlobalOptions {
  // Base URL of the server (--server, else $GEARLOOP_SERVER, else
  // http://127.0.0.1:8080).
  std::string server = "http://127.0.0.1:8080";
  // Bearer token (--token, else $GEARLOOP_TOKEN); empty = none.
  std::string token;
  // Print the server's JSON answers instead of tables (--json).
  bool json = false;
  // Seconds allowed for connecting and for each read/write (--timeout).
  int timeout_seconds = 120;
};

// The list shown by `gearloop --help`.
std::string MainHelp();

// Runs subcommand `name` with its arguments (global options already removed).
// Unknown subcommands are a usage error. "--help" in `args` prints the
// subcommand's help and returns 0.
int RunCommand(const std::string& name,
               const std::vector<std::string>& args,
               const GlobalOptions& global);

}  // namespace gearloop

#endif  // GEARLOOP_CLIENTS_CLI_COMMANDS_H_
