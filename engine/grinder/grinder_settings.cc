#include "engine/grinder/grinder_settings.h"

#include <cmath>

#include "engine/core/units.h"

namespace gearloop {
namespace {
constexpr const char* kAxisNames[kNumAxes] = {"X", "Y", "Z", "A", "B", "C"};
}  // namespace

double MachineSettings::AxisValue(Axis axis, double roll_rad) const {
  const auto& a = axes[static_cast<int>(axis)];
  double value = 0.0;
  for (int k = kAxisPolynomialDegree; k >= 0; --k)
    value = value * roll_rad + a[k];
  return value;
}

double MachineSettings::AxisRate(Axis axis, double roll_rad) const {
  const auto& a = axes[static_cast<int>(axis)];
  double value = 0.0;
  for (int k = kAxisPolynomialDegree; k >= 1; --k)
    value = value * roll_rad + k * a[k];
  return value;
}

Eigen::VectorXd MachineSettings::ToVector() const {
  Eigen::VectorXd zeta(kNumGrinderParameters);
  for (int i = 0; i < kNumAxes; ++i) {
    for (int k = 0; k < kCoefficientsPerAxis; ++k)
      zeta(i * kCoefficientsPerAxis + k) = axes[i][k];
  }
  zeta(kConeAngleIndex) = wheel.cone_angle_rad;
  zeta(kParabolaCoefficientIndex) = wheel.parabola_coefficient_per_mm;
  zeta(kParabolaVertexIndex) = wheel.parabola_vertex_mm;
  return zeta;
}

MachineSettings MachineSettings::FromVector(const Eigen::VectorXd& zeta) {
  MachineSettings s;
  for (int i = 0; i < kNumAxes; ++i) {
    for (int k = 0; k < kCoefficientsPerAxis; ++k)
      s.axes[i][k] = zeta(i * kCoefficientsPerAxis + k);
  }
  s.wheel.cone_angle_rad = zeta(kConeAngleIndex);
  s.wheel.parabola_coefficient_per_mm = zeta(kParabolaCoefficientIndex);
  s.wheel.parabola_vertex_mm = zeta(kParabolaVertexIndex);
  return s;
}

std::string GrinderParameterName(int index) {
  if (index >= 0 && index < kNumAxisCoefficients) {
    return std::string(kAxisNames[index / kCoefficientsPerAxis]) +
           std::to_string(index % kCoefficientsPerAxis);
  }
  switch (index) {
    case kConeAngleIndex:
      return "cone_angle";
    case kParabolaCoefficientIndex:
      return "parabola_coefficient";
    case kParabolaVertexIndex:
      return "parabola_vertex";
    default:
      return "";
  }
}

std::string GrinderParameterUnit(int index) {
  if (index >= 0 && index < kNumAxisCoefficients)
    return index / kCoefficientsPerAxis < 3 ? "mm" : "rad";
  switch (index) {
    case kConeAngleIndex:
      return "rad";
    case kParabolaCoefficientIndex:
      return "1/mm";
    case kParabolaVertexIndex:
      return "mm";
    default:
      return "";
  }
}

MachineSettings NominalSettings(const GrindingSetup& setup) {
  const GearData& g = setup.gear;
  const double alpha = g.normal_pressure_angle_rad;
  const double beta = g.helix_angle_rad;
  const double r_j = g.PitchRadiusMm();
  const double k1 = setup.machine.k1_mm;
  const double k2 = setup.machine.k2_mm;
  const double cs = setup.machine.traverse_mm_per_rad;
  const double s_y =
      setup.wheel.radius_mm * std::cos(alpha) - r_j + g.root_radius_mm;
  const double s_z = kPi * g.normal_module_mm / 4.0 - s_y * std::tan(alpha);
  const double cb = std::cos(beta), sb = std::sin(beta), ca = std::cos(alpha),
               sa = std::sin(alpha);

  MachineSettings s;
  auto& X = s.axes[static_cast<int>(Axis::kX)];
  auto& Y = s.axes[static_cast<int>(Axis::kY)];
  auto& Z = s.axes[static_cast<int>(Axis::kZ)];
  Y[0] = -k1 * sa + r_j + s_y;
  if (setup.flank == Flank::kRight) {
    // MODEL.md §2.
    X[0] = k1 * ca * sb + k2 * cb - s_z * sb;
    X[1] = cs * cb;
    Z[0] = k1 * ca * cb - k2 * sb - s_z * cb;
    Z[1] = -r_j - cs * sb;
    s.axes[static_cast<int>(Axis::kA)][0] = alpha;
  } else {
    // The mirrored machine of engine/grinder/flat_wheel_grinder.h: X0, Y0 and
    // -Z0 of the right-flank machine for helix -beta at roll -phi1.
    X[0] = -k1 * ca * sb + k2 * cb + s_z * sb;
    X[1] = -cs * cb;
    Z[0] = -k1 * ca * cb - k2 * sb + s_z * cb;
    Z[1] = -r_j + cs * sb;
    s.axes[static_cast<int>(Axis::kA)][0] = -alpha;
  }
  s.axes[static_cast<int>(Axis::kB)][0] = beta;
  s.axes[static_cast<int>(Axis::kC)][1] = 1.0;
  return s;
}

}  // namespace gearloop
