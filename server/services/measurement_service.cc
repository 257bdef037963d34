#include "server/services/measurement_service.h"

#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <utility>
#include <vector>

#include "engine/metrology/iso1328.h"
#include "formats/gde.h"
#include "formats/measurement_import.h"
#include "server/codec/grinder_codec.h"
#include "server/codec/machine_kind.h"
#include "server/codec/measurement_codec.h"
#include "server/codec/request_keys.h"
#include "server/services/stored_job.h"

// Last: see server/respond.h.
#include <httplib.h>

namespace gearloop {
namespace {

const char* FlankWord(Flank flank) {
  return flank == Flank::kRight ? "right" : "left";
}

// When the file holds traces of one flank only and it is not the one that
// lands on the request's `flank` (through the datum face: the request's, else
// the file's own, else x_negative, as the import takes it), what to say:
// "the file measures the left flank, the request corrects the right flank".
// "" when the file has the flank (or no traces at all: the reader said why).
std::string FileFlankMismatch(Flank flank,
                              const MeasurementFileRequest& file,
                              const MeasurementImportResult& result) {
  const MeasurementFile& read = result.file;
  if (read.traces.empty()) return "";
  const DatumFace datum = file.datum_face.value_or(
      read.header.datum_face.value_or(DatumFace::kXNegative));
  Flank wanted = flank;
  if (datum == DatumFace::kXPositive)
    wanted = flank == Flank::kRight ? Flank::kLeft : Flank::kRight;
  for (const MeasuredTrace& trace : read.traces)
    if (trace.flank == wanted) return "";
  // Every trace is of the other flank (the file's own naming).
  const Flank file_flank = read.traces.front().flank;
  std::string said =
      std::string("the file measures the ") + FlankWord(file_flank) + " flank";
  if (datum == DatumFace::kXPositive)
    said += " (seen from the x_positive datum face, the request's " +
            std::string(FlankWord(flank == Flank::kRight ? Flank::kLeft
                                                         : Flank::kRight)) +
            " flank)";
  return said + ", the request corrects the " + FlankWord(flank) +
         " flank: send the file of the " + FlankWord(flank) +
         " flank, or set \"flank\": \"" +
         FlankWord(flank == Flank::kRight ? Flank::kLeft : Flank::kRight) +
         "\" if the part was ground on that flank";
}

// Reads `file` onto the gear, grid and flank; the refusal names `path`.content
// (a file of the other flank only: `path`, or "flank" for the import body).
bool ReadMeasurementFile(const GearData& gear,
                         const GridOptions& grid,
                         Flank flank,
                         const MeasurementFileRequest& file,
                         const std::string& path,
                         MeasurementImportResult* result,
                         ApiError* error) {
  MeasurementImportOptions options;
  options.format =
      file.format == "gde" ? MeasurementFormat::kGde : MeasurementFormat::kMka;
  options.flank = flank;
  options.tooth = file.tooth;
  options.datum_face = file.datum_face;
  options.sign = file.sign;
  options.grid = grid;
  *result = ImportMeasurementFile(options, gear, file.content);
  if (result->ok) return true;
  const std::string field = JoinPath(path, "content");
  if (result->error.too_large) {
    *error = ApiError{413,
                      "payload_too_large",
                      "the " + file.format + " file has " +
                          std::to_string(file.content.size()) +
                          " bytes, more than the " +
                          std::to_string(kMaxMeasurementFileBytes) +
                          " bytes a measuring-machine file may have",
                      field};
  } else if (const std::string mismatch =
                 FileFlankMismatch(flank, file, *result);
             !mismatch.empty()) {
    *error =
        ApiError{422, "invalid_file", mismatch, path.empty() ? "flank" : path};
  } else {
    *error = ApiError{422, "invalid_file", result->error.ToString(), field};
  }
  return false;
}

// A stored grid of the result (null = missing, NaN here); empty when absent.
Eigen::VectorXd StoredGrid(const nlohmann::json& result,
                           const char* key,
                           int rows,
                           int columns) {
  if (!result.contains(key)) return Eigen::VectorXd();
  Eigen::VectorXd values;
  std::vector<bool> present;
  ApiError error;
  if (!ParseGridValues(result.at(key),
                       key,
                       rows,
                       columns,
                       /*allow_null=*/true,
                       &values,
                       &present,
                       &error)) {
    throw std::runtime_error("stored " + std::string(key) +
                             " is not a grid: " + error.message);
  }
  for (int i = 0; i < values.size(); ++i) {
    if (!present[i]) values[i] = std::numeric_limits<double>::quiet_NaN();
  }
  return values;
}

// The GDE export of a stored grinder job; false with the refusal.
bool BuildExport(const JobRecord& job, GdeExport* out, ApiError* error) {
  nlohmann::json request, result;
  ParseStoredJob(job, &request, &result);
  MachineKind kind = MachineKind::kFlatWheelGrinder;
  if (!ReadMachineKind(request, &kind, error) ||
      kind != MachineKind::kFlatWheelGrinder) {
    // About the job, not a field of the request.
    *error = InvalidValue("",
                          "job " + std::to_string(job.id) +
                              " is not a flat-wheel grinder job: only an "
                              "involute gear's flank is written as GDE");
    return false;
  }
  if (!ParseGearGridAndFlank(
          request, &out->gear, &out->grid, &out->flank, error)) {
    throw std::runtime_error("stored request of job " + std::to_string(job.id) +
                             " does not parse: " + error->message);
  }
  const int rows = out->grid.profile_points;
  const int columns = out->grid.lead_points;
  const Eigen::VectorXd measured =
      StoredGrid(result, "measured_um", rows, columns);
  const Eigen::VectorXd target = StoredGrid(result, "target_um", rows, columns);
  const Eigen::VectorXd predicted =
      StoredGrid(result, "predicted_residual_um", rows, columns);
  if (measured.size() == 0 || target.size() == 0) {
    *error = InvalidValue("",
                          "job " + std::to_string(job.id) +
                              " was stored before results kept the measured "
                              "and target grids; replay it to export it");
    return false;
  }
  out->drawing_number = "gearloop job " + std::to_string(job.id);
  out->topographies.push_back({"measured", 1, measured});
  out->topographies.push_back({"target", 1, target});
  if (predicted.size() > 0)
    out->topographies.push_back({"predicted", 1, predicted});
  // The L_alpha the result's figures used (a measuring file's own, or the
  // default).
  Iso1328Options iso;
  const nlohmann::json length =
      result.value("iso1328", nlohmann::json::object())
          .value("measured", nlohmann::json::object())
          .value("figures", nlohmann::json::object())
          .value("profile_evaluation_length_mm", nlohmann::json());
  if (length.is_number())
    iso.profile_evaluation_length_mm = length.get<double>();
  const FlankFigures figures =
      ComputeFlankFigures(iso, out->gear, out->grid, measured, target);
  if (figures.ok) {
    out->figures = figures;
    out->classes = ClassifyFlank(iso, out->gear, figures);
  }
  return true;
}

}  // namespace

nlohmann::json FlankQualityJson(const GearData& gear,
                                const GridOptions& grid,
                                const Eigen::VectorXd& deviations_um,
                                const Eigen::VectorXd& target_um,
                                double profile_evaluation_length_mm) {
  Iso1328Options options;
  options.profile_evaluation_length_mm = profile_evaluation_length_mm;
  const FlankFigures figures =
      ComputeFlankFigures(options, gear, grid, deviations_um, target_um);
  AccuracyClasses classes;
  if (figures.ok) classes = ClassifyFlank(options, gear, figures);
  return FlankQualityToJson(figures, classes);
}

bool ResolveMeasurementFile(const nlohmann::json& body,
                            nlohmann::json* resolved,
                            nlohmann::json* file_report,
                            ApiError* error) {
  MachineKind kind = MachineKind::kFlatWheelGrinder;
  if (!ReadMachineKind(body, &kind, error)) return false;
  if (kind != MachineKind::kFlatWheelGrinder) {
    *error = InvalidValue("measurement.file",
                          "a measuring-machine file is read onto an involute "
                          "gear's grid: only a flat-wheel grinder correction "
                          "takes measurement.file");
    return false;
  }
  const nlohmann::json& measurement = body.at("measurement");
  for (const auto& item : measurement.items()) {
    if (item.key() != "file") {
      *error = InvalidRequest("measurement." + item.key(),
                              "measurement takes \"file\" alone, or a grid");
      return false;
    }
  }
  const nlohmann::json* file_object = nullptr;
  GearData gear;
  GridOptions grid;
  Flank flank = Flank::kRight;
  MeasurementFileRequest file;
  if (!RequireObject(
          measurement, "measurement", "file", true, &file_object, error) ||
      !CheckKeys(*file_object,
                 "measurement.file",
                 {"format", "content", "tooth", "datum_face", "sign_factors"},
                 error) ||
      !ParseGearGridAndFlank(body, &gear, &grid, &flank, error) ||
      !ParseMeasurementFileRequest(
          *file_object, "measurement.file", &file, error)) {
    return false;
  }
  MeasurementImportResult imported;
  if (!ReadMeasurementFile(
          gear, grid, flank, file, "measurement.file", &imported, error))
    return false;
  *resolved = body;
  (*resolved)["measurement"] = {{"deviations_um",
                                 GridToJson(imported.grid.deviations_um,
                                            {},
                                            imported.grid.rows,
                                            imported.grid.columns)}};
  nlohmann::json report = MeasurementImportToJson(
      imported.grid, imported.figures, imported.classes, imported.warnings);
  *file_report = {
      {"format", file.format},
      {"warnings", report["warnings"]},
      {"not_measured", report["not_measured"]},
      {"teeth", report["teeth"]},
      {"max_crossing_mismatch_um", report["max_crossing_mismatch_um"]},
      {"profile_evaluation_length_mm",
       imported.iso_options.profile_evaluation_length_mm > 0.0
           ? nlohmann::json(imported.iso_options.profile_evaluation_length_mm)
           : nlohmann::json(nullptr)}};
  return true;
}

void ImportMeasurement(const httplib::Request& req, httplib::Response& res) {
  nlohmann::json body;
  MeasurementImportRequest request;
  ApiError error;
  if (!ParseJsonBody(req.body, &body, &error) ||
      !CheckRequestKeys(RequestSchema::kMeasurementImport, body, "", &error) ||
      !ParseMeasurementImportRequest(body, &request, &error))
    return RespondError(res, error);
  MeasurementImportResult imported;
  if (!ReadMeasurementFile(request.gear,
                           request.grid,
                           request.flank,
                           request.file,
                           "",
                           &imported,
                           &error))
    return RespondError(res, error);
  RespondJson(res,
              200,
              MeasurementImportToJson(imported.grid,
                                      imported.figures,
                                      imported.classes,
                                      imported.warnings));
}

void ExportCorrection(const ServiceContext& context,
                      const httplib::Request& req,
                      httplib::Response& res) {
  const std::optional<JobRecord> job = ReadPathJob(context, req);
  if (!job) return RespondError(res, NoStoredJob(req.matches[1].str()));
  if (!req.has_param("format")) {
    return RespondError(
        res,
        InvalidRequest("query.format",
                       "missing required query parameter format (gde)"));
  }
  if (req.get_param_value_count("format") > 1) {
    return RespondError(
        res, InvalidRequest("query.format", "query.format is given twice"));
  }
  if (req.get_param_value("format") != "gde") {
    return RespondError(
        res,
        InvalidValue("query.format",
                     "query.format must be \"gde\" (the only format written)"));
  }
  GdeExport out;
  ApiError error;
  if (!BuildExport(*job, &out, &error)) return RespondError(res, error);
  res.status = 200;
  res.set_header("Content-Disposition",
                 "attachment; filename=\"correction-" +
                     std::to_string(job->id) + ".gde.xml\"");
  res.set_content(WriteGde(out), "application/xml");
}

}  // namespace gearloop
