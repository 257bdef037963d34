#include "engine/grinder/target_modification.h"

#include <cmath>

#include <Eigen/QR>
#include <gtest/gtest.h>

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
  double At(const Eigen::VectorXd& t, int row, int column) const { return t(row * grid.columns + column); }
};

TEST(TargetModification, KindNamesRoundTrip) {
  for (ModificationKind kind :
       {ModificationKind::kProfileCrowning, ModificationKind::kLeadCrowning, ModificationKind::kProfileSlope,
        ModificationKind::kHelixSlope, ModificationKind::kTipRelief, ModificationKind::kRootRelief,
        ModificationKind::kEndRelief, ModificationKind::kFlankTwist, ModificationKind::kDiagonalEndRelief}) {
    ModificationKind parsed = ModificationKind::kProfileCrowning;
    ASSERT_TRUE(ParseModificationKind(ModificationKindName(kind), &parsed)) << ModificationKindName(kind);
    EXPECT_EQ(parsed, kind);
  }
  ModificationKind parsed;
  EXPECT_FALSE(ParseModificationKind("barrelling", &parsed));
}

// The default 5 x 9 grid: rows at xi = 0, 1/4, ..., 1 and columns at eta = -1, -3/4, ..., 1.
TEST(TargetModification, CoordinatesSpanTheGrid) {
  const Grid g(testing::CutterSetup());
  const TargetCoordinates c = ComputeTargetCoordinates(g.grid, g.setup.gear, g.setup.flank);
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
  const Eigen::VectorXd profile = g.Evaluate({{ModificationKind::kProfileCrowning, 3.0}});
  EXPECT_NEAR(g.At(profile, 0, 3), -3.0, kTolUm);
  EXPECT_NEAR(g.At(profile, 4, 3), -3.0, kTolUm);
  EXPECT_NEAR(g.At(profile, 2, 3), 0.0, kTolUm);
  EXPECT_NEAR(g.At(profile, 1, 3), -0.75, kTolUm);
  const Eigen::VectorXd lead = g.Evaluate({{ModificationKind::kLeadCrowning, 5.0}});
  EXPECT_NEAR(g.At(lead, 2, 0), -5.0, kTolUm);
  EXPECT_NEAR(g.At(lead, 2, 8), -5.0, kTolUm);
  EXPECT_NEAR(g.At(lead, 2, 4), 0.0, kTolUm);
  const Eigen::VectorXd slope = g.Evaluate({{ModificationKind::kProfileSlope, 4.0}});
  EXPECT_NEAR(g.At(slope, 4, 1) - g.At(slope, 0, 1), 4.0, kTolUm);
  EXPECT_NEAR(g.At(slope, 2, 1), 0.0, kTolUm);
  const Eigen::VectorXd helix = g.Evaluate({{ModificationKind::kHelixSlope, -3.0}});
  EXPECT_NEAR(g.At(helix, 3, 8) - g.At(helix, 3, 0), -3.0, kTolUm);
  const Eigen::VectorXd twist = g.Evaluate({{ModificationKind::kFlankTwist, 4.0}});
  EXPECT_NEAR(g.At(twist, 4, 8), 2.0, kTolUm);   // (1 - 1/2) * 1 * 4
  EXPECT_NEAR(g.At(twist, 0, 8), -2.0, kTolUm);
  EXPECT_NEAR(g.At(twist, 4, 0), -2.0, kTolUm);
  EXPECT_NEAR(g.At(twist, 2, 5), 0.0, kTolUm);
}

TEST(TargetModification, ReliefsLinearAndParabolic) {
  const Grid g(testing::CutterSetup());
  TargetModification tip{ModificationKind::kTipRelief, 8.0, 0.5};
  Eigen::VectorXd t = g.Evaluate({tip});
  EXPECT_NEAR(g.At(t, 4, 2), -8.0, kTolUm);
  EXPECT_NEAR(g.At(t, 3, 2), -4.0, kTolUm);  // xi = 0.75: half way into the relief
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
  const TargetModification b{ModificationKind::kTipRelief, 5.0, 0.3, ReliefShape::kParabolic};
  const TargetModification c{ModificationKind::kFlankTwist, -3.0};
  const Eigen::VectorXd sum = g.Evaluate({a, b, c});
  const Eigen::VectorXd parts = g.Evaluate({a}) + g.Evaluate({b}) + g.Evaluate({c});
  EXPECT_LT((sum - parts).cwiseAbs().maxCoeff(), kTolUm);
  EXPECT_LT(g.Evaluate({}).cwiseAbs().maxCoeff(), kTolUm);
}

// w = L - x tan(beta_b) must be constant along a contact line of the generating plane: with the
// nominal settings every grid point is ground at one roll angle phi1, and the points sharing a
// contact line share phi1. So w must be an affine function of the nominal contact roll, on both
// flanks and both hands (this checks the sign convention of MODEL.md §7 against the engine).
TEST(TargetModification, DiagonalCoordinateFollowsContactLines) {
  for (const GrindingSetup& setup :
       {testing::CutterSetup(Flank::kRight), testing::CutterSetup(Flank::kLeft),
        testing::RightHandSetup(Flank::kRight), testing::RightHandSetup(Flank::kLeft)}) {
    const FlatWheelGrinder grinder(setup);
    ModelEvaluation eval;
    grinder.Evaluate(grinder.nominal().ToVector(), false, &eval);
    const TargetCoordinates c = ComputeTargetCoordinates(grinder.grid(), setup.gear, setup.flank);
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
    EXPECT_LT(misfit, 1e-3) << "flank " << (setup.flank == Flank::kLeft ? "left" : "right") << ", beta "
                            << setup.gear.helix_angle_rad;
  }
}

TEST(TargetModification, DiagonalEndReliefAtBothEnds) {
  const Grid g(testing::CutterSetup());
  const TargetCoordinates c = ComputeTargetCoordinates(g.grid, g.setup.gear, g.setup.flank);
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
