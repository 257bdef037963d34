#include "formats/measurement_import.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "formats/mka_reader.h"
#include "tests/formats/metrology_samples.h"

namespace gearloop {
namespace {

using testing::FormsOnGrid;
using testing::ReadSample;
using testing::SampleForms;
using testing::SampleGear;

MeasurementImportResult Import(MeasurementFormat format,
                               Flank flank,
                               const std::string& content) {
  MeasurementImportOptions options;
  options.format = format;
  options.flank = flank;
  return ImportMeasurementFile(options, SampleGear(), content);
}

// shared/formats/README.md: both samples give the same grid (0.001 um) and the
// analytic flank (0.01 um), row 0 of the right flank -11.500 -8.501 -6.250
// -4.750 -4.000 -4.000 -4.750 -6.250 -8.499.
TEST(ImportMeasurementFile, BothSamplesGiveTheSameGridAndTheAnalyticFlank) {
  const MeasurementImportResult mka =
      Import(MeasurementFormat::kMka,
             Flank::kRight,
             ReadSample("sample_topography.mka"));
  ASSERT_TRUE(mka.ok) << mka.error.ToString();
  const MeasurementImportResult gde =
      Import(MeasurementFormat::kGde,
             Flank::kRight,
             ReadSample("sample_topography.gde.xml"));
  ASSERT_TRUE(gde.ok) << gde.error.ToString();
  const Eigen::VectorXd truth =
      FormsOnGrid(SampleForms(Flank::kRight), SampleGear());
  double worst_pair = 0.0, worst_mka = 0.0, worst_gde = 0.0;
  for (int p = 0; p < 45; ++p) {
    worst_pair = std::max(
        worst_pair,
        std::abs(mka.grid.deviations_um[p] - gde.grid.deviations_um[p]));
    worst_mka =
        std::max(worst_mka, std::abs(mka.grid.deviations_um[p] - truth[p]));
    worst_gde =
        std::max(worst_gde, std::abs(gde.grid.deviations_um[p] - truth[p]));
  }
  EXPECT_LE(worst_pair, /*tol_um=*/0.001);
  EXPECT_LE(worst_mka, /*tol_um=*/0.01);
  EXPECT_LE(worst_gde, /*tol_um=*/0.01);
  std::printf(
      "right flank: |mka - gde| <= %.4f um, |mka - truth| <= %.4f um, |gde - "
      "truth| <= %.4f um\n",
      worst_pair,
      worst_mka,
      worst_gde);
  const double row0[] = {
      -11.500, -8.501, -6.250, -4.750, -4.000, -4.000, -4.750, -6.250, -8.499};
  for (int j = 0; j < 9; ++j) {
    EXPECT_NEAR(mka.grid.deviations_um[j], row0[j], 0.0015) << j;
    EXPECT_NEAR(gde.grid.deviations_um[j], row0[j], 0.0015) << j;
  }
  EXPECT_LT(mka.grid.max_crossing_mismatch_um, 0.01);
  EXPECT_TRUE(mka.warnings.empty()) << mka.warnings.front();
  EXPECT_TRUE(gde.warnings.empty()) << gde.warnings.front();
}

TEST(ImportMeasurementFile, TheLeftFlankOfTheMkaSample) {
  const MeasurementImportResult left =
      Import(MeasurementFormat::kMka,
             Flank::kLeft,
             ReadSample("sample_topography.mka"));
  ASSERT_TRUE(left.ok) << left.error.ToString();
  const Eigen::VectorXd truth =
      FormsOnGrid(SampleForms(Flank::kLeft), SampleGear());
  for (int p = 0; p < 45; ++p)
    EXPECT_NEAR(left.grid.deviations_um[p], truth[p], 0.01) << p;
  EXPECT_NEAR(left.figures.fHa_mean_grid, -3.0, 0.005);
  EXPECT_NEAR(left.figures.fHb_mean_grid, -4.0, 0.005);
  EXPECT_NEAR(left.figures.twist_alpha_grid, -3.0, 0.005);
}

// METROLOGY.md §4 from the files: the sample right flank's figures and classes.
TEST(ImportMeasurementFile, SampleFiguresAndClasses) {
  for (const auto& [format, name] :
       {std::make_pair(MeasurementFormat::kMka, "sample_topography.mka"),
        std::make_pair(MeasurementFormat::kGde, "sample_topography.gde.xml")}) {
    const MeasurementImportResult r =
        Import(format, Flank::kRight, ReadSample(name));
    ASSERT_TRUE(r.ok) << r.error.ToString();
    const FlankFigures& f = r.figures;
    EXPECT_NEAR(f.profile_evaluation_length_mm, 24.961, 2e-3) << name;
    EXPECT_NEAR(f.fHa_mean_grid, 4.00, 5e-3) << name;
    EXPECT_NEAR(f.fHa_mean, 5.43, 5e-3) << name;
    EXPECT_NEAR(f.ffa_max_abs, 3.00, 5e-3) << name;
    EXPECT_NEAR(f.Fa_max_abs, 6.75, 5e-3) << name;
    EXPECT_NEAR(f.Ca_mean, 5.525, 5e-3)
        << name;  // 3 (24.961 / 18.393)^2, printed 5.53
    EXPECT_NEAR(f.fHb_mean_grid, 5.00, 5e-3) << name;
    EXPECT_NEAR(f.fHb_mean, 5.625, 5e-3) << name;
    EXPECT_NEAR(f.ffb_max_abs, 6.00, 5e-3) << name;
    EXPECT_NEAR(f.Fb_max_abs, 10.00, 5e-3) << name;
    EXPECT_NEAR(f.Cb_mean, 7.59, 5e-3) << name;
    EXPECT_NEAR(f.twist_alpha_grid, 4.00, 5e-3) << name;
    EXPECT_NEAR(f.twist_beta_grid, 4.00, 5e-3) << name;
    const AccuracyClasses& c = r.classes;
    EXPECT_EQ(c.fHa, 6) << name;
    EXPECT_EQ(c.ffa, 3) << name;
    EXPECT_EQ(c.Fa, 4) << name;
    EXPECT_EQ(c.fHb, 6) << name;
    EXPECT_EQ(c.ffb, 5) << name;
    EXPECT_EQ(c.Fb, 5) << name;
    EXPECT_EQ(c.overall, 6) << name;
    std::printf(
        "%s: fHa %.3f (grid %.3f) ffa %.3f Fa %.3f Ca %.3f fHb %.3f (grid "
        "%.3f) ffb %.3f Fb %.3f Cb %.3f "
        "S %.3f %.3f; classes %d %d %d %d %d %d overall %d\n",
        name,
        f.fHa_mean,
        f.fHa_mean_grid,
        f.ffa_max_abs,
        f.Fa_max_abs,
        f.Ca_mean,
        f.fHb_mean,
        f.fHb_mean_grid,
        f.ffb_max_abs,
        f.Fb_max_abs,
        f.Cb_mean,
        f.twist_alpha_grid,
        f.twist_beta_grid,
        c.fHa.value_or(0),
        c.ffa.value_or(0),
        c.Fa.value_or(0),
        c.fHb.value_or(0),
        c.ffb.value_or(0),
        c.Fb.value_or(0),
        c.overall.value_or(0));
  }
}

TEST(ImportMeasurementFile, HeaderValuesThatContradictTheRequestAreNamed) {
  GearData other = SampleGear();
  other.normal_module_mm = 4.6;
  MeasurementImportOptions options;
  MeasurementImportResult r = ImportMeasurementFile(
      options, other, ReadSample("sample_topography.mka"));
  ASSERT_FALSE(r.ok);
  EXPECT_EQ(r.error.place.line, 18);
  EXPECT_NE(r.error.message.find(
                "code 21 (m_n) is 4.5 mm in the file, 4.6 mm in the request"),
            std::string::npos)
      << r.error.message;
  other = SampleGear();
  other.face_width_mm = 42.0;
  options.format = MeasurementFormat::kGde;
  r = ImportMeasurementFile(
      options, other, ReadSample("sample_topography.gde.xml"));
  ASSERT_FALSE(r.ok);
  EXPECT_EQ(r.error.place.element_path,
            "/GDE/GEAR_DATA/GEOMETRY/BASIC_GEOMETRY/face_width");
  EXPECT_NE(r.error.message.find("40 mm in the file, 42 mm in the request"),
            std::string::npos)
      << r.error.message;
  // A left-hand request for a right-hand file is a warning, not a refusal
  // (|beta| is compared).
  other = SampleGear();
  other.helix_angle_rad = -other.helix_angle_rad;
  r = ImportMeasurementFile(
      MeasurementImportOptions{}, other, ReadSample("sample_topography.mka"));
  ASSERT_TRUE(r.ok) << r.error.ToString();
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_NE(r.warnings[0].find("right-hand"), std::string::npos);
}

TEST(ImportMeasurementFile, RawCurvesOfTheOtherGenerationNeedTheSignOption) {
  // Profile-left and helix curves stored with the opposite sign: the crossings
  // disagree and the import warns; the sign option of METROLOGY.md §2 recovers
  // the flank.
  std::string content = ReadSample("sample_topography.mka");
  MeasurementFile file;
  FileError error;
  ASSERT_TRUE(ReadMkaFile(content, &file, &error));
  MeasurementImportOptions options;
  options.flank = Flank::kLeft;
  options.sign.helix_left =
      -1.0;  // the file stores printout signs: flipping one family is wrong
  const MeasurementImportResult wrong =
      ImportMeasurementFile(options, SampleGear(), content);
  ASSERT_TRUE(wrong.ok);
  EXPECT_GT(wrong.grid.max_crossing_mismatch_um, 2.0);
  EXPECT_FALSE(wrong.warnings.empty());
}

}  // namespace
}  // namespace gearloop
