// tests/engine/test_gears.h: the gears the engine tests grind, with known data.
#ifndef GEARLOOP_TESTS_ENGINE_TEST_GEARS_H_
#define GEARLOOP_TESTS_ENGINE_TEST_GEARS_H_

#include <cmath>

#include "engine/core/units.h"
#include "engine/grinder/grinding_setup.h"

namespace gearloop {
namespace testing {

inline double Deg(double degrees) { return degrees * kPi / 180.0; }

// The plunge-shaving cutter of the published example (Jiang 2015, Table 1): 37
// teeth, m_n 6 mm, 20 deg, helix 15 deg LEFT hand (beta = +15 deg), b = 78 mm,
// R_w = 350 mm, K1 = K2 = 0, fixed wheel.
inline GrindingSetup CutterSetup(Flank flank = Flank::kRight) {
  GrindingSetup s;
  s.gear.teeth = 37;
  s.gear.normal_module_mm = 6.0;
  s.gear.normal_pressure_angle_rad = Deg(20.0);
  s.gear.helix_angle_rad = Deg(15.0);
  s.gear.face_width_mm = 78.0;
  s.gear.tip_radius_mm = 120.9157;
  s.gear.root_radius_mm = 107.1569;
  s.wheel.radius_mm = 350.0;
  s.flank = flank;
  return s;
}

// A spur gear: 25 teeth, m_n 4 mm, 20 deg, b = 40 mm, R_w = 250 mm.
inline GrindingSetup SpurSetup(Flank flank = Flank::kRight) {
  GrindingSetup s;
  s.gear.teeth = 25;
  s.gear.normal_module_mm = 4.0;
  s.gear.normal_pressure_angle_rad = Deg(20.0);
  s.gear.helix_angle_rad = 0.0;
  s.gear.face_width_mm = 40.0;
  s.gear.tip_radius_mm = 54.0;
  s.gear.root_radius_mm = 45.0;
  s.wheel.radius_mm = 250.0;
  s.flank = flank;
  return s;
}

// A right-hand helical gear: 31 teeth, m_n 3 mm, 17.5 deg, helix 22 deg right
// hand (beta = -22 deg), b = 50 mm, R_w = 300 mm.
inline GrindingSetup RightHandSetup(Flank flank = Flank::kRight) {
  GrindingSetup s;
  s.gear.teeth = 31;
  s.gear.normal_module_mm = 3.0;
  s.gear.normal_pressure_angle_rad = Deg(17.5);
  s.gear.helix_angle_rad = Deg(-22.0);
  s.gear.face_width_mm = 50.0;
  const double r_j = s.gear.PitchRadiusMm();
  s.gear.tip_radius_mm = r_j + 3.0;
  s.gear.root_radius_mm = r_j - 3.75;
  s.wheel.radius_mm = 300.0;
  s.flank = flank;
  return s;
}

}  // namespace testing
}  // namespace gearloop

#endif  // GEARLOOP_TESTS_ENGINE_TEST_GEARS_H_
