// server/codec/measurement_codec.h: measuring-machine files in JSON requests
// (POST /api/v1/measurements/import, "measurement": {"file": ...} of a
// correction) and the grid, ISO 1328-1 figures and classes written back
// (METROLOGY.md §2, §4). Pure mapping: the service reads the file
// (formats/measurement_import.h) and computes the figures (engine/metrology).
//
//   MeasurementImportRequest request;
//   ApiError error;
//   if (!ParseMeasurementImportRequest(body, &request, &error))
//     return RespondError(res, error);
//
// Request fields of a file (API names):
//   format        "mka" (Klingelnberg P-series curve file) | "gde" (VDI/VDE
//                 2610 XML)
//   content       the file's text (UTF-8; Latin-1 bytes arrive as their UTF-8
//                 code points)
//   tooth         the tooth to use; absent or 0 = the pointwise mean of every
//                 tooth of the flank
//   datum_face    "x_negative" | "x_positive"; absent = the file's own (GDE)
//                 or x_negative
//   sign_factors  {"profile_right", "profile_left", "helix_right",
//                 "helix_left"}: +1 or -1 each (default +1), for software
//                 that stores raw curves with the other sign
#ifndef GEARLOOP_SERVER_CODEC_MEASUREMENT_CODEC_H_
#define GEARLOOP_SERVER_CODEC_MEASUREMENT_CODEC_H_

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "engine/grinder/grinding_setup.h"
#include "engine/metrology/iso1328.h"
#include "engine/metrology/trace_grid.h"
#include "server/codec/json_read.h"

namespace gearloop {

// A measuring-machine file as a request carries it.
struct MeasurementFileRequest {
  std::string format;   // "mka" | "gde"
  std::string content;  // the file's text
  int tooth = 0;        // 0 = mean of all teeth of the flank
  std::optional<DatumFace> datum_face;
  TraceSignFactors sign;
};

// POST /api/v1/measurements/import: the gear the file is about (the request's
// gear is authoritative, the file's header is cross-checked), the grid to map
// it onto and the flank.
struct MeasurementImportRequest {
  GearData gear;
  GridOptions grid;
  Flank flank = Flank::kRight;
  MeasurementFileRequest file;
};

// Reads format, content, tooth, datum_face and sign_factors of the object at
// `path` ("" for the import body, "measurement.file" for a correction).
bool ParseMeasurementFileRequest(const nlohmann::json& object,
                                 const std::string& path,
                                 MeasurementFileRequest* file,
                                 ApiError* error);

// Reads gear, grid, flank and the file fields of an import body.
bool ParseMeasurementImportRequest(const nlohmann::json& body,
                                   MeasurementImportRequest* request,
                                   ApiError* error);

// True when body.measurement is an object holding "file" (a correction
// that takes a measuring-machine file instead of a grid).
bool HasMeasurementFile(const nlohmann::json& body);

// The figures of one flank as the API names them (METROLOGY.md §4), in um
// except the two evaluation lengths and grid extents [mm]; NaN as null.
nlohmann::json FlankFiguresToJson(const FlankFigures& figures);
// {"fHa", "ffa", "Fa", "fHb", "ffb", "Fb", "overall"}: 1..11, null = worse
// than 11.
nlohmann::json AccuracyClassesToJson(const AccuracyClasses& classes);
// {"figures", "classes"} of one flank; {"figures": null, "classes": null,
// "message"} when the figures could not be formed.
nlohmann::json FlankQualityToJson(const FlankFigures& figures,
                                  const AccuracyClasses& classes);

// The answer of POST /api/v1/measurements/import: deviations_um (rows x
// columns), figures, classes, warnings, not_measured, teeth,
// tooth_spread_um, max_crossing_mismatch_um, profile_traces, helix_traces.
nlohmann::json MeasurementImportToJson(
    const TraceGridResult& grid,
    const FlankFigures& figures,
    const AccuracyClasses& classes,
    const std::vector<std::string>& warnings);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_CODEC_MEASUREMENT_CODEC_H_
