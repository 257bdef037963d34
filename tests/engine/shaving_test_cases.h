// tests/engine/shaving_test_cases.h: the published plunge-shaving case (Jiang
// 2015, Table 1; SHAVING.md §1): the pinion and its cutter, standard
// installation.
#ifndef GEARLOOP_TESTS_ENGINE_SHAVING_TEST_CASES_H_
#define GEARLOOP_TESTS_ENGINE_SHAVING_TEST_CASES_H_

#include "engine/shaving/cutter_target.h"
#include "tests/engine/test_gears.h"

namespace gearloop {
namespace testing {

// Work gear: z1 = 19, m_n 6, alpha_n 20 deg, 9.91 deg right hand (beta1 = -9.91
// deg), b1 = 75, standard tip and root (r_j + m_n, r_j - 1.25 m_n).
inline GearData PublishedPinion() {
  GearData g;
  g.teeth = 19;
  g.normal_module_mm = 6.0;
  g.normal_pressure_angle_rad = Deg(20.0);
  g.helix_angle_rad = Deg(-9.91);
  g.face_width_mm = 75.0;
  return WithStandardRadii(g);
}

// Cutter: z_s = 37, m_n 6, 20 deg, 15 deg left hand (beta_s = +15 deg), b_s =
// 78, r_a = 120.9157, r_f = 107.1569 (the cutter of tests/engine/test_gears.h).
inline GearData PublishedCutter() { return CutterSetup().gear; }

inline ShavingInput PublishedShaving() {
  ShavingInput input;
  input.work_gear = PublishedPinion();
  input.cutter = PublishedCutter();
  input.wheel_check.h_s_mm = 2.0;
  return input;
}

// The certified diagonal modification: C1 = C2 = 20 um, l1 = l2 = 0.3, e = 2, k
// = 0.
inline DiagonalModification CertifiedModification() {
  DiagonalModification m;
  m.root_um = 20.0;
  m.tip_um = 20.0;
  m.root_band = 0.3;
  m.tip_band = 0.3;
  m.exponent = 2;
  return m;
}

}  // namespace testing
}  // namespace gearloop

#endif  // GEARLOOP_TESTS_ENGINE_SHAVING_TEST_CASES_H_
