#include "engine/core/sensitivity.h"

#include <Eigen/SVD>
#include <limits>

namespace gearloop {

SensitivitySummary AnalyzeSensitivity(const Eigen::MatrixXd& matrix,
                                      const Eigen::VectorXd& column_scales,
                                      const SensitivityOptions& options) {
  SensitivitySummary summary;
  Eigen::MatrixXd scaled = matrix;
  if (column_scales.size() == matrix.cols())
    scaled = matrix * column_scales.asDiagonal();
  if (scaled.size() == 0) return summary;
  // Singular values only; a 45 x 45 matrix is small enough for the one-sided
  // Jacobi SVD.
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(scaled);
  summary.singular_values = svd.singularValues();
  const double largest =
      summary.singular_values.size() > 0 ? summary.singular_values(0) : 0.0;
  if (!(largest > 0.0)) {
    summary.rank = 0;
    summary.condition_number = std::numeric_limits<double>::infinity();
    return summary;
  }
  for (int i = 0; i < summary.singular_values.size(); ++i) {
    if (summary.singular_values(i) > options.relative_rank_tolerance * largest)
      summary.rank = i + 1;
  }
  summary.condition_number =
      largest / summary.singular_values(summary.rank - 1);
  return summary;
}

Eigen::VectorXd UnitColumnScales(const Eigen::MatrixXd& matrix) {
  Eigen::VectorXd scales(matrix.cols());
  for (int j = 0; j < matrix.cols(); ++j) {
    const double norm = matrix.col(j).norm();
    scales(j) = norm > 0.0 ? 1.0 / norm : 1.0;
  }
  return scales;
}

}  // namespace gearloop
