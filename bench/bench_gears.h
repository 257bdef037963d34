// bench/bench_gears.h: the gears and targets the correction benchmark and the
// noise-floor study grind (the published cutter and the gears of the engine
// tests).
#ifndef GEARLOOP_BENCH_BENCH_GEARS_H_
#define GEARLOOP_BENCH_BENCH_GEARS_H_

#include <vector>

#include "engine/core/units.h"
#include "engine/grinder/grinding_setup.h"
#include "engine/grinder/target_modification.h"

namespace gearloop {
namespace bench {

// A gear from its data: tip and root radius from the pitch radius +- addendum /
// dedendum [mm].
inline GrindingSetup Gear(int teeth,
                          double module_mm,
                          double pressure_deg,
                          double helix_deg,
                          double face_mm,
                          double addendum_mm,
                          double dedendum_mm,
                          double wheel_mm,
                          Flank flank) {
  GrindingSetup s;
  s.gear.teeth = teeth;
  s.gear.normal_module_mm = module_mm;
  s.gear.normal_pressure_angle_rad = pressure_deg * kRadPerDeg;
  s.gear.helix_angle_rad = helix_deg * kRadPerDeg;
  s.gear.face_width_mm = face_mm;
  const double r_j = s.gear.PitchRadiusMm();
  s.gear.tip_radius_mm = r_j + addendum_mm;
  s.gear.root_radius_mm = r_j - dedendum_mm;
  s.wheel.radius_mm = wheel_mm;
  s.flank = flank;
  return s;
}

// The published cutter, right flank (r_a and r_f as in Jiang 2015: 120.9157 and
// 107.1569 mm).
inline GrindingSetup Cutter() {
  GrindingSetup cutter =
      Gear(37, 6.0, 20.0, 15.0, 78.0, 0.0, 0.0, 350.0, Flank::kRight);
  cutter.gear.tip_radius_mm = 120.9157;
  cutter.gear.root_radius_mm = 107.1569;
  return cutter;
}
// A 31-tooth right-hand helical gear, left flank.
inline GrindingSetup RightHandLeftFlank() {
  return Gear(31, 3.0, 17.5, -22.0, 50.0, 3.0, 3.75, 300.0, Flank::kLeft);
}
// A 23-tooth 25 deg left-hand helical gear, right flank.
inline GrindingSetup Helical() {
  return Gear(23, 5.0, 20.0, 25.0, 60.0, 5.0, 6.25, 300.0, Flank::kRight);
}
// A 25-tooth spur gear, right flank.
inline GrindingSetup Spur() {
  return Gear(25, 4.0, 20.0, 0.0, 40.0, 4.0, 5.0, 250.0, Flank::kRight);
}

// 4 um profile slope, -3 um helix slope and 2 um profile crowning.
inline std::vector<TargetModification> SlopesAndCrowning() {
  return {{ModificationKind::kProfileSlope, 4.0},
          {ModificationKind::kHelixSlope, -3.0},
          {ModificationKind::kProfileCrowning, 2.0}};
}
// 5 um of linear diagonal end relief at both ends, bands of 0.3.
inline TargetModification DiagonalEndRelief() {
  TargetModification diagonal{ModificationKind::kDiagonalEndRelief, 5.0, 0.3};
  diagonal.second_amount_um = 5.0;
  return diagonal;
}

}  // namespace bench
}  // namespace gearloop

#endif  // GEARLOOP_BENCH_BENCH_GEARS_H_
