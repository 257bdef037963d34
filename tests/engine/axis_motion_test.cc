#include "engine/core/axis_motion.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "engine/correction/correction.h"

namespace gearloop {
namespace {

// The grinder's layout (engine/grinder/flat_wheel_grinder.cc): six axis
// polynomials of 7 coefficients, X, Y, Z in mm and A, B, C in rad, then three
// wheel scalars.
std::vector<ParameterBlock> GrinderLikeBlocks() {
  std::vector<ParameterBlock> blocks;
  const char* names[6] = {"X", "Y", "Z", "A", "B", "C"};
  for (int i = 0; i < 6; ++i)
    blocks.push_back({names[i], i < 3 ? "mm" : "rad", 7 * i, 7, true, 1.0});
  blocks.push_back({"cone_angle", "rad", 42, 1, false, 1.0});
  blocks.push_back({"parabola_coefficient", "1/mm", 43, 1, false, 1.0});
  blocks.push_back({"parabola_vertex", "mm", 44, 1, false, 1.0});
  return blocks;
}

const BlockMotion& Block(const AxisMotion& motion, const std::string& name) {
  for (const BlockMotion& b : motion.blocks) {
    if (b.name == name) return b;
  }
  static const BlockMotion kNone;
  ADD_FAILURE() << "no block " << name;
  return kNone;
}

// dX = 1 + 8 phi - 40 phi^2 um over [-0.15, 0.13] rad: worked out by hand
// below.
TEST(ComputeAxisMotion, QuadraticByHand) {
  Eigen::VectorXd delta = Eigen::VectorXd::Zero(45);
  delta(0) = 1e-3;    // X0 [mm]
  delta(1) = 8e-3;    // X1 [mm/rad]
  delta(2) = -40e-3;  // X2 [mm/rad^2]
  const double a = -0.15, b = 0.13;
  const AxisMotion motion = ComputeAxisMotion(GrinderLikeBlocks(), delta, a, b);

  ASSERT_EQ(motion.roll_rad.size(), 9u);
  EXPECT_DOUBLE_EQ(motion.roll_rad.front(), a);
  EXPECT_DOUBLE_EQ(motion.roll_rad.back(), b);
  EXPECT_NEAR(motion.roll_rad[1],
              -0.115,
              /*tol_rad=*/1e-15);  // step (b - a) / 8 = 0.035

  const BlockMotion& x = Block(motion, "X");
  EXPECT_TRUE(x.is_polynomial);
  EXPECT_EQ(x.unit, "um");
  ASSERT_EQ(x.change.size(), 9u);
  // Samples by hand: phi = -0.15: 1 - 1.2 - 0.9 = -1.1; phi = -0.01: 1 - 0.08 -
  // 0.004 = 0.916; phi = 0.095: 1 + 0.76 - 0.361 = 1.399; phi = 0.13: 1 + 1.04
  // - 0.676 = 1.364.
  const double kTolUm = 1e-12;
  EXPECT_NEAR(x.change[0], -1.1, kTolUm);
  EXPECT_NEAR(x.change[4], 0.916, kTolUm);
  EXPECT_NEAR(x.change[7], 1.399, kTolUm);
  EXPECT_NEAR(x.change[8], 1.364, kTolUm);
  // The largest motion lies between samples, at the vertex phi = 0.1: 1 + 0.8 -
  // 0.4 = 1.4.
  EXPECT_NEAR(x.max_abs, 1.4, 1e-9);
  // mean of dX^2 = 1/(b - a) [t + 8 t^2 - 16/3 t^3 - 160 t^4 + 320 t^5]_a^b
  // (dX^2 = 1 + 16 t - 16 t^2 - 640 t^3 + 1600 t^4).
  auto antiderivative = [](double t) {
    return t + 8 * t * t - 16.0 / 3.0 * t * t * t - 160 * std::pow(t, 4) +
           320 * std::pow(t, 5);
  };
  const double rms =
      std::sqrt((antiderivative(b) - antiderivative(a)) / (b - a));
  EXPECT_NEAR(x.rms, rms, kTolUm);

  // Unchanged axes move by nothing.
  const BlockMotion& y = Block(motion, "Y");
  for (double v : y.change) EXPECT_EQ(v, 0.0);
  EXPECT_EQ(y.rms, 0.0);
  EXPECT_EQ(y.max_abs, 0.0);
}

// The alarming case: coefficients of hundreds of mm (and rad) on phi^6 that
// cancel inside the roll range. dA = 1 urad * T6(phi / 0.2), T6(x) = 32 x^6 -
// 48 x^4 + 18 x^2 - 1 (Chebyshev): A6 = 32 / 0.2^6 urad = 0.5 rad (about 29
// deg), yet |dA| <= 1 urad over [-0.2, 0.2], with mean T6^2 = (1 - 1/(4*36 -
// 1)) / 2 = 71/143.
TEST(ComputeAxisMotion, LargeCancellingCoefficientsAreSmallMotion) {
  const double h = 0.2;
  Eigen::VectorXd delta = Eigen::VectorXd::Zero(45);
  const int a0 = 21;  // A0
  delta(a0 + 0) = -1.0e-6;
  delta(a0 + 2) = 18.0e-6 / std::pow(h, 2);
  delta(a0 + 4) = -48.0e-6 / std::pow(h, 4);
  delta(a0 + 6) = 32.0e-6 / std::pow(h, 6);
  ASSERT_NEAR(delta(a0 + 6), 0.5, 1e-12);
  // The same shape in mm on Z: Z6 = 500 mm, |dZ| <= 1 um.
  for (int k = 0; k < 7; ++k) delta(14 + k) = delta(a0 + k) * 1e3;
  ASSERT_NEAR(delta(14 + 6), 500.0, 1e-9);

  const AxisMotion motion =
      ComputeAxisMotion(GrinderLikeBlocks(), delta, -h, h);
  for (const char* name : {"A", "Z"}) {
    const BlockMotion& axis = Block(motion, name);
    EXPECT_EQ(axis.unit, std::string(name) == "A" ? "urad" : "um");
    ASSERT_EQ(axis.change.size(), 9u);
    for (int i = 0; i < 9; ++i) {
      const double x = -1.0 + 0.25 * i;  // the samples in units of h
      EXPECT_NEAR(axis.change[i], std::cos(6.0 * std::acos(x)), 1e-9)
          << name << " sample " << i;
    }
    EXPECT_NEAR(axis.max_abs, 1.0, 1e-9) << name;
    EXPECT_NEAR(axis.rms, std::sqrt(71.0 / 143.0), 1e-9) << name;
  }
}

TEST(ComputeAxisMotion, ScalarBlocksInTheirOwnUnits) {
  Eigen::VectorXd delta = Eigen::VectorXd::Zero(45);
  delta(42) = -2.5e-6;  // cone angle [rad]
  delta(43) = 3e-5;     // parabola coefficient [1/mm]
  delta(44) = -0.75;    // parabola vertex [mm]
  const AxisMotion motion =
      ComputeAxisMotion(GrinderLikeBlocks(), delta, -0.25, 0.13);
  ASSERT_EQ(motion.blocks.size(), 9u);
  const BlockMotion& cone = Block(motion, "cone_angle");
  EXPECT_FALSE(cone.is_polynomial);
  EXPECT_EQ(cone.unit, "rad");
  ASSERT_EQ(cone.change.size(), 1u);
  EXPECT_EQ(cone.change[0], -2.5e-6);
  EXPECT_EQ(cone.max_abs, 2.5e-6);
  EXPECT_EQ(Block(motion, "parabola_coefficient").unit, "1/mm");
  EXPECT_EQ(Block(motion, "parabola_coefficient").change[0], 3e-5);
  EXPECT_EQ(Block(motion, "parabola_vertex").unit, "mm");
  EXPECT_EQ(Block(motion, "parabola_vertex").change[0], -0.75);
  EXPECT_EQ(Block(motion, "parabola_vertex").rms, 0.75);
}

// The per-block correction size (engine/correction/correction.h) is the rms
// motion over the range divided by the block's scale: both measure the same
// axis motion.
TEST(ComputeAxisMotion, RmsAgreesWithCorrectionSize) {
  Eigen::VectorXd delta(45);
  for (int j = 0; j < 45; ++j)
    delta(j) = 1e-4 * std::sin(1.7 * j + 0.3) / (1 + j % 7);
  const double a = -0.25, b = 0.13;
  const std::vector<ParameterBlock> blocks = GrinderLikeBlocks();
  std::vector<BlockCorrectionSize> sizes;
  CorrectionSize(blocks, delta, a, b, {}, &sizes);  // scales 1 mm, 1 rad, ...
  const AxisMotion motion = ComputeAxisMotion(blocks, delta, a, b);
  ASSERT_EQ(sizes.size(), motion.blocks.size());
  for (size_t i = 0; i < sizes.size(); ++i) {
    const BlockMotion& m = motion.blocks[i];
    const double factor =
        m.unit == "um" ? 1e3
                       : (m.unit == "urad" && m.is_polynomial ? 1e6 : 1.0);
    EXPECT_NEAR(m.rms / factor, sizes[i].size, 1e-12 * (1.0 + sizes[i].size))
        << m.name;
    EXPECT_GE(m.max_abs, m.rms * (1.0 - 1e-12)) << m.name;
  }
}

TEST(ComputeAxisMotion, DegenerateRanges) {
  Eigen::VectorXd delta = Eigen::VectorXd::Zero(45);
  delta(0) = 2e-3;
  delta(1) = 1e-2;
  // A point: every sample there, rms = max = |dX(0.1)| = 2 + 1 = 3 um.
  AxisMotion point = ComputeAxisMotion(GrinderLikeBlocks(), delta, 0.1, 0.1);
  ASSERT_EQ(point.roll_rad.size(), 9u);
  EXPECT_NEAR(Block(point, "X").rms, 3.0, 1e-12);
  EXPECT_NEAR(Block(point, "X").max_abs, 3.0, 1e-12);
  // Reversed or not finite: no samples, NaN figures for polynomials, scalars
  // still reported.
  for (const auto& [lo, hi] : std::vector<std::pair<double, double>>{
           {0.2, 0.1}, {std::nan(""), 0.1}}) {
    const AxisMotion none =
        ComputeAxisMotion(GrinderLikeBlocks(), delta, lo, hi);
    EXPECT_TRUE(none.roll_rad.empty());
    EXPECT_TRUE(Block(none, "X").change.empty());
    EXPECT_TRUE(std::isnan(Block(none, "X").rms));
    EXPECT_EQ(Block(none, "cone_angle").change.size(), 1u);
  }
  // A short delta: blocks past its end are NaN, not read out of bounds.
  const AxisMotion short_delta = ComputeAxisMotion(
      GrinderLikeBlocks(), Eigen::VectorXd::Zero(10), -0.1, 0.1);
  EXPECT_TRUE(std::isnan(Block(short_delta, "Y").rms));
  EXPECT_TRUE(std::isnan(Block(short_delta, "cone_angle").change[0]));
  // Another sample count.
  EXPECT_EQ(ComputeAxisMotion(GrinderLikeBlocks(), delta, -0.1, 0.1, 3)
                .roll_rad.size(),
            3u);
}

TEST(AxisMotionUnitFactor, LinearAndRotary) {
  std::string unit;
  EXPECT_EQ(AxisMotionUnitFactor("mm", &unit), 1e3);
  EXPECT_EQ(unit, "um");
  EXPECT_EQ(AxisMotionUnitFactor("rad", &unit), 1e6);
  EXPECT_EQ(unit, "urad");
  EXPECT_EQ(AxisMotionUnitFactor("1/mm", &unit), 1.0);
  EXPECT_EQ(unit, "1/mm");
}

}  // namespace
}  // namespace gearloop
