#include <gtest/gtest.h>

#include <cmath>

#include "engine/metrology/iso1328.h"
#include "tests/formats/metrology_samples.h"

namespace gearloop {
namespace {

using testing::FlankForms;
using testing::FormsOnGrid;
using testing::SampleForms;
using testing::SampleGear;

FlankFigures FiguresOf(const FlankForms& forms) {
  return ComputeFlankFigures(Iso1328Options{},
                             SampleGear(),
                             GridOptions{},
                             FormsOnGrid(forms, SampleGear()));
}

// METROLOGY.md §4, "Worked numbers": class 5 and class 7 of the sample gear.
TEST(ComputeTolerances, TheSampleGearsClass5And7) {
  const Iso1328Tolerances c5 = ComputeTolerances(SampleGear(), 5);
  EXPECT_EQ(c5.fHa, 6.0);
  EXPECT_EQ(c5.ffa, 7.5);
  EXPECT_EQ(c5.Fa, 9.5);
  EXPECT_EQ(c5.fHb, 7.0);
  EXPECT_EQ(c5.ffb, 7.5);
  EXPECT_EQ(c5.Fb, 10.0);
  const Iso1328Tolerances c7 = ComputeTolerances(SampleGear(), 7);
  EXPECT_EQ(c7.fHa, 12.0);
  EXPECT_EQ(c7.ffa, 15.0);
  EXPECT_EQ(c7.Fa, 19.0);
  EXPECT_EQ(c7.fHb, 14.0);
  EXPECT_EQ(c7.ffb, 15.0);
  EXPECT_EQ(c7.Fb, 21.0);
  // Rounded only at the end: class 7 is twice the UNROUNDED class 5 value
  // (5.948 -> 11.896 -> 12).
  EXPECT_NEAR(ComputeTolerances(SampleGear(), 5, /*rounded=*/false).fHa,
              0.4 * 4.5 + 0.001 * 148.453 + 4,
              1e-3);
}

TEST(RoundIso1328Tolerance, ThreeBands) {
  EXPECT_EQ(RoundIso1328Tolerance(10.4), 10.0);
  EXPECT_EQ(RoundIso1328Tolerance(10.6), 11.0);
  EXPECT_EQ(RoundIso1328Tolerance(7.7), 7.5);
  EXPECT_EQ(RoundIso1328Tolerance(5.948), 6.0);
  EXPECT_EQ(RoundIso1328Tolerance(3.74), 3.7);
}

TEST(ComputeTraceFigures, HandCheckedTrace) {
  // e = 2 t + t^2 on t = -1, 0, 1: mean line slope 2 (f_H over 2 mm = 4),
  // residuals 1/3, -2/3, 1/3 (f_f = 1), F = 3 - (-1) = 4, parabola exact: sag
  // below the chord = -1 (concave).
  const TraceFigures f = ComputeTraceFigures({-1, 0, 1}, {-1, 0, 3}, 2.0, 4.0);
  EXPECT_NEAR(f.slope_grid_um, 4.0, 1e-12);
  EXPECT_NEAR(f.slope_iso_um, 8.0, 1e-12);
  EXPECT_NEAR(f.form_um, 1.0, 1e-12);
  EXPECT_NEAR(f.total_um, 4.0, 1e-12);
  EXPECT_NEAR(f.crowning_grid_um, -1.0, 1e-12);
  EXPECT_NEAR(f.crowning_iso_um, -4.0, 1e-12);
  EXPECT_TRUE(std::isnan(ComputeTraceFigures({0, 1}, {0, 1}, 1, 1).form_um));
}

TEST(ComputeFlankFigures, PureProfileSlope) {
  const FlankFigures f = FiguresOf(FlankForms{0, 0, 10.0, 0, 0, 0});
  ASSERT_TRUE(f.ok) << f.message;
  EXPECT_NEAR(f.profile_evaluation_length_mm, 24.961, 5e-4);
  EXPECT_NEAR(f.helix_evaluation_length_mm, 36.0, 1e-12);
  EXPECT_NEAR(f.profile_grid_extent_mm, 18.393, 5e-4);
  EXPECT_NEAR(f.helix_grid_extent_mm, 32.0, 1e-12);
  EXPECT_NEAR(f.fHa_mean_grid, 10.0, 1e-9);
  EXPECT_NEAR(f.fHa_mean, 13.57, 5e-3);
  EXPECT_NEAR(f.ffa_max_abs, 0.0, 1e-9);
  EXPECT_NEAR(f.Fa_max_abs, 10.0, 1e-9);
  const AccuracyClasses c = ClassifyFlank(Iso1328Options{}, SampleGear(), f);
  EXPECT_EQ(c.fHa, 8);  // class 7 allows 12 um, 13.57 um needs class 8
}

TEST(ComputeFlankFigures, PureHelixCrowning) {
  const FlankFigures f = FiguresOf(FlankForms{0, 8.0, 0, 0, 0, 0});
  ASSERT_TRUE(f.ok) << f.message;
  EXPECT_NEAR(f.Cb_mean_grid, 8.0, 1e-9);
  EXPECT_NEAR(f.Fb_max_abs, 8.0, 1e-9);
  EXPECT_NEAR(f.ffb_max_abs, 8.0, 1e-9);  // level mean line
  EXPECT_NEAR(f.Cb_mean, 10.125, 1e-9);   // 8 (36/32)^2
  EXPECT_NEAR(f.fHb_mean, 0.0, 1e-9);
  EXPECT_NEAR(f.Ca_mean, 0.0, 1e-9);
}

TEST(ComputeFlankFigures, PureTwist) {
  const FlankFigures f = FiguresOf(FlankForms{0, 0, 0, 0, 5.0, 0});
  ASSERT_TRUE(f.ok) << f.message;
  EXPECT_NEAR(f.twist_alpha_grid, 10.0, 1e-9);
  EXPECT_NEAR(f.twist_beta_grid, 10.0, 1e-9);
  EXPECT_NEAR(f.profile_traces.front().slope_grid_um, -5.0, 1e-9);
  EXPECT_NEAR(f.profile_traces.back().slope_grid_um, 5.0, 1e-9);
  EXPECT_NEAR(f.fHa_mean, 0.0, 1e-9);
  EXPECT_NEAR(f.fHb_mean, 0.0, 1e-9);
  EXPECT_NEAR(f.twist_alpha,
              10.0 * f.profile_evaluation_length_mm / f.profile_grid_extent_mm,
              1e-9);
}

// METROLOGY.md §4: the sample right flank.
TEST(ComputeFlankFigures, SampleRightFlankFiguresAndClasses) {
  const FlankFigures f = FiguresOf(SampleForms(Flank::kRight));
  ASSERT_TRUE(f.ok) << f.message;
  EXPECT_NEAR(f.fHa_mean_grid, 4.00, 5e-3);
  EXPECT_NEAR(f.fHa_mean, 5.43, 5e-3);
  EXPECT_NEAR(f.ffa_max_abs, 3.00, 5e-3);
  EXPECT_NEAR(f.Fa_max_abs, 6.75, 5e-3);
  EXPECT_NEAR(f.Ca_mean_grid, 3.00, 5e-3);
  EXPECT_NEAR(f.Ca_mean, 5.53, 5e-3);
  EXPECT_NEAR(f.fHb_mean_grid, 5.00, 5e-3);
  EXPECT_NEAR(f.fHb_mean,
              5.625,
              1e-9);  // METROLOGY.md prints 5.63, the sample GDE RESULTS 5.62
  EXPECT_NEAR(f.ffb_max_abs, 6.00, 5e-3);
  EXPECT_NEAR(f.Fb_max_abs, 10.00, 5e-3);
  EXPECT_NEAR(f.Cb_mean, 7.59, 5e-3);
  EXPECT_NEAR(f.twist_alpha_grid, 4.00, 5e-3);
  EXPECT_NEAR(f.twist_beta_grid, 4.00, 5e-3);
  const AccuracyClasses c = ClassifyFlank(Iso1328Options{}, SampleGear(), f);
  EXPECT_EQ(c.fHa, 6);
  EXPECT_EQ(c.ffa, 3);
  EXPECT_EQ(c.Fa, 4);
  EXPECT_EQ(c.fHb, 6);
  EXPECT_EQ(c.ffb, 5);
  EXPECT_EQ(c.Fb, 5);
  EXPECT_EQ(c.overall, 6);
  EXPECT_TRUE(c.warnings.empty());
}

TEST(ComputeFlankFigures, FiguresOfTheDeviationFromATarget) {
  const Eigen::VectorXd measured =
      FormsOnGrid(SampleForms(Flank::kRight), SampleGear());
  const Eigen::VectorXd target = FormsOnGrid(
      FlankForms{3.0, 6.0, 0, 0, 0, 0}, SampleGear());  // the design crowning
  const FlankFigures f = ComputeFlankFigures(
      Iso1328Options{}, SampleGear(), GridOptions{}, measured, target);
  ASSERT_TRUE(f.ok);
  EXPECT_NEAR(f.Ca_mean, 0.0, 1e-9);
  EXPECT_NEAR(f.Cb_mean, 0.0, 1e-9);
  EXPECT_NEAR(f.fHa_mean_grid, 4.0, 1e-9);
}

TEST(ClassifyFlank, WorseThan11IsNoClassAndTheValidityRangeWarns) {
  FlankFigures f = FiguresOf(FlankForms{0, 0, 200.0, 0, 0, 0});
  const AccuracyClasses c = ClassifyFlank(Iso1328Options{}, SampleGear(), f);
  EXPECT_FALSE(c.fHa.has_value());
  EXPECT_FALSE(c.overall.has_value());
  GearData wide = SampleGear();
  wide.helix_angle_rad = DegToRad(50.0);
  EXPECT_EQ(ClassifyFlank(Iso1328Options{}, wide, f).warnings.size(), 1u);
}

TEST(ComputeFlankFigures, BadInputIsAResult) {
  Eigen::VectorXd grid = FormsOnGrid(SampleForms(Flank::kRight), SampleGear());
  EXPECT_FALSE(ComputeFlankFigures(
                   Iso1328Options{}, SampleGear(), GridOptions{}, grid.head(44))
                   .ok);
  grid.segment(0, 3).setConstant(std::nan(""));
  grid.segment(9, 3).setConstant(std::nan(""));
  grid.segment(18, 3).setConstant(std::nan(""));
  const FlankFigures f =
      ComputeFlankFigures(Iso1328Options{}, SampleGear(), GridOptions{}, grid);
  EXPECT_FALSE(f.ok);
  EXPECT_NE(f.message.find("column 0"), std::string::npos) << f.message;
  Iso1328Options bad;
  bad.profile_evaluation_length_mm = -1;
  EXPECT_FALSE(ComputeFlankFigures(bad, SampleGear(), GridOptions{}, grid).ok);
}

}  // namespace
}  // namespace gearloop
