// tests/engine/test_statistics.h: statistics the engine tests compare against.
#ifndef GEARLOOP_TESTS_ENGINE_TEST_STATISTICS_H_
#define GEARLOOP_TESTS_ENGINE_TEST_STATISTICS_H_

#include <cmath>

namespace gearloop {
namespace testing {

// The upper 99% quantile of chi^2 with k degrees of freedom by the
// Wilson-Hilferty cube-root approximation (relative error below 0.2% for k >=
// 3).
inline double ChiSquared99(int k) {
  const double z = 2.326348;  // standard normal 99% quantile
  const double a = 2.0 / (9.0 * k);
  return k * std::pow(1.0 - a + z * std::sqrt(a), 3.0);
}

// The least-squares noise floor of issue 3: the rms flank error a fit of k
// directions leaves with probability 0.99 when the best reachable rms is r and
// N points carry noise sigma.
inline double NoiseFloorUm(double best_reachable_rms_um,
                           double sigma_um,
                           int k,
                           int num_points) {
  return std::sqrt(best_reachable_rms_um * best_reachable_rms_um +
                   sigma_um * sigma_um * ChiSquared99(k) / num_points);
}

}  // namespace testing
}  // namespace gearloop

#endif  // GEARLOOP_TESTS_ENGINE_TEST_STATISTICS_H_
