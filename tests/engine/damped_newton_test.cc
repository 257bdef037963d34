#include "engine/core/damped_newton.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <cmath>
#include <cstdint>
#include <random>

namespace gearloop {
namespace engine_internal {
namespace {

constexpr int kNumRandomSystems = 2000;

// The written-out solve gives exactly Eigen's partialPivLu().solve numbers
// (the contact Newtons' answers must not move with it), on random systems,
// badly scaled ones, and ones whose pivots tie.
template <int N>
void ExpectSameAsEigen(std::mt19937_64* rng) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::uniform_int_distribution<int> exponent(-8, 8);
  for (int trial = 0; trial < kNumRandomSystems; ++trial) {
    Eigen::Matrix<double, N, N> a;
    Eigen::Matrix<double, N, 1> b;
    for (int i = 0; i < N; ++i) {
      const double row_scale = std::ldexp(1.0, exponent(*rng));
      for (int j = 0; j < N; ++j) a(i, j) = row_scale * unit(*rng);
      b(i) = unit(*rng);
    }
    if (trial % 4 == 1) a(N - 1, 0) = -a(0, 0);  // tied pivots
    if (trial % 4 == 2) a.col(N - 1).head(N - 1).setZero();
    const Eigen::Matrix<double, N, 1> eigen = a.partialPivLu().solve(b);
    const Eigen::Matrix<double, N, 1> ours = SolveByPartialPivoting<N>(a, b);
    for (int i = 0; i < N; ++i) {
      if (std::isnan(eigen(i))) {
        EXPECT_TRUE(std::isnan(ours(i))) << "N " << N << " trial " << trial;
      } else {
        EXPECT_EQ(ours(i), eigen(i)) << "N " << N << " trial " << trial;
      }
    }
  }
}

TEST(SolveByPartialPivoting, SameNumbersAsEigenPartialPivLu) {
  std::mt19937_64 rng(20261123);
  ExpectSameAsEigen<2>(&rng);
  ExpectSameAsEigen<3>(&rng);
  ExpectSameAsEigen<4>(&rng);
}

TEST(SolveByPartialPivoting, SingularSystemGivesNonFiniteStep) {
  Eigen::Matrix3d a;
  a << 1.0, 2.0, 3.0, 2.0, 4.0, 6.0, 0.0, 1.0, 1.0;
  const Eigen::Vector3d x =
      SolveByPartialPivoting<3>(a, Eigen::Vector3d(1.0, 1.0, 1.0));
  EXPECT_FALSE(x.allFinite());
}

// The contact on a normal line: the step by the tangents and Cramer's rule is
// LU's step to rounding, on random systems whose last column is (-n, 0),
// scaled as the grinder's are (u_w in mm, phi_w and the roll in rad on radii
// of 100-2000 mm, the meshing row in its own units).
constexpr double kNormalLineStepRelTol = 1e-10;

// A random contact system on a normal line: unit normal n, the last column
// (-n, 0), the columns scaled as the grinder's.
struct RandomNormalLineSystem {
  explicit RandomNormalLineSystem(std::uint64_t seed) : rng(seed) {}
  void Next(Eigen::Vector3d* n, Eigen::Matrix4d* jacobian) {
    *n = Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).normalized();
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 3; ++j) (*jacobian)(i, j) = unit(rng);
    jacobian->col(1) *= radius_mm(rng);
    jacobian->col(2) *= radius_mm(rng);
    jacobian->row(3) *= std::ldexp(1.0, exponent(rng));
    jacobian->block<3, 1>(0, 3) = -*n;
    (*jacobian)(3, 3) = 0.0;
  }
  std::mt19937_64 rng;
  std::uniform_real_distribution<double> unit{-1.0, 1.0};
  std::uniform_real_distribution<double> radius_mm{100.0, 2000.0};
  std::uniform_int_distribution<int> exponent{-6, 6};
};

// A contact system on the normal line n = e_z whose meshing row lies in the
// span of the tangent rows: M is singular.
Eigen::Matrix4d SingularNormalLineSystem() {
  Eigen::Matrix4d jacobian;
  jacobian << 1.0, 2.0, 0.0, 0.0,  //
      0.0, 1.0, 3.0, 0.0,          //
      0.5, 0.5, 0.5, -1.0,         //
      1.0, 3.0, 3.0, 0.0;          // = row 0 + row 1 over x3
  return jacobian;
}

