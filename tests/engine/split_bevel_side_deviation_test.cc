// The side deviation of SPLIT_BEVEL.md §5 (engine/split_bevel/trajectory.h)
// and its foot points (SplitBevelFlankSurface::Nearest with FlankAnchors,
// engine/split_bevel/flank.h) against a slow, careful reference of the test's
// own: the distance from the tool's side-line point X to the flank sampled
// densely along the face, the nearest sample's neighbourhood bisected on the
// sign of the distance's central difference. The reference uses only the
// flank's pitch point and ruling (checked by invariant (c) and the derivative
// tests), not the engine's analytic derivatives nor its Newton.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <string>

#include "engine/core/units.h"
#include "engine/split_bevel/flank.h"
#include "engine/split_bevel/trajectory.h"
#include "tests/engine/split_bevel_test_gears.h"

namespace gearloop {
namespace {

// The reference's window around the station and its samples: 0.005 mm apart.
constexpr double kWindowMm = 2.0;
constexpr int kSamples = 801;
// Central-difference step and bisection width of the reference [mm].
constexpr double kDifferenceStepMm = 1e-3;
constexpr double kBisectionWidthMm = 1e-11;
// The reference foot is within about 1e-8 mm of the true one: the distance
// carries the rounding of a pitch point ~1 500 mm from the apex (1e-13 mm),
// over the central difference's 2e-3 mm that is 1e-10 of slope, and the
// distance curves by ~0.1 / mm along the face. The gap depends on the foot only
// to second order.
constexpr double kFootToleranceMm = 5e-8;
constexpr double kGapToleranceMm = 1e-10;

class SideDeviationGears : public ::testing::TestWithParam<std::string> {};
INSTANTIATE_TEST_SUITE_P(Gears,
                         SideDeviationGears,
                         ::testing::Values("RightHandWheel",
                                           "LeftHandWheel",
                                           "LeftHandPinion"));

SplitBevelRequest RequestNamed(const std::string& name) {
  for (const auto& g : split_bevel_test::AllGears())
    if (g.name == name) return g.request;
  ADD_FAILURE() << "no test gear " << name;
  return {};
}

// The reference foot point of X: its cone distance and the signed gap (X - F)
// . N - r0 with N into the slot, by sampling and bisection.
struct ReferenceFoot {
  double cone_distance_mm = 0.0;
  double gap_mm = 0.0;
};

ReferenceFoot ReferenceFootOf(const SplitBevelFlankSurface& flank,
                              const Eigen::Vector3d& x,
                              double station_mm,
                              double tool_radius_mm) {
  // X - F(R, h*(R)) with the nearest point of the ruling at R.
  const auto residual = [&](double r) -> Eigen::Vector3d {
    const FlankSection s = flank.Section(r);
    const double u = (x - s.pitch_point_mm).dot(s.ruling);
    return x - s.pitch_point_mm - u * s.ruling;
  };
  const auto distance = [&](double r) { return residual(r).norm(); };
  const double lo = station_mm - kWindowMm;
  const double step = 2.0 * kWindowMm / (kSamples - 1);
  int best = 0;
  double best_distance = distance(lo);
  for (int i = 1; i < kSamples; ++i) {
    const double d = distance(lo + i * step);
    if (d < best_distance) {
      best_distance = d;
      best = i;
    }
  }
  EXPECT_GT(best, 0) << "the foot is outside the reference's window";
  EXPECT_LT(best, kSamples - 1) << "the foot is outside the reference's window";
  // The distance falls before the foot and rises after it.
  const auto rising = [&](double r) {
    return distance(r + kDifferenceStepMm) > distance(r - kDifferenceStepMm);
  };
  double a = lo + (best - 1) * step, b = lo + (best + 1) * step;
  while (b - a > kBisectionWidthMm) {
    const double m = 0.5 * (a + b);
    (rising(m) ? b : a) = m;
  }
  ReferenceFoot foot;
  foot.cone_distance_mm = 0.5 * (a + b);
  const Eigen::Vector3d res = residual(foot.cone_distance_mm);
  const FlankSection s = flank.Section(foot.cone_distance_mm);
  foot.gap_mm =
      (res.dot(s.slot_side) >= 0.0 ? res.norm() : -res.norm()) - tool_radius_mm;
  return foot;
}

// Every foot point of every pass, from the engine's first guess (the station)
// and from guesses 0.5 mm off (beyond the station's grid of sections), agrees
// with the reference; each pass's side deviation is the reference's range.
TEST_P(SideDeviationGears, FootPointsAndSideDeviationAgreeWithTheReference) {
  const SplitBevelRequest request = RequestNamed(GetParam());
  const SplitBevelResult result = ComputeSplitTrajectory(request);
  ASSERT_TRUE(result.ok) << result.message;
  const SplitBevelGearData& d = result.derived;
  const double cos_alpha = std::cos(d.pressure_angle_rad);
  double worst_foot = 0.0, worst_gap = 0.0, worst_range = 0.0;
  for (const SplitBevelPass& pass : result.passes) {
    const SplitBevelFlankSurface flank(d, pass.slot, pass.flank);
    FlankAnchors anchors(flank);
    double lo = 1e300, hi = -1e300;
    for (const SplitBevelPoint& p : pass.points) {
      anchors.Centre(flank.Section(p.cone_distance_mm));
      for (int i = 0; i < kSplitBevelDeviationHeights; ++i) {
        const double height =
            pass.tip_height_mm + (d.addendum_mm - pass.tip_height_mm) * i /
                                     (kSplitBevelDeviationHeights - 1);
        const Eigen::Vector3d x =
            p.tool_centre_mm +
            (height - pass.tip_height_mm) / cos_alpha * p.tool_axis;
        const ReferenceFoot ref = ReferenceFootOf(
            flank, x, p.cone_distance_mm, request.tool.radius_mm);
        lo = std::min(lo, ref.gap_mm);
        hi = std::max(hi, ref.gap_mm);
        for (const double guess_off : {0.0, -0.5, 0.5}) {
          const SplitBevelFlankSurface::NearestPoint near =
              flank.Nearest(x, p.cone_distance_mm + guess_off, &anchors);
          ASSERT_TRUE(near.converged);
          const double gap =
              (x - near.point_mm).dot(near.normal) - request.tool.radius_mm;
          worst_foot =
              std::max(worst_foot,
                       std::abs(near.cone_distance_mm - ref.cone_distance_mm));
          worst_gap = std::max(worst_gap, std::abs(gap - ref.gap_mm));
        }
      }
    }
    worst_range = std::max({worst_range,
                            std::abs(pass.side_deviation_mm.min_mm - lo),
                            std::abs(pass.side_deviation_mm.max_mm - hi)});
  }
  EXPECT_LT(worst_foot, kFootToleranceMm);
  EXPECT_LT(worst_gap, kGapToleranceMm);
  EXPECT_LT(worst_range, kGapToleranceMm);
  std::printf(
      "[ %s ] against the reference: foot %.2g mm, gap %.2g mm, side "
      "deviation %.2g mm\n",
      GetParam().c_str(),
      worst_foot,
      worst_gap,
      worst_range);
}

// The side deviation does not depend on which passes are computed together
// (the levels of a flank share their stations' sections and foot-point
// guesses): the first flank alone gives its passes' ranges bit for bit, and
// the root level alone (with a chord tolerance: the same tip height, so the
// same stations) that of the last of several levels.
TEST_P(SideDeviationGears, PassesComputedApartGiveTheSameSideDeviation) {
  SplitBevelRequest request = RequestNamed(GetParam());
  const SplitBevelResult all = ComputeSplitTrajectory(request);
  ASSERT_TRUE(all.ok) << all.message;
  request.cut.flanks = {all.passes.front().flank};
  const SplitBevelResult one_flank = ComputeSplitTrajectory(request);
  ASSERT_TRUE(one_flank.ok) << one_flank.message;
  // The first flank's passes are the same with or without the second.
  for (size_t i = 0; i < one_flank.passes.size(); ++i) {
    EXPECT_EQ(one_flank.passes[i].side_deviation_mm.min_mm,
              all.passes[i].side_deviation_mm.min_mm);
    EXPECT_EQ(one_flank.passes[i].side_deviation_mm.max_mm,
              all.passes[i].side_deviation_mm.max_mm);
  }
  // The deepest level alone (L = 1 puts the tip on the root, as the last
  // level of L levels does).
  request.cut.depth_levels = 1;
  const SplitBevelResult root = ComputeSplitTrajectory(request);
  ASSERT_TRUE(root.ok) << root.message;
  const SplitBevelPass& last = one_flank.passes.back();
  ASSERT_EQ(root.passes.size(), 1u);
  EXPECT_DOUBLE_EQ(root.passes[0].tip_height_mm, last.tip_height_mm);
  EXPECT_NEAR(root.passes[0].side_deviation_mm.min_mm,
              last.side_deviation_mm.min_mm,
              kGapToleranceMm);
  EXPECT_NEAR(root.passes[0].side_deviation_mm.max_mm,
              last.side_deviation_mm.max_mm,
              kGapToleranceMm);
}

}  // namespace
}  // namespace gearloop
