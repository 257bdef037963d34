#include "engine/split_bevel/nc_program.h"

#include <cctype>
#include <cstdio>
#include <string>

#include "engine/core/units.h"

namespace gearloop {

namespace {

std::string Fixed(double x, int decimals) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.*f", decimals, x);
  std::string s = buffer;
  // A value that rounds to zero is written without its sign.
  if (s[0] == '-' && s.find_first_not_of("-0.") == std::string::npos) s.erase(0, 1);
  return s;
}

std::string Upper(const char* s) {
  std::string out = s;
  for (char& c : out) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return out;
}

std::string AxisWords(const HeadAxes& axes) {
  return "X" + Fixed(axes.x_mm, 4) + " Y" + Fixed(axes.y_mm, 4) + " Z" + Fixed(axes.z_mm, 4) + " A" +
         Fixed(RadToDeg(axes.a_rad), 4) + " B" + Fixed(RadToDeg(axes.b_rad), 4);
}

// The pivot moved back (toward the spindle) along the tool axis, same A and B.
HeadAxes StandBack(const HeadAxes& axes) {
  const Eigen::Vector3d axis = HeadToolAxis(axes.a_rad, axes.b_rad);
  HeadAxes out = axes;
  out.x_mm += kSplitBevelClearanceMm * axis.x();
  out.y_mm += kSplitBevelClearanceMm * axis.y();
  out.z_mm += kSplitBevelClearanceMm * axis.z();
  return out;
}

}  // namespace

std::string FormatSplitBevelNcProgram(const SplitBevelRequest& request, const SplitBevelResult& result) {
  if (!result.ok) return std::string();
  const SplitBevelGearData& d = result.derived;
  const auto mm = [](double x) { return Fixed(x, 6); };
  const auto deg = [](double rad) { return Fixed(RadToDeg(rad), 6); };
  std::string nc;
  nc.reserve(256 + 64 * 60 * result.passes.size() * (result.passes.empty() ? 0 : result.passes[0].points.size()));
  nc += "%\n(GEARLOOP SPLIT-BEVEL 1)\n";
  nc += "(GEAR Z=" + std::to_string(d.teeth) + " DELTA=" + deg(d.pitch_angle_rad) +
        " RE=" + mm(d.outer_cone_distance_mm) + " B=" + mm(d.outer_cone_distance_mm - d.inner_cone_distance_mm) +
        " BETAM=" + deg(d.mean_spiral_angle_rad) + " HAND=" + Upper(SplitBevelHandName(d.hand)) +
        " ALPHA=" + deg(d.pressure_angle_rad) + ")\n";
  nc += "(DERIVED RB=" + mm(d.base_radius_mm) + " MN=" + mm(d.normal_module_mm) + " ZC=" + mm(d.crown_teeth) +
        " RI=" + mm(d.inner_cone_distance_mm) + " RM=" + mm(d.mean_cone_distance_mm) +
        " RE=" + mm(d.outer_cone_distance_mm) + " BETAI=" + deg(d.inner_spiral_angle_rad) +
        " BETAM=" + deg(d.mean_spiral_angle_rad) + " BETAE=" + deg(d.outer_spiral_angle_rad) +
        " HA=" + mm(d.addendum_mm) + " HF=" + mm(d.dedendum_mm) + " W=" + mm(d.slot_width_mm) + ")\n";
  nc += "(TOOL R0=" + mm(request.tool.radius_mm) + " S=" + mm(request.tool.stock_mm) + ")\n";
  const HeadLimits& limits = request.machine.limits;
  nc += "(MACHINE P=" + mm(request.machine.pivot_length_mm) + " AMIN=" + deg(limits.a_min_rad) +
        " AMAX=" + deg(limits.a_max_rad) + " BMIN=" + deg(limits.b_min_rad) + " BMAX=" + deg(limits.b_max_rad) +
        ")\n";
  const Eigen::Vector3d& apex = request.setup.apex_mm;
  nc += "(SETUP APEXX=" + mm(apex.x()) + " APEXY=" + mm(apex.y()) + " APEXZ=" + mm(apex.z()) +
        " PSIMID=" + deg(result.segment_mid_rad) + " SEGMENT=" +
        (request.setup.segment_angle_rad ? deg(*request.setup.segment_angle_rad) : std::string("NONE")) + ")\n";
  nc += "G90 G21 G94\n";
  const std::string feed = " F" + Fixed(request.cut.feed_mm_per_min, 1);
  for (size_t i = 0; i < result.passes.size(); ++i) {
    const SplitBevelPass& pass = result.passes[i];
    nc += "(PASS " + std::to_string(i + 1) + " SLOT " + std::to_string(pass.slot) + " FLANK " +
          Upper(SplitBevelFlankName(pass.flank)) + " LEVEL " + std::to_string(pass.level) + " POINTS " +
          std::to_string(pass.points.size()) + ")\n";
    if (pass.points.empty()) continue;
    nc += "G00 " + AxisWords(StandBack(pass.points.front().axes)) + "\n";
    for (size_t j = 0; j < pass.points.size(); ++j) {
      nc += "G01 " + AxisWords(pass.points[j].axes);
      if (j == 0) nc += feed;
      nc += "\n";
    }
    nc += "G00 " + AxisWords(StandBack(pass.points.back().axes)) + "\n";
  }
  nc += "M30\n%\n";
  return nc;
}

}  // namespace gearloop
