// server/services/measurement_service.h: measuring-machine files in and out
// (METROLOGY.md §2-§5): POST /api/v1/measurements/import, the
// "measurement": {"file": ...} of a correction, the ISO 1328-1 figures and
// classes every grinder correction result carries, and GET
// /api/v1/corrections/{id}/export?format=gde. Reading and writing the files is
// formats/ (measurement_import.h, gde.h), the figures engine/metrology; the
// JSON shapes are codec/measurement_codec.h.
//
//   ImportMeasurement(req, res);  // 200 {deviations_um, figures, classes, ...}
//
// A file the readers refuse is a 422 with code invalid_file, its field the
// request's content and its message naming the file line ("file:line 37: ...")
// or the element path ("/GDE/GEAR_DATA/.../P[12]/@dev: ..."); a file over the
// upload limit (4 MiB, formats/measurement_file.h) a 413. Nothing is stored.
#ifndef GEARLOOP_SERVER_SERVICES_MEASUREMENT_SERVICE_H_
#define GEARLOOP_SERVER_SERVICES_MEASUREMENT_SERVICE_H_

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <string>

#include "engine/grinder/grinding_setup.h"
#include "server/respond.h"
#include "server/services/service_context.h"

namespace gearloop {

// The ISO 1328-1 figures and classes (codec FlankQualityToJson) of a grid of
// `gear` on `grid`, on deviations - target when `target_um` is non-empty, with
// the profile evaluation length L_alpha of a measuring file (0 = the default
// 0.95 (L_a - L_form)).
nlohmann::json FlankQualityJson(const GearData& gear,
                                const GridOptions& grid,
                                const Eigen::VectorXd& deviations_um,
                                const Eigen::VectorXd& target_um,
                                double profile_evaluation_length_mm = 0.0);

// A correction body whose measurement is {"file": {...}}: reads the file onto
// the body's gear, grid and flank and returns the body with measurement
// {"deviations_um": grid} in `resolved`, and what the import reports
// ({"format", "warnings", "not_measured", "teeth", "max_crossing_mismatch_um",
// "profile_evaluation_length_mm"}: L_alpha of the file, null when it states
// none) in `file_report`. Only a flat-wheel grinder request has an involute
// gear to read a file for (422 otherwise).
bool ResolveMeasurementFile(const nlohmann::json& body,
                            nlohmann::json* resolved,
                            nlohmann::json* file_report,
                            ApiError* error);

// POST /api/v1/measurements/import.
void ImportMeasurement(const httplib::Request& req, httplib::Response& res);

// GET /api/v1/corrections/{id}/export?format=gde: the stored grinder job's
// gear data, its measured, target and predicted grids as GDE TOPOGRAPHY nets
// and the figures of the measured flank (relative to the target) in RESULTS.
void ExportCorrection(const ServiceContext& context,
                      const httplib::Request& req,
                      httplib::Response& res);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_SERVICES_MEASUREMENT_SERVICE_H_
