// Tests of the segment setup and the head-head kinematics
// (engine/split_bevel/head_kinematics.h) and of the invariants (a), (e), (f) of
// SPLIT_BEVEL.md §7 on the three test gears. The forward kinematics is rebuilt
// here from Eigen's angle-axis rotations, independently of the engine's.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "engine/core/units.h"
#include "engine/split_bevel/head_kinematics.h"
#include "engine/split_bevel/trajectory.h"
#include "tests/engine/split_bevel_test_gears.h"

namespace gearloop {
namespace {

using split_bevel_test::AllGears;
using split_bevel_test::LeftHandWheel;
using split_bevel_test::RightHandWheel;

// a_m = RotY(B) RotX(A) z and centre = pivot - P a_m, by Eigen's rotations.
struct Pose {
  Eigen::Vector3d centre, axis;
};
Pose TestForward(const HeadAxes& h, double pivot_length_mm) {
  const Eigen::Vector3d axis =
      (Eigen::AngleAxisd(h.b_rad, Eigen::Vector3d::UnitY()) *
       Eigen::AngleAxisd(h.a_rad, Eigen::Vector3d::UnitX()) *
       Eigen::Vector3d::UnitZ());
  return {Eigen::Vector3d(h.x_mm, h.y_mm, h.z_mm) - pivot_length_mm * axis,
          axis};
}
Eigen::Matrix3d TestSetupRotation(double psi_mid) {
  return (Eigen::AngleAxisd(kPi, Eigen::Vector3d::UnitX()) *
          Eigen::AngleAxisd(-psi_mid, Eigen::Vector3d::UnitZ()))
      .toRotationMatrix();
}

TEST(HeadForward, AxisDirectionsAtQuarterTurns) {
  const double p = 100.0;
  const HeadAxes zero{1.0, 2.0, 3.0, 0.0, 0.0};
  EXPECT_LT((HeadForward(zero, p).axis - Eigen::Vector3d::UnitZ()).norm(),
            1e-15);
  EXPECT_LT(
      (HeadForward(zero, p).centre_mm - Eigen::Vector3d(1.0, 2.0, 3.0 - p))
          .norm(),
      1e-12);
  // A = +90 deg turns the tool about +X from +Z to -Y; B = +90 deg about +Y
  // from +Z to +X.
  EXPECT_LT((HeadToolAxis(kPi / 2, 0.0) - Eigen::Vector3d(0, -1, 0)).norm(),
            1e-15);
  EXPECT_LT((HeadToolAxis(0.0, kPi / 2) - Eigen::Vector3d(1, 0, 0)).norm(),
            1e-15);
  for (double a = -1.5; a <= 1.5; a += 0.37) {
    for (double b = -6.0; b <= 6.0; b += 0.71) {
      const HeadAxes h{10.0, -20.0, 30.0, a, b};
      const Pose t = TestForward(h, p);
      const ToolPose e = HeadForward(h, p);
      EXPECT_LT((e.axis - t.axis).norm(), 1e-15);
      EXPECT_LT((e.centre_mm - t.centre).norm(), 1e-12);
    }
  }
}

TEST(SplitBevelBlankToMachine, IsRotXPiAfterRotZMinusPsiMid) {
  const Eigen::Vector3d apex(5.0, -7.0, 11.0);
  for (const double psi : {0.0, 0.3, -2.0, 3.0}) {
    const Eigen::Matrix4d t = SplitBevelBlankToMachine(psi, apex);
    EXPECT_LT((t.block<3, 3>(0, 0) - TestSetupRotation(psi)).norm(), 1e-15);
    EXPECT_LT((t.block<3, 1>(0, 3) - apex).norm(), 0.0 + 1e-15);
    EXPECT_EQ(t.row(3), Eigen::RowVector4d(0, 0, 0, 1));
    // The gear axis points down; the pitch cone normal at psi_mid points up,
    // toward +X.
    const Eigen::Matrix3d m = t.block<3, 3>(0, 0);
    EXPECT_LT((m * Eigen::Vector3d::UnitZ() + Eigen::Vector3d::UnitZ()).norm(),
              1e-15);
    const double d = DegToRad(60.0);
    const Eigen::Vector3d k(
        std::cos(d) * std::cos(psi), std::cos(d) * std::sin(psi), -std::sin(d));
    const Eigen::Vector3d p(
        std::sin(d) * std::cos(psi), std::sin(d) * std::sin(psi), std::cos(d));
    EXPECT_GT((m * k).z(), 0.0);
    EXPECT_GT((m * p).x(), 0.0);
    EXPECT_NEAR((m * p).y(), 0.0, 1e-15);
  }
}

TEST(HeadInverseBranches, BothBranchesGiveTheAxis) {
  for (double a = -1.5; a <= 1.5; a += 0.3) {
    for (double b = -3.0; b <= 3.0; b += 0.5) {
      const Eigen::Vector3d axis = HeadToolAxis(a, b);
      const auto branches = HeadInverseBranches(axis, 0.0);
      EXPECT_NEAR(branches[0].a_rad, a, 1e-12);
      EXPECT_NEAR(branches[0].b_rad, b, 1e-12);
      for (const HeadAngles& h : branches) {
        EXPECT_LT((HeadToolAxis(h.a_rad, h.b_rad) - axis).norm(), 1e-15);
        EXPECT_GT(h.a_rad, -kPi);
        EXPECT_LE(h.a_rad, kPi);
      }
    }
  }
}

TEST(ChooseHeadAngles, FirstPointIsBranchOneWithBInMinus180To180) {
  HeadAngles h;
  ASSERT_TRUE(ChooseHeadAngles(
      HeadToolAxis(0.3, DegToRad(170.0)), nullptr, HeadLimits(), &h));
  EXPECT_NEAR(h.a_rad, 0.3, 1e-14);
  EXPECT_NEAR(h.b_rad, DegToRad(170.0), 1e-14);
  ASSERT_TRUE(ChooseHeadAngles(
      HeadToolAxis(0.3, DegToRad(190.0)), nullptr, HeadLimits(), &h));
  EXPECT_NEAR(h.b_rad, DegToRad(-170.0), 1e-14);
}

TEST(ChooseHeadAngles, UnwrapsBAcrossHalfATurn) {
  const HeadAngles previous{0.3, DegToRad(175.0)};
  HeadAngles h;
  ASSERT_TRUE(ChooseHeadAngles(
      HeadToolAxis(0.3, DegToRad(185.0)), &previous, HeadLimits(), &h));
  EXPECT_NEAR(h.b_rad, DegToRad(185.0), 1e-12);
  // A turn further on: B keeps counting within the limits.
  const HeadAngles far{0.3, DegToRad(355.0)};
  HeadLimits wide_b;
  wide_b.b_max_rad = DegToRad(400.0);
  ASSERT_TRUE(
      ChooseHeadAngles(HeadToolAxis(0.3, DegToRad(5.0)), &far, wide_b, &h));
  EXPECT_NEAR(h.b_rad, DegToRad(365.0), 1e-12);
  // With the default limits 365 deg is out of [-360, 360]: B goes back to 5
  // deg.
  ASSERT_TRUE(ChooseHeadAngles(
      HeadToolAxis(0.3, DegToRad(5.0)), &far, HeadLimits(), &h));
  EXPECT_NEAR(h.b_rad, DegToRad(5.0), 1e-12);
}

TEST(ChooseHeadAngles, BLimitForcesTheOtherTurn) {
  HeadLimits limits;
  limits.b_max_rad = DegToRad(181.0);
  const HeadAngles previous{0.3, DegToRad(175.0)};
  HeadAngles h;
  ASSERT_TRUE(ChooseHeadAngles(
      HeadToolAxis(0.3, DegToRad(185.0)), &previous, limits, &h));
  EXPECT_NEAR(h.b_rad,
              DegToRad(-175.0),
              1e-12);  // branch 2 (A = 162.8 deg) is outside the A limits
  EXPECT_NEAR(h.a_rad, 0.3, 1e-14);
}

TEST(ChooseHeadAngles, NearerBranchTwoWinsAndTiesGoToBranchOne) {
  HeadLimits wide;
  wide.a_min_rad = -kPi;
  wide.a_max_rad = kPi;
  HeadAngles h;
  // Previous near A = 100 deg: branch 2 of an axis at A1 = 80 deg, B1 = 0 is
  // (100 deg, 180 deg).
  const HeadAngles near_two{DegToRad(100.0), DegToRad(175.0)};
  ASSERT_TRUE(
      ChooseHeadAngles(HeadToolAxis(DegToRad(80.0), 0.0), &near_two, wide, &h));
  EXPECT_NEAR(h.a_rad, DegToRad(100.0), 1e-12);
  EXPECT_NEAR(h.b_rad, kPi, 1e-12);
  // Exactly equidistant: branch 1 (0.5, 0) and branch 2 (pi - 0.5, pi) from
  // (pi/2, pi/2).
  const HeadAngles middle{kPi / 2, kPi / 2};
  ASSERT_TRUE(ChooseHeadAngles(HeadToolAxis(0.5, 0.0), &middle, wide, &h));
  EXPECT_NEAR(h.a_rad, 0.5, 1e-14);
  EXPECT_EQ(h.b_rad, 0.0);
}

TEST(ChooseHeadAngles, ToolAlongYKeepsThePreviousB) {
  const HeadAngles previous{1.0, 0.7};
  HeadAngles h;
  ASSERT_TRUE(ChooseHeadAngles(
      Eigen::Vector3d(0.0, -1.0, 0.0), &previous, HeadLimits(), &h));
  EXPECT_NEAR(h.a_rad, kPi / 2, 1e-15);
  EXPECT_EQ(h.b_rad, 0.7);
}

TEST(ChooseHeadAngles, FirstPointAlongYTakesBZero) {
  HeadAngles h{1.0, 1.0};
  ASSERT_TRUE(ChooseHeadAngles(
      Eigen::Vector3d(0.0, 1.0, 0.0), nullptr, HeadLimits(), &h));
  EXPECT_NEAR(h.a_rad, -kPi / 2, 1e-15);
  EXPECT_EQ(h.b_rad, 0.0);
}

TEST(ChooseHeadAngles, NoCandidateWithinTheLimits) {
  HeadLimits narrow;
  narrow.a_min_rad = DegToRad(-10.0);
  narrow.a_max_rad = DegToRad(10.0);
  HeadAngles h;
  const HeadAngles previous{0.0, 0.0};
  EXPECT_FALSE(ChooseHeadAngles(
      HeadToolAxis(DegToRad(30.0), 0.2), &previous, narrow, &h));
  EXPECT_FALSE(
      ChooseHeadAngles(HeadToolAxis(DegToRad(30.0), 0.2), nullptr, narrow, &h));
}

class SplitBevelKinematics : public ::testing::TestWithParam<int> {
 protected:
  SplitBevelRequest request() const { return AllGears()[GetParam()].request; }
};
INSTANTIATE_TEST_SUITE_P(Gears,
                         SplitBevelKinematics,
                         ::testing::Values(0, 1, 2));

// §7 a: forward kinematics of every output gives its tool centre and axis in Si
// to 1e-9.
TEST_P(SplitBevelKinematics, InvariantA_ForwardKinematicsGivesCentreAndAxis) {
  const SplitBevelRequest r = request();
  const SplitBevelResult result = ComputeSplitTrajectory(r);
  ASSERT_TRUE(result.ok) << result.message;
  const double psi_mid = r.setup.segment_mid_rad.value_or(
      2 * kPi * r.cut.slot_index / r.gear.teeth);
  const Eigen::Matrix3d m = TestSetupRotation(psi_mid);
  EXPECT_LT((result.blank_to_machine.block<3, 3>(0, 0) - m).norm(), 1e-15);
  EXPECT_LT(
      (result.blank_to_machine.block<3, 1>(0, 3) - r.setup.apex_mm).norm(),
      1e-15);
  for (const SplitBevelPass& pass : result.passes) {
    for (const SplitBevelPoint& p : pass.points) {
      const Pose machine = TestForward(p.axes, r.machine.pivot_length_mm);
      const Eigen::Vector3d centre =
          m.transpose() * (machine.centre - r.setup.apex_mm);
      const Eigen::Vector3d axis = m.transpose() * machine.axis;
      EXPECT_LT((centre - p.tool_centre_mm).norm(), 1e-9);
      EXPECT_LT((axis - p.tool_axis).norm(), 1e-9);
      // And the engine's own forward function agrees.
      const ToolPose e = HeadForwardInBlank(
          p.axes, r.machine.pivot_length_mm, result.blank_to_machine);
      EXPECT_LT((e.centre_mm - p.tool_centre_mm).norm(), 1e-9);
      EXPECT_LT((e.axis - p.tool_axis).norm(), 1e-12);
      EXPECT_GE(p.axes.a_rad, r.machine.limits.a_min_rad);
      EXPECT_LE(p.axes.a_rad, r.machine.limits.a_max_rad);
      EXPECT_GE(p.axes.b_rad, r.machine.limits.b_min_rad);
      EXPECT_LE(p.axes.b_rad, r.machine.limits.b_max_rad);
    }
  }
}

// §7 f: consecutive points of a pass: |dA|, |dB| <= max(5 deg, 3 x the angle
// between their axes).
TEST_P(SplitBevelKinematics, InvariantF_ConsecutiveAnglesMoveLittle) {
  const SplitBevelResult result = ComputeSplitTrajectory(request());
  ASSERT_TRUE(result.ok) << result.message;
  for (const SplitBevelPass& pass : result.passes) {
    for (size_t j = 1; j < pass.points.size(); ++j) {
      const SplitBevelPoint &p = pass.points[j - 1], &q = pass.points[j];
      const double between =
          std::acos(std::clamp(p.tool_axis.dot(q.tool_axis), -1.0, 1.0));
      const double bound = std::max(DegToRad(5.0), 3.0 * between);
      EXPECT_LE(std::abs(q.axes.a_rad - p.axes.a_rad), bound);
      EXPECT_LE(std::abs(q.axes.b_rad - p.axes.b_rad), bound);
    }
  }
}

// §7 e: the other hand, slot -k, segment_mid -psi_mid and apex y negated mirror
// every vector (y -> -y in Si) and the axes (X, Z, B unchanged, Y -> -Y, A ->
// -A).
TEST_P(SplitBevelKinematics, InvariantE_MirrorBetweenHands) {
  const SplitBevelRequest r = request();
  SplitBevelRequest m = r;
  m.gear.hand = r.gear.hand == SplitBevelHand::kLeft ? SplitBevelHand::kRight
                                                     : SplitBevelHand::kLeft;
  m.cut.slot_index = -r.cut.slot_index;
  const double psi_mid = r.setup.segment_mid_rad.value_or(
      2 * kPi * r.cut.slot_index / r.gear.teeth);
  m.setup.segment_mid_rad = -psi_mid;
  m.setup.apex_mm.y() = -r.setup.apex_mm.y();
  const SplitBevelResult a = ComputeSplitTrajectory(r);
  const SplitBevelResult b = ComputeSplitTrajectory(m);
  ASSERT_TRUE(a.ok) << a.message;
  ASSERT_TRUE(b.ok) << b.message;
  ASSERT_EQ(a.passes.size(), b.passes.size());
  const Eigen::Vector3d flip(1.0, -1.0, 1.0);
  const auto mirrored = [&](const Eigen::Vector3d& u,
                            const Eigen::Vector3d& v) {
    return (u.cwiseProduct(flip) - v).norm();
  };
  for (size_t i = 0; i < a.passes.size(); ++i) {
    const SplitBevelPass &pa = a.passes[i], &pb = b.passes[i];
    ASSERT_EQ(pa.points.size(), pb.points.size());
    EXPECT_EQ(pa.flank, pb.flank);
    EXPECT_NEAR(pa.side_deviation_mm.min_mm, pb.side_deviation_mm.min_mm, 1e-9);
    EXPECT_NEAR(pa.side_deviation_mm.max_mm, pb.side_deviation_mm.max_mm, 1e-9);
    for (size_t j = 0; j < pa.points.size(); ++j) {
      const SplitBevelPoint &p = pa.points[j], &q = pb.points[j];
      EXPECT_LT(mirrored(p.pitch_point_mm, q.pitch_point_mm), 1e-9);
      EXPECT_LT(mirrored(p.flank_point_mm, q.flank_point_mm), 1e-9);
      EXPECT_LT(mirrored(p.flank_normal, q.flank_normal), 1e-12);
      EXPECT_LT(mirrored(p.tool_centre_mm, q.tool_centre_mm), 1e-9);
      EXPECT_LT(mirrored(p.tool_axis, q.tool_axis), 1e-12);
      EXPECT_NEAR(p.axes.x_mm, q.axes.x_mm, 1e-9);
      EXPECT_NEAR(p.axes.y_mm, -q.axes.y_mm, 1e-9);
      EXPECT_NEAR(p.axes.z_mm, q.axes.z_mm, 1e-9);
      EXPECT_NEAR(p.axes.a_rad, -q.axes.a_rad, 1e-12);
      EXPECT_NEAR(p.axes.b_rad, q.axes.b_rad, 1e-12);
    }
  }
}

TEST(ComputeSplitTrajectory, PointOutOfTheALimitsIsAnError) {
  SplitBevelRequest r = RightHandWheel();
  r.machine.limits.a_min_rad = DegToRad(-0.5);
  r.machine.limits.a_max_rad = DegToRad(0.5);
  std::string field, message;
  EXPECT_TRUE(r.IsValid(&field, &message)) << message;
  const SplitBevelResult result = ComputeSplitTrajectory(r);
  EXPECT_FALSE(result.ok);
  EXPECT_EQ(result.field, "machine.a_limits_deg");
  EXPECT_TRUE(result.passes.empty());
}

// Across passes too, each point's head position is the one nearest the previous
// point's: no jump of a turn or a branch where a pass starts again at the toe.
TEST_P(SplitBevelKinematics, AnglesContinueAcrossPasses) {
  const SplitBevelResult result = ComputeSplitTrajectory(request());
  ASSERT_TRUE(result.ok) << result.message;
  for (size_t i = 1; i < result.passes.size(); ++i) {
    const SplitBevelPoint& p = result.passes[i - 1].points.back();
    const SplitBevelPoint& q = result.passes[i].points.front();
    const double between =
        std::acos(std::clamp(p.tool_axis.dot(q.tool_axis), -1.0, 1.0));
    const double bound = std::max(DegToRad(5.0), 3.0 * between);
    EXPECT_LE(std::abs(q.axes.a_rad - p.axes.a_rad), bound);
    EXPECT_LE(std::abs(q.axes.b_rad - p.axes.b_rad), bound);
  }
}

}  // namespace
}  // namespace gearloop
