#include "engine/split_bevel/flank.h"

#include <cmath>

#include <Eigen/Geometry>

namespace gearloop {

Eigen::Vector3d FlankSection::Normal(double height_mm) const {
  Eigen::Vector3d n = DPointDR(height_mm).cross(ruling).normalized();
  return n.dot(slot_side) < 0.0 ? Eigen::Vector3d(-n) : n;
}

SplitBevelFlankSurface::SplitBevelFlankSurface(const SplitBevelGearData& gear, int slot, SplitBevelFlank flank)
    : gear_(gear),
      slot_(slot),
      flank_(flank),
      azimuth_offset_rad_(FlankLineAzimuthOffset(gear, slot, flank)),
      slot_sign_(flank == SplitBevelFlank::kConcave ? 1.0 : -1.0),
      sin_delta_(std::sin(gear.pitch_angle_rad)),
      cos_delta_(std::cos(gear.pitch_angle_rad)),
      sin_alpha_(std::sin(gear.pressure_angle_rad)),
      cos_alpha_(std::cos(gear.pressure_angle_rad)) {}

// Every vector of the section is written in the cone's moving basis E = (e_R, e_psi, k) at psi_f(R)
// as coefficients v = (v0, v1, v2). The basis turns with psi: de_R/dpsi = sin d e_psi,
// de_psi/dpsi = -(sin d e_R + cos d k), dk/dpsi = cos d e_psi, i.e. dE/dR = omega A with
// omega = dpsi/dR and the constant skew map A v = (-sin d v1, sin d v0 + cos d v2, -cos d v1). So
//   (v E)'  = (v' + omega A v) E
//   (v E)'' = (v'' + omega' A v + 2 omega A v' + omega^2 A A v) E,
// with the closed forms (R cos b = r_b):
//   b' = cot b / R,  b'' = -(cot b / R^2)(1 + 1 / sin^2 b),
//   omega = sigma tan b / (R sin d),  omega' = sigma cot b / (R^2 sin d).
// Pitch point v = (R, 0, 0). Ruling g = cos a k - sin a n_s with n_s = eps c, c = (-sin b, sigma
// cos b, 0): v = (eps sin a sin b, -eps sigma sin a cos b, cos a).
FlankSection SplitBevelFlankSurface::Section(double cone_distance_mm) const {
  const double r = cone_distance_mm;
  const double sigma = gear_.hand_sign;
  const double eps = slot_sign_;
  const double cb = gear_.base_radius_mm / r;
  // sin b from (R - r_b)(R + r_b): no cancellation near the base circle.
  const double sb = std::sqrt((r - gear_.base_radius_mm) * (r + gear_.base_radius_mm)) / r;
  const double tb = sb / cb, cot_b = cb / sb;
  const double beta = std::atan2(sb, cb);
  const double psi = azimuth_offset_rad_ + sigma * (tb - beta) / sin_delta_;
  const double sp = std::sin(psi), cp = std::cos(psi);
  const Eigen::Vector3d e_r(sin_delta_ * cp, sin_delta_ * sp, cos_delta_);
  const Eigen::Vector3d e_psi(-sp, cp, 0.0);
  const Eigen::Vector3d k(cos_delta_ * cp, cos_delta_ * sp, -sin_delta_);

  const double omega = sigma * tb / (r * sin_delta_);
  const double d_omega = sigma * cot_b / (r * r * sin_delta_);
  const double d_beta = cot_b / r;
  const double d2_beta = -(cot_b / (r * r)) * (1.0 + 1.0 / (sb * sb));

  const auto a_map = [&](const Eigen::Vector3d& v) {
    return Eigen::Vector3d(-sin_delta_ * v(1), sin_delta_ * v(0) + cos_delta_ * v(2), -cos_delta_ * v(1));
  };
  const auto to_si = [&](const Eigen::Vector3d& v) -> Eigen::Vector3d { return v(0) * e_r + v(1) * e_psi + v(2) * k; };
  const auto first = [&](const Eigen::Vector3d& v, const Eigen::Vector3d& dv) -> Eigen::Vector3d {
    return dv + omega * a_map(v);
  };
  const auto second = [&](const Eigen::Vector3d& v, const Eigen::Vector3d& dv, const Eigen::Vector3d& d2v) {
    return Eigen::Vector3d(d2v + d_omega * a_map(v) + 2.0 * omega * a_map(dv) + omega * omega * a_map(a_map(v)));
  };

  FlankSection s;
  s.cone_distance_mm = r;
  s.spiral_angle_rad = beta;
  s.azimuth_rad = psi;
  s.cos_pressure_angle = cos_alpha_;

  const Eigen::Vector3d p(r, 0.0, 0.0), dp(1.0, 0.0, 0.0), d2p(0.0, 0.0, 0.0);
  s.pitch_point_mm = r * e_r;
  s.d_pitch_point = to_si(first(p, dp));
  s.d2_pitch_point = to_si(second(p, dp, d2p));

  const double sa = sin_alpha_, ca = cos_alpha_;
  const Eigen::Vector3d g(eps * sa * sb, -eps * sigma * sa * cb, ca);
  const Eigen::Vector3d g_turn(eps * sa * cb, eps * sigma * sa * sb, 0.0);  // dg_coeff / d beta
  const Eigen::Vector3d g_turn2(-eps * sa * sb, eps * sigma * sa * cb, 0.0);  // d2g_coeff / d beta2
  const Eigen::Vector3d dg = d_beta * g_turn;
  const Eigen::Vector3d d2g = d2_beta * g_turn + d_beta * d_beta * g_turn2;
  s.ruling = to_si(g);
  s.d_ruling = to_si(first(g, dg));
  s.d2_ruling = to_si(second(g, dg, d2g));

  s.tangent = cb * e_r + sigma * sb * e_psi;
  s.slot_side = eps * (-sb * e_r + sigma * cb * e_psi);
  return s;
}

// Newton on D(R) = |X - F(R, h*(R))|^2 / 2 with h*(R) = (X - p) . g (g is a unit vector). With
// r = X - F and F_R = p' + h g':
//   D'  = -r . F_R                         (envelope: r . g = 0 at h*)
//   D'' = F_R . F_R + h*' (p' . g) - r . (p'' + h g'') - h*' (r . g'),   h*' = -p' . g + (X - p) . g'.
// The step is accepted without a new section once it is below the tolerance: the point is then
// off by less than |F_R| times the tolerance along the flank, which moves the normal distance only
// to second order.
SplitBevelFlankSurface::NearestPoint SplitBevelFlankSurface::Nearest(const Eigen::Vector3d& point_mm,
                                                                     const FlankSection& start,
                                                                     double step_tolerance_mm,
                                                                     int max_iterations) const {
  NearestPoint out;
  FlankSection s = start;
  for (int iteration = 0; iteration <= max_iterations; ++iteration) {
    const double u = (point_mm - s.pitch_point_mm).dot(s.ruling);  // h* (length along g)
    const Eigen::Vector3d f = s.pitch_point_mm + u * s.ruling;
    const Eigen::Vector3d f_r = s.d_pitch_point + u * s.d_ruling;
    const Eigen::Vector3d res = point_mm - f;
    const double pg = s.d_pitch_point.dot(s.ruling);
    const double du = -pg + (point_mm - s.pitch_point_mm).dot(s.d_ruling);
    const double gradient = res.dot(f_r);  // -D'
    double hessian =
        f_r.squaredNorm() + du * pg - res.dot(s.d2_pitch_point + u * s.d2_ruling) - du * res.dot(s.d_ruling);
    if (!(hessian > 0.0)) hessian = f_r.squaredNorm();  // not convex here: a gradient step
    const double step = gradient / hessian;
    out.iterations = iteration;
    if (std::abs(step) < step_tolerance_mm || iteration == max_iterations) {
      out.converged = std::abs(step) < step_tolerance_mm;
      out.cone_distance_mm = s.cone_distance_mm;
      out.height_mm = u * cos_alpha_;
      out.point_mm = f;
      out.normal = s.Normal(out.height_mm);
      break;
    }
    const double next = s.cone_distance_mm + step;
    if (!(next > gear_.base_radius_mm)) break;  // left the involute's domain: not converged
    s = Section(next);
  }
  return out;
}

}  // namespace gearloop
