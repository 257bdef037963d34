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
namespace {

// Three coordinates in plain doubles: the Newton evaluation below is a chain
// of small dot products that the compiler keeps in registers this way (Eigen's
// 3-vectors split into a pair and a single and go through memory between).
struct V3 {
  double x, y, z;
};
inline V3 Of(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }
inline V3 operator+(V3 a, V3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline V3 operator-(V3 a, V3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline V3 operator*(double s, V3 a) { return {s * a.x, s * a.y, s * a.z}; }
inline double Dot(V3 a, V3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

// One Newton evaluation at R = r on the anchor section `a` (above).
struct NewtonEvaluation {
  double step = 0.0;  // dR
  double u = 0.0;     // h*, length along the ruling
  V3 f, f_r, g;
};

__attribute__((always_inline)) inline NewtonEvaluation Evaluate(
    const FlankSection& a, double r, const V3& x) {
  const double d = r - a.cone_distance_mm;
  const V3 dp = Of(a.d_pitch_point), d2p = Of(a.d2_pitch_point);
  const V3 dg = Of(a.d_ruling), d2g = Of(a.d2_ruling);
  const V3 p = Of(a.pitch_point_mm) + d * (dp + (0.5 * d) * d2p);
  const V3 p1 = dp + d * d2p;
  const V3 g = Of(a.ruling) + d * (dg + (0.5 * d) * d2g);
  const V3 g1 = dg + d * d2g;

  NewtonEvaluation e;
  const V3 xp = x - p;
  e.u = Dot(xp, g);
  e.f = p + e.u * g;
  e.f_r = p1 + e.u * g1;
  e.g = g;
  const V3 res = x - e.f;
  const double pg = Dot(p1, g);
  const double du = -pg + Dot(xp, g1);
  const double gradient = Dot(res, e.f_r);  // -D'
  const double f_r2 = Dot(e.f_r, e.f_r);
  double hessian =
      f_r2 + du * pg - Dot(res, d2p + e.u * d2g) - du * Dot(res, g1);
  if (!(hessian > 0.0)) hessian = f_r2;  // not convex here: a gradient step
  e.step = gradient / hessian;
  return e;
}

// The result from the last evaluation, its step taken to first order: F(R +
// step) = F + F_R step + O(step^2).
__attribute__((always_inline)) inline void Finish(
    const NewtonEvaluation& e,
    const FlankSection& a,
    double r,
    double cos_alpha,
    SplitBevelFlankSurface::NearestPoint* out) {
  out->cone_distance_mm = r + e.step;
  out->height_mm = e.u * cos_alpha;
  const V3 q = e.f + e.step * e.f_r;
  out->point_mm = Eigen::Vector3d(q.x, q.y, q.z);
  const V3 c = {e.f_r.y * e.g.z - e.f_r.z * e.g.y,
                e.f_r.z * e.g.x - e.f_r.x * e.g.z,
                e.f_r.x * e.g.y - e.f_r.y * e.g.x};
  // Unit, into the slot.
  const double scale =
      (Dot(c, Of(a.slot_side)) < 0.0 ? -1.0 : 1.0) / std::sqrt(Dot(c, c));
  out->normal = Eigen::Vector3d(scale * c.x, scale * c.y, scale * c.z);
}

}  // namespace

void SplitBevelFlankSurface::Continue(const Eigen::Vector3d& point_mm,
                                      double r,
                                      int first_iteration,
                                      FlankAnchors* anchors,
                                      double step_tolerance_mm,
                                      int max_iterations,
                                      NearestPoint* out) const {
  for (int iteration = first_iteration; iteration <= max_iterations;
       ++iteration) {
    if (!(r > gear_.base_radius_mm))
      break;  // left the involute's domain: not converged
    const FlankSection& a = anchors->Near(r, &out->exact_sections);
    const NewtonEvaluation e = Evaluate(a, r, Of(point_mm));
    out->iterations = iteration;
    if (std::abs(e.step) < step_tolerance_mm || iteration == max_iterations) {
      out->converged = std::abs(e.step) < step_tolerance_mm;
      Finish(e, a, r, cos_alpha_, out);
      break;
    }
    r += e.step;
  }
}

SplitBevelFlankSurface::NearestPoint SplitBevelFlankSurface::Nearest(
    const Eigen::Vector3d& point_mm,
    double guess_mm,
    FlankAnchors* anchors,
    double step_tolerance_mm,
    int max_iterations) const {
  NearestPoint out;
  Continue(
      point_mm, guess_mm, 0, anchors, step_tolerance_mm, max_iterations, &out);
  return out;
}

// The first evaluation of every search in one loop: the searches are
// independent, so the processor overlaps them (one search is a long chain of
// dependent operations ending in a division and a square root).
void SplitBevelFlankSurface::NearestOfEach(const Eigen::Vector3d* points_mm,
                                           const double* guesses_mm,
                                           int count,
                                           FlankAnchors* anchors,
                                           NearestPoint* out,
                                           double step_tolerance_mm,
                                           int max_iterations) const {
  int unfinished = 0;
  for (int i = 0; i < count; ++i) {
    out[i] = NearestPoint();
    const double r = guesses_mm[i];
    if (!(r > gear_.base_radius_mm) || max_iterations < 1) {
      ++unfinished;
      continue;
    }
    const FlankSection& a = anchors->Near(r, &out[i].exact_sections);
    const NewtonEvaluation e = Evaluate(a, r, Of(points_mm[i]));
    if (std::abs(e.step) < step_tolerance_mm) {
      out[i].converged = true;
      Finish(e, a, r, cos_alpha_, &out[i]);
    } else {
      out[i].cone_distance_mm = r + e.step;  // where the search goes on
      ++unfinished;
    }
  }
  if (unfinished == 0) return;
  for (int i = 0; i < count; ++i) {
    if (out[i].converged) continue;
    const double r = guesses_mm[i];
    if (!(r > gear_.base_radius_mm) || max_iterations < 1) {
      out[i] =
          Nearest(points_mm[i], r, anchors, step_tolerance_mm, max_iterations);
      continue;
    }
    const double r_next = out[i].cone_distance_mm;
    out[i].cone_distance_mm = 0.0;
    Continue(points_mm[i],
             r_next,
             1,
             anchors,
             step_tolerance_mm,
             max_iterations,
             &out[i]);
  }
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
  // The nearest grid point, R_c + slot kSpacingMm: the section a search is
  // given depends on its R only, not on the searches before it.
  const double offset = (cone_distance_mm - centre_mm_) / kSpacingMm;
  const double shifted = offset + (kGridSlots + 0.5);
  if (shifted >= 0.0 && shifted < kSlots) {
    const int i = static_cast<int>(shifted);  // floor: shifted >= 0
    if (!filled_[i]) {
      grid_[i] = flank_.Section(centre_mm_ + (i - kGridSlots) * kSpacingMm);
      filled_[i] = true;
      ++*exact_sections;
    }
    return grid_[i];
  }
  const double slot = std::round(offset);
  if (!outside_filled_ || slot != outside_slot_) {
    outside_ = flank_.Section(centre_mm_ + slot * kSpacingMm);
    outside_slot_ = slot;
    outside_filled_ = true;
    ++*exact_sections;
  }
  return outside_;
}

}  // namespace gearloop
