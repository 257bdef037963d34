// engine/split_bevel/gear.h: the split equal-base-circle bevel wheel
// (SPLIT_BEVEL.md §1-§4): its input data with the either/or pairs, the derived
// data resolved from them, and the tooth lines (involutes of one base circle on
// the developed pitch cone) of every slot and flank.
//
//   SplitBevelGear gear;                       // z, delta, Re or m_et, b,
//   beta_m or beta_e, ... gear.teeth = 75; gear.pitch_angle_rad =
//   DegToRad(70.0); ... const SplitBevelGearData data =
//   DeriveSplitBevelGear(gear);   // gear must be valid const double psi =
//   FlankLineAzimuth(data, /*slot=*/0, SplitBevelFlank::kConvex, R);
//
// Blank frame Si (§3): origin at the pitch-cone apex, z along the gear axis
// from the apex toward the back of the wheel, right-handed. At cone distance R
// and azimuth psi the pitch point is R e_R with
//   e_R = (sin d cos psi, sin d sin psi, cos d), e_psi = (-sin psi, cos psi,
//   0), k   = (cos d cos psi, cos d sin psi, -sin d)   (outward pitch-cone
//   normal, toward the tips).
// The pitch cone develops onto the crown plane with polar radius R and polar
// angle theta = psi sin d. Every tooth line there is an involute of the base
// circle r_b: the spiral angle beta(R), measured from the cone generatrix,
// obeys R cos beta(R) = r_b at every R.
#ifndef GEARLOOP_ENGINE_SPLIT_BEVEL_GEAR_H_
#define GEARLOOP_ENGINE_SPLIT_BEVEL_GEAR_H_

#include <optional>

namespace gearloop {

// Hand of spiral (AGMA/ISO 23509): looking at the teeth from the apex side, the
// outer half of a left-hand tooth curves counter-clockwise. In Si a right-hand
// line has d psi / dR > 0.
enum class SplitBevelHand { kLeft, kRight };
// The two flanks of a slot. The convex flank's pitch line is the one on the
// side of the centre of curvature of the slot's centre line; the slot lies away
// from that centre (n_s = -c).
enum class SplitBevelFlank { kConvex, kConcave };
// "left" / "right", "convex" / "concave": the API's words.
const char* SplitBevelHandName(SplitBevelHand hand);
const char* SplitBevelFlankName(SplitBevelFlank flank);

// The gear as requested (SPLIT_BEVEL.md §1). Lengths mm, angles rad. Exactly
// one of each either/or pair is set; the optional tooth proportions default
// from the normal module m_n.
struct SplitBevelGear {
  // Number of teeth z (>= 1).
  int teeth = 0;
  // Pitch-cone angle delta, 0 < delta <= 90 deg.
  double pitch_angle_rad = 0.0;
  // Outer cone distance Re [mm], or the outer transverse module m_et [mm]: Re =
  // z m_et / (2 sin d).
  std::optional<double> outer_cone_distance_mm;
  std::optional<double> outer_transverse_module_mm;
  // Face width b [mm], 0 < b < Re: inner cone distance Ri = Re - b, mean Rm =
  // Re - b / 2.
  double face_width_mm = 0.0;
  // Mean spiral angle beta_m (at Rm) or outer spiral angle beta_e (at Re), 0 <
  // beta < 60 deg.
  std::optional<double> mean_spiral_angle_rad;
  std::optional<double> outer_spiral_angle_rad;
  SplitBevelHand hand = SplitBevelHand::kRight;
  // Flank angle to the pitch-cone normal, alpha, 0 < alpha < 45 deg.
  double pressure_angle_rad = 0.0;
  // Addendum h_a, dedendum h_f, slot width w at the pitch cone [mm]; defaults
  // m_n, 1.25 m_n, pi m_n / 2.
  std::optional<double> addendum_mm;
  std::optional<double> dedendum_mm;
  std::optional<double> slot_width_mm;
};

// The derived data of SPLIT_BEVEL.md §2, every either/or resolved. Lengths mm,
// angles rad.
struct SplitBevelGearData {
  int teeth = 0;
  double pitch_angle_rad = 0.0;
  double pressure_angle_rad = 0.0;
  SplitBevelHand hand = SplitBevelHand::kRight;
  // sigma = +1 right hand, -1 left hand.
  double hand_sign = 1.0;
  // r_b = Rm cos beta_m (or Re cos beta_e): the base circle of every tooth
  // line, both flanks, all slots.
  double base_radius_mm = 0.0;
  // m_n = 2 r_b sin d / z, constant along the face.
  double normal_module_mm = 0.0;
  // z_c = z / sin d, teeth of the crown (developed pitch) gear.
  double crown_teeth = 0.0;
  double inner_cone_distance_mm = 0.0;
  double mean_cone_distance_mm = 0.0;
  double outer_cone_distance_mm = 0.0;
  // beta(R) = acos(r_b / R) at Ri, Rm, Re.
  double inner_spiral_angle_rad = 0.0;
  double mean_spiral_angle_rad = 0.0;
  double outer_spiral_angle_rad = 0.0;
  double addendum_mm = 0.0;
  double dedendum_mm = 0.0;
  double slot_width_mm = 0.0;
};

// Resolves the either/or pairs and defaults. `gear` must be valid
// (SplitBevelRequest::IsValid, engine/split_bevel/trajectory.h); then r_b < Ri
// and every derived value is finite.
SplitBevelGearData DeriveSplitBevelGear(const SplitBevelGear& gear);

// inv x = tan x - x (the grinder family has its own gearloop::Involute; the
// families include nothing of each other).
double SplitBevelInvolute(double x_rad);
// beta(R) = acos(r_b / R) [rad], for R >= r_b.
double SpiralAngleAt(const SplitBevelGearData& gear, double cone_distance_mm);
// Pitch-line arc length from the inner end, S(R) = (R^2 - Ri^2) / (2 r_b) [mm]
// (the same for every line of the gear), and its inverse R(S) = sqrt(Ri^2 + 2
// r_b S).
double ArcLengthAt(const SplitBevelGearData& gear, double cone_distance_mm);
double ConeDistanceAtArc(const SplitBevelGearData& gear, double arc_mm);
// Azimuth 2 pi k / z of slot k's centre line at Rm [rad].
double SlotAzimuth(const SplitBevelGearData& gear, int slot);
// Centre line of slot k: psi_c(R) = 2 pi k / z + sigma (inv beta(R) - inv
// beta_m) / sin d [rad].
double CentreLineAzimuth(const SplitBevelGearData& gear,
                         int slot,
                         double cone_distance_mm);
// Flank line: psi_f = psi_c + sigma w / (2 r_b sin d) (convex) or - (concave)
// [rad].
double FlankLineAzimuth(const SplitBevelGearData& gear,
                        int slot,
                        SplitBevelFlank flank,
                        double cone_distance_mm);
// The constant psi_f(R) - sigma inv beta(R) / sin d of a flank line [rad] (phi0
// / sin d, §7 d).
double FlankLineAzimuthOffset(const SplitBevelGearData& gear,
                              int slot,
                              SplitBevelFlank flank);

}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_SPLIT_BEVEL_GEAR_H_
