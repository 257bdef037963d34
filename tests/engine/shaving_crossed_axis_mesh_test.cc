#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "engine/grinder/flank_grid.h"
#include "engine/shaving/crossed_axis_mesh.h"
#include "tests/engine/shaving_test_cases.h"

namespace gearloop {
namespace {

CrossedAxisMesh PublishedMesh(const DiagonalModification& m) {
  const GearData pinion = testing::PublishedPinion();
  const GearData cutter = testing::PublishedCutter();
  return CrossedAxisMesh(DiagonallyModifiedFlank(pinion, m),
                         cutter.teeth,
                         CrossedAxesAngleRad(pinion, cutter),
                         pinion.PitchRadiusMm() + cutter.PitchRadiusMm());
}

// The Newton's analytic Jacobian (SHAVING.md §4) against central differences of
// the system itself. Step h = 1e-5 (mm, rad): truncation h^2 g''' / 6 ~ 1e-9
// for |g'''| up to ~100 (the theta1 column carries radii of ~170 mm), rounding
// 1e-16 * 170 / h ~ 2e-9; tolerance 1e-7 relative to 1 + |entry|, i.e. 50x
// above both.
TEST(ConjugatePointSystem, AnalyticJacobianMatchesCentralDifferences) {
  constexpr double kStep = 1e-5;
  constexpr double kJacobianTol = 1e-7;
  const GearData cutter = testing::PublishedCutter();
  GrindingSetup setup;
  setup.gear = cutter;
  const FlankGrid grid = BuildFlankGrid(setup);
  DiagonalModification type2 = testing::CertifiedModification();
  type2.root_slope = 0.6;
  type2.tip_slope = -0.3;
  DiagonalModification linear = type2;
  linear.exponent = 1;
  for (const DiagonalModification& m : {DiagonalModification(),
                                        testing::CertifiedModification(),
                                        type2,
                                        linear}) {
    const CrossedAxisMesh mesh = PublishedMesh(m);
    // Near the contacts of the example (L1, x1, theta1) and a little off them.
    const Eigen::Vector4d unknowns[] = {{21.86, 0.15, -0.05, 1e-3},
                                        {28.42, -30.55, 0.177, 5e-3},
                                        {8.92, 30.31, -0.397, 2e-3},
                                        {15.3, 23.0, -0.25, 0.0},
                                        {12.0, 33.0, -0.3, 1e-2},
                                        {31.5, -34.0, 0.2, -1e-3}};
    for (const FlankGridPoint& q :
         {grid.At(2, 4), grid.At(1, 0), grid.At(4, 8)}) {
      for (const Eigen::Vector4d& u : unknowns) {
        Eigen::Vector4d g;
        Eigen::Matrix4d jacobian;
        ConjugatePointSystem(mesh, q.position_mm, q.normal, u, &g, &jacobian);
        for (int j = 0; j < 4; ++j) {
          Eigen::Vector4d up = u, um = u, gp, gm;
          up(j) += kStep;
          um(j) -= kStep;
          ConjugatePointSystem(mesh, q.position_mm, q.normal, up, &gp, nullptr);
          ConjugatePointSystem(mesh, q.position_mm, q.normal, um, &gm, nullptr);
          const Eigen::Vector4d column = (gp - gm) / (2.0 * kStep);
          for (int i = 0; i < 4; ++i) {
            EXPECT_NEAR(jacobian(i, j),
                        column(i),
                        kJacobianTol * (1.0 + std::abs(column(i))))
                << "row " << i << ", column " << j << " at " << u.transpose();
          }
        }
      }
    }
  }
}

TEST(CrossedAxisMesh, FramesAndPhase) {
  const CrossedAxisMesh mesh = PublishedMesh(DiagonalModification());
  EXPECT_NEAR(mesh.crossed_axes_angle_rad(), testing::Deg(5.09), 1e-15);
  EXPECT_NEAR(mesh.ratio(), 19.0 / 37.0, 1e-15);
  EXPECT_NEAR(mesh.CutterAngleRad(0.0), -kPi / 37.0, 1e-15);
  // x_t = Rot_y(gamma) e_x.
  const double g = mesh.crossed_axes_angle_rad();
  EXPECT_LT(
      (mesh.CutterAxis() - Eigen::Vector3d(std::cos(g), 0.0, -std::sin(g)))
          .norm(),
      1e-15);
  // CutterToWork inverts the P_s map.
  for (double theta1 : {-0.4, 0.0, 0.3}) {
    const MeshEvaluation m = mesh.Evaluate(20.0, 5.0, theta1);
    const Eigen::Vector3d back = mesh.CutterToWork(m.cutter_point_mm, theta1);
    EXPECT_LT((back - mesh.work_flank().At(20.0, 5.0).position_mm).norm(),
              1e-12);
  }
  // Zero backlash with this phase: the middle grid point of the cutter, carried
  // into S1 at its contact angle, lies on the pinion's flank (found by the
  // contact solve: lambda ~ 0 there).
  const GearData cutter = testing::PublishedCutter();
  GrindingSetup setup;
  setup.gear = cutter;
  const FlankGridPoint q = BuildFlankGrid(setup).At(2, 4);
  const Eigen::Vector3d p1 = mesh.CutterToWork(q.position_mm, -0.05);
  const double r = std::hypot(p1.y(), p1.z());
  const double rb = testing::PublishedPinion().BaseRadiusMm();
  const FlankGridPoint f = InvoluteFlankPoint(testing::PublishedPinion(),
                                              Flank::kRight,
                                              std::sqrt(r * r - rb * rb),
                                              p1.x());
  EXPECT_LT(std::abs(std::remainder(
                std::atan2(p1.z(), p1.y()) -
                    std::atan2(f.position_mm.z(), f.position_mm.y()),
                2 * kPi)) *
                r,
            0.01);
}

// The meshing function is the normal component of the relative velocity: zero
// when the flank normal is perpendicular to it; the velocity is that of gear 1
// minus that of the cutter.
TEST(CrossedAxisMesh, RelativeVelocityIsTheDifferenceOfTheTwoRotations) {
  const CrossedAxisMesh mesh = PublishedMesh(DiagonalModification());
  const double theta1 = 0.1, h = 1e-6;
  const MeshEvaluation m = mesh.Evaluate(22.0, -4.0, theta1);
  // A point fixed on the cutter, seen in Sf, moves with -(z1/z_s) x_t x (P_f -
  // a e_y) per unit theta1; a point fixed on gear 1 with e_x x P_f. Check the
  // cutter part through CutterToWork.
  const Eigen::Vector3d on_cutter = m.cutter_point_mm;
  auto in_sf = [&](double t) {
    const Eigen::Vector3d p1 = mesh.CutterToWork(on_cutter, t);
    return Eigen::Vector3d(p1.x(),
                           std::cos(t) * p1.y() - std::sin(t) * p1.z(),
                           std::sin(t) * p1.y() + std::cos(t) * p1.z());
  };
  const Eigen::Vector3d cutter_velocity =
      (in_sf(theta1 + h) - in_sf(theta1 - h)) / (2 * h);
  const Eigen::Vector3d work_velocity =
      Eigen::Vector3d::UnitX().cross(m.work_point_mm);
  EXPECT_LT((m.velocity_mm - (work_velocity - cutter_velocity)).norm(), 1e-6);
  EXPECT_NEAR(m.meshing, m.work_normal.dot(m.velocity_mm), 1e-12);
}

}  // namespace
}  // namespace gearloop
