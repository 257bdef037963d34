// The split-bevel requests the tests share
// (tests/engine/split_bevel_*_test.cc): a right-hand wheel, a left-hand wheel
// with every optional field given, and a left-hand pinion cut to a chord
// tolerance. Degrees written as degrees, converted here as the API's codec
// will.
#ifndef GEARLOOP_TESTS_ENGINE_SPLIT_BEVEL_TEST_GEARS_H_
#define GEARLOOP_TESTS_ENGINE_SPLIT_BEVEL_TEST_GEARS_H_

#include <string>
#include <vector>

#include "engine/core/units.h"
#include "engine/split_bevel/trajectory.h"

namespace gearloop {
namespace split_bevel_test {

// z = 75, delta = 70 deg, m_et = 40 mm (Re = 1596.3 mm), b = 240 mm, beta_m =
// 35 deg right hand, alpha = 20 deg, default tooth proportions; r0 = 8 mm, 0.2
// mm stock; slot 3, both flanks, 4 levels, 61 stations from the toe; TCP mode,
// apex at the machine origin.
inline SplitBevelRequest RightHandWheel() {
  SplitBevelRequest r;
  r.gear.teeth = 75;
  r.gear.pitch_angle_rad = DegToRad(70.0);
  r.gear.outer_transverse_module_mm = 40.0;
  r.gear.face_width_mm = 240.0;
  r.gear.mean_spiral_angle_rad = DegToRad(35.0);
  r.gear.hand = SplitBevelHand::kRight;
  r.gear.pressure_angle_rad = DegToRad(20.0);
  r.tool.radius_mm = 8.0;
  r.tool.stock_mm = 0.2;
  r.cut.slot_index = 3;
  r.cut.flanks = {SplitBevelFlank::kConvex, SplitBevelFlank::kConcave};
  r.cut.depth_levels = 4;
  r.cut.steps = 61;
  return r;
}

// z = 60, delta = 60 deg, Re = 1200 mm, b = 180 mm, beta_e = 40 deg left hand,
// alpha = 22.5 deg, h_a = 24, h_f = 31, w = 40 mm; r0 = 7 mm, 0.5 mm stock;
// slot -2, concave then convex, 3 levels, 25 stations from the heel; pivot 350
// mm, apex at (400, -50, 600), a 30 deg segment.
inline SplitBevelRequest LeftHandWheel() {
  SplitBevelRequest r;
  r.gear.teeth = 60;
  r.gear.pitch_angle_rad = DegToRad(60.0);
  r.gear.outer_cone_distance_mm = 1200.0;
  r.gear.face_width_mm = 180.0;
  r.gear.outer_spiral_angle_rad = DegToRad(40.0);
  r.gear.hand = SplitBevelHand::kLeft;
  r.gear.pressure_angle_rad = DegToRad(22.5);
  r.gear.addendum_mm = 24.0;
  r.gear.dedendum_mm = 31.0;
  r.gear.slot_width_mm = 40.0;
  r.tool.radius_mm = 7.0;
  r.tool.stock_mm = 0.5;
  r.cut.slot_index = -2;
  r.cut.flanks = {SplitBevelFlank::kConcave, SplitBevelFlank::kConvex};
  r.cut.depth_levels = 3;
  r.cut.steps = 25;
  r.cut.from = SplitBevelStart::kHeel;
  r.cut.feed_mm_per_min = 150.0;
  r.machine.pivot_length_mm = 350.0;
  r.setup.apex_mm = Eigen::Vector3d(400.0, -50.0, 600.0);
  r.setup.segment_angle_rad = DegToRad(30.0);
  return r;
}

// z = 19, delta = 20 deg, m_et = 30 mm, b = 120 mm, beta_m = 35 deg left hand,
// alpha = 20 deg; r0 = 6 mm, no stock; slot 0, both flanks, 2 levels, stations
// for a 0.01 mm chord tolerance; pivot 200 mm.
inline SplitBevelRequest LeftHandPinion() {
  SplitBevelRequest r;
  r.gear.teeth = 19;
  r.gear.pitch_angle_rad = DegToRad(20.0);
  r.gear.outer_transverse_module_mm = 30.0;
  r.gear.face_width_mm = 120.0;
  r.gear.mean_spiral_angle_rad = DegToRad(35.0);
  r.gear.hand = SplitBevelHand::kLeft;
  r.gear.pressure_angle_rad = DegToRad(20.0);
  r.tool.radius_mm = 6.0;
  r.cut.slot_index = 0;
  r.cut.flanks = {SplitBevelFlank::kConvex, SplitBevelFlank::kConcave};
  r.cut.depth_levels = 2;
  r.cut.chord_tolerance_mm = 0.01;
  r.machine.pivot_length_mm = 200.0;
  return r;
}

struct NamedRequest {
  std::string name;
  SplitBevelRequest request;
};

inline std::vector<NamedRequest> AllGears() {
  return {{"RightHandWheel", RightHandWheel()},
          {"LeftHandWheel", LeftHandWheel()},
          {"LeftHandPinion", LeftHandPinion()}};
}

}  // namespace split_bevel_test
}  // namespace gearloop

#endif  // GEARLOOP_TESTS_ENGINE_SPLIT_BEVEL_TEST_GEARS_H_
