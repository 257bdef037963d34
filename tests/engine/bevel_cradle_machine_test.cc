// Tests of the cradle-type hypoid generator (engine/bevel/cradle_machine.h):
// the published pinion's summary, the generated flank as an envelope, and the
// grid on it.
#include <gtest/gtest.h>

#include <cmath>

#include "engine/bevel/cradle_machine.h"
#include "engine/core/units.h"

namespace gearloop {
namespace {

class CradleSides : public ::testing::TestWithParam<BevelFlankSide> {};

TEST_P(CradleSides, PublishedJobIsValidAndGridIsFound) {
  const BevelPinionJob job = PublishedPinionJob(GetParam());
  std::string field, message;
  ASSERT_TRUE(job.IsValid(&field, &message)) << field << ": " << message;
  const BevelFlankGrid grid = CradleGenerator(job).BuildGrid();
  ASSERT_TRUE(grid.ok) << grid.message;
  EXPECT_EQ(grid.NumPoints(), 45);
  EXPECT_LT(grid.roll_min_rad, grid.roll_max_rad);
}

// Every grid point lies on the cradle flank: f = n . v = 0 at its contact, at
// the requested cone distance and polar angle, and its normal is the cutter
// normal reversed.
TEST_P(CradleSides, GridPointsSatisfyMeshingEquation) {
  const BevelPinionJob job = PublishedPinionJob(GetParam());
  const CradleGenerator cradle(job);
  const BevelFlankGrid grid = cradle.BuildGrid();
  ASSERT_TRUE(grid.ok) << grid.message;
  const double tol_meshing_mm =
      1e-9;  // f is a velocity [mm/rad] along a unit normal
  const double tol_position_mm = 1e-9;
  for (const BevelGridPoint& p : grid.points) {
    ASSERT_EQ(p.contact.status, PointStatus::kOk) << p.row << "," << p.column;
    Eigen::Vector3d n;
    double f = 1.0;
    const Eigen::Vector3d r = cradle.SurfacePoint(p.contact.blade_u_mm,
                                                  p.contact.cutter_theta_rad,
                                                  p.contact.roll_rad,
                                                  &n,
                                                  &f);
    EXPECT_NEAR(f, 0.0, tol_meshing_mm);
    EXPECT_LT((r - p.position_mm).norm(), tol_position_mm);
    EXPECT_NEAR(r.norm(), p.cone_distance_mm, tol_position_mm);
    EXPECT_NEAR(
        std::atan2(std::hypot(r.y(), r.z()), r.x()), p.polar_angle_rad, 1e-12);
    EXPECT_NEAR((n + p.normal).norm(), 0.0, 1e-12);
  }
}

// The analytic meshing function equals n . dR1/dt taken by central differences
// of the chain, so the velocity in the meshing equation belongs to the chain
// that places the cutter.
TEST_P(CradleSides, MeshingFunctionIsNormalVelocityOfChain) {
  const CradleGenerator cradle(PublishedPinionJob(GetParam()));
  const double h = 1e-5;
  const double tol_mm_per_rad = 1e-5;
  for (double u : {-1.0, 3.0, 12.0}) {
    for (double theta : {2.5, 2.9, 3.1}) {
      for (double t : {-0.1, 0.05, 0.2}) {
        Eigen::Vector3d n;
        double f = 0.0;
        cradle.SurfacePoint(u, theta, t, &n, &f);
        const Eigen::Vector3d forward =
            cradle.SurfacePoint(u, theta, t + h, nullptr, nullptr);
        const Eigen::Vector3d backward =
            cradle.SurfacePoint(u, theta, t - h, nullptr, nullptr);
        EXPECT_NEAR(f, n.dot(forward - backward) / (2.0 * h), tol_mm_per_rad)
            << u << " " << theta << " " << t;
      }
    }
  }
}

// The envelope touches and does not cut: at a grid point's contact the cutter
// at nearby rolls stays on the cutter side of the flank's tangent plane to
// second order (the distance of the contact circle's nearest point from the
// tangent plane changes by O(dt^2), not O(dt)).
TEST_P(CradleSides, CutterTouchesFlankToFirstOrderInRoll) {
  const CradleGenerator cradle(PublishedPinionJob(GetParam()));
  const BevelFlankGrid grid = cradle.BuildGrid();
  ASSERT_TRUE(grid.ok);
  const BevelGridPoint& p = grid.points[22];
  const double dt = 1e-3;
  for (double sign : {-1.0, 1.0}) {
    // Along the cutter's fixed surface point, the normal offset grows like
    // dt^2.
    const Eigen::Vector3d moved =
        cradle.SurfacePoint(p.contact.blade_u_mm,
                            p.contact.cutter_theta_rad,
                            p.contact.roll_rad + sign * dt,
                            nullptr,
                            nullptr);
    const double offset_mm = p.normal.dot(moved - p.position_mm);
    const double travel_mm = (moved - p.position_mm).norm();
    EXPECT_GT(travel_mm, 0.05);  // the point really moves (~0.1 mm)
    EXPECT_LT(std::abs(offset_mm),
              1e-2 * travel_mm);  // but not across the flank (O(dt^2))
  }
}

TEST(ComputeCradleGeometry, PublishedConvexSummary) {
  const BevelPinionJob job = PublishedPinionJob(BevelFlankSide::kConvex);
  const CradleGeometry g = ComputeCradleGeometry(job.machine);
  // Double eccentric: S_r = 2 K2 sin(beta / 2), q = Q + beta / 2 - 90 deg.
  EXPECT_NEAR(g.radial_distance_mm,
              2.0 * 111.125 * std::sin(0.5 * (102.0 + 6.0 / 60.0) * kRadPerDeg),
              1e-12);
  EXPECT_NEAR(g.cutter_centre_c_mm.norm(), g.radial_distance_mm, 1e-9);
  EXPECT_NEAR(g.cutter_azimuth_rad,
              (104.0 + 56.0 / 60.0 + 51.05 - 90.0) * kRadPerDeg,
              1e-12);
  // Tilt from the tilt-mechanism rotation: i = 2 asin(sin 7.5 deg |sin(I_x /
  // 2)|) = 13.36 deg.
  const double expected_tilt =
      2.0 * std::asin(std::sin(7.5 * kRadPerDeg) *
                      std::abs(std::sin(0.5 * job.machine.tilt_rotation_rad)));
  EXPECT_NEAR(g.tilt_rad, expected_tilt, 1e-12);
  EXPECT_NEAR(g.tilt_rad / kRadPerDeg, 13.36, 0.01);
  // The cutter axis lies on the cone of the tilt axis: its angle to the tilt
  // axis is kappa.
  EXPECT_NEAR(std::acos(g.cradle_from_cutter.col(2).dot(g.tilt_axis_c)),
              7.5 * kRadPerDeg,
              1e-12);
  // The work axis passes E1 below the machine centre.
  EXPECT_NEAR(g.apex_m_mm.y(), -42.62, 1e-12);
}

// At the centre roll the cutter axis in the work frame makes the angle 90 deg -
// B with the pinion axis; with no tilt B is the machine root angle, and the
// work rotates i0 times the cradle.
TEST(CradleWorkFromCutter, UntiltedCutterKeepsMachineRootAngle) {
  BevelPinionJob job = PublishedPinionJob(BevelFlankSide::kConvex);
  job.machine.tilt_rotation_rad = 0.0;
  for (double t : {-0.2, 0.0, 0.15}) {
    const RigidTransform w = CradleWorkFromCutter(job.machine, t);
    EXPECT_NEAR(
        std::asin(w.rotation(0, 2)), job.machine.machine_root_angle_rad, 1e-12);
  }
  // The cutter centre turns about the work axis by -(i0 - cos(gm)-part of the
  // cradle): check the pure work rotation by comparing against the frame
  // without it.
  const double t = 0.1;
  const RigidTransform w = CradleWorkFromCutter(job.machine, t);
  BevelPinionJob fixed = job;
  fixed.machine.ratio_of_roll = 0.0;
  const RigidTransform w0 = CradleWorkFromCutter(fixed.machine, t);
  const double c = std::cos(-job.machine.ratio_of_roll * t),
               s = std::sin(-job.machine.ratio_of_roll * t);
  Eigen::Matrix3d rot_x;
  rot_x << 1, 0, 0, 0, c, -s, 0, s, c;
  EXPECT_LT((w.rotation - rot_x * w0.rotation).cwiseAbs().maxCoeff(), 1e-14);
  EXPECT_LT(
      (w.translation_mm - rot_x * w0.translation_mm).cwiseAbs().maxCoeff(),
      1e-12);
}

// The choice of the tilt mechanism (axis inclined 7.5 deg, mounting 25 deg)
// makes the root line that the blade tip cuts run parallel to the blank's root
// cone on both published sides: the blade parameter of the root-side grid row
// is nearly the same along the face width.
TEST(CradleGenerator, RootRowRunsParallelToBlankRootCone) {
  const double tol_spread_mm[2] = {0.2, 1.0};
  int k = 0;
  for (BevelFlankSide side :
       {BevelFlankSide::kConvex, BevelFlankSide::kConcave}) {
    const BevelFlankGrid grid =
        CradleGenerator(PublishedPinionJob(side)).BuildGrid();
    ASSERT_TRUE(grid.ok);
    double lo = 1e9, hi = -1e9;
    for (int c = 0; c < grid.columns; ++c) {
      lo = std::min(lo, grid.points[c].contact.blade_u_mm);
      hi = std::max(hi, grid.points[c].contact.blade_u_mm);
    }
    EXPECT_LT(hi - lo, tol_spread_mm[k++]) << BevelFlankSideName(side);
  }
}

// Spiral hand: going from the toe to the heel along a grid row the tooth turns
// clockwise about +x1 seen from the back, i.e. counter-clockwise for an
// observer at the apex looking at the pinion face: a LEFT-hand pinion, with its
// offset E1 below centre (docs/bevel-machines.md).
TEST_P(CradleSides, PinionIsLeftHand) {
  const BevelFlankGrid grid =
      CradleGenerator(PublishedPinionJob(GetParam())).BuildGrid();
  ASSERT_TRUE(grid.ok);
  const int row = grid.rows / 2;
  double previous = 0.0;
  for (int c = 0; c < grid.columns; ++c) {
    const Eigen::Vector3d& p = grid.points[row * grid.columns + c].position_mm;
    const double angle = std::atan2(p.z(), p.y());
    if (c > 0) {
      EXPECT_LT(std::remainder(angle - previous, 2.0 * kPi), 0.0);
    }
    previous = angle;
  }
}

// Direction of roll: the work turns +i0 t about x1 while the cradle turns +t
// about z_m. With the opposite sense the straight blade generates nothing in
// the blank: the convex grid lands on the edge radius only and the concave
// flank is not found.
TEST(CradleGenerator, ReversedRollDoesNotGenerateWithTheBlade) {
  BevelPinionJob convex = PublishedPinionJob(BevelFlankSide::kConvex);
  convex.machine.ratio_of_roll = -convex.machine.ratio_of_roll;
  const BevelFlankGrid grid = CradleGenerator(convex).BuildGrid();
  for (const BevelGridPoint& p : grid.points) {
    if (p.contact.status != PointStatus::kNotConverged) {
      EXPECT_LT(p.contact.blade_u_mm, 0.0);
    }
  }
  BevelPinionJob concave = PublishedPinionJob(BevelFlankSide::kConcave);
  concave.machine.ratio_of_roll = -concave.machine.ratio_of_roll;
  EXPECT_FALSE(CradleGenerator(concave).BuildGrid().ok);
  // With the machine's sense both flanks are generated by the straight blade
  // (and, on the concave side, its edge radius near the root).
  const BevelFlankGrid nominal =
      CradleGenerator(PublishedPinionJob(BevelFlankSide::kConvex)).BuildGrid();
  for (const BevelGridPoint& p : nominal.points)
    EXPECT_GT(p.contact.blade_u_mm, 0.0);
}

TEST(BevelPinionJob, InvalidFieldIsNamed) {
  BevelPinionJob job = PublishedPinionJob(BevelFlankSide::kConvex);
  job.machine.ratio_of_roll = -1.0;
  std::string field, message;
  EXPECT_FALSE(job.IsValid(&field, &message));
  EXPECT_EQ(field, "machine.ratio_of_roll");
  job = PublishedPinionJob(BevelFlankSide::kConvex);
  job.blank.face_angle_rad = job.blank.root_angle_rad;
  EXPECT_FALSE(job.IsValid(&field, &message));
  EXPECT_EQ(field, "blank.face_angle_rad");
}

INSTANTIATE_TEST_SUITE_P(
    BothSides,
    CradleSides,
    ::testing::Values(BevelFlankSide::kConvex, BevelFlankSide::kConcave),
    [](const ::testing::TestParamInfo<BevelFlankSide>& info) {
      return std::string(BevelFlankSideName(info.param));
    });

}  // namespace
}  // namespace gearloop
