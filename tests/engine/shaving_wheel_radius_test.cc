#include <gtest/gtest.h>

#include <cmath>

#include "engine/shaving/wheel_radius.h"
#include "tests/engine/shaving_test_cases.h"

namespace gearloop {
namespace {

// SHAVING.md §5, the cutter of the example with h_s = 2 mm.
TEST(ComputeWheelRadiusCheck, CertifiedCutterRadii) {
  const WheelRadiusCheck check =
      ComputeWheelRadiusCheck(testing::PublishedCutter(), /*h_s_mm=*/2.0);
  EXPECT_NEAR(check.contact_angle_rad * kDegPerRad, 5.236, 5e-4);
  EXPECT_NEAR(check.contact_line_fixed_mm, 75.342, 5e-4);
  EXPECT_NEAR(check.contact_line_traversing_mm,
              75.342,
              5e-4);  // limited to B cos(beta)
  EXPECT_NEAR(check.wheel_radius_min_fixed_mm, 355.78, 5e-3);
  EXPECT_NEAR(check.wheel_radius_min_traversing_mm, 336.97, 5e-3);
}

// On a narrow-enough face the traversing contact line is the depth over
// tan(beta_b), not B cos(beta).
TEST(ComputeWheelRadiusCheck, TraversingLineFromTheDepth) {
  GearData wide = testing::PublishedCutter();
  wide.face_width_mm = 400.0;
  const WheelRadiusCheck check = ComputeWheelRadiusCheck(wide, 2.0);
  const double r_b = wide.BaseRadiusMm();
  const double expected =
      std::sqrt(wide.tip_radius_mm * wide.tip_radius_mm - r_b * r_b) /
      wide.TanBaseHelixAngle();
  EXPECT_NEAR(check.contact_line_traversing_mm,
              expected,
              1e-9);  // r_f < r_b: the root term is 0
  EXPECT_LT(check.contact_line_traversing_mm, check.contact_line_fixed_mm);
}

// The exact reach from the grinding model (MODEL.md §4): a small wheel leaves
// the root corners, a large one reaches the whole grid; the count never falls
// as R_w grows.
TEST(ComputeWheelReach, FromTheGrindingModel) {
  const GearData cutter = testing::PublishedCutter();
  int previous = -1;
  for (double radius : {120.0, 200.0, 350.0, 355.78, 1000.0}) {
    const WheelReach reach =
        ComputeWheelReach(cutter, Flank::kRight, GridOptions(), radius);
    ASSERT_EQ(reach.status.size(), 45u);
    EXPECT_GE(reach.NumReached(), previous) << radius;
    previous = reach.NumReached();
    for (PointStatus s : reach.status)
      EXPECT_NE(s, PointStatus::kNotConverged) << radius;
    if (radius == 120.0) {
      EXPECT_EQ(reach.status[0],
                PointStatus::kNotReached);  // root row, x < 0 corner
      EXPECT_EQ(reach.status[8],
                PointStatus::kNotReached);            // root row, x > 0 corner
      EXPECT_EQ(reach.status[22], PointStatus::kOk);  // middle
    }
  }
  EXPECT_EQ(previous, 45);
}

}  // namespace
}  // namespace gearloop
