// engine/core/axis_motion.h: a parameter change read as the machine motion it
// causes. The monomial coefficients of a corrected axis polynomial can be large
// (thousands of mm on phi1^6) and cancel each other inside the roll range
// actually used, where the axis moves by microns; this states the change of
// each axis position at a few roll angles over that range, with its rms and
// largest magnitude, in um for linear axes and urad for rotary ones (MODEL.md
// §6).
//
//   const AxisMotion motion = ComputeAxisMotion(model.ParameterBlocks(),
//   result.delta,
//                                               result.summary.roll_min_rad,
//                                               result.summary.roll_max_rad);
//   // motion.roll_rad[i]; for each block b: b.change[i] (polynomial) or
//   b.change[0] (scalar)
//
// Generic over the model's parameter blocks (engine/core/machine_model.h): a
// polynomial block C(phi1) = sum_k a_k phi1^k changes by dC(phi1) = sum_k
// delta_k phi1^k; a scalar block changes by its delta, reported as is.
#ifndef GEARLOOP_ENGINE_CORE_AXIS_MOTION_H_
#define GEARLOOP_ENGINE_CORE_AXIS_MOTION_H_

#include <Eigen/Core>
#include <string>
#include <vector>

#include "engine/core/machine_model.h"

namespace gearloop {

// The change of one parameter block.
struct BlockMotion {
  std::string name;  // ParameterBlock::name ("X".."C", "cone_angle", ...)
  bool is_polynomial = false;
  // Unit of `change`, `rms` and `max_abs`. Polynomial blocks: "um" for a block
  // in "mm", "urad" for a block in "rad", the block's own unit otherwise.
  // Scalar blocks: the block's own unit.
  std::string unit;
  // Polynomial: dC at each of AxisMotion::roll_rad. Scalar: one entry, the
  // change itself.
  std::vector<double> change;
  // Polynomial: sqrt(mean of dC^2 over [roll_min, roll_max]) and max |dC| over
  // that range (continuous, not over the samples only); |dC(roll_min)| both
  // when the range is a point; NaN when the range is not finite or reversed.
  // Scalar: |change| both.
  double rms = 0.0;
  double max_abs = 0.0;
};

struct AxisMotion {
  // The roll angles the polynomial blocks are sampled at [rad]: evenly spaced
  // over [roll_min, roll_max], both ends included. Empty when the range is not
  // finite or reversed.
  std::vector<double> roll_rad;
  // One entry per block, in the model's order.
  std::vector<BlockMotion> blocks;
};

// The default number of roll angles a correction's axis motion is stated at.
constexpr int kAxisMotionSamples = 9;

// The motion `delta` (NumParameters entries, parameter units) causes, block by
// block, over [roll_min_rad, roll_max_rad]. `num_samples` >= 2 (smaller values
// are taken as 2). Blocks reaching past the end of `delta` get NaN values.
AxisMotion ComputeAxisMotion(const std::vector<ParameterBlock>& blocks,
                             const Eigen::VectorXd& delta,
                             double roll_min_rad,
                             double roll_max_rad,
                             int num_samples = kAxisMotionSamples);

// The factor and unit an axis motion in `unit` is stated in: {1e3, "um"} for
// "mm", {1e6, "urad"} for "rad", {1, unit} for anything else.
double AxisMotionUnitFactor(const std::string& unit, std::string* motion_unit);

}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_CORE_AXIS_MOTION_H_
