// Step 1 of the correction (correction.h): orthonormal Legendre coordinates per
// parameter block, and the public correction size built on them.
#include "engine/correction/legendre_coordinates.h"

#include <Eigen/Core>
#include <cmath>

#include "engine/correction/correction.h"

namespace gearloop {
namespace correction_internal {

Eigen::MatrixXd LegendreToMonomial(int n,
                                   double roll_min_rad,
                                   double roll_max_rad) {
  double c = 0.5 * (roll_min_rad + roll_max_rad);
  double h = 0.5 * (roll_max_rad - roll_min_rad);
  if (!(h > 0.0)) {  // no roll range known: fall back to [-1, 1]
    c = 0.0;
    h = 1.0;
  }
  // Legendre polynomials in s as monomial coefficients in s: p(k, j) multiplies
  // s^j.
  Eigen::MatrixXd p = Eigen::MatrixXd::Zero(n, n);
  p(0, 0) = 1.0;
  if (n > 1) p(1, 1) = 1.0;
  for (int k = 1; k + 1 < n; ++k) {
    for (int j = 0; j < n; ++j) {
      double v = -k * p(k - 1, j);
      if (j > 0) v += (2 * k + 1) * p(k, j - 1);
      p(k + 1, j) = v / (k + 1);
    }
  }
  // s^j = ((phi - c) / h)^j = sum_i binom(j, i) phi^i (-c)^(j-i) / h^j.
  Eigen::MatrixXd s_to_phi =
      Eigen::MatrixXd::Zero(n, n);  // (i, j): coefficient of phi^i in s^j
  for (int j = 0; j < n; ++j) {
    double binom = 1.0;
    for (int i = 0; i <= j; ++i) {
      if (i > 0) binom = binom * (j - i + 1) / i;
      s_to_phi(i, j) = binom * std::pow(-c, j - i) / std::pow(h, j);
    }
  }
  Eigen::MatrixXd l(n, n);
  for (int k = 0; k < n; ++k) {
    l.col(k) = std::sqrt(2.0 * k + 1.0) * (s_to_phi * p.row(k).transpose());
  }
  return l;
}

double BlockScale(const ParameterBlock& block,
                  const std::map<std::string, double>& scales) {
  const auto it = scales.find(block.name);
  return it != scales.end() ? it->second : block.default_scale;
}

// The linear map coordinates -> delta for all coefficients of all blocks
// (square, block diagonal).
Eigen::MatrixXd CoordinateMap(const std::vector<ParameterBlock>& blocks,
                              int num_parameters,
                              double roll_min_rad,
                              double roll_max_rad,
                              const std::map<std::string, double>& scales) {
  Eigen::MatrixXd t = Eigen::MatrixXd::Zero(num_parameters, num_parameters);
  // One basis change per polynomial degree: the axes share it (the six axes
  // made it six times, 1 % of a correction's instructions).
  std::map<int, Eigen::MatrixXd> basis_change;
  for (const ParameterBlock& b : blocks) {
    const double s = BlockScale(b, scales);
    if (b.is_polynomial) {
      auto known = basis_change.find(b.num_coefficients);
      if (known == basis_change.end()) {
        known =
            basis_change
                .emplace(b.num_coefficients,
                         LegendreToMonomial(
                             b.num_coefficients, roll_min_rad, roll_max_rad))
                .first;
      }
      t.block(b.first_index,
              b.first_index,
              b.num_coefficients,
              b.num_coefficients) = s * known->second;
    } else {
      for (int k = 0; k < b.num_coefficients; ++k)
        t(b.first_index + k, b.first_index + k) = s;
    }
  }
  return t;
}

}  // namespace correction_internal

using correction_internal::CoordinateMap;

Eigen::VectorXd DeltaFromCorrectionCoordinates(
    const std::vector<ParameterBlock>& blocks,
    const Eigen::VectorXd& coordinates,
    double roll_min_rad,
    double roll_max_rad,
    const std::map<std::string, double>& block_scales) {
  return CoordinateMap(blocks,
                       static_cast<int>(coordinates.size()),
                       roll_min_rad,
                       roll_max_rad,
                       block_scales) *
         coordinates;
}

Eigen::VectorXd CorrectionCoordinates(
    const std::vector<ParameterBlock>& blocks,
    const Eigen::VectorXd& delta,
    double roll_min_rad,
    double roll_max_rad,
    const std::map<std::string, double>& block_scales) {
  const Eigen::MatrixXd t = CoordinateMap(blocks,
                                          static_cast<int>(delta.size()),
                                          roll_min_rad,
                                          roll_max_rad,
                                          block_scales);
  // Block diagonal and each block upper triangular: a triangular solve per
  // block is exact.
  Eigen::VectorXd y = Eigen::VectorXd::Zero(delta.size());
  for (const ParameterBlock& b : blocks) {
    const int f = b.first_index, n = b.num_coefficients;
    y.segment(f, n) = t.block(f, f, n, n)
                          .triangularView<Eigen::Upper>()
                          .solve(delta.segment(f, n));
  }
  return y;
}

double CorrectionSize(const std::vector<ParameterBlock>& blocks,
                      const Eigen::VectorXd& delta,
                      double roll_min_rad,
                      double roll_max_rad,
                      const std::map<std::string, double>& block_scales,
                      std::vector<BlockCorrectionSize>* block_sizes) {
  const Eigen::VectorXd y = CorrectionCoordinates(
      blocks, delta, roll_min_rad, roll_max_rad, block_scales);
  if (block_sizes != nullptr) block_sizes->clear();
  double total2 = 0.0;
  for (const ParameterBlock& b : blocks) {
    const double s2 =
        y.segment(b.first_index, b.num_coefficients).squaredNorm();
    total2 += s2;
    if (block_sizes != nullptr) block_sizes->push_back({b.name, std::sqrt(s2)});
  }
  return std::sqrt(total2);
}

}  // namespace gearloop
