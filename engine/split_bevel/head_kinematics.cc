#include "engine/split_bevel/head_kinematics.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "engine/core/units.h"

namespace gearloop {

namespace {

// Below this sqrt(a_x^2 + a_z^2) the tool is along Y and B is kept (§6).
constexpr double kVerticalTolerance = 1e-9;

// x brought into (-pi, pi].
double WrapPi(double x) {
  double y = std::remainder(x, 2.0 * kPi);  // [-pi, pi]
  if (y <= -kPi) y += 2.0 * kPi;
  return y;
}

}  // namespace

Eigen::Matrix4d SplitBevelBlankToMachine(double segment_mid_rad,
                                         const Eigen::Vector3d& apex_mm) {
  // RotX(pi) = diag(1, -1, -1) exactly; RotZ(-psi_mid) = [[c, s, 0], [-s, c,
  // 0], [0, 0, 1]].
  const double c = std::cos(segment_mid_rad), s = std::sin(segment_mid_rad);
  Eigen::Matrix4d t = Eigen::Matrix4d::Identity();
  t.block<3, 3>(0, 0) << c, s, 0.0, s, -c, 0.0, 0.0, 0.0, -1.0;
  t.block<3, 1>(0, 3) = apex_mm;
  return t;
}

Eigen::Vector3d HeadToolAxis(double a_rad, double b_rad) {
  const double ca = std::cos(a_rad);
  return Eigen::Vector3d(
      std::sin(b_rad) * ca, -std::sin(a_rad), std::cos(b_rad) * ca);
}

ToolPose HeadForward(const HeadAxes& axes, double pivot_length_mm) {
  ToolPose pose;
  pose.axis = HeadToolAxis(axes.a_rad, axes.b_rad);
  pose.centre_mm = Eigen::Vector3d(axes.x_mm, axes.y_mm, axes.z_mm) -
                   pivot_length_mm * pose.axis;
  return pose;
}

ToolPose HeadForwardInBlank(const HeadAxes& axes,
                            double pivot_length_mm,
                            const Eigen::Matrix4d& blank_to_machine) {
  const ToolPose m = HeadForward(axes, pivot_length_mm);
  const Eigen::Matrix3d rotation = blank_to_machine.block<3, 3>(0, 0);
  ToolPose pose;
  pose.centre_mm =
      rotation.transpose() * (m.centre_mm - blank_to_machine.block<3, 1>(0, 3));
  pose.axis = rotation.transpose() * m.axis;
  return pose;
}

HeadAxes HeadPivot(const Eigen::Vector3d& centre_m_mm,
                   const HeadAngles& angles,
                   double pivot_length_mm) {
  const Eigen::Vector3d pivot =
      centre_m_mm + pivot_length_mm * HeadToolAxis(angles.a_rad, angles.b_rad);
  return HeadAxes{pivot.x(), pivot.y(), pivot.z(), angles.a_rad, angles.b_rad};
}

std::array<HeadAngles, 2> HeadInverseBranches(const Eigen::Vector3d& axis_m,
                                              double b_when_vertical_rad) {
  const double horizontal = std::hypot(axis_m.x(), axis_m.z());
  const double a1 = std::atan2(-axis_m.y(), horizontal);
  const double b1 = horizontal < kVerticalTolerance
                        ? b_when_vertical_rad
                        : std::atan2(axis_m.x(), axis_m.z());
  return {HeadAngles{a1, b1}, HeadAngles{WrapPi(kPi - a1), b1 + kPi}};
}

bool HeadAxisAlongY(const Eigen::Vector3d& axis_m) {
  return std::hypot(axis_m.x(), axis_m.z()) < kVerticalTolerance;
}

bool ChooseHeadAngles(const Eigen::Vector3d& axis_m,
                      const HeadAngles* previous,
                      const HeadLimits& limits,
                      HeadAngles* chosen) {
  return ChooseHeadAnglesFrom(
      HeadInverseBranches(axis_m, previous ? previous->b_rad : 0.0),
      previous,
      limits,
      chosen);
}

bool ChooseHeadAnglesFrom(const std::array<HeadAngles, 2>& branches,
                          const HeadAngles* previous,
                          const HeadLimits& limits,
                          HeadAngles* chosen) {
  const auto in_limits = [&](const HeadAngles& h) {
    return h.a_rad >= limits.a_min_rad && h.a_rad <= limits.a_max_rad &&
           h.b_rad >= limits.b_min_rad && h.b_rad <= limits.b_max_rad;
  };
  if (previous == nullptr) {
    const HeadAngles first = branches[0];  // B = atan2 in (-pi, pi]
    if (!in_limits(first)) return false;
    *chosen = first;
    return true;
  }
  bool found = false;
  double best = std::numeric_limits<double>::infinity();
  for (const HeadAngles& branch : branches) {
    if (branch.a_rad < limits.a_min_rad || branch.a_rad > limits.a_max_rad)
      continue;
    // B + 2 pi m within the limits: m in [m_lo, m_hi]; the distance to the
    // previous B is convex in m, so the nearest admissible m is the nearest
    // integer clamped into that range.
    const double two_pi = 2.0 * kPi;
    const double m_lo = std::ceil((limits.b_min_rad - branch.b_rad) / two_pi);
    const double m_hi = std::floor((limits.b_max_rad - branch.b_rad) / two_pi);
    if (m_lo > m_hi) continue;
    double m = std::round((previous->b_rad - branch.b_rad) / two_pi);
    m = std::min(std::max(m, m_lo), m_hi);
    // Both neighbours of the rounded m when it was clamped are no nearer; check
    // m and m +- 1 within range anyway so that rounding at exactly half a turn
    // cannot pick the farther one.
    for (double mm = m - 1.0; mm <= m + 1.0; mm += 1.0) {
      if (mm < m_lo || mm > m_hi) continue;
      const HeadAngles candidate{branch.a_rad, branch.b_rad + mm * two_pi};
      if (!in_limits(candidate)) continue;  // the ends of the range, rounding
      const double distance =
          std::max(std::abs(candidate.a_rad - previous->a_rad),
                   std::abs(candidate.b_rad - previous->b_rad));
      if (distance <
          best) {  // strict: ties stay with the earlier (branch 1, smaller m)
        best = distance;
        *chosen = candidate;
        found = true;
      }
    }
  }
  return found;
}

}  // namespace gearloop
