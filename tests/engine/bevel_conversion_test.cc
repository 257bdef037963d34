// Tests of the cradle -> free-form conversion (engine/bevel/conversion.h).
#include <gtest/gtest.h>

#include <cmath>

#include "engine/bevel/conversion.h"
#include "engine/core/units.h"

namespace gearloop {
namespace {

class ConversionSides : public ::testing::TestWithParam<BevelFlankSide> {};

// The free-form chain driven by the exact per-instant axes reproduces the
// cradle machine's cutter-to-work transform to machine precision.
TEST_P(ConversionSides, ExactInstantReproducesCradleTransform) {
  const BevelPinionJob job = PublishedPinionJob(GetParam());
  const double tol =
      1e-12;  // rotation entries, and translation in mm (|t| ~ 200 mm)
  double a_ref = 0.0, c_ref = 0.0;
  for (double t = -0.3; t <= 0.3001; t += 0.05) {
    const InstantConversion s = ConvertInstant(job.machine, t, a_ref, c_ref);
    a_ref = s.axes.a_rad;
    c_ref = s.axes.c_rad;
    const RigidTransform cradle = CradleWorkFromCutter(job.machine, t);
    const RigidTransform free_form = FreeFormWorkFromCutter(s.axes);
    EXPECT_LT((cradle.rotation - free_form.rotation).cwiseAbs().maxCoeff(), tol)
        << t;
    EXPECT_LT((cradle.translation_mm - free_form.translation_mm)
                  .cwiseAbs()
                  .maxCoeff(),
              tol)
        << t;
    EXPECT_LT(s.polished_residual, 1e-14);
    EXPECT_LT(std::abs(s.axes.b_rad), 0.5 * kPi);  // the |B| < 90 deg branch
  }
}

// The default fit (degree 5) cuts a flank within 0.1 um of the cradle flank on
// the grid, and the fitted transform is close to the cradle's everywhere on the
// fit range.
TEST_P(ConversionSides, DefaultFitCutsFlankWithinTolerance) {
  const ConversionResult c = ConvertCradleToFreeForm(
      ConversionOptions(), PublishedPinionJob(GetParam()));
  ASSERT_TRUE(c.ok) << c.message;
  EXPECT_EQ(c.flank_points_found, 45);
  const double tol_flank_um = 0.1;
  EXPECT_LT(c.flank_max_distance_um, tol_flank_um);
  EXPECT_LT(c.exact_max_rotation_difference, 1e-12);
  EXPECT_LT(c.exact_max_translation_difference_mm, 1e-12);
  EXPECT_LT(c.fitted_max_rotation_difference, 1e-7);
  EXPECT_LT(c.fitted_max_translation_difference_mm, 1e-4);
  for (const AxisFitReport& f : c.fit) {
    EXPECT_LT(f.max_residual, f.unit == "mm" ? 1e-4 : 1e-7) << f.axis;
    EXPECT_LE(f.rms_residual, f.max_residual) << f.axis;
  }
  EXPECT_GT(c.fit[0].max_residual,
            0.0);  // a fit, not an interpolation of the checks
}

// A too-low degree is seen by the flank distance (it is not a metric that
// always passes).
TEST_P(ConversionSides, DegreeThreeMissesTolerance) {
  ConversionOptions options;
  options.polynomial_degree = 3;
  const ConversionResult c =
      ConvertCradleToFreeForm(options, PublishedPinionJob(GetParam()));
  ASSERT_TRUE(c.ok) << c.message;
  EXPECT_GT(c.flank_max_distance_um, 0.1);
  EXPECT_LT(c.flank_max_distance_um, 5.0);
}

// Our chains reproduce the published free-form motion (Tang 2011, convex side,
// degree 5): the paper's frames differ from ours by the cutter z axis (phi = pi
// - B), a mirror of the machine (x_m, y_m and the cradle sense: xm = -X, ym =
// -Y) and the work-head setting X1 (its work frame origin sits X1 nearer the
// machine centre), so xm ~ -(X + X1), ym ~ -Y, psi ~ A + const, phi ~ pi - B.
// The fit ranges differ, so compare value and slope at t = 0.
TEST(ConvertCradleToFreeForm, ReproducesPublishedConvexMotion) {
  const BevelPinionJob job = PublishedPinionJob(BevelFlankSide::kConvex);
  const ConversionResult c = ConvertCradleToFreeForm(ConversionOptions(), job);
  ASSERT_TRUE(c.ok);
  const FreeFormMotion& m = c.motion;
  const double x1 = job.machine.horizontal_offset_mm;
  EXPECT_NEAR(m.Rate(FreeFormAxis::kA, 0.0),
              7.49107,
              0.05);  // published psi' (rad/rad)
  EXPECT_NEAR(-(m.Value(FreeFormAxis::kX, 0.0) + x1), -72.3686, 1.0);
  EXPECT_NEAR(-m.Rate(FreeFormAxis::kX, 0.0), -158.648, 1.0);
  EXPECT_NEAR(-m.Value(FreeFormAxis::kY, 0.0), 116.253, 1.0);
  EXPECT_NEAR(-m.Rate(FreeFormAxis::kY, 0.0), -73.0893, 1.5);
  EXPECT_NEAR(kPi - m.Value(FreeFormAxis::kB, 0.0), 2.98765, 0.02);
}

// Choosing the degree: the smallest that keeps the flank within the goal
// (degree 4 here, whose flank distance is 0.03-0.07 um; degree 3 gives 0.6-1.1
// um).
TEST_P(ConversionSides, ChosenDegreeIsSmallestMeetingGoal) {
  ConversionOptions options;
  options.choose_degree = true;
  options.max_flank_distance_um = 0.1;
  const ConversionResult c =
      ConvertCradleToFreeForm(options, PublishedPinionJob(GetParam()));
  ASSERT_TRUE(c.ok) << c.message;
  EXPECT_EQ(c.motion.degree, 4);
  EXPECT_LT(c.flank_max_distance_um, 0.1);
}

TEST(ConvertCradleToFreeForm, InvalidOptionsAreReported) {
  ConversionOptions options;
  options.polynomial_degree = 0;
  const ConversionResult c = ConvertCradleToFreeForm(
      options, PublishedPinionJob(BevelFlankSide::kConvex));
  EXPECT_FALSE(c.ok);
  EXPECT_NE(c.message.find("polynomial_degree"), std::string::npos);
}

INSTANTIATE_TEST_SUITE_P(
    BothSides,
    ConversionSides,
    ::testing::Values(BevelFlankSide::kConvex, BevelFlankSide::kConcave),
    [](const ::testing::TestParamInfo<BevelFlankSide>& info) {
      return std::string(BevelFlankSideName(info.param));
    });

}  // namespace
}  // namespace gearloop
