// clients/cli/commands/subcommands.h: the subcommands of `gearloop`, one file
// per resource of the API (internal to the CLI). Each command is its option
// spec (with the --help text) and a function that runs it on parsed arguments;
// the dispatcher (clients/cli/commands.cc) lists them and parses the arguments.
//
//   ParsedArgs parsed;                    // checked against kSubmit
//   int code = RunSubmit(parsed, &client, global);
//
// Each Run* prints a table for a person or (--json) the server's JSON for a
// script, sends diagnostics to stderr, and returns an ExitCode (commands.h).
#ifndef GEARLOOP_CLIENTS_CLI_COMMANDS_SUBCOMMANDS_H_
#define GEARLOOP_CLIENTS_CLI_COMMANDS_SUBCOMMANDS_H_

#include <nlohmann/json.hpp>

#include "clients/cli/api_client.h"
#include "clients/cli/command_util.h"
#include "clients/cli/commands.h"

namespace gearloop {
namespace cli_internal {

// commands/corrections.cc: compute a correction and store it as a job.
extern const CommandSpec kSubmit;
int RunSubmit(const ParsedArgs& args,
              ApiClient* client,
              const GlobalOptions& global);
// The request of submit or correct, with --settings-from, --residual-csv and
// --settings-out of `args`, sent and printed.
int SubmitCorrectionRequest(ApiClient* client,
                            nlohmann::json request,
                            const ParsedArgs& args,
                            const GlobalOptions& global);
extern const CommandSpec kReplay;
int RunReplay(const ParsedArgs& args,
              ApiClient* client,
              const GlobalOptions& global);

// commands/history.cc: the stored jobs.
extern const CommandSpec kList;
int RunList(const ParsedArgs& args,
            ApiClient* client,
            const GlobalOptions& global);
extern const CommandSpec kShow;
int RunShow(const ParsedArgs& args,
            ApiClient* client,
            const GlobalOptions& global);
extern const CommandSpec kReport;
int RunReport(const ParsedArgs& args,
              ApiClient* client,
              const GlobalOptions& global);

// commands/batches.cc: a folder of measurements as one batch.
extern const CommandSpec kBatch;
int RunBatch(const ParsedArgs& args,
             ApiClient* client,
             const GlobalOptions& global);

// commands/simulations.cc: the simulated measuring machine and closed loop of a
// gear grinder.
extern const CommandSpec kSimulate;
int RunSimulate(const ParsedArgs& args,
                ApiClient* client,
                const GlobalOptions& global);
extern const CommandSpec kClosedLoop;
int RunClosedLoop(const ParsedArgs& args,
                  ApiClient* client,
                  const GlobalOptions& global);

// commands/bevel.cc: spiral-bevel pinions on the free-form generator.
extern const CommandSpec kBevelConvert;
int RunBevelConvert(const ParsedArgs& args,
                    ApiClient* client,
                    const GlobalOptions& global);
extern const CommandSpec kBevelClosedLoop;
int RunBevelClosedLoop(const ParsedArgs& args,
                       ApiClient* client,
                       const GlobalOptions& global);

// commands/split_bevel.cc: split bevel wheels milled on a head-head 5-axis
// machine.
extern const CommandSpec kSplitTrajectory;
int RunSplitTrajectory(const ParsedArgs& args,
                       ApiClient* client,
                       const GlobalOptions& global);
// The derived data and the per-pass table of a split-trajectory result (the
// POST answer or a stored job's "result"); `gearloop show` uses it too.
void PrintSplitTrajectory(const nlohmann::json& result);

// commands/grinder.cc: the grinder model without a correction.
extern const CommandSpec kNominal;
int RunNominal(const ParsedArgs& args,
               ApiClient* client,
               const GlobalOptions& global);
extern const CommandSpec kEvaluate;
int RunEvaluate(const ParsedArgs& args,
                ApiClient* client,
                const GlobalOptions& global);

// commands/measurements.cc: gear measuring machines' files (.mka, GDE).
extern const CommandSpec kImport;
int RunImport(const ParsedArgs& args,
              ApiClient* client,
              const GlobalOptions& global);
extern const CommandSpec kCorrect;
int RunCorrect(const ParsedArgs& args,
               ApiClient* client,
               const GlobalOptions& global);
extern const CommandSpec kExport;
int RunExport(const ParsedArgs& args,
              ApiClient* client,
              const GlobalOptions& global);
// commands/shaving.cc: the plunge-shaving cutter target.
extern const CommandSpec kShavingTarget;
int RunShavingTarget(const ParsedArgs& args,
                     ApiClient* client,
                     const GlobalOptions& global);

// commands/history.cc: the settings lineage of a job.
extern const CommandSpec kLineage;
int RunLineage(const ParsedArgs& args,
               ApiClient* client,
               const GlobalOptions& global);
// commands/bevel.cc: the bevel generator's axes ranked by flank error.
extern const CommandSpec kBevelSensitivity;
int RunBevelSensitivity(const ParsedArgs& args,
                        ApiClient* client,
                        const GlobalOptions& global);

// commands/reach.cc: the share of a target the machine can make.
extern const CommandSpec kReach;
int RunReach(const ParsedArgs& args,
             ApiClient* client,
             const GlobalOptions& global);

// commands/settings.cc: the machine-ready settings listing of a job.
extern const CommandSpec kSettings;
int RunSettings(const ParsedArgs& args,
                ApiClient* client,
                const GlobalOptions& global);

// commands/health.cc: whether the server is up.
extern const CommandSpec kHealth;
int RunHealth(const ParsedArgs& args,
              ApiClient* client,
              const GlobalOptions& global);

}  // namespace cli_internal
}  // namespace gearloop

#endif  // GEARLOOP_CLIENTS_CLI_COMMANDS_SUBCOMMANDS_H_
