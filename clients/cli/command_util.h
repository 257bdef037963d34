// clients/cli/command_util.h: what the subcommands of `gearloop` share
// (internal to the CLI): the option spec and parsed arguments of a subcommand,
// number parsing, table output, the mapping of an answer to an exit code, and
// the request and output steps that more than one command file uses (a
// correction request from files, a correction summary, a closed loop).
//
//   const ApiResponse answer = client->Get("/api/v1/corrections/" +
//   std::to_string(id)); const int failure = CheckAnswer(answer);   // -1 when
//   the answer is fine if (failure >= 0) return failure;
//   PrintCorrectionSummary(answer.body);
#ifndef GEARLOOP_CLIENTS_CLI_COMMAND_UTIL_H_
#define GEARLOOP_CLIENTS_CLI_COMMAND_UTIL_H_

#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "clients/cli/api_client.h"
#include "clients/cli/commands.h"

namespace gearloop {
namespace cli_internal {

// --- Arguments
// -----------------------------------------------------------------------------------

// The options one subcommand takes: names that take a value, and flags.
struct CommandSpec {
  const char* name;
  std::string usage;  // the full --help text
  std::set<std::string> valued;
  std::set<std::string> flags;
  int min_positional;
  int max_positional;
};

struct ParsedArgs {
  std::vector<std::string> positional;
  std::map<std::string, std::vector<std::string>> values;
  std::set<std::string> flags;

  bool Has(const std::string& name) const {
    return values.count(name) > 0 || flags.count(name) > 0;
  }
  std::string Value(const std::string& name,
                    const std::string& fallback = "") const {
    auto it = values.find(name);
    return it == values.end() ? fallback : it->second.back();
  }
};

// An integer in full within [min, max]; false for anything else.
bool ParseCount(const std::string& text,
                long long min,
                long long max,
                long long* value);

// A number in full ("0.5", "-3e-3"); false for anything else.
bool ParseNumber(const std::string& text, double* value);

// A job id: an integer in 1..2^53.
bool ParseJobId(const std::string& text, long long* id);

// --- Output
// --------------------------------------------------------------------------------------

// A number with `digits` decimals; "-" for anything else.
std::string Fixed(const nlohmann::json& value, int digits = 3);
// A string as it is, null as "-", anything else as JSON.
std::string Text(const nlohmann::json& value);
// Text(object[key]); "-" when there is no such member.
std::string Member(const nlohmann::json& object, const char* key);

// A grid as a table with the tip at the top, the way the flank is drawn (and
// the dashboard shows it): profile rows down the side, lead columns across.
void PrintGrid(const std::string& title, const nlohmann::json& grid);

void PrintJson(const nlohmann::json& value);

// Maps an answer to an exit code and prints its error. Returns -1 when the
// answer is fine.
int CheckAnswer(const ApiResponse& answer);

// Prints "gearloop: <message>" and returns kExitInput.
int InputError(const std::string& message);

// A text answer (a listing, an export, a report) to standard output, or with
// --output FILE to that file ("wrote FILE" on standard error). Returns the
// exit code.
int PrintOrWriteText(const ParsedArgs& args, const std::string& text);

// --- Corrections (submit, replay, batch, show)
// ---------------------------------------------------

// The summary of a correction job (the answer of POST /api/v1/corrections or
// GET /api/v1/corrections/{id}): status, deviation before and after, solver,
// regularisation, machine state, the predicted residual grid and the axis
// motion.
void PrintCorrectionSummary(const nlohmann::json& answer);

// The members of `object` named in `keys`, the others left out: the server
// refuses keys its operation does not take (strict input), so a command that
// reads the setup of a correction request file (nominal, evaluate) or a
// closed-loop scenario (simulate) sends only what its operation takes.
nlohmann::json OnlyKeys(const nlohmann::json& object,
                        const std::vector<std::string>& keys);

// The setup keys of the grinder's own operations (nominal, evaluate).
extern const std::vector<std::string> kGrinderSetupKeys;

// "FAIL/PASS": the verdicts of the measured and the predicted part of a
// result with a tolerance; "-" without one.
std::string VerdictCell(const nlohmann::json& result);

// Builds a correction request from the files (an empty `measurement_path`
// leaves the measurement to the caller); returns -1 when done, or an exit
// code.
int BuildCorrectionRequest(const std::string& request_path,
                           const std::string& measurement_path,
                           const ParsedArgs& args,
                           nlohmann::json* request);

// The trace options of submit and correct (--part-number, --serial, --teeth,
// --measured-at, --machine-id, --file-name), as the help lists them.
extern const char* const kTraceOptionsHelp;

// Writes the trace options into request.trace (over a trace of the request
// file); --file-name defaults to the measuring file's name when
// `measurement_path` is a machine's file. Returns -1, or the usage exit code
// after printing the reason.
int ApplyTraceOptions(const std::string& command,
                      const ParsedArgs& args,
                      const std::string& machine_file_path,
                      nlohmann::json* request);

// With --settings-from ID and no "settings" in the request file, the part was
// ground with job ID's corrected settings: fetch them (once; `cache` keeps them
// for the items of a batch) so the server corrects from where the machine
// really was. Returns -1, or an exit code.
int FillSourceSettings(ApiClient* client,
                       nlohmann::json* request,
                       nlohmann::json* cache);

// --- Simulations (simulate, closed-loop, bevel-closed-loop)
// --------------------------------------

// --seed N and --noise UM of a simulation scenario (simulate,
// bevel-closed-loop). Returns -1, or the usage exit code after printing the
// reason.
int ApplySeedAndNoise(const CommandSpec& spec,
                      const ParsedArgs& args,
                      nlohmann::json* scenario);

// --corrections N and --store of a closed loop (closed-loop,
// bevel-closed-loop). Returns -1, or the usage exit code after printing the
// reason.
int ApplyCorrectionsAndStore(const CommandSpec& spec,
                             const ParsedArgs& args,
                             nlohmann::json* scenario);

// Sends a closed-loop scenario and prints one line per part (or the JSON).
// `made` says how a part comes about ("ground", "cut"). Exit 5 when the loop
// stopped early.
int SendClosedLoop(ApiClient* client,
                   const nlohmann::json& scenario,
                   const char* made,
                   const GlobalOptions& global);

}  // namespace cli_internal
}  // namespace gearloop

#endif  // GEARLOOP_CLIENTS_CLI_COMMAND_UTIL_H_
