#include "engine/split_bevel/flank.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <iterator>

namespace gearloop {

Eigen::Vector3d FlankSection::Normal(double height_mm) const {
  Eigen::Vector3d n = DPointDR(height_mm).cross(ruling).normalized();
  return n.dot(slot_side) < 0.0 ? Eigen::Vector3d(-n) : n;
}

SplitBevelFlankSurface::SplitBevelFlankSurface(const SplitBevelGearData& gear,
                                               int slot,
                                               SplitBevelFlank flank)
    : gear_(gear),
      slot_(slot),
      flank_(flank),
      azimuth_offset_rad_(FlankLineAzimuthOffset(gear, slot, flank)),
      slot_sign_(flank == SplitBevelFlank::kConcave ? 1.0 : -1.0),
      sin_delta_(std::sin(gear.pitch_angle_rad)),
      cos_delta_(std::cos(gear.pitch_angle_rad)),
      sin_alpha_(std::sin(gear.pressure_angle_rad)),
      cos_alpha_(std::cos(gear.pressure_angle_rad)) {}

// Every vector of the section is written in the cone's moving basis E = (e_R,
// e_psi, k) at psi_f(R) as coefficients v = (v0, v1, v2). The basis turns with
// psi: de_R/dpsi = sin d e_psi, de_psi/dpsi = -(sin d e_R + cos d k), dk/dpsi =
// cos d e_psi, i.e. dE/dR = omega A with omega = dpsi/dR and the constant skew
// map A v = (-sin d v1, sin d v0 + cos d v2, -cos d v1). So
//   (v E)'  = (v' + omega A v) E
//   (v E)'' = (v'' + omega' A v + 2 omega A v' + omega^2 A A v) E,
// with the closed forms (R cos b = r_b):
//   b' = cot b / R,  b'' = -(cot b / R^2)(1 + 1 / sin^2 b),
//   omega = sigma tan b / (R sin d),  omega' = sigma cot b / (R^2 sin d).
// Pitch point v = (R, 0, 0). Ruling g = cos a k - sin a n_s with n_s = eps c, c
// = (-sin b, sigma cos b, 0): v = (eps sin a sin b, -eps sigma sin a cos b, cos
// a).
FlankSection SplitBevelFlankSurface::Section(double cone_distance_mm) const {
  const double r = cone_distance_mm;
  const double sigma = gear_.hand_sign;
  const double eps = slot_sign_;
  const double cb = gear_.base_radius_mm / r;
  // sin b from (R - r_b)(R + r_b): no cancellation near the base circle.
  const double sb =
      std::sqrt((r - gear_.base_radius_mm) * (r + gear_.base_radius_mm)) / r;
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
    return Eigen::Vector3d(-sin_delta_ * v(1),
                           sin_delta_ * v(0) + cos_delta_ * v(2),
                           -cos_delta_ * v(1));
  };
  const auto to_si = [&](const Eigen::Vector3d& v) -> Eigen::Vector3d {
    return v(0) * e_r + v(1) * e_psi + v(2) * k;
  };
  const auto first = [&](const Eigen::Vector3d& v,
                         const Eigen::Vector3d& dv) -> Eigen::Vector3d {
    return dv + omega * a_map(v);
  };
  const auto second = [&](const Eigen::Vector3d& v,
                          const Eigen::Vector3d& dv,
                          const Eigen::Vector3d& d2v) {
    return Eigen::Vector3d(d2v + d_omega * a_map(v) + 2.0 * omega * a_map(dv) +
                           omega * omega * a_map(a_map(v)));
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
  const Eigen::Vector3d g_turn(
      eps * sa * cb, eps * sigma * sa * sb, 0.0);  // dg_coeff / d beta
  const Eigen::Vector3d g_turn2(
      -eps * sa * sb, eps * sigma * sa * cb, 0.0);  // d2g_coeff / d beta2
  const Eigen::Vector3d dg = d_beta * g_turn;
  const Eigen::Vector3d d2g = d2_beta * g_turn + d_beta * d_beta * g_turn2;
  s.ruling = to_si(g);
  s.d_ruling = to_si(first(g, dg));
  s.d2_ruling = to_si(second(g, dg, d2g));

  s.tangent = cb * e_r + sigma * sb * e_psi;
  s.slot_side = eps * (-sb * e_r + sigma * cb * e_psi);
  return s;
}

// Newton on D(R) = |X - F(R, h*(R))|^2 / 2 with h*(R) = (X - p) . g (g is a
// unit vector). With r = X - F and F_R = p' + h g':
//   D'  = -r . F_R                         (envelope: r . g = 0 at h*)
//   D'' = F_R . F_R + h*' (p' . g) - r . (p'' + h g'') - h*' (r . g'),   h*' =
//   -p' . g + (X - p) . g'.
// Each iterate takes p, p', g, g' (and p'', g'') from an anchor section by
// Taylor expansion in d = R - R_anchor (exact at d = 0), |d| <= kTaylorRadiusMm
// (FlankAnchors: a section on the station's grid). Newton stops after a
// step below the tolerance and takes that step to first order (point F + F_R
// step, normal of the section before it): Newton's error after a step s is
// about (D''' / 2 D'') s^2, some 1e-13 mm for s = 1e-5 mm here, the first-order
// point is off by |F_RR| s^2 / 2 (1e-13 mm), and the normal turns by |N_R| s
// (1e-8 rad), which moves the normal distance (X - F) . N only to second order.
SplitBevelFlankSurface::NearestPoint SplitBevelFlankSurface::Nearest(
    const Eigen::Vector3d& point_mm,
    double guess_mm,
    FlankAnchors* anchors,
    double step_tolerance_mm,
    int max_iterations) const {
  NearestPoint out;
  double r = guess_mm;
  for (int iteration = 0; iteration <= max_iterations; ++iteration) {
    if (!(r > gear_.base_radius_mm))
      break;  // left the involute's domain: not converged
    const FlankSection& a = anchors->Near(r, &out.exact_sections);
    const double d = r - a.cone_distance_mm;
    const Eigen::Vector3d p =
        a.pitch_point_mm + d * (a.d_pitch_point + (0.5 * d) * a.d2_pitch_point);
    const Eigen::Vector3d p1 = a.d_pitch_point + d * a.d2_pitch_point;
    const Eigen::Vector3d g =
        a.ruling + d * (a.d_ruling + (0.5 * d) * a.d2_ruling);
    const Eigen::Vector3d g1 = a.d_ruling + d * a.d2_ruling;

    const Eigen::Vector3d xp = point_mm - p;
    const double u = xp.dot(g);  // h* (length along g)
    const Eigen::Vector3d f = p + u * g;
    const Eigen::Vector3d f_r = p1 + u * g1;
    const Eigen::Vector3d res = point_mm - f;
    const double pg = p1.dot(g);
    const double du = -pg + xp.dot(g1);
    const double gradient = res.dot(f_r);  // -D'
    double hessian = f_r.squaredNorm() + du * pg -
                     res.dot(a.d2_pitch_point + u * a.d2_ruling) -
                     du * res.dot(g1);
    if (!(hessian > 0.0))
      hessian = f_r.squaredNorm();  // not convex here: a gradient step
    const double step = gradient / hessian;
    out.iterations = iteration;
    if (std::abs(step) < step_tolerance_mm || iteration == max_iterations) {
      out.converged = std::abs(step) < step_tolerance_mm;
      // The last step taken to first order: F(R + step) = F + F_R step +
      // O(step^2).
      out.cone_distance_mm = r + step;
      out.height_mm = u * cos_alpha_;
      out.point_mm = f + step * f_r;
      const Eigen::Vector3d n = f_r.cross(g).normalized();
      out.normal = n.dot(a.slot_side) < 0.0 ? Eigen::Vector3d(-n) : n;
      break;
    }
    r += step;
  }
  return out;
}

void FlankAnchors::Centre(const FlankSection& centre) {
  centre_mm_ = centre.cone_distance_mm;
  std::fill(std::begin(filled_), std::end(filled_), false);
  grid_[kGridSlots] = centre;
  filled_[kGridSlots] = true;
  outside_filled_ = false;
}

const FlankSection& FlankAnchors::Near(double cone_distance_mm,
                                       int* exact_sections) {
  constexpr double kSpacingMm = 2.0 * SplitBevelFlankSurface::kTaylorRadiusMm;
  const double slot = std::round((cone_distance_mm - centre_mm_) / kSpacingMm);
  if (std::abs(slot) <= kGridSlots) {
    const int i = static_cast<int>(slot) + kGridSlots;
    if (!filled_[i]) {
      grid_[i] = flank_.Section(centre_mm_ + slot * kSpacingMm);
      filled_[i] = true;
      ++*exact_sections;
    }
    return grid_[i];
  }
  if (!outside_filled_ ||
      std::abs(cone_distance_mm - outside_.cone_distance_mm) >
          SplitBevelFlankSurface::kTaylorRadiusMm) {
    outside_ = flank_.Section(cone_distance_mm);
    outside_filled_ = true;
    ++*exact_sections;
  }
  return outside_;
}

}  // namespace gearloop
