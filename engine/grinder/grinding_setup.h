// engine/grinder/grinding_setup.h: the data of one grinding job: gear, wheel,
// machine constants, flank and measurement grid (MODEL.md §1 and §4), with
// validation that names the field at fault.
//
//   GrindingSetup setup;
//   setup.gear.teeth = 37; ...
//   ValidationIssue issue;
//   if (!ValidateSetup(setup, &issue)) { /* issue.field, issue.message */ }
//
// All lengths in mm, all angles in rad. The helix angle is SIGNED as in
// MODEL.md §1: beta > 0 is a LEFT-hand helix, beta < 0 a right-hand helix, 0 a
// spur gear.
#ifndef GEARLOOP_ENGINE_GRINDER_GRINDING_SETUP_H_
#define GEARLOOP_ENGINE_GRINDER_GRINDING_SETUP_H_

#include <string>

namespace gearloop {

struct GearData {
  // Number of teeth z (>= 5).
  int teeth = 0;
  // Normal module m_n [mm] (> 0).
  double normal_module_mm = 0.0;
  // Normal pressure angle alpha_n [rad], in (0, 45 deg).
  double normal_pressure_angle_rad = 0.0;
  // Signed helix angle beta [rad], |beta| < 60 deg; > 0 left hand, < 0 right
  // hand.
  double helix_angle_rad = 0.0;
  // Face width b [mm] (> 0).
  double face_width_mm = 0.0;
  // Tip radius r_a [mm]: must lie above the form radius and the base radius.
  double tip_radius_mm = 0.0;
  // Radius reached by the wheel rim r_f [mm] (the root), below the pitch
  // radius.
  double root_radius_mm = 0.0;

  // r_j = z m_n / (2 cos beta) [mm].
  double PitchRadiusMm() const;
  // alpha_t = atan(tan alpha_n / cos beta) [rad].
  double TransversePressureAngleRad() const;
  // r_b = r_j cos alpha_t [mm].
  double BaseRadiusMm() const;
  // tan beta_b = tan beta cos alpha_t (signed like beta).
  double TanBaseHelixAngle() const;
  // Roll length of the form point where the wheel rim's tip line meets the line
  // of action, L_form = max(0, r_j sin alpha_t - (r_j - r_f) / sin alpha_t)
  // [mm] (MODEL.md §4).
  double FormRollLengthMm() const;
  // Roll length of the tip, L_a = sqrt(r_a^2 - r_b^2) [mm].
  double TipRollLengthMm() const;
};

// The grinding wheel: its radius R_w [mm]. Its profile (cone angle, parabola)
// is part of the corrected settings (MachineSettings::wheel), not of this fixed
// description.
struct WheelData {
  double radius_mm = 0.0;
};

// Machine constants of MODEL.md §1.
struct MachineConstants {
  // K1: wheel-head pivot offset along the wheel axis [mm].
  double k1_mm = 0.0;
  // K2: wheel-head pivot offset along the lead [mm].
  double k2_mm = 0.0;
  // C_s: wheel traverse along the lead per radian of roll [mm/rad]; 0 = wheel
  // fixed.
  double traverse_mm_per_rad = 0.0;
};

enum class Flank { kRight, kLeft };

// The measurement grid (MODEL.md §4). Row 0 lies at the root side, column 0 at
// x < 0.
struct GridOptions {
  // Number of profile rows (>= 2) and lead columns (>= 2).
  int profile_points = 5;
  int lead_points = 9;
  // Fractions of the roll-length range [L_form, L_a] spanned by the rows, 0 <=
  // begin < end <= 1.
  double profile_begin = 0.2;
  double profile_end = 0.9;
  // Fractions of the face width b spanned by the columns (x = l b), -0.5 <=
  // begin < end <= 0.5.
  double lead_begin = -0.4;
  double lead_end = 0.4;
};

struct GrindingSetup {
  GearData gear;
  WheelData wheel;
  MachineConstants machine;
  Flank flank = Flank::kRight;
  GridOptions grid;
};

// What is wrong with an input: `field` is a path into the setup using the C++
// field names
// ("gear.tip_radius_mm", "grid.profile_begin"), `message` says why in words a
// gear engineer reads (angles quoted in degrees).
struct ValidationIssue {
  std::string field;
  std::string message;
};

// Fills `issue` (if non-null) with `field` and `message` and returns false: the
// refusal of every engine validator (grinder, shaving, metrology).
bool FailValidation(ValidationIssue* issue,
                    const std::string& field,
                    const std::string& message);
// A number as validation messages quote it: 6 significant digits.
std::string FormatValidationNumber(double value);

// Each returns true when valid; otherwise fills `issue` (if non-null) with the
// first problem.
bool ValidateGear(const GearData& gear, ValidationIssue* issue);
bool ValidateGrid(const GridOptions& grid, ValidationIssue* issue);
// Checks everything, including that the wheel is large enough to generate the
// whole flank (R_w cos alpha_n must exceed the depth from the root to the tip)
// and that the grid lies on the involute (L_form < L_a).
bool ValidateSetup(const GrindingSetup& setup, ValidationIssue* issue);

// inv(alpha) = tan(alpha) - alpha.
double Involute(double alpha_rad);

}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_GRINDER_GRINDING_SETUP_H_
