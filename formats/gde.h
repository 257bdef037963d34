// formats/gde.h: GDE (VDI/VDE 2610) XML in and out, through ONE table of
// element names.
//
//   MeasurementFile file;
//   FileError error;
//   if (!ReadGdeFile(content, GdeReadOptions{}, &file, &error)) return
//   Refuse(error);
//   // error.ToString():
//   "/GDE/GEAR_DATA/INSPECTION/MEASUREMENT_RESULTS/TOPOGRAPHY[1]/P[12]/@dev:
//   ..."
//
//   GdeExport out;   // gear, grid, the measured / target / predicted nets,
//   figures, classes std::string xml = WriteGde(out);
//
// Only the outline of the guideline is public (gear data: identification,
// geometry, inspection; a datum face fixes left and right). Every element and
// attribute name below the root is a placeholder of this project
// (shared/formats/README.md) and lives in GdeNames, so that the guideline's
// real names replace them without a code change: the reader and the writer read
// every name from the table they are given.
//
// A TOPOGRAPHY net (P elements with d, z, dev; rows of equal d, columns of
// equal z) is the curve network of METROLOGY.md §2: each column a profile
// trace, each row a helix trace. Refused, with the element path: not XML or not
// well-formed; root not GDE; a number that does not parse, NaN/inf, a decimal
// comma; an unknown unit; a repeated single element; a net that is not full,
// has duplicate points or disagrees with its rows/columns attributes; an
// unknown flank.
#ifndef GEARLOOP_FORMATS_GDE_H_
#define GEARLOOP_FORMATS_GDE_H_

#include <Eigen/Core>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "engine/grinder/grinding_setup.h"
#include "engine/metrology/iso1328.h"
#include "engine/metrology/trace_grid.h"
#include "formats/measurement_file.h"

namespace gearloop {

// The mapping table. Paths are relative to the root and separated by '/'.
struct GdeNames {
  std::string root = "GDE";
  std::string version_attribute = "version";
  std::string drawing_number = "GEAR_DATA/IDENTIFICATION/drawing_number";
  std::string teeth = "GEAR_DATA/GEOMETRY/BASIC_GEOMETRY/number_of_teeth";
  std::string normal_module = "GEAR_DATA/GEOMETRY/BASIC_GEOMETRY/normal_module";
  std::string normal_pressure_angle =
      "GEAR_DATA/GEOMETRY/BASIC_GEOMETRY/normal_pressure_angle";
  std::string helix_angle = "GEAR_DATA/GEOMETRY/BASIC_GEOMETRY/helix_angle";
  std::string helix_direction =
      "GEAR_DATA/GEOMETRY/BASIC_GEOMETRY/helix_direction";
  std::string face_width = "GEAR_DATA/GEOMETRY/BASIC_GEOMETRY/face_width";
  std::string tip_diameter = "GEAR_DATA/GEOMETRY/BASIC_GEOMETRY/tip_diameter";
  std::string root_diameter = "GEAR_DATA/GEOMETRY/BASIC_GEOMETRY/root_diameter";
  std::string datum_face = "GEAR_DATA/GEOMETRY/BASIC_GEOMETRY/datum_face";
  std::string tolerance_standard = "GEAR_DATA/GEOMETRY/TOLERANCES/standard";
  std::string tolerance_class = "GEAR_DATA/GEOMETRY/TOLERANCES/tolerance_class";
  std::string profile_evaluation_range =
      "GEAR_DATA/INSPECTION/MEASURING_CONDITIONS/profile_evaluation_range";
  std::string helix_evaluation_range =
      "GEAR_DATA/INSPECTION/MEASURING_CONDITIONS/helix_evaluation_range";
  std::string deviation_sign =
      "GEAR_DATA/INSPECTION/MEASURING_CONDITIONS/deviation_sign";
  std::string measurement_results = "GEAR_DATA/INSPECTION/MEASUREMENT_RESULTS";
  std::string results = "GEAR_DATA/INSPECTION/RESULTS";
  // Children of measurement_results, and their attributes.
  std::string topography = "TOPOGRAPHY";
  std::string topography_tooth = "tooth";
  std::string topography_flank = "flank";
  std::string topography_kind = "kind";
  std::string topography_rows = "rows";
  std::string topography_columns = "columns";
  std::string length_unit_attribute = "length_unit";
  std::string deviation_unit_attribute = "deviation_unit";
  std::string point = "P";
  std::string point_diameter = "d";
  std::string point_axial = "z";
  std::string point_deviation = "dev";
  // Attributes of the range elements, and the unit attribute of a value
  // element.
  std::string range_from = "from";
  std::string range_to = "to";
  std::string unit_attribute = "unit";
  // Values.
  std::string flank_right = "right";
  std::string flank_left = "left";
  std::string datum_x_negative = "x_negative";
  std::string datum_x_positive = "x_positive";
  std::string hand_right = "right";
  std::string hand_left = "left";
  std::string hand_spur = "spur";
  std::string sign_material_positive = "material_positive";
  std::string sign_material_negative = "material_negative";
};

// The names of the sample (shared/formats/sample_topography.gde.xml).
const GdeNames& DefaultGdeNames();

struct GdeReadOptions {
  // Which TOPOGRAPHY nets to read, by their kind attribute (a net without one
  // counts as "measured"): an export holds measured, target and predicted nets.
  std::string topography_kind = "measured";
};

bool ReadGdeFile(std::string_view content,
                 const GdeReadOptions& options,
                 MeasurementFile* file,
                 FileError* error,
                 const GdeNames& names = DefaultGdeNames());

// One net to write: the grid's values at its points (NaN points are left out; a
// net with one is not full and its re-import is refused).
struct GdeTopography {
  std::string kind = "measured";  // measured | target | predicted
  int tooth = 1;
  Eigen::VectorXd deviations_um;  // row-major on `grid`
};

struct GdeExport {
  GearData gear;
  GridOptions grid;
  Flank flank = Flank::kRight;
  DatumFace datum_face = DatumFace::kXNegative;
  std::string drawing_number;
  std::vector<GdeTopography> topographies;
  // RESULTS: the figures of METROLOGY.md §4 and their classes, when given.
  std::optional<FlankFigures> figures;
  std::optional<AccuracyClasses> classes;
};

// GDE XML of `data`: gear data, the evaluation ranges (the grid's extent as
// d1..d2 and z), the nets at the grid points (d = 2 sqrt(L^2 + r_b^2), z from
// the datum face) and RESULTS.
std::string WriteGde(const GdeExport& data,
                     const GdeNames& names = DefaultGdeNames());

}  // namespace gearloop

#endif  // GEARLOOP_FORMATS_GDE_H_
