// The 422 list of SPLIT_BEVEL.md §8: every invalid request is refused by
// SplitBevelRequest::IsValid (or, for the two the computation finds, by
// ComputeSplitTrajectory) with the field as the API names it, and
// ComputeSplitTrajectory returns the same refusal without computing.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "engine/core/units.h"
#include "engine/split_bevel/trajectory.h"
#include "tests/engine/split_bevel_test_gears.h"

namespace gearloop {
namespace {

using split_bevel_test::AllGears;
using split_bevel_test::LeftHandPinion;
using split_bevel_test::LeftHandWheel;
using split_bevel_test::RightHandWheel;

struct Case {
  std::string name;
  std::function<void(SplitBevelRequest*)> change;
  std::string field;
};

std::vector<Case> Cases() {
  const double nan = std::nan("");
  return {
      {"teeth zero",
       [](SplitBevelRequest* r) { r->gear.teeth = 0; },
       "gear.teeth"},
      {"pitch angle zero",
       [](SplitBevelRequest* r) { r->gear.pitch_angle_rad = 0.0; },
       "gear.pitch_angle_deg"},
      {"pitch angle above 90",
       [](SplitBevelRequest* r) { r->gear.pitch_angle_rad = DegToRad(90.5); },
       "gear.pitch_angle_deg"},
      {"pitch angle NaN",
       [nan](SplitBevelRequest* r) { r->gear.pitch_angle_rad = nan; },
       "gear.pitch_angle_deg"},
      {"both Re and m_et",
       [](SplitBevelRequest* r) { r->gear.outer_cone_distance_mm = 1500.0; },
       "gear.outer_cone_distance_mm"},
      {"neither Re nor m_et",
       [](SplitBevelRequest* r) { r->gear.outer_transverse_module_mm.reset(); },
       "gear.outer_cone_distance_mm"},
      {"m_et negative",
       [](SplitBevelRequest* r) { r->gear.outer_transverse_module_mm = -40.0; },
       "gear.outer_transverse_module_mm"},
      {"Re zero",
       [](SplitBevelRequest* r) {
         r->gear.outer_transverse_module_mm.reset();
         r->gear.outer_cone_distance_mm = 0.0;
       },
       "gear.outer_cone_distance_mm"},
      {"face width zero",
       [](SplitBevelRequest* r) { r->gear.face_width_mm = 0.0; },
       "gear.face_width_mm"},
      {"face width reaches Re",
       [](SplitBevelRequest* r) { r->gear.face_width_mm = 1600.0; },
       "gear.face_width_mm"},
      {"both spiral angles",
       [](SplitBevelRequest* r) {
         r->gear.outer_spiral_angle_rad = DegToRad(40.0);
       },
       "gear.mean_spiral_angle_deg"},
      {"neither spiral angle",
       [](SplitBevelRequest* r) { r->gear.mean_spiral_angle_rad.reset(); },
       "gear.mean_spiral_angle_deg"},
      {"mean spiral angle 60",
       [](SplitBevelRequest* r) {
         r->gear.mean_spiral_angle_rad = DegToRad(60.0);
       },
       "gear.mean_spiral_angle_deg"},
      {"outer spiral angle zero",
       [](SplitBevelRequest* r) {
         r->gear.mean_spiral_angle_rad.reset();
         r->gear.outer_spiral_angle_rad = 0.0;
       },
       "gear.outer_spiral_angle_deg"},
      {"pressure angle 45",
       [](SplitBevelRequest* r) {
         r->gear.pressure_angle_rad = DegToRad(45.0);
       },
       "gear.pressure_angle_deg"},
      {"pressure angle zero",
       [](SplitBevelRequest* r) { r->gear.pressure_angle_rad = 0.0; },
       "gear.pressure_angle_deg"},
      {"addendum negative",
       [](SplitBevelRequest* r) { r->gear.addendum_mm = -1.0; },
       "gear.addendum_mm"},
      {"dedendum zero",
       [](SplitBevelRequest* r) { r->gear.dedendum_mm = 0.0; },
       "gear.dedendum_mm"},
      {"slot width negative",
       [](SplitBevelRequest* r) { r->gear.slot_width_mm = -3.0; },
       "gear.slot_width_mm"},
      {"tool radius zero",
       [](SplitBevelRequest* r) { r->tool.radius_mm = 0.0; },
       "tool.radius_mm"},
      {"stock eats the tool",
       [](SplitBevelRequest* r) { r->tool.stock_mm = -8.0; },
       "tool.stock_mm"},
      {"slot index z",
       [](SplitBevelRequest* r) { r->cut.slot_index = 75; },
       "cut.slot_index"},
      {"slot index -z",
       [](SplitBevelRequest* r) { r->cut.slot_index = -75; },
       "cut.slot_index"},
      {"no flank",
       [](SplitBevelRequest* r) { r->cut.flanks.clear(); },
       "cut.flanks"},
      {"a flank twice",
       [](SplitBevelRequest* r) {
         r->cut.flanks = {SplitBevelFlank::kConcave, SplitBevelFlank::kConcave};
       },
       "cut.flanks"},
      {"levels zero",
       [](SplitBevelRequest* r) { r->cut.depth_levels = 0; },
       "cut.depth_levels"},
      {"levels 101",
       [](SplitBevelRequest* r) { r->cut.depth_levels = 101; },
       "cut.depth_levels"},
      {"steps 1", [](SplitBevelRequest* r) { r->cut.steps = 1; }, "cut.steps"},
      {"steps 20002",
       [](SplitBevelRequest* r) { r->cut.steps = 20002; },
       "cut.steps"},
      {"steps and tolerance",
       [](SplitBevelRequest* r) { r->cut.chord_tolerance_mm = 0.01; },
       "cut.steps"},
      {"tolerance below 1e-4",
       [](SplitBevelRequest* r) {
         r->cut.steps.reset();
         r->cut.chord_tolerance_mm = 9e-5;
       },
       "cut.chord_tolerance_mm"},
      {"feed zero",
       [](SplitBevelRequest* r) { r->cut.feed_mm_per_min = 0.0; },
       "cut.feed_mm_per_min"},
      {"pivot negative",
       [](SplitBevelRequest* r) { r->machine.pivot_length_mm = -1.0; },
       "machine.pivot_length_mm"},
      {"A limits reversed",
       [](SplitBevelRequest* r) {
         std::swap(r->machine.limits.a_min_rad, r->machine.limits.a_max_rad);
       },
       "machine.a_limits_deg"},
      {"B limits empty",
       [](SplitBevelRequest* r) {
         r->machine.limits.b_max_rad = r->machine.limits.b_min_rad;
       },
       "machine.b_limits_deg"},
      {"apex NaN",
       [nan](SplitBevelRequest* r) { r->setup.apex_mm.y() = nan; },
       "setup.apex_mm"},
      {"segment mid infinite",
       [](SplitBevelRequest* r) { r->setup.segment_mid_rad = INFINITY; },
       "setup.segment_mid_deg"},
      {"segment angle zero",
       [](SplitBevelRequest* r) { r->setup.segment_angle_rad = 0.0; },
       "setup.segment_angle_deg"},
      {"segment angle above 360",
       [](SplitBevelRequest* r) {
         r->setup.segment_angle_rad = DegToRad(361.0);
       },
       "setup.segment_angle_deg"},
      // r_b >= Ri: beta_m = 20 deg puts r_b = Rm cos 20 = 1387 mm above Ri =
      // 1356 mm. The field is the spiral angle that was given.
      {"base circle outside Ri (mean)",
       [](SplitBevelRequest* r) {
         r->gear.mean_spiral_angle_rad = DegToRad(20.0);
       },
       "gear.mean_spiral_angle_deg"},
      {"base circle outside Ri (outer)",
       [](SplitBevelRequest* r) {
         r->gear.mean_spiral_angle_rad.reset();
         r->gear.outer_spiral_angle_rad = DegToRad(25.0);
       },
       "gear.outer_spiral_angle_deg"},
      // Root slot width w - 2 h_f tan(alpha) <= 0.
      {"slot closes above the root",
       [](SplitBevelRequest* r) { r->gear.dedendum_mm = 70.0; },
       "gear.dedendum_mm"},
      // (2 r0 + s) cos(2 alpha) > w cos(alpha) - 2 h_f sin(alpha) = 18.8 mm: r0
      // = 12.5.
      {"tool too wide",
       [](SplitBevelRequest* r) { r->tool.radius_mm = 12.5; },
       "tool.radius_mm"},
      {"segment too narrow",
       [](SplitBevelRequest* r) { r->setup.segment_angle_rad = DegToRad(5.0); },
       "cut.slot_index"},
      {"segment elsewhere",
       [](SplitBevelRequest* r) {
         r->setup.segment_angle_rad = DegToRad(40.0);
         r->setup.segment_mid_rad = DegToRad(40.0);
       },
       "cut.slot_index"},
  };
}

TEST(SplitBevelRequest, TestGearsAreValid) {
  for (const auto& g : AllGears()) {
    std::string field, message;
    EXPECT_TRUE(g.request.IsValid(&field, &message))
        << g.name << ": " << field << ": " << message;
  }
}

TEST(SplitBevelRequest, EveryRefusalNamesItsField) {
  for (const Case& c : Cases()) {
    SplitBevelRequest r = RightHandWheel();
    c.change(&r);
    std::string field, message;
    EXPECT_FALSE(r.IsValid(&field, &message)) << c.name;
    EXPECT_EQ(field, c.field) << c.name << ": " << message;
    EXPECT_FALSE(message.empty()) << c.name;
    const SplitBevelResult result = ComputeSplitTrajectory(r);
    EXPECT_FALSE(result.ok) << c.name;
    EXPECT_EQ(result.field, c.field) << c.name;
    EXPECT_EQ(result.message, message) << c.name;
    EXPECT_TRUE(result.passes.empty()) << c.name;
  }
}

TEST(SplitBevelRequest, BoundsThemselvesAreValid) {
  SplitBevelRequest r = RightHandWheel();
  std::string field, message;
  r.cut.steps = 2;
  EXPECT_TRUE(r.IsValid(&field, &message)) << message;
  r.cut.depth_levels = 100;
  EXPECT_TRUE(r.IsValid(&field, &message)) << message;
  r.cut.steps.reset();
  r.cut.chord_tolerance_mm = 1e-4;
  EXPECT_TRUE(r.IsValid(&field, &message)) << message;
  r.setup.segment_angle_rad = DegToRad(360.0);
  EXPECT_TRUE(r.IsValid(&field, &message)) << message;
  SplitBevelRequest crown = RightHandWheel();
  crown.gear.pitch_angle_rad = DegToRad(90.0);
  EXPECT_TRUE(crown.IsValid(&field, &message)) << message;
}

// Concave flank more curved than the tool allows: r0 + s >= (Ri sin(beta_i) -
// h_f tan(alpha)) / cos(alpha). A narrow-spiral pinion with a wide slot makes
// the bound smaller than the tool.
TEST(SplitBevelRequest, ConcaveFlankTooCurvedForTheTool) {
  SplitBevelRequest r = LeftHandPinion();
  r.gear.outer_transverse_module_mm.reset();
  r.gear.outer_cone_distance_mm = 100.0;
  r.gear.face_width_mm = 30.0;
  // beta_m chosen so that r_b lies just inside Ri = 70 mm: Ri sin(beta_i) is
  // then small.
  const double ri = 70.0, rm = 85.0;
  const double rb = ri - 0.05;
  r.gear.mean_spiral_angle_rad = std::acos(rb / rm);
  r.gear.slot_width_mm = 40.0;
  r.gear.dedendum_mm = 3.0;
  r.gear.addendum_mm = 3.0;
  r.tool.radius_mm = 4.0;
  const double beta_i = std::acos(rb / ri);
  const double bound =
      (ri * std::sin(beta_i) - 3.0 * std::tan(DegToRad(20.0))) /
      std::cos(DegToRad(20.0));
  ASSERT_LT(bound, 4.0);
  std::string field, message;
  r.cut.flanks = {SplitBevelFlank::kConvex, SplitBevelFlank::kConcave};
  EXPECT_FALSE(r.IsValid(&field, &message));
  EXPECT_EQ(field, "tool.radius_mm") << message;
  EXPECT_NE(message.find("concave"), std::string::npos) << message;
  // The convex flank alone is not bounded by the concave curvature.
  r.cut.flanks = {SplitBevelFlank::kConvex};
  EXPECT_TRUE(r.IsValid(&field, &message)) << field << ": " << message;
}

// More than 20001 stations needed for the chord tolerance: a line starting just
// outside its base circle (curvature radius ~0 at the toe, R sin(beta) =
// sqrt(R^2 - r_b^2)) over a long face, the tool centre 1 um off the convex
// flank, at the smallest tolerance 1e-4 mm.
TEST(ComputeSplitTrajectory, ChordToleranceNeedingTooManyStations) {
  SplitBevelRequest r = LeftHandPinion();
  r.gear.outer_transverse_module_mm.reset();
  r.gear.outer_cone_distance_mm = 5766.0;
  r.gear.face_width_mm = 3766.0;  // Ri = 2000, Rm = 3883 mm
  r.gear.mean_spiral_angle_rad =
      std::acos((2000.0 - 1e-4) / 3883.0);  // r_b = Ri - 0.1 um
  r.gear.addendum_mm = 0.01;
  r.gear.dedendum_mm = 0.01;
  r.tool.radius_mm = 1.0;
  r.tool.stock_mm = -0.999;
  r.cut.chord_tolerance_mm = 1e-4;
  r.cut.depth_levels = 1;
  r.cut.flanks = {SplitBevelFlank::kConvex};
  std::string field, message;
  ASSERT_TRUE(r.IsValid(&field, &message)) << field << ": " << message;
  const SplitBevelResult result = ComputeSplitTrajectory(r);
  EXPECT_FALSE(result.ok);
  EXPECT_EQ(result.field, "cut.chord_tolerance_mm") << result.message;
  // A looser tolerance on the same gear is met.
  r.cut.chord_tolerance_mm = 0.05;
  const SplitBevelResult loose = ComputeSplitTrajectory(r);
  EXPECT_TRUE(loose.ok) << loose.message;
}

TEST(ComputeSplitTrajectory, DefaultStationsAreFortyOne) {
  SplitBevelRequest r = LeftHandWheel();
  r.cut.steps.reset();
  const SplitBevelResult result = ComputeSplitTrajectory(r);
  ASSERT_TRUE(result.ok) << result.message;
  ASSERT_EQ(result.passes.size(), 6u);
  for (const SplitBevelPass& pass : result.passes)
    EXPECT_EQ(pass.points.size(), 41u);
  EXPECT_EQ(result.passes[0].flank, SplitBevelFlank::kConcave);
  EXPECT_EQ(result.passes[0].level, 0);
  EXPECT_EQ(result.passes[2].level, 2);
  EXPECT_EQ(result.passes[3].flank, SplitBevelFlank::kConvex);
  // Levels: y_j = h_a - (j + 1)(h_a + h_f) / L, the last on the root.
  EXPECT_NEAR(result.passes[0].tip_height_mm, 24.0 - 55.0 / 3, 1e-12);
  EXPECT_NEAR(result.passes[2].tip_height_mm, -31.0, 1e-12);
}

}  // namespace
}  // namespace gearloop
