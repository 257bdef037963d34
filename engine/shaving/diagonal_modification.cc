#include "engine/shaving/diagonal_modification.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "engine/core/units.h"

namespace gearloop {
namespace {

constexpr double kUmToMm = 1e-3;

// One band: g(w) = max(0, s)^e with s = s0 + s_w w, and g', g'' with respect to
// w.
struct Band {
  double g = 0.0, dg = 0.0, ddg = 0.0;
};
Band EvaluateBand(double s, double ds_dw, int exponent) {
  Band b;
  if (s <= 0.0) return b;
  if (exponent == 1) {
    b.g = s;
    b.dg = ds_dw;
  } else {
    b.g = s * s;
    b.dg = 2.0 * s * ds_dw;
    b.ddg = 2.0 * ds_dw * ds_dw;
  }
  return b;
}

}  // namespace

bool ValidateDiagonalModification(const DiagonalModification& m,
                                  ValidationIssue* issue) {
  if (!std::isfinite(m.root_um) || m.root_um < 0.0 || m.root_um > 200.0) {
    return FailValidation(
        issue, "root_um", "the root-corner relief must lie in [0, 200] um");
  }
  if (!std::isfinite(m.tip_um) || m.tip_um < 0.0 || m.tip_um > 200.0) {
    return FailValidation(
        issue, "tip_um", "the tip-corner relief must lie in [0, 200] um");
  }
  if (!(m.root_band > 0.0 && m.root_band <= 1.0)) {
    return FailValidation(
        issue,
        "root_band",
        "the root band must be a fraction in (0, 1] of the contact-line range");
  }
  if (!(m.tip_band > 0.0 && m.tip_band <= 1.0)) {
    return FailValidation(
        issue,
        "tip_band",
        "the tip band must be a fraction in (0, 1] of the contact-line range");
  }
  if (m.exponent != 1 && m.exponent != 2) {
    return FailValidation(
        issue, "exponent", "the exponent must be 1 (linear) or 2 (parabolic)");
  }
  if (!std::isfinite(m.root_slope) || std::abs(m.root_slope) > 1.0) {
    return FailValidation(
        issue,
        "root_slope",
        "the root slope along the contact line must lie in [-1, 1]");
  }
  if (!std::isfinite(m.tip_slope) || std::abs(m.tip_slope) > 1.0) {
    return FailValidation(
        issue,
        "tip_slope",
        "the tip slope along the contact line must lie in [-1, 1]");
  }
  return true;
}

DiagonallyModifiedFlank::DiagonallyModifiedFlank(
    const GearData& work_gear, const DiagonalModification& modification)
    : gear_(work_gear), modification_(modification) {
  base_radius_mm_ = gear_.BaseRadiusMm();
  lead_rate_per_mm_ = std::tan(gear_.helix_angle_rad) / gear_.PitchRadiusMm();
  psi0_rad_ =
      kPi / (2.0 * gear_.teeth) + Involute(gear_.TransversePressureAngleRad());
  tan_base_helix_ = gear_.TanBaseHelixAngle();
  cos_base_helix_ = 1.0 / std::sqrt(1.0 + tan_base_helix_ * tan_base_helix_);
  sin_base_helix_ = tan_base_helix_ * cos_base_helix_;
  form_roll_length_mm_ = gear_.FormRollLengthMm();
  tip_roll_length_mm_ = gear_.TipRollLengthMm();
  // w over the four corners of the active flank: L + x tan(beta_b) is linear,
  // so its extremes lie at corners.
  const double half = 0.5 * gear_.face_width_mm;
  double lo = 1e300, hi = -1e300;
  for (double roll : {form_roll_length_mm_, tip_roll_length_mm_}) {
    for (double x : {-half, half}) {
      const double v = roll + x * tan_base_helix_;
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  }
  w_min_mm_ = lo;
  w_span_mm_ = hi > lo ? hi - lo : 1.0;
}

bool DiagonallyModifiedFlank::OnActiveFlank(double roll_length_mm,
                                            double x_mm) const {
  return roll_length_mm >= form_roll_length_mm_ &&
         roll_length_mm <= tip_roll_length_mm_ &&
         std::abs(x_mm) <= 0.5 * gear_.face_width_mm;
}

double DiagonallyModifiedFlank::ContactLineCoordinate(double roll_length_mm,
                                                      double x_mm) const {
  return (roll_length_mm + x_mm * tan_base_helix_ - w_min_mm_) / w_span_mm_;
}

ReliefDerivatives DiagonallyModifiedFlank::Relief(double roll_length_mm,
                                                  double x_mm) const {
  const DiagonalModification& m = modification_;
  ReliefDerivatives r;
  const double w = ContactLineCoordinate(roll_length_mm, x_mm);
  const double w_l = 1.0 / w_span_mm_;
  const double w_x = tan_base_helix_ / w_span_mm_;
  const double eta = 2.0 * x_mm / gear_.face_width_mm;
  const double eta_x = 2.0 / gear_.face_width_mm;
  // Term j: T = -C (1 + k eta) g(w). With a = 1 + k eta (a_x = k eta_x):
  //   T_L = -C a g' w_L,            T_x = -C (k eta_x g + a g' w_x),
  //   T_LL = -C a g'' w_L^2,        T_Lx = -C (k eta_x g' w_L + a g'' w_L w_x),
  //   T_xx = -C (2 k eta_x g' w_x + a g'' w_x^2).
  auto add = [&](double amount, double slope, const Band& b) {
    if (amount == 0.0 || (b.g == 0.0 && b.dg == 0.0)) return;
    const double a = 1.0 + slope * eta;
    const double a_x = slope * eta_x;
    r.value_um += -amount * a * b.g;
    r.d_roll += -amount * a * b.dg * w_l;
    r.d_x += -amount * (a_x * b.g + a * b.dg * w_x);
    r.d_roll_roll += -amount * a * b.ddg * w_l * w_l;
    r.d_roll_x += -amount * (a_x * b.dg * w_l + a * b.ddg * w_l * w_x);
    r.d_x_x += -amount * (2.0 * a_x * b.dg * w_x + a * b.ddg * w_x * w_x);
  };
  const double l1 = m.root_band;
  const double l2 = m.tip_band;
  add(m.root_um,
      m.root_slope,
      EvaluateBand((l1 - w) / l1, -1.0 / l1, m.exponent));
  add(m.tip_um,
      m.tip_slope,
      EvaluateBand((w - 1.0 + l2) / l2, 1.0 / l2, m.exponent));
  return r;
}

ModifiedFlankPoint DiagonallyModifiedFlank::At(double roll_length_mm,
                                               double x_mm,
                                               bool with_normal) const {
  const double rb = base_radius_mm_;
  const double k = lead_rate_per_mm_;
  const double cb = cos_base_helix_;
  const double sb = sin_base_helix_;
  const double L = roll_length_mm;
  const double psi =
      psi0_rad_ - k * x_mm - L / rb;  // psi_L = -1/r_b, psi_x = -k
  const double c = std::cos(psi), s = std::sin(psi);
  // e = e(psi), t = e'(psi) = e(psi + pi/2), as 3-vectors with x = 0.
  const Eigen::Vector3d e(0.0, c, s);
  const Eigen::Vector3d t(0.0, -s, c);
  const Eigen::Vector3d ex = Eigen::Vector3d::UnitX();

  // Involute helicoid and its derivatives (de/dpsi = t, dt/dpsi = -e).
  const Eigen::Vector3d r1 = x_mm * ex + rb * e + L * t;
  const Eigen::Vector3d r_l = (L / rb) * e;
  const Eigen::Vector3d r_x = ex - k * (rb * t - L * e);
  const Eigen::Vector3d r_ll = e / rb - (L / (rb * rb)) * t;
  const Eigen::Vector3d r_lx = -(k * L / rb) * t;
  const Eigen::Vector3d r_xx = -k * k * (rb * e + L * t);
  // Outward unit normal n1 = (sin beta_b, cos beta_b t) and its derivatives.
  const Eigen::Vector3d n = sb * ex + cb * t;
  const Eigen::Vector3d n_l = (cb / rb) * e;
  const Eigen::Vector3d n_x = (cb * k) * e;
  const Eigen::Vector3d n_ll = -(cb / (rb * rb)) * t;
  const Eigen::Vector3d n_lx = -(cb * k / rb) * t;
  const Eigen::Vector3d n_xx = -(cb * k * k) * t;

  ModifiedFlankPoint p;
  p.relief = Relief(L, x_mm);
  p.unmodified_normal = n;
  const double d = p.relief.value_um * kUmToMm;
  const double d_l = p.relief.d_roll * kUmToMm;
  const double d_x = p.relief.d_x * kUmToMm;
  const double d_ll = p.relief.d_roll_roll * kUmToMm;
  const double d_lx = p.relief.d_roll_x * kUmToMm;
  const double d_xx = p.relief.d_x_x * kUmToMm;
  // R1r = R1 + delta n and its derivatives up to the second order.
  p.position_mm = r1 + d * n;
  p.d_roll = r_l + d_l * n + d * n_l;
  p.d_x = r_x + d_x * n + d * n_x;
  if (!with_normal) return p;
  const Eigen::Vector3d p_ll = r_ll + d_ll * n + 2.0 * d_l * n_l + d * n_ll;
  const Eigen::Vector3d p_lx =
      r_lx + d_lx * n + d_l * n_x + d_x * n_l + d * n_lx;
  const Eigen::Vector3d p_xx = r_xx + d_xx * n + 2.0 * d_x * n_x + d * n_xx;
  // N1r = p_x x p_L and its derivatives.
  p.normal = p.d_x.cross(p.d_roll);
  p.d_normal_d_roll = p_lx.cross(p.d_roll) + p.d_x.cross(p_ll);
  p.d_normal_d_x = p_xx.cross(p.d_roll) + p.d_x.cross(p_lx);
  return p;
}

}  // namespace gearloop
