// clients/cli/commands/measurements.cc: gear measuring machines' files
// (METROLOGY.md): `gearloop import` (POST /api/v1/measurements/import),
// `gearloop correct --measurement-file` (POST /api/v1/corrections with
// "measurement": {"file": ...}) and `gearloop export` (GET
// /api/v1/corrections/ID/export?format=gde).
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>

#include "clients/cli/command_util.h"
#include "clients/cli/commands/subcommands.h"
#include "clients/cli/csv_grid.h"
#include "clients/cli/grid_files.h"

namespace gearloop {
namespace cli_internal {
namespace {

using nlohmann::json;

// True when `text` is valid UTF-8.
bool IsUtf8(const std::string& text) {
  size_t i = 0;
  while (i < text.size()) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    int follow = 0;
    if (c < 0x80) {
      follow = 0;
    } else if ((c & 0xE0) == 0xC0 && c >= 0xC2) {
      follow = 1;
    } else if ((c & 0xF0) == 0xE0) {
      follow = 2;
    } else if ((c & 0xF8) == 0xF0 && c <= 0xF4) {
      follow = 3;
    } else {
      return false;
    }
    if (i + follow >= text.size()) return false;
    for (int k = 1; k <= follow; ++k) {
      if ((static_cast<unsigned char>(text[i + k]) & 0xC0) != 0x80)
        return false;
    }
    i += follow + 1;
  }
  return true;
}

// The file's bytes as the JSON text the API takes: UTF-8 as it is, anything
// else read as Latin-1 (older P-series exports) and converted; the server
// refuses what is not text.
std::string FileText(const std::string& bytes) {
  if (IsUtf8(bytes)) return bytes;
  std::string out;
  out.reserve(bytes.size() + bytes.size() / 8);
  for (const char ch : bytes) {
    const unsigned char c = static_cast<unsigned char>(ch);
    if (c < 0x80) {
      out.push_back(ch);
    } else {
      out.push_back(static_cast<char>(0xC0 | (c >> 6)));
      out.push_back(static_cast<char>(0x80 | (c & 0x3F)));
    }
  }
  return out;
}

// {"format", "content", "tooth"?} of a measuring machine's file: the format
// from --format, else from the name (.mka; .xml or .gde). Returns -1 or an
// exit code.
int ReadMachineFile(const char* command,
                    const std::string& path,
                    const ParsedArgs& args,
                    json* file) {
  std::string format = args.Value("--format");
  if (format.empty()) {
    if (HasExtension(path, ".mka")) {
      format = "mka";
    } else if (HasExtension(path, ".xml") || HasExtension(path, ".gde")) {
      format = "gde";
    } else {
      std::cerr << "gearloop " << command << ": cannot tell the format of "
                << path
                << " from its name; give --format mka or --format gde\n";
      return kExitUsage;
    }
  }
  if (format != "mka" && format != "gde") {
    std::cerr << "gearloop " << command << ": --format takes mka or gde, got '"
              << format << "'\n";
    return kExitUsage;
  }
  std::string bytes;
  std::string error;
  if (!ReadTextFile(path, &bytes, &error)) return InputError(error);
  *file = {{"format", format}, {"content", FileText(bytes)}};
  if (args.Has("--tooth")) {
    long long tooth = 0;
    if (!ParseCount(args.Value("--tooth"), 0, 100000, &tooth)) {
      std::cerr << "gearloop " << command
                << ": --tooth takes a tooth number (0 = mean of all teeth)\n";
      return kExitUsage;
    }
    (*file)["tooth"] = tooth;
  }
  if (args.Has("--datum-face"))
    (*file)["datum_face"] = args.Value("--datum-face");
  return -1;
}

// The figures and classes of one flank as a table.
void PrintFigures(const json& figures, const json& classes) {
  struct Row {
    const char* label;
    const char* figure;
    const char* grid;
    const char* klass;
  };
  const Row rows[] = {
      {"f_Ha mean (slope)", "fHa_mean", "fHa_mean_grid", "fHa"},
      {"f_fa (form)", "ffa_max_abs", nullptr, "ffa"},
      {"F_a (total)", "Fa_max_abs", nullptr, "Fa"},
      {"C_a (crowning)", "Ca_mean", "Ca_mean_grid", nullptr},
      {"f_Hb mean (slope)", "fHb_mean", "fHb_mean_grid", "fHb"},
      {"f_fb (form)", "ffb_max_abs", nullptr, "ffb"},
      {"F_b (total)", "Fb_max_abs", nullptr, "Fb"},
      {"C_b (crowning)", "Cb_mean", "Cb_mean_grid", nullptr},
      {"twist S_a", "twist_alpha", "twist_alpha_grid", nullptr},
      {"twist S_b", "twist_beta", "twist_beta_grid", nullptr},
  };
  std::cout << "ISO 1328-1 [um]        value    (grid)  class\n";
  for (const Row& r : rows) {
    std::cout << std::left << std::setw(20) << r.label << std::right
              << std::setw(9) << Fixed(figures.value(r.figure, json()), 2)
              << std::setw(10)
              << (r.grid ? "(" + Fixed(figures.value(r.grid, json()), 2) + ")"
                         : std::string())
              << std::setw(7)
              << (r.klass ? Text(classes.value(r.klass, json())) : "") << "\n";
  }
  std::cout << std::left << std::setw(20) << "overall class" << std::right
            << std::setw(26) << Text(classes.value("overall", json())) << "\n";
}

}  // namespace

const CommandSpec kImport{
    "import",
    "usage: gearloop import FILE --setup REQUEST.json [options]\n\n"
    "Reads a gear measuring machine's file onto the deviation grid and judges "
    "it by ISO 1328-1\n"
    "(POST /api/v1/measurements/import; nothing is stored). FILE is a "
    "Klingelnberg P-series\n"
    "curve file (.mka) or GDE XML (.xml, .gde). REQUEST.json gives the gear "
    "(authoritative: the\n"
    "file's header must agree with it), the grid and the flank, as a "
    "correction request does.\n\n"
    "options:\n"
    "  --setup FILE        JSON with gear, and optionally grid and flank "
    "(required)\n"
    "  --format F          mka or gde (default: from FILE's name)\n"
    "  --flank F           right or left (default: the setup's, else right)\n"
    "  --tooth N           one tooth (default 0: the mean of all teeth of "
    "the flank)\n"
    "  --datum-face D      x_negative or x_positive (default: the file's, "
    "else x_negative)\n"
    "  --csv FILE          write the grid as CSV (for submit, or a "
    "spreadsheet)\n\n"
    "Exit 0 read, 3 the file or setup was refused (the message names the "
    "file line or\n"
    "element path), 4 a local file could not be read.\n",
    {"--setup", "--format", "--flank", "--tooth", "--datum-face", "--csv"},
    {},
    1,
    1};

int RunImport(const ParsedArgs& args,
              ApiClient* client,
              const GlobalOptions& global) {
  if (!args.Has("--setup")) {
    std::cerr << "gearloop import: --setup REQUEST.json is required (the "
                 "gear the file is about)\n";
    return kExitUsage;
  }
  json setup;
  std::string error;
  if (!ReadJsonFile(args.Value("--setup"), &setup, &error))
    return InputError(error);
  if (!setup.is_object())
    return InputError(args.Value("--setup") + ": must be a JSON object");
  json body;
  const int read = ReadMachineFile("import", args.positional[0], args, &body);
  if (read >= 0) return read;
  for (const char* key : {"gear", "grid", "flank"}) {
    if (setup.contains(key)) body[key] = setup[key];
  }
  if (args.Has("--flank")) body["flank"] = args.Value("--flank");
  const ApiResponse answer = client->Post("/api/v1/measurements/import", body);
  const int failure = CheckAnswer(answer);
  if (failure >= 0) return failure;
  if (args.Has("--csv")) {
    CsvGrid grid;
    if (JsonToCsvGrid(answer.body["deviations_um"], &grid) &&
        !WriteTextFile(
            args.Value("--csv"), FormatCsvGrid(grid, true), &error)) {
      return InputError(error);
    }
  }
  if (global.json) {
    PrintJson(answer.body);
    return kExitOk;
  }
  PrintGrid("measured flank", answer.body["deviations_um"]);
  std::cout << "\n";
  PrintFigures(answer.body.value("figures", json::object()),
               answer.body.value("classes", json::object()));
  for (const auto& warning : answer.body.value("warnings", json::array()))
    std::cout << "warning: " << Text(warning) << "\n";
  return kExitOk;
}

const CommandSpec kCorrect{
    "correct",
    "usage: gearloop correct REQUEST.json --measurement-file FILE "
    "[options]\n\n"
    "Computes a correction from a gear measuring machine's file and stores "
    "it as a job (POST\n"
    "/api/v1/corrections with \"measurement\": {\"file\": ...}): the server "
    "reads the file onto the\n"
    "request's grid, so the stored job keeps the file and a replay reads it "
    "again.\n"
    "REQUEST.json holds the setup as for submit.\n\n"
    "options:\n"
    "  --measurement-file FILE  .mka curve file or GDE XML (required)\n"
    "  --format F               mka or gde (default: from the file's name)\n"
    "  --tooth N                one tooth (default 0: the mean of all "
    "teeth)\n"
    "  --datum-face D           x_negative or x_positive\n"
    "  --target FILE            wanted topography: CSV grid or JSON "
    "{modifications:[...]}\n"
    "  --options FILE           JSON object of solver options, merged over "
    "REQUEST.json's\n"
    "  --settings-from ID       the part was ground with the corrected "
    "settings of job ID\n"
    "  --residual-csv FILE      write the predicted residual grid as CSV\n"
    "  --settings-out FILE      write the new machine settings as JSON\n"
    "(trace of the part, each optional:)\n" +
        std::string(kTraceOptionsHelp) +
        "\nExit 0 converged, 5 stored but not converged, 3 refused (the "
        "message names the field,\n"
        "the file line or the element path).\n",
    {"--measurement-file",
     "--format",
     "--tooth",
     "--datum-face",
     "--target",
     "--options",
     "--settings-from",
     "--residual-csv",
     "--settings-out",
     "--part-number",
     "--serial",
     "--teeth",
     "--measured-at",
     "--machine-id",
     "--file-name"},
    {},
    1,
    1};

int RunCorrect(const ParsedArgs& args,
               ApiClient* client,
               const GlobalOptions& global) {
  if (!args.Has("--measurement-file")) {
    std::cerr << "gearloop correct: --measurement-file FILE is required\n";
    return kExitUsage;
  }
  json request;
  int built = BuildCorrectionRequest(args.positional[0], "", args, &request);
  if (built >= 0) return built;
  json file;
  built =
      ReadMachineFile("correct", args.Value("--measurement-file"), args, &file);
  if (built >= 0) return built;
  request["measurement"] = {{"file", file}};
  built = ApplyTraceOptions(
      "correct", args, args.Value("--measurement-file"), &request);
  if (built >= 0) return built;
  return SubmitCorrectionRequest(client, request, args, global);
}

const CommandSpec kExport{
    "export",
    "usage: gearloop export ID --format gde [-o FILE]\n\n"
    "Writes stored job ID as a GDE (VDI/VDE 2610) XML file: the gear data, "
    "the measured,\n"
    "target and predicted grids and the ISO 1328-1 figures (GET "
    "/api/v1/corrections/ID/export).\n"
    "`gearloop import` reads it back.\n\n"
    "options:\n"
    "  --format F      gde (the only format written; required)\n"
    "  -o, --output F  the file to write (default: standard output)\n",
    {"--format", "--output"},
    {},
    1,
    1};

int RunExport(const ParsedArgs& args, ApiClient* client, const GlobalOptions&) {
  long long id = 0;
  if (!ParseJobId(args.positional[0], &id)) {
    std::cerr << "gearloop export: '" << args.positional[0]
              << "' is not a job id\n";
    return kExitUsage;
  }
  if (args.Value("--format") != "gde") {
    std::cerr << "gearloop export: give --format gde (the only format "
                 "written)\n";
    return kExitUsage;
  }
  const ApiResponse answer = client->Get(
      "/api/v1/corrections/" + std::to_string(id) + "/export?format=gde");
  if (!answer.transport_error.empty() || answer.IsApiError())
    return CheckAnswer(answer);
  if (!answer.ok() || answer.text.find("<GDE") == std::string::npos) {
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
