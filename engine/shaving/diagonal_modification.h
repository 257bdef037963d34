// engine/shaving/diagonal_modification.h: the diagonally modified flank of the
// work gear ("pinion") of plunge shaving (SHAVING.md §2): relief in the root
// corner at one face end and the tip corner at the other, bounded by contact
// lines, with the modified flank's point, its first and second derivatives and
// its normal, all in closed form.
//
//   DiagonalModification m;
//   m.root_um = 20.0; m.tip_um = 20.0; m.root_band = m.tip_band = 0.3;
//   m.exponent = 2; const DiagonallyModifiedFlank flank(work_gear, m);      //
//   work_gear must pass ValidateGear const ModifiedFlankPoint p =
//   flank.At(/*roll_length_mm=*/25.0, /*x_mm=*/-10.0);
//   // p.position_mm = R1r, p.normal = N1r, p.relief.value_um = delta1
//
// Frame and flank: the work frame S1 of MODEL.md §3 (x = gear axis, origin at
// mid face width), the RIGHT flank of the tooth on polar angle 0 (the flank
// that drives the cutter's right flank in the mesh of SHAVING.md §3). With the
// roll length L = sqrt(r^2 - r_b^2), k = tan(beta) / r_j and the base-circle
// tangent angle psi = pi/(2z) + inv(alpha_t) - k x - L / r_b, the involute
// helicoid is
//   R1(L, x) = (x, r_b e(psi) + L e'(psi)),   e(psi) = (cos psi, sin psi), e' =
//   de/dpsi,
// (the same surface as MODEL.md §3's theta(r, x): r_b e + L e' has radius
// sqrt(r_b^2 + L^2) and polar angle psi + atan(L / r_b)), and its outward unit
// normal is n1 = (sin beta_b, cos beta_b e'(psi)), beta_b the signed base helix
// angle (tan beta_b = tan beta cos alpha_t).
//
// Modification (SHAVING.md §2), delta1 in um, positive = material left on:
//   w     = (L + x tan beta_b - w_min) / (w_max - w_min)   over the 4 corners L
//   in {L_f, L_a}, x = +-b/2 eta   = 2 x / b delta1 = -C1 (1 + k1 eta) max(0,
//   (l1 - w)/l1)^e - C2 (1 + k2 eta) max(0, (w - 1 + l2)/l2)^e
// L + x tan beta_b is constant along the straight contact lines (generators) of
// this flank. Modified flank R1r = R1 + delta1 n1 (delta1 in mm there), normal
// N1r = dR1r/dx x dR1r/dL: the order that points it like n1 (dR1/dL x dR1/dx
// points into the material). N1r is not normalised; the meshing equation needs
// only its direction, and its size is |dR1r/dx x dR1r/dL|. Derivatives of
// delta1, n1 and R1 are analytic (written out in the .cc); with e = 1 the
// relief has a kink at the band edge, where the one-sided derivative of the
// band side (w inside the band) is not taken: max(0, s) counts as 0 at s = 0.
#ifndef GEARLOOP_ENGINE_SHAVING_DIAGONAL_MODIFICATION_H_
#define GEARLOOP_ENGINE_SHAVING_DIAGONAL_MODIFICATION_H_

#include <Eigen/Core>

#include "engine/grinder/grinding_setup.h"

namespace gearloop {

// SHAVING.md §2 and §6 ("diagonal_modification"): field names are the API's
// keys.
struct DiagonalModification {
  // C1: relief at the root corner (low w: root of one face end) [um], in [0,
  // 200]. 0 = none.
  double root_um = 0.0;
  // C2: relief at the tip corner (high w: tip of the other face end) [um], in
  // [0, 200]. 0 = none.
  double tip_um = 0.0;
  // l1, l2: band widths as fractions of the w range, in (0, 1].
  double root_band = 0.3;
  double tip_band = 0.3;
  // e: 1 linear, 2 parabolic.
  int exponent = 2;
  // k1, k2: the amount varies along the contact line as C (1 + k eta), |k| <=
  // 1; 0 = constant along a contact line (type I), otherwise type II.
  double root_slope = 0.0;
  double tip_slope = 0.0;
};

// Checks the ranges of SHAVING.md §7; fills `issue` with the field name
// relative to the modification ("root_um", "tip_band", "exponent", ...) and
// returns false.
bool ValidateDiagonalModification(const DiagonalModification& modification,
                                  ValidationIssue* issue);

// delta1 [um] and its partial derivatives in (L, x) [um/mm, um/mm^2].
struct ReliefDerivatives {
  double value_um = 0.0;
  double d_roll = 0.0;
  double d_x = 0.0;
  double d_roll_roll = 0.0;
  double d_roll_x = 0.0;
  double d_x_x = 0.0;
};

// The modified flank at one (L, x), in S1 [mm]; derivatives with respect to L
// and x.
struct ModifiedFlankPoint {
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();  // R1r
  Eigen::Vector3d d_roll = Eigen::Vector3d::Zero();       // dR1r/dL
  Eigen::Vector3d d_x = Eigen::Vector3d::Zero();          // dR1r/dx
  Eigen::Vector3d normal =
      Eigen::Vector3d::Zero();  // N1r = dR1r/dx x dR1r/dL (not unit)
  Eigen::Vector3d d_normal_d_roll = Eigen::Vector3d::Zero();    // dN1r/dL
  Eigen::Vector3d d_normal_d_x = Eigen::Vector3d::Zero();       // dN1r/dx
  Eigen::Vector3d unmodified_normal = Eigen::Vector3d::Zero();  // n1 (unit)
  ReliefDerivatives relief;
};

class DiagonallyModifiedFlank {
 public:
  // `work_gear` must pass ValidateGear, `modification`
  // ValidateDiagonalModification.
  DiagonallyModifiedFlank(const GearData& work_gear,
                          const DiagonalModification& modification);

  const GearData& gear() const { return gear_; }
  const DiagonalModification& modification() const { return modification_; }

  // The active flank: L in [L_f, L_a] (L_f from the root radius as in MODEL.md
  // §4), |x| <= b/2.
  double form_roll_length_mm() const { return form_roll_length_mm_; }
  double tip_roll_length_mm() const { return tip_roll_length_mm_; }
  bool OnActiveFlank(double roll_length_mm, double x_mm) const;

  // The normalised contact-line coordinate w (0 at the root corner, 1 at the
  // tip corner).
  double ContactLineCoordinate(double roll_length_mm, double x_mm) const;
  // delta1 and its derivatives.
  ReliefDerivatives Relief(double roll_length_mm, double x_mm) const;
  // R1r, its first derivatives and N1r with its first derivatives (second
  // derivatives of R1r). With `with_normal` false only R1r and its first
  // derivatives are filled (the normal and its derivatives stay zero).
  ModifiedFlankPoint At(double roll_length_mm,
                        double x_mm,
                        bool with_normal = true) const;

 private:
  GearData gear_;
  DiagonalModification modification_;
  double base_radius_mm_ = 0.0;
  double lead_rate_per_mm_ = 0.0;  // k = tan(beta) / r_j
  double psi0_rad_ = 0.0;          // pi/(2z) + inv(alpha_t)
  double sin_base_helix_ = 0.0;
  double cos_base_helix_ = 0.0;
  double tan_base_helix_ = 0.0;
  double form_roll_length_mm_ = 0.0;
  double tip_roll_length_mm_ = 0.0;
  double w_min_mm_ = 0.0;
  double w_span_mm_ = 1.0;
};

}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_SHAVING_DIAGONAL_MODIFICATION_H_
