#include "engine/core/damped_newton.h"

#include <gtest/gtest.h>

#include <Eigen/LU>
#include <cmath>
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

}  // namespace
}  // namespace engine_internal
}  // namespace gearloop
