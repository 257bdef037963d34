#include "engine/split_bevel/gear.h"

#include <cmath>

#include "engine/core/units.h"

namespace gearloop {

const char* SplitBevelHandName(SplitBevelHand hand) {
  return hand == SplitBevelHand::kLeft ? "left" : "right";
}

const char* SplitBevelFlankName(SplitBevelFlank flank) {
  return flank == SplitBevelFlank::kConvex ? "convex" : "concave";
}

SplitBevelGearData DeriveSplitBevelGear(const SplitBevelGear& gear) {
  SplitBevelGearData d;
  d.teeth = gear.teeth;
  d.pitch_angle_rad = gear.pitch_angle_rad;
  d.pressure_angle_rad = gear.pressure_angle_rad;
  d.hand = gear.hand;
  d.hand_sign = gear.hand == SplitBevelHand::kRight ? 1.0 : -1.0;
  const double sin_delta = std::sin(gear.pitch_angle_rad);
  d.outer_cone_distance_mm =
      gear.outer_cone_distance_mm
          ? *gear.outer_cone_distance_mm
          : gear.teeth * gear.outer_transverse_module_mm.value_or(0.0) /
                (2.0 * sin_delta);
  d.inner_cone_distance_mm = d.outer_cone_distance_mm - gear.face_width_mm;
  d.mean_cone_distance_mm = d.outer_cone_distance_mm - 0.5 * gear.face_width_mm;
  d.base_radius_mm =
      gear.mean_spiral_angle_rad
          ? d.mean_cone_distance_mm * std::cos(*gear.mean_spiral_angle_rad)
          : d.outer_cone_distance_mm *
                std::cos(gear.outer_spiral_angle_rad.value_or(0.0));
  d.normal_module_mm = 2.0 * d.base_radius_mm * sin_delta / gear.teeth;
  d.crown_teeth = gear.teeth / sin_delta;
  d.inner_spiral_angle_rad = SpiralAngleAt(d, d.inner_cone_distance_mm);
  // The given angle itself where it was given (acos(cos x) loses a few ulps).
  d.mean_spiral_angle_rad = gear.mean_spiral_angle_rad
                                ? *gear.mean_spiral_angle_rad
                                : SpiralAngleAt(d, d.mean_cone_distance_mm);
  d.outer_spiral_angle_rad = gear.outer_spiral_angle_rad
                                 ? *gear.outer_spiral_angle_rad
                                 : SpiralAngleAt(d, d.outer_cone_distance_mm);
  d.addendum_mm = gear.addendum_mm.value_or(d.normal_module_mm);
  d.dedendum_mm = gear.dedendum_mm.value_or(1.25 * d.normal_module_mm);
  d.slot_width_mm = gear.slot_width_mm.value_or(0.5 * kPi * d.normal_module_mm);
  return d;
}

double SplitBevelInvolute(double x_rad) { return std::tan(x_rad) - x_rad; }

double SpiralAngleAt(const SplitBevelGearData& gear, double cone_distance_mm) {
  return std::acos(gear.base_radius_mm / cone_distance_mm);
}

double ArcLengthAt(const SplitBevelGearData& gear, double cone_distance_mm) {
  const double ri = gear.inner_cone_distance_mm;
  return (cone_distance_mm - ri) * (cone_distance_mm + ri) /
         (2.0 * gear.base_radius_mm);
}

double ConeDistanceAtArc(const SplitBevelGearData& gear, double arc_mm) {
  const double ri = gear.inner_cone_distance_mm;
  return std::sqrt(ri * ri + 2.0 * gear.base_radius_mm * arc_mm);
}

double SlotAzimuth(const SplitBevelGearData& gear, int slot) {
  return 2.0 * kPi * slot / gear.teeth;
}

double CentreLineAzimuth(const SplitBevelGearData& gear,
                         int slot,
                         double cone_distance_mm) {
  return SlotAzimuth(gear, slot) +
         gear.hand_sign *
             (SplitBevelInvolute(SpiralAngleAt(gear, cone_distance_mm)) -
              SplitBevelInvolute(gear.mean_spiral_angle_rad)) /
             std::sin(gear.pitch_angle_rad);
}

namespace {
// sigma w / (2 r_b sin d) with the flank's sign: offsetting an involute along
// its normal by w/2 turns it by w / (2 r_b) in the developed plane.
double FlankTurn(const SplitBevelGearData& gear, SplitBevelFlank flank) {
  const double turn =
      gear.hand_sign * gear.slot_width_mm /
      (2.0 * gear.base_radius_mm * std::sin(gear.pitch_angle_rad));
  return flank == SplitBevelFlank::kConvex ? turn : -turn;
}
}  // namespace

double FlankLineAzimuth(const SplitBevelGearData& gear,
                        int slot,
                        SplitBevelFlank flank,
                        double cone_distance_mm) {
  return CentreLineAzimuth(gear, slot, cone_distance_mm) +
         FlankTurn(gear, flank);
}

double FlankLineAzimuthOffset(const SplitBevelGearData& gear,
                              int slot,
                              SplitBevelFlank flank) {
  return SlotAzimuth(gear, slot) -
         gear.hand_sign * SplitBevelInvolute(gear.mean_spiral_angle_rad) /
             std::sin(gear.pitch_angle_rad) +
         FlankTurn(gear, flank);
}

}  // namespace gearloop
