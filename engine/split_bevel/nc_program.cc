#include "engine/split_bevel/nc_program.h"

#include <cctype>
#include <cmath>
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
  if (s[0] == '-' && s.find_first_not_of("-0.") == std::string::npos)
    s.erase(0, 1);
  return s;
}

std::string Upper(const char* s) {
  std::string out = s;
  for (char& c : out)
    c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return out;
}

// Appends x with 4 decimals, x * 10^4 rounded half away from zero: the same
// digits as "%.4f" but for values whose x * 10^4 sits within a rounding error
// of a half (printf rounds the binary value exactly, this the product); -0.0000
// is written 0.0000. Forty thousand points make 200 000 numbers, which snprintf
// would spend most of the listing's time on.
void AppendFixed4(double x, std::string* out) {
  const double scaled = x * 1e4;
  if (!(std::abs(scaled) <
        9e15)) {  // not representable as an exact integer count of 1e-4
    *out += Fixed(x, 4);
    return;
  }
  long long q = std::llround(scaled);
  if (q < 0) {
    out->push_back('-');
    q = -q;
  }
  char digits[24];
  int n = 0;
  long long whole = q / 10000;
  do {
    digits[n++] = static_cast<char>('0' + whole % 10);
    whole /= 10;
  } while (whole != 0);
  while (n > 0) out->push_back(digits[--n]);
  const int fraction = static_cast<int>(q % 10000);
  const char tail[5] = {'.',
                        static_cast<char>('0' + fraction / 1000),
                        static_cast<char>('0' + fraction / 100 % 10),
                        static_cast<char>('0' + fraction / 10 % 10),
                        static_cast<char>('0' + fraction % 10)};
  out->append(tail, 5);
}

void AppendAxisWords(const HeadAxes& axes, std::string* out) {
  out->push_back('X');
  AppendFixed4(axes.x_mm, out);
  out->append(" Y");
  AppendFixed4(axes.y_mm, out);
  out->append(" Z");
  AppendFixed4(axes.z_mm, out);
  out->append(" A");
  AppendFixed4(RadToDeg(axes.a_rad), out);
  out->append(" B");
  AppendFixed4(RadToDeg(axes.b_rad), out);
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

std::string FormatSplitBevelNcProgram(const SplitBevelRequest& request,
                                      const SplitBevelResult& result) {
  if (!result.ok) return std::string();
  const SplitBevelGearData& d = result.derived;
  const auto mm = [](double x) { return Fixed(x, 6); };
  const auto deg = [](double rad) { return Fixed(RadToDeg(rad), 6); };
  std::string nc;
  size_t lines = 0;
  for (const SplitBevelPass& pass : result.passes)
    lines += pass.points.size() + 3;
  nc.reserve(1024 + 72 * lines);
  nc += "%\n(GEARLOOP SPLIT-BEVEL 1)\n";
  nc += "(GEAR Z=" + std::to_string(d.teeth) +
        " DELTA=" + deg(d.pitch_angle_rad) +
        " RE=" + mm(d.outer_cone_distance_mm) +
        " B=" + mm(d.outer_cone_distance_mm - d.inner_cone_distance_mm) +
        " BETAM=" + deg(d.mean_spiral_angle_rad) +
        " HAND=" + Upper(SplitBevelHandName(d.hand)) +
        " ALPHA=" + deg(d.pressure_angle_rad) + ")\n";
  nc += "(DERIVED RB=" + mm(d.base_radius_mm) +
        " MN=" + mm(d.normal_module_mm) + " ZC=" + mm(d.crown_teeth) +
        " RI=" + mm(d.inner_cone_distance_mm) +
        " RM=" + mm(d.mean_cone_distance_mm) +
        " RE=" + mm(d.outer_cone_distance_mm) +
        " BETAI=" + deg(d.inner_spiral_angle_rad) +
        " BETAM=" + deg(d.mean_spiral_angle_rad) +
        " BETAE=" + deg(d.outer_spiral_angle_rad) + " HA=" + mm(d.addendum_mm) +
        " HF=" + mm(d.dedendum_mm) + " W=" + mm(d.slot_width_mm) + ")\n";
  nc += "(TOOL R0=" + mm(request.tool.radius_mm) +
        " S=" + mm(request.tool.stock_mm) + ")\n";
  const HeadLimits& limits = request.machine.limits;
  nc += "(MACHINE P=" + mm(request.machine.pivot_length_mm) +
        " AMIN=" + deg(limits.a_min_rad) + " AMAX=" + deg(limits.a_max_rad) +
        " BMIN=" + deg(limits.b_min_rad) + " BMAX=" + deg(limits.b_max_rad) +
        ")\n";
  const Eigen::Vector3d& apex = request.setup.apex_mm;
  nc += "(SETUP APEXX=" + mm(apex.x()) + " APEXY=" + mm(apex.y()) +
        " APEXZ=" + mm(apex.z()) + " PSIMID=" + deg(result.segment_mid_rad) +
        " SEGMENT=" +
        (request.setup.segment_angle_rad ? deg(*request.setup.segment_angle_rad)
                                         : std::string("NONE")) +
        ")\n";
  nc += "G90 G21 G94\n";
  const std::string feed = " F" + Fixed(request.cut.feed_mm_per_min, 1);
  for (size_t i = 0; i < result.passes.size(); ++i) {
    const SplitBevelPass& pass = result.passes[i];
    nc += "(PASS " + std::to_string(i + 1) + " SLOT " +
          std::to_string(pass.slot) + " FLANK " +
          Upper(SplitBevelFlankName(pass.flank)) + " LEVEL " +
          std::to_string(pass.level) + " POINTS " +
          std::to_string(pass.points.size()) + ")\n";
    if (pass.points.empty()) continue;
    nc += "G00 ";
    AppendAxisWords(StandBack(pass.points.front().axes), &nc);
    nc += "\n";
    for (size_t j = 0; j < pass.points.size(); ++j) {
      nc += "G01 ";
      AppendAxisWords(pass.points[j].axes, &nc);
      if (j == 0) nc += feed;
      nc += "\n";
    }
    nc += "G00 ";
    AppendAxisWords(StandBack(pass.points.back().axes), &nc);
    nc += "\n";
  }
  nc += "M30\n%\n";
  return nc;
}

}  // namespace gearloop
