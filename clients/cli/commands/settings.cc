// clients/cli/commands/settings.cc: `gearloop settings ID`, the corrected
// settings of a stored job as the machine takes them (GET
// /api/v1/corrections/ID/settings; docs/settings-listing.md).
#include <iostream>
#include <string>

#include "clients/cli/command_util.h"
#include "clients/cli/commands/subcommands.h"
#include "clients/cli/grid_files.h"

namespace gearloop {
namespace cli_internal {

const CommandSpec kSettings{
    "settings",
    "usage: gearloop settings ID [--format table|csv|nc] [--samples N] "
    "[-o FILE]\n\n"
    "Prints the corrected machine settings of job ID (GET "
    "/api/v1/corrections/ID/settings):\n"
    "every coefficient of every axis absolute and changed with its unit, and "
    "each axis's\n"
    "position and change over the roll range (um for linear, urad for rotary "
    "axes).\n\n"
    "options:\n"
    "  --format F   table (default, for a person), csv (one record per line) "
    "or nc\n"
    "               (the parameter listing of docs/settings-listing.md)\n"
    "  --samples N  roll angles the axes are sampled at (2..1001, default "
    "9)\n"
    "  -o FILE      write to FILE instead of stdout\n",
    {"--format", "--samples", "--output"},
    {},
    1,
    1};

int RunSettings(const ParsedArgs& args,
                ApiClient* client,
                const GlobalOptions&) {
  long long id = 0;
  if (!ParseJobId(args.positional[0], &id)) {
    std::cerr << "gearloop settings: '" << args.positional[0]
              << "' is not a job id\n";
    return kExitUsage;
  }
  const std::string format =
      args.Has("--format") ? args.Value("--format") : "table";
  if (format != "table" && format != "csv" && format != "nc") {
    std::cerr << "gearloop settings: --format takes table, csv or nc\n";
    return kExitUsage;
  }
  std::string path = "/api/v1/corrections/" + std::to_string(id) +
                     "/settings?format=" + format;
  if (args.Has("--samples")) {
    long long samples = 0;
    if (!ParseCount(args.Value("--samples"), 2, 1001, &samples)) {
      std::cerr << "gearloop settings: --samples takes 2 to 1001\n";
      return kExitUsage;
    }
    path += "&samples=" + std::to_string(samples);
  }
  const ApiResponse answer = client->Get(path);
  if (!answer.transport_error.empty() || answer.IsApiError())
    return CheckAnswer(answer);
  const bool listing =
      answer.text.find("gearloop settings listing") != std::string::npos ||
      answer.text.rfind("record,", 0) == 0;
  if (!answer.ok() || !listing) {
    std::cerr << "gearloop: unexpected answer " << answer.status
              << " from the server\n";
    return kExitTransport;
  }
  if (!args.Has("--output")) {
    std::cout << answer.text;
    return kExitOk;
  }
  std::string error;
  if (!WriteTextFile(args.Value("--output"), answer.text, &error))
    return InputError(error);
  std::cerr << "wrote " << args.Value("--output") << "\n";
  return kExitOk;
}

}  // namespace cli_internal
}  // namespace gearloop
