// clients/cli/commands.cc: the dispatcher of the `gearloop` subcommands: the
// command table (in the order `gearloop --help` lists it), the main help text,
// and the parsing of a subcommand's options against its spec. The subcommands
// live one file per resource in commands/ (subcommands.h); what they share is
// in command_util.h.
#include "clients/cli/commands.h"

#include <iomanip>
#include <iostream>
#include <optional>
#include <sstream>

#include "clients/cli/api_client.h"
#include "clients/cli/command_util.h"
#include "clients/cli/commands/subcommands.h"

namespace gearloop {
namespace cli_internal {
namespace {

bool UsageError(const CommandSpec& spec, const std::string& message) {
  std::cerr << "gearloop " << spec.name << ": " << message << "\n"
            << "Try 'gearloop " << spec.name << " --help'.\n";
  return false;
}

// Accepts "--name value" and "--name=value". Returns false after printing a
// usage error.
bool ParseArgs(const CommandSpec& spec,
               const std::vector<std::string>& args,
               ParsedArgs* parsed) {
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
  if (n > spec.max_positional)
    return UsageError(
        spec, "unexpected argument '" + parsed->positional[n - 1] + "'");
  return true;
}

struct Command {
  const CommandSpec* spec;
  int (*run)(const ParsedArgs&, ApiClient*, const GlobalOptions&);
  const char* summary;
};

const std::vector<Command>& Commands() {
  static const std::vector<Command> commands = {
      {&kSubmit,
       RunSubmit,
       "compute and store a correction from a request and a measurement file"},
      {&kList, RunList, "list stored jobs, newest first"},
      {&kShow, RunShow, "show one job, or export one of its grids as CSV"},
      {&kReplay,
       RunReplay,
       "re-run a stored measurement with changed options or target"},
      {&kBatch,
       RunBatch,
       "correct every measurement file of a folder as one batch"},
      {&kSimulate,
       RunSimulate,
       "simulate a CMM measurement of a machine with hidden errors"},
      {&kClosedLoop, RunClosedLoop, "simulate grind-measure-correct loops"},
      {&kBevelConvert,
       RunBevelConvert,
       "convert a bevel pinion's cradle summary to free-form axis motions"},
      {&kBevelClosedLoop,
       RunBevelClosedLoop,
       "simulate cut-measure-correct loops of a bevel pinion"},
      {&kSplitTrajectory,
       RunSplitTrajectory,
       "5-axis milling trajectory and NC program of a split bevel wheel"},
      {&kReport, RunReport, "write a printable HTML report of a job"},
      {&kNominal, RunNominal, "print the nominal machine settings of a setup"},
      {&kEvaluate,
       RunEvaluate,
       "print the flank that given settings grind, on the grid"},
      {&kHealth, RunHealth, "check that the server is up"},
      {&kImport,
       RunImport,
       "read a measuring machine's file (.mka, GDE) with its ISO 1328 figures"},
      {&kCorrect,
       RunCorrect,
       "compute and store a correction from a measuring machine's file"},
      {&kExport, RunExport, "write a stored job as a GDE file"},
      {&kShavingTarget,
       RunShavingTarget,
       "compute the plunge-shaving cutter target of a modified work gear"},
      {&kSettings,
       RunSettings,
       "print a job's corrected settings for the machine (table, csv, nc)"},
      {&kReach,
       RunReach,
       "tell how much of a target the machine can make, before grinding"},
      {&kLineage,
       RunLineage,
       "list the settings lineage of a job (ground with whose settings)"},
      {&kBevelSensitivity,
       RunBevelSensitivity,
       "rank a bevel generator's axes by the flank error their errors cause"},
  };
  return commands;
}

}  // namespace
}  // namespace cli_internal

namespace {

using cli_internal::Command;
using cli_internal::Commands;
using cli_internal::ParseArgs;
using cli_internal::ParsedArgs;

}  // namespace

std::string MainHelp() {
  std::ostringstream out;
  out << "usage: gearloop [--server URL] [--token T] [--json] [--timeout S] "
         "COMMAND [ARGS]\n\n"
         "Command-line client of the gearloop server: closed-loop correction "
         "of gear grinding.\n\n"
         "commands:\n";
  for (const Command& c : Commands())
    out << "  " << std::left << std::setw(19) << c.spec->name << c.summary
        << "\n";
  out << "\nglobal options (anywhere on the line):\n"
         "  --server URL   server base URL (default $GEARLOOP_SERVER or "
         "http://127.0.0.1:8080)\n"
         "  --token T      send \"Authorization: Bearer T\" (default "
         "$GEARLOOP_TOKEN)\n"
         "  --json         print the server's JSON instead of tables\n"
         "  --timeout S    seconds for connecting and each read (default 120)\n"
         "  --help         this text; `gearloop COMMAND --help` for a command\n"
         "  --version      the client's version\n\n"
         "exit codes:\n"
         "  0  done, and the outcome is good\n"
         "  1  wrong arguments or options\n"
         "  2  server not reachable, timed out, answered 5xx or not the API\n"
         "  3  the server refused the request (4xx; the message names the "
         "field)\n"
         "  4  a local file could not be read or is invalid (the message names "
         "line and column)\n"
         "  5  done, but a correction did not converge, its predicted part "
         "misses the\n"
         "     job's tolerance (target_partly_reachable), a closed loop "
         "diverged or batch\n"
         "     items failed\n\n"
         "files: CSV grids and JSON measurement files are described in "
         "clients/FORMATS.md.\n";
  return out.str();
}

int RunCommand(const std::string& name,
               const std::vector<std::string>& args,
               const GlobalOptions& global) {
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
  std::cerr << "gearloop: unknown command '" << name
            << "'\nTry 'gearloop --help'.\n";
  return kExitUsage;
}

}  // namespace gearloop
