// engine/correction/legendre_coordinates.h (internal): step 1 of the correction
// (correction.h), the orthonormal Legendre coordinates of the parameter blocks
// over the roll range, in which the correction size is the Euclidean norm. The
// public CorrectionSize, CorrectionCoordinates and
// DeltaFromCorrectionCoordinates (correction.h) are defined in
// legendre_coordinates.cc.
//
//   const Eigen::MatrixXd t = CoordinateMap(blocks, np, roll_min_rad,
//   roll_max_rad, options.block_scales); const Eigen::VectorXd delta = t * y;
//   // CorrectionSize(blocks, delta, ...) == y.norm()
#ifndef GEARLOOP_ENGINE_CORRECTION_LEGENDRE_COORDINATES_H_
#define GEARLOOP_ENGINE_CORRECTION_LEGENDRE_COORDINATES_H_

#include <Eigen/Core>
#include <map>
#include <string>
#include <vector>

#include "engine/core/machine_model.h"

namespace gearloop {
namespace correction_internal {

// Column k: the monomial coefficients (in phi) of sqrt(2k+1) P_k((phi - c) /
// h), n x n, upper triangular, c and h the centre and half width of
// [roll_min_rad, roll_max_rad] ([-1, 1] when the range is empty). The mean over
// the range of (sum_k y_k column_k(phi))^2 is |y|^2.
Eigen::MatrixXd LegendreToMonomial(int n,
                                   double roll_min_rad,
                                   double roll_max_rad);

// The block's correction-size scale: `scales[block.name]` if given, else its
// default_scale.
double BlockScale(const ParameterBlock& block,
                  const std::map<std::string, double>& scales);

// The linear map coordinates -> delta for all coefficients of all blocks
// (num_parameters square, block diagonal, each block upper triangular): s L for
// a polynomial block, s for a scalar.
Eigen::MatrixXd CoordinateMap(const std::vector<ParameterBlock>& blocks,
                              int num_parameters,
                              double roll_min_rad,
                              double roll_max_rad,
                              const std::map<std::string, double>& scales);

}  // namespace correction_internal
}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_CORRECTION_LEGENDRE_COORDINATES_H_
