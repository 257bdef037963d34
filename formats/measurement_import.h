// formats/measurement_import.h: a measuring-machine file -> the deviation grid,
// its ISO 1328-1 figures and classes (METROLOGY.md §2 and §4): read (mka or
// GDE), cross-check the header with the request's gear, interpolate the traces,
// evaluate.
//
//   MeasurementImportOptions options;
//   options.format = MeasurementFormat::kMka;
//   options.flank = Flank::kRight;
//   MeasurementImportResult result = ImportMeasurementFile(options, gear,
//   content); if (!result.ok) return Refuse(result.error.too_large ? 413 : 422,
//   result.error); result.grid.deviations_um;  result.figures;  result.classes;
//   result.warnings;
//
// Nothing here throws on any content; a refusal names the file line or element
// path.
#ifndef GEARLOOP_FORMATS_MEASUREMENT_IMPORT_H_
#define GEARLOOP_FORMATS_MEASUREMENT_IMPORT_H_

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "engine/grinder/grinding_setup.h"
#include "engine/metrology/iso1328.h"
#include "engine/metrology/trace_grid.h"
#include "formats/gde.h"
#include "formats/measurement_file.h"

namespace gearloop {

struct MeasurementImportOptions {
  MeasurementFormat format = MeasurementFormat::kMka;
  // The grid's flank and the tooth (0 = mean of all teeth of the flank).
  Flank flank = Flank::kRight;
  int tooth = 0;
  // Datum face; unset = the file's own (GDE) or x_negative. Set and
  // contradicting the file: the option wins and a warning says so.
  std::optional<DatumFace> datum_face;
  TraceSignFactors sign;
  GridOptions grid;
  // GDE: which nets to read (an export holds measured, target and predicted).
  std::string gde_topography_kind = "measured";
  // Header values may differ from the request by this much before the file is
  // refused: lengths [mm], angles [deg].
  double length_tolerance_mm = 1e-3;
  double angle_tolerance_deg = 1e-3;
  double class_resolution_um = 0.01;
};

struct MeasurementImportResult {
  bool ok = false;
  FileError error;
  MeasurementFile file;
  TraceGridResult grid;
  Iso1328Options iso_options;
  FlankFigures figures;
  AccuracyClasses classes;
  // Crossing mismatch, header vs request (tip/root diameter, helix hand), datum
  // face, ISO range.
  std::vector<std::string> warnings;
};

MeasurementImportResult ImportMeasurementFile(
    const MeasurementImportOptions& options,
    const GearData& gear,
    std::string_view content);

}  // namespace gearloop

#endif  // GEARLOOP_FORMATS_MEASUREMENT_IMPORT_H_
