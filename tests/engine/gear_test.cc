#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "engine/grinder/flank_grid.h"
#include "engine/grinder/grinding_setup.h"
#include "tests/engine/test_gears.h"

namespace gearloop {
namespace {

using testing::CutterSetup;
using testing::Deg;

TEST(GearData, DerivedRadiiOfTheCutter) {
  const GearData gear = CutterSetup().gear;
  EXPECT_NEAR(
      gear.PitchRadiusMm(), 37 * 6.0 / (2.0 * std::cos(Deg(15))), 1e-12);
  const double alpha_t = std::atan(std::tan(Deg(20)) / std::cos(Deg(15)));
  EXPECT_NEAR(gear.TransversePressureAngleRad(), alpha_t, 1e-15);
  EXPECT_NEAR(
      gear.BaseRadiusMm(), gear.PitchRadiusMm() * std::cos(alpha_t), 1e-12);
  EXPECT_NEAR(Involute(Deg(20)), 0.014904383867336446, 1e-15);
}

TEST(ValidateSetup, AcceptsTheCutter) {
  ValidationIssue issue;
  EXPECT_TRUE(ValidateSetup(CutterSetup(), &issue))
      << issue.field << ": " << issue.message;
}

struct InvalidCase {
  std::string expected_field;
  std::function<void(GrindingSetup*)> spoil;
};

TEST(ValidateSetup, NamesTheFieldAtFault) {
  const std::vector<InvalidCase> cases = {
      {"gear.teeth", [](GrindingSetup* s) { s->gear.teeth = 4; }},
      {"gear.teeth", [](GrindingSetup* s) { s->gear.teeth = -37; }},
      {"gear.normal_module_mm",
       [](GrindingSetup* s) { s->gear.normal_module_mm = 0.0; }},
      {"gear.normal_module_mm",
       [](GrindingSetup* s) { s->gear.normal_module_mm = NAN; }},
      {"gear.normal_pressure_angle_rad",
       [](GrindingSetup* s) { s->gear.normal_pressure_angle_rad = 0.0; }},
      {"gear.normal_pressure_angle_rad",
       [](GrindingSetup* s) { s->gear.normal_pressure_angle_rad = Deg(45); }},
      {"gear.helix_angle_rad",
       [](GrindingSetup* s) { s->gear.helix_angle_rad = Deg(60); }},
      {"gear.helix_angle_rad",
       [](GrindingSetup* s) { s->gear.helix_angle_rad = Deg(-75); }},
      {"gear.face_width_mm",
       [](GrindingSetup* s) { s->gear.face_width_mm = -1.0; }},
      {"gear.tip_radius_mm",
       [](GrindingSetup* s) { s->gear.tip_radius_mm = 100.0; }},
      {"gear.tip_radius_mm",
       [](GrindingSetup* s) { s->gear.tip_radius_mm = INFINITY; }},
      {"gear.root_radius_mm",
       [](GrindingSetup* s) { s->gear.root_radius_mm = 130.0; }},
      {"gear.root_radius_mm",
       [](GrindingSetup* s) { s->gear.root_radius_mm = 0.0; }},
      {"wheel.radius_mm", [](GrindingSetup* s) { s->wheel.radius_mm = 0.0; }},
      {"wheel.radius_mm", [](GrindingSetup* s) { s->wheel.radius_mm = 20.0; }},
      {"machine.k1_mm", [](GrindingSetup* s) { s->machine.k1_mm = NAN; }},
      {"machine.traverse_mm_per_rad",
       [](GrindingSetup* s) { s->machine.traverse_mm_per_rad = INFINITY; }},
      {"grid.profile_points",
       [](GrindingSetup* s) { s->grid.profile_points = 1; }},
      {"grid.lead_points",
       [](GrindingSetup* s) { s->grid.lead_points = 1000; }},
      {"grid.profile_end",
       [](GrindingSetup* s) {
         s->grid.profile_end = 0.1;
       }},  // range the wrong way round
      {"grid.lead_begin", [](GrindingSetup* s) { s->grid.lead_begin = -0.7; }},
      {"grid.lead_end", [](GrindingSetup* s) { s->grid.lead_end = 0.6; }},
  };
  for (const InvalidCase& c : cases) {
    GrindingSetup setup = CutterSetup();
    c.spoil(&setup);
    ValidationIssue issue;
    EXPECT_FALSE(ValidateSetup(setup, &issue)) << c.expected_field;
    EXPECT_EQ(issue.field, c.expected_field) << issue.message;
    EXPECT_FALSE(issue.message.empty());
  }
}

TEST(BuildFlankGrid, RowsAndColumnsFollowModelSection4) {
  const GrindingSetup setup = CutterSetup();
  const FlankGrid grid = BuildFlankGrid(setup);
  ASSERT_EQ(grid.rows, 5);
  ASSERT_EQ(grid.columns, 9);
  const double span = grid.tip_roll_length_mm - grid.form_roll_length_mm;
  EXPECT_NEAR(grid.At(0, 0).roll_length_mm,
              grid.form_roll_length_mm + 0.2 * span,
              1e-12);
  EXPECT_NEAR(grid.At(4, 8).roll_length_mm,
              grid.form_roll_length_mm + 0.9 * span,
              1e-12);
  EXPECT_NEAR(grid.At(2, 0).x_mm, -0.4 * 78.0, 1e-12);
  EXPECT_NEAR(grid.At(2, 8).x_mm, 0.4 * 78.0, 1e-12);
  EXPECT_NEAR(grid.At(2, 4).x_mm, 0.0, 1e-12);
  for (const FlankGridPoint& p : grid.points) {
    EXPECT_NEAR(p.normal.norm(), 1.0, 1e-14);
    EXPECT_NEAR(
        std::hypot(p.position_mm.y(), p.position_mm.z()), p.radius_mm, 1e-12);
    // Right flank: the outward normal points toward +theta (out of the tooth
    // centred on 0).
    const Eigen::Vector3d tangential(
        0.0, -p.position_mm.z(), p.position_mm.y());
    EXPECT_GT(p.normal.dot(tangential), 0.0);
  }
}

TEST(InvoluteFlankPoint, NormalIsPerpendicularToTheFlank) {
  const GearData gear = CutterSetup().gear;
  for (Flank flank : {Flank::kRight, Flank::kLeft}) {
    const FlankGridPoint p = InvoluteFlankPoint(gear, flank, 20.0, 10.0);
    const double h = 1e-4;
    const Eigen::Vector3d along_profile =
        (InvoluteFlankPoint(gear, flank, 20.0 + h, 10.0).position_mm -
         InvoluteFlankPoint(gear, flank, 20.0 - h, 10.0).position_mm);
    const Eigen::Vector3d along_lead =
        (InvoluteFlankPoint(gear, flank, 20.0, 10.0 + h).position_mm -
         InvoluteFlankPoint(gear, flank, 20.0, 10.0 - h).position_mm);
    EXPECT_LT(std::abs(p.normal.dot(along_profile.normalized())), 1e-8);
    EXPECT_LT(std::abs(p.normal.dot(along_lead.normalized())), 1e-8);
  }
}

}  // namespace
}  // namespace gearloop