TEST(NormalLineNewtonStep, SameStepAsPartialPivotingToRounding) {
  RandomNormalLineSystem systems(20261129);
  double worst = 0.0;
  for (int trial = 0; trial < kNumRandomSystems; ++trial) {
    Eigen::Vector3d n;
    Eigen::Matrix4d jacobian;
    systems.Next(&n, &jacobian);
    auto& unit = systems.unit;
    auto& rng = systems.rng;
    const Eigen::Vector4d g(unit(rng), unit(rng), unit(rng), unit(rng));
    const Eigen::Vector4d lu = SolveByPartialPivoting<4>(jacobian, -g);
    const Eigen::Vector4d ours =
        NormalLineNewtonStep(jacobian, g, n, NormalLineTangents(n));
    ASSERT_TRUE(ours.allFinite()) << "trial " << trial;
    // Each unknown against its own size in the step (the step's entries
    // differ by the radii), through the residual the step leaves.
    const Eigen::Vector4d left = jacobian * ours + g;
    const double scale = (jacobian.cwiseAbs() * ours.cwiseAbs()).maxCoeff() +
                         g.cwiseAbs().maxCoeff();
    worst = std::max(worst, left.cwiseAbs().maxCoeff() / scale);
    for (int i = 0; i < 4; ++i) {
      EXPECT_NEAR(ours(i),
                  lu(i),
                  kNormalLineStepRelTol *
                      (std::abs(lu(i)) + lu.cwiseAbs().maxCoeff() * 1e-3))
          << "trial " << trial << " unknown " << i;
    }
  }
  EXPECT_LT(worst, 1e-14);
}

// The row of J^-1 that gives dlambda: LU's solve of J^T y = e_4 to rounding,
// on the same random systems.
TEST(NormalLineNewtonStep, LambdaRowIsTheTransposedSolve) {
  RandomNormalLineSystem systems(20261130);
  for (int trial = 0; trial < kNumRandomSystems; ++trial) {
    Eigen::Vector3d n;
    Eigen::Matrix4d jacobian;
    systems.Next(&n, &jacobian);
    const Eigen::Vector4d lu =
        jacobian.transpose().partialPivLu().solve(Eigen::Vector4d::UnitW());
    const Eigen::Vector4d ours =
        NormalLineLambdaRow(jacobian, n, NormalLineTangents(n));
    ASSERT_TRUE(ours.allFinite()) << "trial " << trial;
    for (int i = 0; i < 4; ++i) {
      EXPECT_NEAR(ours(i),
                  lu(i),
                  kNormalLineStepRelTol *
                      (std::abs(lu(i)) + lu.cwiseAbs().maxCoeff() * 1e-3))
          << "trial " << trial << " entry " << i;
    }
  }
  // The singular system: no finite row.
  const Eigen::Vector3d n(0.0, 0.0, 1.0);
  EXPECT_FALSE(
      NormalLineLambdaRow(SingularNormalLineSystem(), n, NormalLineTangents(n))
          .allFinite());
}

TEST(NormalLineNewtonStep, TangentsAreOrthonormalAndNormalToN) {
  for (const Eigen::Vector3d& n :
       {Eigen::Vector3d(0.0, 0.0, 1.0),
        Eigen::Vector3d(1.0, 0.0, 0.0),
        Eigen::Vector3d(0.3, -0.4, 0.5).normalized()}) {
    const Eigen::Matrix<double, 2, 3> t = NormalLineTangents(n);
    EXPECT_NEAR(
        (t * t.transpose() - Eigen::Matrix2d::Identity()).norm(), 0.0, 1e-15);
    EXPECT_NEAR((t * n).norm(), 0.0, 1e-15);
  }
}

