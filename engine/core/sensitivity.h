// engine/core/sensitivity.h: singular values, numerical rank and condition
// number of a sensitivity matrix S (MODEL.md §5).
//
//   SensitivitySummary s = AnalyzeSensitivity(eval.jacobian_um, column_scales);
//   // s.singular_values (descending), s.rank, s.condition_number
#ifndef GEARLOOP_ENGINE_CORE_SENSITIVITY_H_
#define GEARLOOP_ENGINE_CORE_SENSITIVITY_H_

#include <Eigen/Core>

namespace gearloop {

struct SensitivityOptions {
  // A singular value counts toward the rank when it exceeds this fraction of
  // the largest.
  double relative_rank_tolerance = 1e-6;
};

struct SensitivitySummary {
  Eigen::VectorXd singular_values;  // descending
  int rank = 0;  // number above relative_rank_tolerance * largest
  // Largest over smallest singular value counted in the rank (1 for rank <= 1;
  // inf if S = 0).
  double condition_number = 0.0;
};

// Analyses S diag(column_scales) (pass an empty vector for S itself).
SensitivitySummary AnalyzeSensitivity(
    const Eigen::MatrixXd& matrix,
    const Eigen::VectorXd& column_scales,
    const SensitivityOptions& options = SensitivityOptions());

// Scales that make every column of S unit length (1 for an all-zero column).
Eigen::VectorXd UnitColumnScales(const Eigen::MatrixXd& matrix);

}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_CORE_SENSITIVITY_H_
