#include "formats/gde.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "formats/measurement_import.h"
#include "tests/formats/metrology_samples.h"

namespace gearloop {
namespace {

using testing::FormsOnGrid;
using testing::ReadSample;
using testing::SampleForms;
using testing::SampleGear;

std::string Replace(std::string s,
                    const std::string& from,
                    const std::string& to) {
  for (size_t at = s.find(from); at != std::string::npos;
       at = s.find(from, at + to.size()))
    s.replace(at, from.size(), to);
  return s;
}

TEST(ReadGdeFile, TheSampleNetIsElevenProfileAndSevenHelixTraces) {
  MeasurementFile file;
  FileError error;
  ASSERT_TRUE(ReadGdeFile(
      ReadSample("sample_topography.gde.xml"), GdeReadOptions{}, &file, &error))
      << error.ToString();
  ASSERT_EQ(file.traces.size(), 18u);
  EXPECT_EQ(file.traces[0].kind, TraceKind::kProfile);
  EXPECT_DOUBLE_EQ(file.traces[0].position_mm, 2.0);
  EXPECT_EQ(file.traces[0].abscissa_mm.size(), 7u);
  EXPECT_DOUBLE_EQ(file.traces[0].values_um[0], -15.934);
  EXPECT_EQ(file.traces[11].kind, TraceKind::kHelix);
  EXPECT_DOUBLE_EQ(file.traces[11].position_mm, 141.0);
  EXPECT_EQ(file.traces[11].values_um.size(), 11u);
  EXPECT_EQ(file.trace_places[0].element_path,
            "/GDE/GEAR_DATA/INSPECTION/MEASUREMENT_RESULTS/TOPOGRAPHY[1]");
  EXPECT_DOUBLE_EQ(file.header.teeth->value, 31);
  EXPECT_DOUBLE_EQ(file.header.normal_module_mm->value, 4.5);
  EXPECT_EQ(file.header.normal_module_mm->place.element_path,
            "/GDE/GEAR_DATA/GEOMETRY/BASIC_GEOMETRY/normal_module");
  EXPECT_EQ(file.header.datum_face, DatumFace::kXNegative);
  EXPECT_DOUBLE_EQ(file.header.profile_evaluation_begin_diameter_mm->value,
                   140.243);
}

// The element names come from one table: a file with other names reads with a
// table that says so.
TEST(ReadGdeFile, ElementNamesComeFromTheMappingTable) {
  std::string renamed = Replace(
      ReadSample("sample_topography.gde.xml"), "TOPOGRAPHY", "Topografie");
  renamed = Replace(
      Replace(renamed, "<P ", "<Punkt "), "normal_module", "NormalModul");
  MeasurementFile file;
  FileError error;
  EXPECT_FALSE(ReadGdeFile(renamed, GdeReadOptions{}, &file, &error));
  GdeNames names;
  names.topography = "Topografie";
  names.point = "Punkt";
  names.normal_module = "GEAR_DATA/GEOMETRY/BASIC_GEOMETRY/NormalModul";
  ASSERT_TRUE(ReadGdeFile(renamed, GdeReadOptions{}, &file, &error, names))
      << error.ToString();
  EXPECT_EQ(file.traces.size(), 18u);
  EXPECT_DOUBLE_EQ(file.header.normal_module_mm->value, 4.5);
  // And the writer writes them.
  GdeExport out;
  out.gear = SampleGear();
  out.topographies.push_back(
      {"measured", 1, FormsOnGrid(SampleForms(Flank::kRight), SampleGear())});
  const std::string xml = WriteGde(out, names);
  EXPECT_NE(xml.find("<Topografie "), std::string::npos);
  EXPECT_NE(xml.find("<Punkt "), std::string::npos);
  EXPECT_EQ(xml.find("<TOPOGRAPHY"), std::string::npos);
}

// METROLOGY.md §3: write -> read gives the same grid (0.001 um), for every net
// of an export.
TEST(WriteGde, RoundTripGivesTheSameGrids) {
  const GearData gear = SampleGear();
  const Eigen::VectorXd measured =
      FormsOnGrid(SampleForms(Flank::kRight), gear);
  const Eigen::VectorXd target =
      FormsOnGrid(testing::FlankForms{3.0, 6.0, 0, 0, 0, 0}, gear);
  const Eigen::VectorXd predicted = measured - target;
  for (DatumFace datum : {DatumFace::kXNegative, DatumFace::kXPositive}) {
    for (Flank flank : {Flank::kRight, Flank::kLeft}) {
      GdeExport out;
      out.gear = gear;
      out.flank = flank;
      out.datum_face = datum;
      out.drawing_number = "GL-31-45 <R&D>";
      out.topographies = {{"measured", 1, measured},
                          {"target", 1, target},
                          {"predicted", 1, predicted}};
      out.figures =
          ComputeFlankFigures(Iso1328Options{}, gear, GridOptions{}, measured);
      out.classes = ClassifyFlank(Iso1328Options{}, gear, *out.figures);
      const std::string xml = WriteGde(out);
      for (const auto& [kind, grid] :
           {std::make_pair("measured", measured),
            std::make_pair("target", target),
            std::make_pair("predicted", predicted)}) {
        MeasurementImportOptions options;
        options.format = MeasurementFormat::kGde;
        options.flank = flank;
        options.gde_topography_kind = kind;
        const MeasurementImportResult back =
            ImportMeasurementFile(options, gear, xml);
        ASSERT_TRUE(back.ok) << kind << ": " << back.error.ToString();
        for (int p = 0; p < 45; ++p)
          EXPECT_NEAR(back.grid.deviations_um[p], grid[p], /*tol_um=*/1e-3)
              << kind << " " << p;
        if (std::string(kind) == "measured") {
          EXPECT_NEAR(back.figures.fHa_mean, out.figures->fHa_mean, 1e-3);
          EXPECT_EQ(back.classes.overall, out.classes->overall);
        }
      }
    }
  }
}

}  // namespace
}  // namespace gearloop
