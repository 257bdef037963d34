#include "engine/core/sensitivity.h"

#include <gtest/gtest.h>

#include "engine/grinder/flat_wheel_grinder.h"
#include "tests/engine/test_gears.h"

namespace gearloop {
namespace {

TEST(AnalyzeSensitivity, KnownDiagonalMatrix) {
  Eigen::MatrixXd m = Eigen::MatrixXd::Zero(4, 3);
  m(0, 0) = 10.0;
  m(1, 1) = 1e-3;
  m(2, 2) = 1e-9;
  const SensitivitySummary s = AnalyzeSensitivity(m, Eigen::VectorXd());
  ASSERT_EQ(s.singular_values.size(), 3);
  EXPECT_DOUBLE_EQ(s.singular_values(0), 10.0);
  EXPECT_EQ(s.rank, 2);
  EXPECT_NEAR(s.condition_number, 1e4, 1e-6);
  const SensitivitySummary scaled = AnalyzeSensitivity(m, UnitColumnScales(m));
  EXPECT_EQ(scaled.rank, 3);
  EXPECT_NEAR(scaled.condition_number, 1.0, 1e-12);
}

TEST(AnalyzeSensitivity, ZeroMatrixHasRankZero) {
  const SensitivitySummary s =
      AnalyzeSensitivity(Eigen::MatrixXd::Zero(3, 3), Eigen::VectorXd());
  EXPECT_EQ(s.rank, 0);
}

// MODEL.md §5: about 13 of 45 singular values of the raw S above 1e-6 of the
// largest, about 16-17 once the columns are normalised; d_w has no effect while
// a_w = 0.
TEST(AnalyzeSensitivity, CutterMatrixIsSeverelyRankDeficient) {
  const FlatWheelGrinder grinder(testing::CutterSetup());
  ModelEvaluation eval;
  grinder.Evaluate(grinder.nominal().ToVector(), true, &eval);
  const SensitivitySummary raw =
      AnalyzeSensitivity(eval.jacobian_um, Eigen::VectorXd());
  const SensitivitySummary normalised =
      AnalyzeSensitivity(eval.jacobian_um, UnitColumnScales(eval.jacobian_um));
  EXPECT_GE(raw.rank, 12);
  EXPECT_LE(raw.rank, 14);
  EXPECT_GE(normalised.rank, 16);
  EXPECT_LE(normalised.rank, 18);
  EXPECT_LT(eval.jacobian_um.col(kParabolaVertexIndex).norm(), 1e-12);
  // Translations along the wheel's own plane do not move the flank: the
  // combination of X, Y, Z offsets along the two in-plane directions of the
  // wheel has no effect.
  const double alpha = testing::Deg(20), beta = testing::Deg(15);
  // In-plane direction of the wheel face along the lead, in Sf: (cos b, 0, -sin
  // b); the machine axes count X and Z opposite to Sf (D = diag(-1, 1, -1)).
  const Eigen::Vector3d along_lead_machine(
      -std::cos(beta), 0.0, std::sin(beta));
  const Eigen::VectorXd lead_shift =
      eval.jacobian_um.col(ParameterIndex(Axis::kX, 0)) *
          along_lead_machine(0) +
      eval.jacobian_um.col(ParameterIndex(Axis::kZ, 0)) * along_lead_machine(2);
  EXPECT_LT(lead_shift.norm(),
            1e-9 * eval.jacobian_um.col(ParameterIndex(Axis::kZ, 0)).norm());
  // A shift of the wheel along its face normal n_w (away from the tooth) leaves
  // the same material everywhere: +1 mm per mm.
  const Eigen::Vector3d n_w(std::cos(alpha) * std::sin(beta),
                            std::sin(alpha),
                            std::cos(alpha) * std::cos(beta));
  const Eigen::VectorXd normal_shift =
      -eval.jacobian_um.col(ParameterIndex(Axis::kX, 0)) * n_w(0) +
      eval.jacobian_um.col(ParameterIndex(Axis::kY, 0)) * n_w(1) -
      eval.jacobian_um.col(ParameterIndex(Axis::kZ, 0)) * n_w(2);
  for (int i = 0; i < 45; ++i) EXPECT_NEAR(normal_shift(i), 1000.0, 1e-6) << i;
}

}  // namespace
}  // namespace gearloop
