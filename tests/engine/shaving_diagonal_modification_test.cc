#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "engine/grinder/flank_grid.h"
#include "engine/shaving/diagonal_modification.h"
#include "tests/engine/shaving_test_cases.h"

namespace gearloop {
namespace {

// Central differences with step h [mm] on functions of size ~1..60 mm:
// truncation ~ h^2 f''' / 6 and rounding ~ 1e-16 |f| / h; with h = 1e-4 both
// are below 1e-7 (relative to the derivative's size).
constexpr double kStepMm = 1e-4;
constexpr double kFiniteDifferenceTol = 1e-7;

DiagonalModification TypeTwo() {
  DiagonalModification m = testing::CertifiedModification();
  m.root_um = 30.0;
  m.tip_um = 12.0;
  m.root_slope = 0.7;
  m.tip_slope = -0.4;
  m.root_band = 0.45;
  m.tip_band = 0.35;
  return m;
}

// Points inside both bands, between them, and one type per exponent.
struct Sample {
  double roll_mm, x_mm;
};
constexpr Sample kSamples[] = {{12.0, -30.0},
                               {14.0, -20.0},
                               {22.0, 0.0},
                               {31.0, 28.0},
                               {30.0, 15.0},
                               {26.0, 33.0}};

TEST(DiagonallyModifiedFlank, UnmodifiedIsTheModelInvolute) {
  const GearData pinion = testing::PublishedPinion();
  const DiagonallyModifiedFlank flank(pinion, DiagonalModification());
  for (const Sample& s : kSamples) {
    const ModifiedFlankPoint p = flank.At(s.roll_mm, s.x_mm);
    const FlankGridPoint q =
        InvoluteFlankPoint(pinion, Flank::kRight, s.roll_mm, s.x_mm);
    EXPECT_LT((p.position_mm - q.position_mm).norm(), 1e-12);
    EXPECT_LT((p.unmodified_normal - q.normal).norm(), 1e-12);
    EXPECT_LT((p.normal.normalized() - q.normal).norm(), 1e-12);
    EXPECT_EQ(p.relief.value_um, 0.0);
  }
}

// SHAVING.md §2: L + x tan(beta_b) is constant along a contact line, so are w
// and (type I) delta1; w is 0 and 1 at two corners of the active flank.
TEST(DiagonallyModifiedFlank, ReliefIsConstantAlongContactLines) {
  const GearData pinion = testing::PublishedPinion();
  const DiagonallyModifiedFlank flank(pinion, testing::CertifiedModification());
  const double tan_base = pinion.TanBaseHelixAngle();
  for (double t : {-20.0, -5.0, 7.0, 25.0}) {
    const double w0 = flank.ContactLineCoordinate(14.0, -10.0);
    EXPECT_NEAR(
        flank.ContactLineCoordinate(14.0 - t * tan_base, -10.0 + t), w0, 1e-14);
    EXPECT_NEAR(flank.Relief(14.0 - t * tan_base, -10.0 + t).value_um,
                flank.Relief(14.0, -10.0).value_um,
                1e-12);
  }
  const double half = 0.5 * pinion.face_width_mm;
  const double lf = flank.form_roll_length_mm(),
               la = flank.tip_roll_length_mm();
  // beta1 < 0 (right hand): tan(beta_b) < 0, so w is lowest at (L_f, +b/2) and
  // highest at (L_a, -b/2).
  EXPECT_NEAR(flank.ContactLineCoordinate(lf, half), 0.0, 1e-14);
  EXPECT_NEAR(flank.ContactLineCoordinate(la, -half), 1.0, 1e-14);
  EXPECT_NEAR(flank.Relief(lf, half).value_um, -20.0, 1e-12);
  EXPECT_NEAR(flank.Relief(la, -half).value_um, -20.0, 1e-12);
  const double w_mid_roll = 0.5 * (lf + la);
  EXPECT_EQ(flank.Relief(w_mid_roll, 0.0).value_um, 0.0);
  // Type II: C (1 + k eta) along the line.
  DiagonalModification m = testing::CertifiedModification();
  m.root_slope = 0.5;
  const DiagonallyModifiedFlank type2(pinion, m);
  EXPECT_NEAR(type2.Relief(lf, half).value_um, -20.0 * 1.5, 1e-12);
}

TEST(DiagonallyModifiedFlank, ReliefDerivativesMatchFiniteDifferences) {
  const GearData pinion = testing::PublishedPinion();
  for (const DiagonalModification& m :
       {testing::CertifiedModification(), TypeTwo()}) {
    const DiagonallyModifiedFlank flank(pinion, m);
    for (const Sample& s : kSamples) {
      const ReliefDerivatives r = flank.Relief(s.roll_mm, s.x_mm);
      const double h = kStepMm;
      const ReliefDerivatives lp = flank.Relief(s.roll_mm + h, s.x_mm),
                              lm = flank.Relief(s.roll_mm - h, s.x_mm);
      const ReliefDerivatives xp = flank.Relief(s.roll_mm, s.x_mm + h),
                              xm = flank.Relief(s.roll_mm, s.x_mm - h);
      const double scale = 1.0 + std::abs(r.value_um);
      EXPECT_NEAR(r.d_roll,
                  (lp.value_um - lm.value_um) / (2 * h),
                  kFiniteDifferenceTol * scale * 1e2);
      EXPECT_NEAR(r.d_x,
                  (xp.value_um - xm.value_um) / (2 * h),
                  kFiniteDifferenceTol * scale * 1e2);
      EXPECT_NEAR(r.d_roll_roll,
                  (lp.d_roll - lm.d_roll) / (2 * h),
                  kFiniteDifferenceTol * scale * 1e2);
      EXPECT_NEAR(r.d_roll_x,
                  (xp.d_roll - xm.d_roll) / (2 * h),
                  kFiniteDifferenceTol * scale * 1e2);
      EXPECT_NEAR(r.d_roll_x,
                  (lp.d_x - lm.d_x) / (2 * h),
                  kFiniteDifferenceTol * scale * 1e2);
      EXPECT_NEAR(r.d_x_x,
                  (xp.d_x - xm.d_x) / (2 * h),
                  kFiniteDifferenceTol * scale * 1e2);
    }
  }
}

// SHAVING.md §2: N1r = dR1r/dx x dR1r/dL from analytic derivatives; here
// against the cross product of central differences of R1r itself, and N1r's own
// derivatives against differences of N1r.
TEST(DiagonallyModifiedFlank, ModifiedNormalMatchesFiniteDifferences) {
  const GearData pinion = testing::PublishedPinion();
  for (const DiagonalModification& m :
       {testing::CertifiedModification(), TypeTwo()}) {
    const DiagonallyModifiedFlank flank(pinion, m);
    for (const Sample& s : kSamples) {
      const ModifiedFlankPoint p = flank.At(s.roll_mm, s.x_mm);
      const double h = kStepMm;
      const ModifiedFlankPoint lp = flank.At(s.roll_mm + h, s.x_mm),
                               lm = flank.At(s.roll_mm - h, s.x_mm);
      const ModifiedFlankPoint xp = flank.At(s.roll_mm, s.x_mm + h),
                               xm = flank.At(s.roll_mm, s.x_mm - h);
      const Eigen::Vector3d d_roll =
          (lp.position_mm - lm.position_mm) / (2 * h);
      const Eigen::Vector3d d_x = (xp.position_mm - xm.position_mm) / (2 * h);
      EXPECT_LT((p.d_roll - d_roll).norm(), kFiniteDifferenceTol);
      EXPECT_LT((p.d_x - d_x).norm(), kFiniteDifferenceTol);
      const Eigen::Vector3d normal = d_x.cross(d_roll);
      EXPECT_LT((p.normal.normalized() - normal.normalized()).norm(),
                kFiniteDifferenceTol);
      EXPECT_GT(p.normal.dot(p.unmodified_normal), 0.0);  // oriented like n1
      EXPECT_LT((p.d_normal_d_roll - (lp.normal - lm.normal) / (2 * h)).norm(),
                kFiniteDifferenceTol);
      EXPECT_LT((p.d_normal_d_x - (xp.normal - xm.normal) / (2 * h)).norm(),
                kFiniteDifferenceTol);
      // The relief moves the point along n1 by delta1.
      const FlankGridPoint q =
          InvoluteFlankPoint(pinion, Flank::kRight, s.roll_mm, s.x_mm);
      EXPECT_NEAR((p.position_mm - q.position_mm).dot(q.normal) * 1e3,
                  p.relief.value_um,
                  1e-9);
    }
  }
}

TEST(ValidateDiagonalModification, NamesTheField) {
  ValidationIssue issue;
  EXPECT_TRUE(
      ValidateDiagonalModification(testing::CertifiedModification(), &issue));
  DiagonalModification m = testing::CertifiedModification();
  m.exponent = 0;
  EXPECT_FALSE(ValidateDiagonalModification(m, &issue));
  EXPECT_EQ(issue.field, "exponent");
  m = testing::CertifiedModification();
  m.root_slope = -1.01;
  EXPECT_FALSE(ValidateDiagonalModification(m, &issue));
  EXPECT_EQ(issue.field, "root_slope");
}

}  // namespace
}  // namespace gearloop
