#include "engine/grinder/target_modification.h"

#include <gtest/gtest.h>

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <string>

#include "engine/grinder/flat_wheel_grinder.h"
#include "tests/engine/test_gears.h"

namespace gearloop {
namespace {

constexpr double kTolUm = 1e-12;

struct Grid {
  GrindingSetup setup;
  FlankGrid grid;
  explicit Grid(const GrindingSetup& s) : setup(s), grid(BuildFlankGrid(s)) {}
  Eigen::VectorXd Evaluate(const std::vector<TargetModification>& m) const {
    return EvaluateTargetModifications(m, grid, setup.gear, setup.flank);
  }
  double At(const Eigen::VectorXd& t, int row, int column) const {
    return t(row * grid.columns + column);
  }
};

TEST(TargetModification, KindNamesRoundTrip) {
  for (ModificationKind kind : {ModificationKind::kProfileCrowning,
                                ModificationKind::kLeadCrowning,
                                ModificationKind::kProfileSlope,
                                ModificationKind::kHelixSlope,
                                ModificationKind::kTipRelief,
                                ModificationKind::kRootRelief,
                                ModificationKind::kEndRelief,
                                ModificationKind::kFlankTwist,
                                ModificationKind::kDiagonalEndRelief}) {
    ModificationKind parsed = ModificationKind::kProfileCrowning;
    ASSERT_TRUE(ParseModificationKind(ModificationKindName(kind), &parsed))
        << ModificationKindName(kind);
    EXPECT_EQ(parsed, kind);
  }
  ModificationKind parsed;
  EXPECT_FALSE(ParseModificationKind("barrelling", &parsed));
}

// The default 5 x 9 grid: rows at xi = 0, 1/4, ..., 1 and columns at eta = -1,
// -3/4, ..., 1.
TEST(TargetModification, CoordinatesSpanTheGrid) {
  const Grid g(testing::CutterSetup());
  const TargetCoordinates c =
      ComputeTargetCoordinates(g.grid, g.setup.gear, g.setup.flank);
  for (int row = 0; row < 5; ++row) {
    for (int col = 0; col < 9; ++col) {
      EXPECT_NEAR(c.xi(row * 9 + col), row / 4.0, 1e-12);
      EXPECT_NEAR(c.eta(row * 9 + col), -1.0 + col / 4.0, 1e-12);
    }
  }
  EXPECT_NEAR(c.w.minCoeff(), 0.0, 1e-12);
  EXPECT_NEAR(c.w.maxCoeff(), 1.0, 1e-12);
}

TEST(TargetModification, CrowningsAndSlopes) {
  const Grid g(testing::CutterSetup());
  const Eigen::VectorXd profile =
      g.Evaluate({{ModificationKind::kProfileCrowning, 3.0}});
  EXPECT_NEAR(g.At(profile, 0, 3), -3.0, kTolUm);
  EXPECT_NEAR(g.At(profile, 4, 3), -3.0, kTolUm);
  EXPECT_NEAR(g.At(profile, 2, 3), 0.0, kTolUm);
  EXPECT_NEAR(g.At(profile, 1, 3), -0.75, kTolUm);
  const Eigen::VectorXd lead =
      g.Evaluate({{ModificationKind::kLeadCrowning, 5.0}});
  EXPECT_NEAR(g.At(lead, 2, 0), -5.0, kTolUm);
  EXPECT_NEAR(g.At(lead, 2, 8), -5.0, kTolUm);
  EXPECT_NEAR(g.At(lead, 2, 4), 0.0, kTolUm);
  const Eigen::VectorXd slope =
      g.Evaluate({{ModificationKind::kProfileSlope, 4.0}});
  EXPECT_NEAR(g.At(slope, 4, 1) - g.At(slope, 0, 1), 4.0, kTolUm);
  EXPECT_NEAR(g.At(slope, 2, 1), 0.0, kTolUm);
  const Eigen::VectorXd helix =
      g.Evaluate({{ModificationKind::kHelixSlope, -3.0}});
  EXPECT_NEAR(g.At(helix, 3, 8) - g.At(helix, 3, 0), -3.0, kTolUm);
  const Eigen::VectorXd twist =
      g.Evaluate({{ModificationKind::kFlankTwist, 4.0}});
  EXPECT_NEAR(g.At(twist, 4, 8), 2.0, kTolUm);  // (1 - 1/2) * 1 * 4
  EXPECT_NEAR(g.At(twist, 0, 8), -2.0, kTolUm);
  EXPECT_NEAR(g.At(twist, 4, 0), -2.0, kTolUm);
  EXPECT_NEAR(g.At(twist, 2, 5), 0.0, kTolUm);
}

TEST(TargetModification, ReliefsLinearAndParabolic) {
  const Grid g(testing::CutterSetup());
  TargetModification tip{ModificationKind::kTipRelief, 8.0, 0.5};
  Eigen::VectorXd t = g.Evaluate({tip});
  EXPECT_NEAR(g.At(t, 4, 2), -8.0, kTolUm);
  EXPECT_NEAR(
      g.At(t, 3, 2), -4.0, kTolUm);  // xi = 0.75: half way into the relief
  EXPECT_NEAR(g.At(t, 2, 2), 0.0, kTolUm);
  EXPECT_NEAR(g.At(t, 0, 2), 0.0, kTolUm);
  tip.shape = ReliefShape::kParabolic;
  t = g.Evaluate({tip});
  EXPECT_NEAR(g.At(t, 3, 2), -2.0, kTolUm);
  const TargetModification root{ModificationKind::kRootRelief, 6.0, 0.5};
  t = g.Evaluate({root});
  EXPECT_NEAR(g.At(t, 0, 7), -6.0, kTolUm);
  EXPECT_NEAR(g.At(t, 1, 7), -3.0, kTolUm);
  EXPECT_NEAR(g.At(t, 2, 7), 0.0, kTolUm);
  EXPECT_NEAR(g.At(t, 4, 7), 0.0, kTolUm);
  const TargetModification end{ModificationKind::kEndRelief, 10.0, 0.5};
  t = g.Evaluate({end});
  EXPECT_NEAR(g.At(t, 2, 0), -10.0, kTolUm);
  EXPECT_NEAR(g.At(t, 2, 8), -10.0, kTolUm);
  EXPECT_NEAR(g.At(t, 2, 1), -5.0, kTolUm);  // |eta| = 0.75
  EXPECT_NEAR(g.At(t, 2, 2), 0.0, kTolUm);   // |eta| = 0.5
  EXPECT_NEAR(g.At(t, 2, 4), 0.0, kTolUm);
}

TEST(TargetModification, SumOfModificationsAddsUp) {
  const Grid g(testing::RightHandSetup());
  const TargetModification a{ModificationKind::kProfileCrowning, 2.0};
  const TargetModification b{
      ModificationKind::kTipRelief, 5.0, 0.3, ReliefShape::kParabolic};
  const TargetModification c{ModificationKind::kFlankTwist, -3.0};
  const Eigen::VectorXd sum = g.Evaluate({a, b, c});
  const Eigen::VectorXd parts =
      g.Evaluate({a}) + g.Evaluate({b}) + g.Evaluate({c});
  EXPECT_LT((sum - parts).cwiseAbs().maxCoeff(), kTolUm);
  EXPECT_LT(g.Evaluate({}).cwiseAbs().maxCoeff(), kTolUm);
}

// w = L + s x tan(beta_b) (s = +1 right flank, -1 left, MODEL.md §7) must be
// constant along a contact line of the generating plane: with the nominal
// settings every grid point is ground at one roll angle phi1, and the points
// sharing a contact line share phi1. So w must be an affine function of the
// nominal contact roll, on both flanks and both hands.
TEST(TargetModification, DiagonalCoordinateFollowsContactLines) {
  for (const GrindingSetup& setup : {testing::CutterSetup(Flank::kRight),
                                     testing::CutterSetup(Flank::kLeft),
                                     testing::RightHandSetup(Flank::kRight),
                                     testing::RightHandSetup(Flank::kLeft)}) {
    const FlatWheelGrinder grinder(setup);
    ModelEvaluation eval;
    grinder.Evaluate(grinder.nominal().ToVector(), false, &eval);
    const TargetCoordinates c =
        ComputeTargetCoordinates(grinder.grid(), setup.gear, setup.flank);
    const int n = grinder.grid().NumPoints();
    Eigen::MatrixXd a(n, 2);
    Eigen::VectorXd roll(n);
    for (int i = 0; i < n; ++i) {
      ASSERT_EQ(eval.status[i], PointStatus::kOk);
      a(i, 0) = 1.0;
      a(i, 1) = eval.contact_roll_rad[i];
    }
    const Eigen::VectorXd fit = a.colPivHouseholderQr().solve(c.w);
    const double misfit = (a * fit - c.w).cwiseAbs().maxCoeff();
    EXPECT_LT(misfit, 1e-3)
        << "flank " << (setup.flank == Flank::kLeft ? "left" : "right")
        << ", beta " << setup.gear.helix_angle_rad;
  }
}

// The same property seen directly (issue 18): hold the roll phi1 of the middle
// grid point's contact, follow the flat wheel's instantaneous contact line
// across the face (for each phi_w the u_w where the meshing function of the
// FlatWheelGrinder vanishes), and read w at its points. w does not move along
// the line on either flank and either hand; with the other sign of the x term
// it moves by about b tan(beta_b) (the sign MODEL.md §7 printed before its
// correction).
TEST(TargetModification,
     DiagonalCoordinateIsConstantAlongTheInstantaneousContactLine) {
  for (const GrindingSetup& setup : {testing::CutterSetup(Flank::kRight),
                                     testing::CutterSetup(Flank::kLeft),
                                     testing::RightHandSetup(Flank::kRight),
                                     testing::RightHandSetup(Flank::kLeft)}) {
    const FlatWheelGrinder grinder(setup);
    const MachineSettings& nominal = grinder.nominal();
    const FlankGrid& grid = grinder.grid();
    const EnvelopeContact middle = grinder.SolveContact(nominal, grid.At(2, 4));
    ASSERT_EQ(middle.status, PointStatus::kOk);
    const GearData& gear = setup.gear;
    const double r_b = gear.BaseRadiusMm();
    const double half_span_rad =
        0.3 * gear.face_width_mm / setup.wheel.radius_mm;
    const double sign = setup.flank == Flank::kRight ? 1.0 : -1.0;
    // One row: 9 points of the contact line, then two corners of the grid that
    // fix the normalisation of w (ComputeTargetCoordinates normalises over the
    // points it is given).
    FlankGrid line;
    line.rows = 1;
    line.columns = 11;
    double wrong_min = 1e300, wrong_max = -1e300, x_min = 1e300, x_max = -1e300;
    for (int k = 0; k < 9; ++k) {
      const double phi_w = middle.wheel_phi_rad + half_span_rad * (k - 4) / 4.0;
      double u = middle.wheel_u_mm;
      double f = 0.0;
      for (int it = 0; it < 50;
           ++it) {  // Newton on f(u_w) with a central-difference slope
        grinder.SurfacePoint(nominal, u, phi_w, middle.roll_rad, &f);
        if (std::abs(f) < 1e-12) break;
        double fp = 0.0, fm = 0.0;
        grinder.SurfacePoint(nominal, u + 1e-6, phi_w, middle.roll_rad, &fp);
        grinder.SurfacePoint(nominal, u - 1e-6, phi_w, middle.roll_rad, &fm);
        u -= f / ((fp - fm) / 2e-6);
      }
      ASSERT_LT(std::abs(f), 1e-9);
      const Eigen::Vector3d p =
          grinder.SurfacePoint(nominal, u, phi_w, middle.roll_rad, nullptr);
      FlankGridPoint point;
      point.x_mm = p.x();
      point.radius_mm = std::hypot(p.y(), p.z());
      point.roll_length_mm =
          std::sqrt(point.radius_mm * point.radius_mm - r_b * r_b);
      line.points.push_back(point);
      const double wrong =
          point.roll_length_mm - sign * point.x_mm * gear.TanBaseHelixAngle();
      wrong_min = std::min(wrong_min, wrong);
      wrong_max = std::max(wrong_max, wrong);
      x_min = std::min(x_min, p.x());
      x_max = std::max(x_max, p.x());
    }
    line.points.push_back(grid.At(0, 0));
    line.points.push_back(grid.At(4, 8));
    const TargetCoordinates c =
        ComputeTargetCoordinates(line, gear, setup.flank);
    const std::string what =
        std::string(setup.flank == Flank::kLeft ? "left" : "right") +
        " flank, beta " + std::to_string(gear.helix_angle_rad);
    EXPECT_GT(x_max - x_min, 0.4 * gear.face_width_mm)
        << what;  // the line crosses the face
    const double spread = c.w.head(9).maxCoeff() - c.w.head(9).minCoeff();
    EXPECT_LT(spread, /*tol=*/1e-9) << what;
    EXPECT_GT(wrong_max - wrong_min,
              0.8 * (x_max - x_min) * std::abs(gear.TanBaseHelixAngle()))
        << what;
  }
}

TEST(TargetModification, DiagonalEndReliefAtBothEnds) {
  const Grid g(testing::CutterSetup());
  const TargetCoordinates c =
      ComputeTargetCoordinates(g.grid, g.setup.gear, g.setup.flank);
  TargetModification d{ModificationKind::kDiagonalEndRelief, 6.0, 0.3};
  d.second_amount_um = 4.0;
  d.second_length_fraction = 0.2;
  const Eigen::VectorXd t = g.Evaluate({d});
  int low = 0, high = 0;
  c.w.minCoeff(&low);
  c.w.maxCoeff(&high);
  EXPECT_NEAR(t(low), -6.0, kTolUm);
  EXPECT_NEAR(t(high), -4.0, kTolUm);
  for (int i = 0; i < t.size(); ++i) {
    if (c.w(i) >= 0.3 && c.w(i) <= 0.8) {
      EXPECT_NEAR(t(i), 0.0, kTolUm) << i;
    }
    EXPECT_LE(t(i), kTolUm);
  }
  // Amounts varying along the contact line: C_1 + g_1 eta.
  d.amount_gradient_um = 2.0;
  const Eigen::VectorXd varied = g.Evaluate({d});
  EXPECT_NEAR(varied(low), -(6.0 + 2.0 * c.eta(low)), kTolUm);
}

TEST(TargetModification, ValidationNamesTheField) {
  ValidationIssue issue;
  TargetModification m{ModificationKind::kTipRelief, 5.0, 0.0};
  EXPECT_FALSE(ValidateTargetModification(m, &issue));
  EXPECT_EQ(issue.field, "length_fraction");
  m.length_fraction = 0.3;
  m.amount_um = std::nan("");
  EXPECT_FALSE(ValidateTargetModification(m, &issue));
  EXPECT_EQ(issue.field, "amount_um");
  m.amount_um = 5.0;
  EXPECT_TRUE(ValidateTargetModification(m, &issue));
  TargetModification d{ModificationKind::kDiagonalEndRelief, 5.0, 0.3};
  d.second_length_fraction = 1.5;
  EXPECT_FALSE(ValidateTargetModification(d, &issue));
  EXPECT_EQ(issue.field, "second_length_fraction");
}

}  // namespace
}  // namespace gearloop
