#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "engine/grinder/flank_grid.h"
#include "engine/shaving/crossed_axis_mesh.h"
#include "engine/shaving/cutter_target.h"
#include "tests/engine/shaving_test_cases.h"

namespace gearloop {
namespace {

// SHAVING.md §4: certified grids are given to +-0.05 um.
constexpr double kCertifiedTolUm = 0.05;

// SHAVING.md §4, delta1 = 0, rows 1-4 of the default 5 x 9 grid [um].
constexpr double kCertifiedBase[4][9] = {
    {6.47, 3.50, 1.42, 0.26, 0.03, 0.77, 2.48, 5.20, 8.94},
    {7.20, 4.04, 1.77, 0.42, 0.00, 0.54, 2.05, 4.55, 8.08},
    {7.96, 4.62, 2.17, 0.62, 0.01, 0.35, 1.65, 3.95, 7.27},
    {8.76, 5.24, 2.60, 0.87, 0.06, 0.20, 1.30, 3.40, 6.50},
};
// C1 = C2 = 20 um, l1 = l2 = 0.3, e = 2, k = 0: rows 1 and 4 [um].
constexpr double kCertifiedModifiedRow1[9] = {
    12.29, 7.46, 3.88, 1.59, 0.58, 0.87, 2.48, 5.20, 8.94};
constexpr double kCertifiedModifiedRow4[9] = {
    8.76, 5.24, 2.60, 0.87, 0.06, 0.20, 1.47, 4.05, 7.96};

ShavingResult Solve(const ShavingInput& input,
                    const ShavingOptions& options = ShavingOptions()) {
  return ComputeShavingCutterTarget(options, input);
}

double At(const ShavingResult& r,
          const Eigen::VectorXd& grid,
          int row,
          int column) {
  return grid(row * r.columns + column);
}

TEST(ComputeShavingCutterTarget, CertifiedUnmodifiedGrid) {
  const ShavingResult r = Solve(testing::PublishedShaving());
  ASSERT_TRUE(r.summary.IsSolutionUsable()) << r.summary.BriefReport();
  EXPECT_NEAR(r.crossed_axes_angle_rad * kDegPerRad, 5.09, 1e-12);
  EXPECT_NEAR(r.centre_distance_mm, 172.7790, 5e-5);
  for (int row = 1; row <= 4; ++row) {
    for (int column = 0; column < 9; ++column) {
      ASSERT_EQ(r.status[row * 9 + column], ShavingPointStatus::kOk)
          << row << "," << column;
      EXPECT_NEAR(At(r, r.base_um, row, column),
                  kCertifiedBase[row - 1][column],
                  kCertifiedTolUm)
          << "row " << row << ", column " << column;
      // delta1 = 0: the modified solve is the unmodified one.
      EXPECT_NEAR(At(r, r.delta_s_um, row, column),
                  At(r, r.base_um, row, column),
                  1e-9);
    }
  }
}

TEST(ComputeShavingCutterTarget, CertifiedDiagonallyModifiedRows) {
  ShavingInput input = testing::PublishedShaving();
  input.diagonal_modification = testing::CertifiedModification();
  const ShavingResult r = Solve(input);
  ASSERT_TRUE(r.summary.IsSolutionUsable()) << r.summary.BriefReport();
  for (int column = 0; column < 9; ++column) {
    EXPECT_NEAR(At(r, r.delta_s_um, 1, column),
                kCertifiedModifiedRow1[column],
                kCertifiedTolUm)
        << column;
    EXPECT_NEAR(At(r, r.delta_s_um, 4, column),
                kCertifiedModifiedRow4[column],
                kCertifiedTolUm)
        << column;
    EXPECT_NEAR(
        At(r, r.base_um, 1, column), kCertifiedBase[0][column], kCertifiedTolUm)
        << column;
  }
}

// Row 0 (the cutter's root side) meshes beyond the pinion's standard tip: L1
// ~ 35.0 > L_a1 = 33.65.
TEST(ComputeShavingCutterTarget, RowZeroIsOutsideTheWorkFlank) {
  const ShavingResult r = Solve(testing::PublishedShaving());
  const GearData pinion = testing::PublishedPinion();
  EXPECT_NEAR(pinion.TipRollLengthMm(), 33.65, 5e-3);
  ASSERT_EQ(r.outside_work_flank.size(), 9u);
  EXPECT_TRUE(r.not_converged.empty());
  for (int column = 0; column < 9; ++column) {
    EXPECT_EQ(r.outside_work_flank[column].row, 0);
    EXPECT_EQ(r.outside_work_flank[column].column, column);
    EXPECT_EQ(r.status[column], ShavingPointStatus::kOutsideWorkFlank);
    EXPECT_TRUE(std::isnan(r.delta_s_um(column)));
    EXPECT_TRUE(std::isnan(r.stock_target_um(column)));
    // The contact is still reported: past the tip.
    EXPECT_NEAR(r.contacts[column].roll_length_mm, 35.0, 0.3) << column;
    EXPECT_GT(r.contacts[column].roll_length_mm, pinion.TipRollLengthMm());
  }
  EXPECT_EQ(r.summary.num_solved, 36);
}

TEST(ComputeShavingCutterTarget, StockTargetIsReferencedToTheHighestPoint) {
  ShavingInput input = testing::PublishedShaving();
  input.diagonal_modification = testing::CertifiedModification();
  const ShavingResult r = Solve(input);
  double max_delta = -1e300, max_stock = -1e300;
  for (int i = 0; i < r.summary.num_points; ++i) {
    if (r.status[i] != ShavingPointStatus::kOk) continue;
    max_delta = std::max(max_delta, r.delta_s_um(i));
    max_stock = std::max(max_stock, r.stock_target_um(i));
    EXPECT_LE(r.stock_target_um(i), 0.0);
  }
  EXPECT_EQ(max_stock, 0.0);
  for (int i = 0; i < r.summary.num_points; ++i) {
    if (r.status[i] != ShavingPointStatus::kOk) continue;
    EXPECT_NEAR(r.stock_target_um(i), r.delta_s_um(i) - max_delta, 1e-12);
  }
}

// Test (a): parallel axes (beta_s = -beta1, gamma = 0): the envelope of an
// involute is the involute. ShavingInput::IsValid refuses gamma = 0, so the
// mesh is built directly.
TEST(ComputeShavingCutterTarget, ParallelAxesGiveTheInvolute) {
  const GearData pinion = testing::PublishedPinion();
  GearData cutter = testing::PublishedCutter();
  cutter.helix_angle_rad = -pinion.helix_angle_rad;
  cutter.tip_radius_mm = 0.0;
  cutter.root_radius_mm = 0.0;
  cutter = WithStandardRadii(cutter);
  const CrossedAxisMesh mesh(
      DiagonallyModifiedFlank(pinion, DiagonalModification()),
      cutter.teeth,
      CrossedAxesAngleRad(pinion, cutter),
      pinion.PitchRadiusMm() + cutter.PitchRadiusMm());
  ASSERT_EQ(mesh.crossed_axes_angle_rad(), 0.0);
  GrindingSetup setup;
  setup.gear = cutter;
  const FlankGrid grid = BuildFlankGrid(setup);
  const ShavingOptions options;
  int generated = 0;
  for (const FlankGridPoint& q : grid.points) {
    Eigen::Vector4d start;
    if (!FindGlobalStart(options, mesh, q, &start)) continue;
    const ConjugatePointSolution s =
        RefineConjugatePoint(options, mesh, q, start);
    ASSERT_TRUE(s.converged) << q.row << "," << q.column;
    if (!mesh.work_flank().OnActiveFlank(s.unknowns(0), s.unknowns(1)))
      continue;
    ++generated;
    EXPECT_LT(std::abs(s.unknowns(3) * 1e3), /*tol_um=*/1e-3)
        << q.row << "," << q.column;
  }
  EXPECT_GE(generated, 27);
}

// Test (b): delta1 = 0 leaves material everywhere (delta_s >= 0) and touches
// the involute along the path of contact: on a fine lead grid (81 columns, 0.78
// mm apart) each profile row comes within a few nm of 0.
TEST(ComputeShavingCutterTarget,
     UnmodifiedEnvelopeTouchesAlongThePathOfContact) {
  ShavingInput input = testing::PublishedShaving();
  input.grid.lead_points = 81;
  const ShavingResult r = Solve(input);
  ASSERT_TRUE(r.summary.IsSolutionUsable());
  for (int row = 1; row < r.rows; ++row) {
    double row_min = std::numeric_limits<double>::infinity();
    for (int column = 0; column < r.columns; ++column) {
      const int i = row * r.columns + column;
      ASSERT_EQ(r.status[i], ShavingPointStatus::kOk);
      EXPECT_GE(r.base_um(i), /*tol_um=*/-1e-3);
      row_min = std::min(row_min, r.base_um(i));
    }
    EXPECT_LT(row_min, /*tol_um=*/5e-3) << "row " << row;
  }
}

// Test (c): transfer. delta_s(mod) - delta_s(0) ~ -delta1 at the conjugate
// point, within 5 % of max |delta1| (second-order effects); type I and type II,
// linear and parabolic.
TEST(ComputeShavingCutterTarget, ModificationTransfersToTheCutter) {
  DiagonalModification type2 = testing::CertifiedModification();
  type2.root_um = 15.0;
  type2.tip_um = 25.0;
  type2.root_slope = 0.5;
  type2.tip_slope = -0.8;
  type2.exponent = 1;
  type2.root_band = 0.4;
  for (const DiagonalModification& m :
       {testing::CertifiedModification(), type2}) {
    ShavingInput input = testing::PublishedShaving();
    input.diagonal_modification = m;
    const ShavingResult r = Solve(input);
    ASSERT_TRUE(r.summary.IsSolutionUsable());
    const double max_relief = std::max(m.root_um * (1 + std::abs(m.root_slope)),
                                       m.tip_um * (1 + std::abs(m.tip_slope)));
    int relieved = 0;
    for (int i = 0; i < r.summary.num_points; ++i) {
      if (r.status[i] != ShavingPointStatus::kOk) continue;
      const double transfer = r.delta_s_um(i) - r.base_um(i);
      EXPECT_NEAR(transfer, -r.contacts[i].work_relief_um, 0.05 * max_relief)
          << i;
      if (r.contacts[i].work_relief_um < -1.0) ++relieved;
    }
    EXPECT_GE(
        relieved,
        3);  // the test sees relieved points, not only the unmodified middle
  }
}

// Points are reported one by one: a Newton that cannot converge nulls its
// points, and a grid with no generated point is the one outcome that refuses
// the request (field "grid").
TEST(ComputeShavingCutterTarget, NotConvergedPointsAreReportedNotFatal) {
  ShavingOptions options;
  options.max_iterations = 1;
  const ShavingResult r = Solve(testing::PublishedShaving(), options);
  EXPECT_EQ(r.summary.termination,
            ShavingSummary::Termination::kNoPointGenerated);
  EXPECT_EQ(r.summary.field, "grid");
  EXPECT_EQ(r.not_converged.size() + r.outside_work_flank.size(), 45u);
  EXPECT_EQ(r.rows, 5);
  EXPECT_EQ(r.columns, 9);

  // A grid wholly on the cutter's root side, where no point meets the pinion's
  // flank.
  ShavingInput input = testing::PublishedShaving();
  input.grid.profile_begin = 0.0;
  input.grid.profile_end = 0.05;
  const ShavingResult root = Solve(input);
  EXPECT_EQ(root.summary.termination,
            ShavingSummary::Termination::kNoPointGenerated);
  EXPECT_EQ(root.summary.num_solved, 0);
  EXPECT_EQ(root.outside_work_flank.size() + root.not_converged.size(), 45u);
}

TEST(ComputeShavingCutterTarget, WheelCheckIsReported) {
  const ShavingResult r = Solve(testing::PublishedShaving());
  EXPECT_NEAR(r.contact_line_length_mm, 75.342, 5e-4);
  EXPECT_NEAR(r.wheel.wheel_radius_min_fixed_mm, 355.78, 5e-3);
  EXPECT_NEAR(r.wheel.wheel_radius_min_traversing_mm, 336.97, 5e-3);
}

struct Refusal {
  const char* what;
  void (*change)(ShavingInput*);
  const char* field;
  const char* words;  // part of the message
};

TEST(ShavingInput, IsValidNamesTheFieldOfSection7) {
  const Refusal refusals[] = {
      {"teeth",
       [](ShavingInput* i) { i->work_gear.teeth = 0; },
       "work_gear.teeth",
       "positive"},
      {"module",
       [](ShavingInput* i) { i->cutter.normal_module_mm = -6.0; },
       "cutter.normal_module_mm",
       "positive"},
      {"face",
       [](ShavingInput* i) { i->work_gear.face_width_mm = 0.0; },
       "work_gear.face_width_mm",
       "positive"},
      {"tip",
       [](ShavingInput* i) { i->cutter.tip_radius_mm = -1.0; },
       "cutter.tip_radius_mm",
       "positive"},
      {"root",
       [](ShavingInput* i) { i->work_gear.root_radius_mm = 0.0; },
       "work_gear.root_radius_mm",
       "positive"},
      {"helix",
       [](ShavingInput* i) { i->cutter.helix_angle_rad = testing::Deg(45.0); },
       "cutter.helix_angle_rad",
       "45"},
      {"tip below root",
       [](ShavingInput* i) { i->cutter.tip_radius_mm = 100.0; },
       "cutter.tip_radius_mm",
       "root radius"},
      {"h_s",
       [](ShavingInput* i) { i->wheel_check.h_s_mm = 0.0; },
       "wheel_check.h_s_mm",
       "positive"},
      {"base pitch",
       [](ShavingInput* i) {
         i->cutter.normal_pressure_angle_rad = testing::Deg(20.5);
       },
       "cutter.normal_module_mm",
       "not conjugate"},
      {"gamma",
       [](ShavingInput* i) { i->cutter.helix_angle_rad = testing::Deg(9.95); },
       "cutter.helix_angle_rad",
       "crossed-axes angle is zero: not plunge shaving"},
      {"a too large",
       [](ShavingInput* i) { i->centre_distance_mm = 184.78; },
       "centre_distance_mm",
       "no contact"},
      {"a too small",
       [](ShavingInput* i) { i->centre_distance_mm = 150.0; },
       "centre_distance_mm",
       "no contact"},
      {"amount",
       [](ShavingInput* i) { i->diagonal_modification.root_um = -1.0; },
       "diagonal_modification.root_um",
       "[0, 200]"},
      {"amount high",
       [](ShavingInput* i) { i->diagonal_modification.tip_um = 200.5; },
       "diagonal_modification.tip_um",
       "[0, 200]"},
      {"band",
       [](ShavingInput* i) { i->diagonal_modification.root_band = 0.0; },
       "diagonal_modification.root_band",
       "(0, 1]"},
      {"band high",
       [](ShavingInput* i) { i->diagonal_modification.tip_band = 1.5; },
       "diagonal_modification.tip_band",
       "(0, 1]"},
      {"exponent",
       [](ShavingInput* i) { i->diagonal_modification.exponent = 3; },
       "diagonal_modification.exponent",
       "1 (linear) or 2"},
      {"slope",
       [](ShavingInput* i) { i->diagonal_modification.tip_slope = 1.2; },
       "diagonal_modification.tip_slope",
       "[-1, 1]"},
      {"grid",
       [](ShavingInput* i) { i->grid.lead_points = 1; },
       "grid.lead_points",
       "between 2 and 101"},
  };
  ValidationIssue issue;
  ShavingInput valid = testing::PublishedShaving();
  valid.diagonal_modification = testing::CertifiedModification();
  ASSERT_TRUE(valid.IsValid(&issue)) << issue.field << ": " << issue.message;
  valid.centre_distance_mm = 172.779;
  ASSERT_TRUE(valid.IsValid(&issue)) << issue.field << ": " << issue.message;
  for (const Refusal& refusal : refusals) {
    ShavingInput input = valid;
    refusal.change(&input);
    issue = ValidationIssue();
    EXPECT_FALSE(input.IsValid(&issue)) << refusal.what;
    EXPECT_EQ(issue.field, refusal.field) << refusal.what;
    EXPECT_NE(issue.message.find(refusal.words), std::string::npos)
        << refusal.what << ": " << issue.message;
    // The computation refuses it the same way and solves nothing.
    const ShavingResult r = ComputeShavingCutterTarget(ShavingOptions(), input);
    EXPECT_EQ(r.summary.termination, ShavingSummary::Termination::kInvalidInput)
        << refusal.what;
    EXPECT_EQ(r.summary.field, refusal.field) << refusal.what;
  }
}

TEST(ShavingOptions, IsValid) {
  std::string error;
  EXPECT_TRUE(ShavingOptions().IsValid(&error));
  ShavingOptions options;
  options.num_start_angles = 1;
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_NE(error.find("num_start_angles"), std::string::npos);
}

TEST(WithStandardRadii, FillsOnlyUnsetRadii) {
  GearData g = testing::PublishedPinion();
  EXPECT_NEAR(g.tip_radius_mm, g.PitchRadiusMm() + 6.0, 1e-12);
  EXPECT_NEAR(g.root_radius_mm, g.PitchRadiusMm() - 7.5, 1e-12);
  g.tip_radius_mm = 64.0;
  EXPECT_EQ(WithStandardRadii(g).tip_radius_mm, 64.0);
}

}  // namespace
}  // namespace gearloop
