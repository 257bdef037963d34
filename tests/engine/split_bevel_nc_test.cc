// The NC listing of a split-bevel trajectory (engine/split_bevel/nc_program.h,
// SPLIT_BEVEL.md §8): its line formats, and the round trip: the listing parsed
// back gives every point's X Y Z A B to its 4 decimals. The parser lives here,
// in the test: the engine only builds the text.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include "engine/core/units.h"
#include "engine/split_bevel/head_kinematics.h"
#include "engine/split_bevel/nc_program.h"
#include "engine/split_bevel/trajectory.h"
#include "tests/engine/split_bevel_test_gears.h"

namespace gearloop {
namespace {

using split_bevel_test::AllGears;
using split_bevel_test::LeftHandWheel;

// One motion line: G code, X Y Z [mm], A B [deg], feed (0 when absent).
struct NcMove {
  int g = -1;
  double x = 0, y = 0, z = 0, a = 0, b = 0, f = 0;
};
struct NcPass {
  int number = 0, slot = 0, level = 0, points = 0;
  std::string flank;
  std::vector<NcMove> moves;  // approach, points, retract
};
struct NcListing {
  std::vector<std::string> lines;
  std::vector<NcPass> passes;
};

// Parses "G0x X.. Y.. Z.. A.. B.. [F..]" words; returns false on anything else.
bool ParseMove(const std::string& line, NcMove* move) {
  std::istringstream in(line);
  std::string word;
  in >> word;
  if (word == "G00")
    move->g = 0;
  else if (word == "G01")
    move->g = 1;
  else
    return false;
  std::string expected = "XYZAB";
  double* targets[] = {&move->x, &move->y, &move->z, &move->a, &move->b};
  for (int i = 0; i < 5; ++i) {
    if (!(in >> word) || word[0] != expected[i]) return false;
    size_t used = 0;
    *targets[i] = std::stod(word.substr(1), &used);
    if (used + 1 != word.size()) return false;
    // Exactly four decimals.
    const size_t dot = word.find('.');
    if (dot == std::string::npos || word.size() - dot - 1 != 4) return false;
  }
  if (in >> word) {
    if (word[0] != 'F') return false;
    move->f = std::stod(word.substr(1));
  }
  return !(in >> word);
}

NcListing ParseListing(const std::string& text) {
  NcListing listing;
  std::string line;
  std::istringstream in(text);
  while (std::getline(in, line)) {
    listing.lines.push_back(line);
    if (line.rfind("(PASS ", 0) == 0) {
      NcPass pass;
      char flank[32] = {0};
      EXPECT_EQ(std::sscanf(line.c_str(),
                            "(PASS %d SLOT %d FLANK %31s LEVEL %d POINTS %d)",
                            &pass.number,
                            &pass.slot,
                            flank,
                            &pass.level,
                            &pass.points),
                5)
          << line;
      pass.flank = flank;
      listing.passes.push_back(pass);
    } else if (line.rfind("G0", 0) == 0 && line != "G90 G21 G94") {
      NcMove move;
      EXPECT_TRUE(ParseMove(line, &move)) << line;
      EXPECT_FALSE(listing.passes.empty()) << line;
      if (!listing.passes.empty()) listing.passes.back().moves.push_back(move);
    }
  }
  return listing;
}

double Rounded4(double x) { return std::round(x * 1e4) / 1e4; }

TEST(FormatSplitBevelNcProgram, LineFormats) {
  SplitBevelRequest r = LeftHandWheel();
  r.nc_program = true;
  const SplitBevelResult result = ComputeSplitTrajectory(r);
  ASSERT_TRUE(result.ok) << result.message;
  ASSERT_FALSE(result.nc_program.empty());
  EXPECT_EQ(result.nc_program, FormatSplitBevelNcProgram(r, result));
  EXPECT_EQ(result.nc_program.back(), '\n');
  const NcListing nc = ParseListing(result.nc_program);
  ASSERT_GE(nc.lines.size(), 9u);
  EXPECT_EQ(nc.lines[0], "%");
  EXPECT_EQ(nc.lines[1], "(GEARLOOP SPLIT-BEVEL 1)");
  EXPECT_EQ(nc.lines[2].rfind("(GEAR Z=60 ", 0), 0u) << nc.lines[2];
  EXPECT_EQ(nc.lines[3].rfind("(DERIVED RB=", 0), 0u) << nc.lines[3];
  EXPECT_EQ(nc.lines[4], "(TOOL R0=7.000000 S=0.500000)");
  EXPECT_EQ(nc.lines[5].rfind("(MACHINE P=350.000000 ", 0), 0u) << nc.lines[5];
  EXPECT_EQ(
      nc.lines[6].rfind(
          "(SETUP APEXX=400.000000 APEXY=-50.000000 APEXZ=600.000000 ", 0),
      0u)
      << nc.lines[6];
  EXPECT_EQ(nc.lines[7], "G90 G21 G94");
  EXPECT_EQ(nc.lines[nc.lines.size() - 2], "M30");
  EXPECT_EQ(nc.lines.back(), "%");
  // Comment lines hold KEY=value pairs and no nested parentheses.
  for (int i = 2; i <= 6; ++i) {
    EXPECT_EQ(nc.lines[i].find('(', 1), std::string::npos);
    EXPECT_EQ(nc.lines[i].find(')'), nc.lines[i].size() - 1);
  }
  EXPECT_NE(nc.lines[2].find("HAND=LEFT"), std::string::npos);
  // Passes: header, one approach G00, n G01 (F on the first only), one retract
  // G00.
  ASSERT_EQ(nc.passes.size(), result.passes.size());
  for (size_t i = 0; i < nc.passes.size(); ++i) {
    const NcPass& p = nc.passes[i];
    const SplitBevelPass& q = result.passes[i];
    EXPECT_EQ(p.number, static_cast<int>(i) + 1);
    EXPECT_EQ(p.slot, -2);
    EXPECT_EQ(p.flank,
              q.flank == SplitBevelFlank::kConvex ? "CONVEX" : "CONCAVE");
    EXPECT_EQ(p.level, q.level);
    EXPECT_EQ(p.points, static_cast<int>(q.points.size()));
    ASSERT_EQ(p.moves.size(), q.points.size() + 2);
    EXPECT_EQ(p.moves.front().g, 0);
    EXPECT_EQ(p.moves.back().g, 0);
    for (size_t j = 1; j + 1 < p.moves.size(); ++j) {
      EXPECT_EQ(p.moves[j].g, 1);
      EXPECT_EQ(p.moves[j].f, j == 1 ? 150.0 : 0.0);
    }
    // Approach and retract: the first / last pivot 5 mm back along the tool
    // axis, same A B.
    for (const auto& [move, point] :
         {std::make_pair(p.moves.front(), q.points.front()),
          std::make_pair(p.moves.back(), q.points.back())}) {
      const Eigen::Vector3d axis =
          HeadToolAxis(point.axes.a_rad, point.axes.b_rad);
      EXPECT_NEAR(move.x, Rounded4(point.axes.x_mm + 5.0 * axis.x()), 1e-9);
      EXPECT_NEAR(move.y, Rounded4(point.axes.y_mm + 5.0 * axis.y()), 1e-9);
      EXPECT_NEAR(move.z, Rounded4(point.axes.z_mm + 5.0 * axis.z()), 1e-9);
      EXPECT_NEAR(move.a, Rounded4(RadToDeg(point.axes.a_rad)), 1e-9);
      EXPECT_NEAR(move.b, Rounded4(RadToDeg(point.axes.b_rad)), 1e-9);
      // The tool centre stands back from the flank: farther from the apex-side
      // work.
      const ToolPose stand = HeadForward(
          HeadAxes{move.x, move.y, move.z, DegToRad(move.a), DegToRad(move.b)},
          r.machine.pivot_length_mm);
      const ToolPose at = HeadForward(point.axes, r.machine.pivot_length_mm);
      EXPECT_NEAR((stand.centre_mm - at.centre_mm).norm(), 5.0, 1e-3);
    }
  }
}

// The listing parsed back gives every point's X Y Z A B to its 4 decimals, on
// every test gear.
TEST(FormatSplitBevelNcProgram, RoundTripToFourDecimals) {
  for (const auto& g : AllGears()) {
    SplitBevelRequest r = g.request;
    r.nc_program = true;
    const SplitBevelResult result = ComputeSplitTrajectory(r);
    ASSERT_TRUE(result.ok) << g.name << ": " << result.message;
    const NcListing nc = ParseListing(result.nc_program);
    ASSERT_EQ(nc.passes.size(), result.passes.size()) << g.name;
    size_t count = 0;
    for (size_t i = 0; i < nc.passes.size(); ++i) {
      const SplitBevelPass& q = result.passes[i];
      ASSERT_EQ(nc.passes[i].moves.size(), q.points.size() + 2) << g.name;
      for (size_t j = 0; j < q.points.size(); ++j) {
        const NcMove& m = nc.passes[i].moves[j + 1];
        const HeadAxes& a = q.points[j].axes;
        // Within half a unit of the fourth decimal, and equal to the value
        // rounded there.
        const double half = 0.5e-4 * (1 + 1e-9);
        EXPECT_LE(std::abs(m.x - a.x_mm), half);
        EXPECT_LE(std::abs(m.y - a.y_mm), half);
        EXPECT_LE(std::abs(m.z - a.z_mm), half);
        EXPECT_LE(std::abs(m.a - RadToDeg(a.a_rad)), half);
        EXPECT_LE(std::abs(m.b - RadToDeg(a.b_rad)), half);
        EXPECT_NEAR(m.x, Rounded4(a.x_mm), 1e-9);
        EXPECT_NEAR(m.b, Rounded4(RadToDeg(a.b_rad)), 1e-9);
        ++count;
      }
    }
    EXPECT_GT(count, 100u) << g.name;
    EXPECT_EQ(result.nc_program.find("-0.0000 "), std::string::npos);
    EXPECT_EQ(result.nc_program.find("-0.0000\n"), std::string::npos);
  }
}

TEST(FormatSplitBevelNcProgram, NotBuiltUnlessAskedAndEmptyForAFailedResult) {
  SplitBevelRequest r = LeftHandWheel();
  const SplitBevelResult result = ComputeSplitTrajectory(r);
  ASSERT_TRUE(result.ok);
  EXPECT_TRUE(result.nc_program.empty());
  SplitBevelResult failed;
  EXPECT_EQ(FormatSplitBevelNcProgram(r, failed), "");
}

}  // namespace
}  // namespace gearloop