// A meshing row in the span of the tangent rows leaves M singular: the step is
// not finite, and Newton stops there without moving.
TEST(NormalLineNewtonStep, SingularSystemGivesNonFiniteStep) {
  const Eigen::Vector3d n(0.0, 0.0, 1.0);
  const Eigen::Matrix4d jacobian = SingularNormalLineSystem();
  const Eigen::Vector4d g(1.0, 1.0, 1.0, 1.0);
  EXPECT_FALSE(
      NormalLineNewtonStep(jacobian, g, n, NormalLineTangents(n)).allFinite());
  Eigen::Vector4d x = Eigen::Vector4d::Zero();
  const DampedNewtonSummary summary = DampedNewtonBySteps<4>(
      DampedNewtonOptions{},
      Eigen::Vector4d::Ones(),
      [&](const Eigen::Vector4d&, Eigen::Vector4d* dx) {
        *dx = NormalLineNewtonStep(jacobian, g, n, NormalLineTangents(n));
      },
      &x);
  EXPECT_FALSE(summary.converged);
  EXPECT_EQ(summary.num_iterations, 0);
  EXPECT_TRUE(x.isZero(0.0));
}

// The stop without a confirming iteration: only when two whole steps fell
// steeply and the next is predicted below a tenth of the tolerance.
TEST(NextStepBelow, OnlyInTheQuadraticRegime) {
  const double tol_mm = 1e-11;
  EXPECT_TRUE(NextStepBelow(1e-3, 1e-7, tol_mm));   // next about 1e-15
  EXPECT_FALSE(NextStepBelow(1e-3, 5e-6, tol_mm));  // next about 1.3e-10
  EXPECT_FALSE(NextStepBelow(1e-6, 1e-7, tol_mm));  // a slow, linear fall
  EXPECT_FALSE(NextStepBelow(-1.0, 1e-9, tol_mm));  // no whole step before
  EXPECT_FALSE(NextStepBelow(0.0, 1e-9, tol_mm));
}

// x^2 + y^2 = 4, x = y: a simple root, reached to within the tolerance, and
// without the confirming iteration (the step after the last is below it).
TEST(DampedNewton, StopsAtASimpleRootWithinTheTolerance) {
  const DampedNewtonOptions options;
  const auto system = [](const Eigen::Vector2d& x,
                         Eigen::Vector2d* g,
                         Eigen::Matrix2d* jacobian) {
    *g << x(0) * x(0) + x(1) * x(1) - 4.0, x(0) - x(1);
    *jacobian << 2.0 * x(0), 2.0 * x(1), 1.0, -1.0;
  };
  Eigen::Vector2d x(3.0, 1.0);
  const DampedNewtonSummary summary =
      DampedNewton<2>(options, Eigen::Vector2d::Ones(), system, &x);
  ASSERT_TRUE(summary.converged);
  EXPECT_LT(
      (x - Eigen::Vector2d::Constant(std::sqrt(2.0))).cwiseAbs().maxCoeff(),
      options.step_tolerance_mm);
  // One more Newton step from the answer moves it by less than the tolerance.
  Eigen::Vector2d g;
  Eigen::Matrix2d jacobian;
  system(x, &g, &jacobian);
  const Eigen::Vector2d dx = SolveByPartialPivoting<2>(jacobian, -g);
  EXPECT_LT(dx.cwiseAbs().maxCoeff(), 0.1 * options.step_tolerance_mm);
  EXPECT_LE(summary.num_iterations, 6);
}

// x^2 = 0: a double root, where Newton only halves its distance each step. The
// steps never fall steeply, so it runs on until a step is below the tolerance.
TEST(DampedNewton, RunsOnAtADoubleRootUntilTheStepIsBelowTheTolerance) {
  const DampedNewtonOptions options{200, 1e-11, 20.0};
  Eigen::Matrix<double, 1, 1> x;
  x << 1.0;
  const DampedNewtonSummary summary = DampedNewton<1>(
      options,
      Eigen::Matrix<double, 1, 1>::Ones(),
      [](const Eigen::Matrix<double, 1, 1>& x,
         Eigen::Matrix<double, 1, 1>* g,
         Eigen::Matrix<double, 1, 1>* jacobian) {
        (*g)(0) = x(0) * x(0);
        (*jacobian)(0, 0) = 2.0 * x(0);
      },
      &x);
  ASSERT_TRUE(summary.converged);
  EXPECT_LT(std::abs(x(0)), 2.0 * options.step_tolerance_mm);
  EXPECT_GE(summary.num_iterations, 36);  // 2^-36 ~ 1.5e-11
}

}  // namespace
}  // namespace engine_internal
}  // namespace gearloop
