// engine/grinder/grinder_settings.h: the 45 corrected parameters of the
// flat-wheel grinder (MODEL.md §2): six axes, each a 6th-order polynomial of
// the roll angle phi1, and the three wheel-profile parameters.
//
//   MachineSettings s = NominalSettings(setup);
//   double z_mm = s.AxisValue(Axis::kZ, /*roll_rad=*/0.1);
//   Eigen::VectorXd zeta = s.ToVector();   // X0..X6, Y0..Y6, ..., C0..C6,
//   cone, parabola, vertex
#ifndef GEARLOOP_ENGINE_GRINDER_GRINDER_SETTINGS_H_
#define GEARLOOP_ENGINE_GRINDER_GRINDER_SETTINGS_H_

#include <Eigen/Core>
#include <array>
#include <string>

#include "engine/grinder/grinding_setup.h"

namespace gearloop {

// X, Y, Z: wheel-head pivot position [mm]; A: pressure-angle axis [rad]; B:
// helix-angle axis [rad]; C: work rotation [rad].
enum class Axis { kX = 0, kY = 1, kZ = 2, kA = 3, kB = 4, kC = 5 };

constexpr int kNumAxes = 6;
constexpr int kAxisPolynomialDegree = 6;
constexpr int kCoefficientsPerAxis = kAxisPolynomialDegree + 1;
constexpr int kNumAxisCoefficients = kNumAxes * kCoefficientsPerAxis;  // 42
constexpr int kNumWheelProfileParameters = 3;
constexpr int kNumGrinderParameters =
    kNumAxisCoefficients + kNumWheelProfileParameters;  // 45
// Indices of the wheel-profile parameters in the parameter vector.
constexpr int kConeAngleIndex = kNumAxisCoefficients;                // 42
constexpr int kParabolaCoefficientIndex = kNumAxisCoefficients + 1;  // 43
constexpr int kParabolaVertexIndex = kNumAxisCoefficients + 2;       // 44

// Wheel profile of MODEL.md §3: delta_w = a_w (u_w - d_w)^2 on a cone of angle
// theta_w.
struct WheelProfile {
  double cone_angle_rad = 0.0;               // theta_w
  double parabola_coefficient_per_mm = 0.0;  // a_w [1/mm]
  double parabola_vertex_mm = 0.0;           // d_w [mm]
};

struct MachineSettings {
  // axes[i][k] multiplies phi1^k for axis i (Axis order X, Y, Z, A, B, C).
  std::array<std::array<double, kCoefficientsPerAxis>, kNumAxes> axes{};
  WheelProfile wheel;

  // C_i(phi1) and its first two derivatives with respect to phi1.
  double AxisValue(Axis axis, double roll_rad) const;
  double AxisRate(Axis axis, double roll_rad) const;

  // The parameter vector zeta: X0..X6, Y0..Y6, Z0..Z6, A0..A6, B0..B6, C0..C6,
  // theta_w, a_w, d_w (the column order of the sensitivity matrix, API.md).
  Eigen::VectorXd ToVector() const;
  // Inverse of ToVector; `zeta` must have kNumGrinderParameters entries.
  static MachineSettings FromVector(const Eigen::VectorXd& zeta);
};

// Index of coefficient `order` of `axis` in the parameter vector.
constexpr int ParameterIndex(Axis axis, int order) {
  return static_cast<int>(axis) * kCoefficientsPerAxis + order;
}
// "X0".."C6", "cone_angle", "parabola_coefficient", "parabola_vertex".
std::string GrinderParameterName(int index);
// The unit of parameter `index` as the engine holds it: "mm", "rad", "1/mm".
std::string GrinderParameterUnit(int index);

// The nominal settings of MODEL.md §2 (they generate the exact involute
// helicoid), for the right flank as written there and, for the left flank, the
// mirrored machine described in engine/grinder/flat_wheel_grinder.h. `setup`
// must be valid.
MachineSettings NominalSettings(const GrindingSetup& setup);

}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_GRINDER_GRINDER_SETTINGS_H_
