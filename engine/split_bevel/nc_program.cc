#include "engine/split_bevel/nc_program.h"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <string>

#include "engine/core/units.h"

namespace gearloop {

namespace {

std::string Fixed(double x, int decimals) {
  const int length = std::snprintf(nullptr, 0, "%.*f", decimals, x);
  std::string s(static_cast<size_t>(length), '\0');
  std::snprintf(s.data(), s.size() + 1, "%.*f", decimals, x);
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

// Writes x with 4 decimals at *cursor and advances it: x * 10^4 rounded half
// away from zero (the digits of "%.4f" except where x * 10^4 sits within a
// rounding error of a half: printf rounds the binary value exactly, this the
// product); -0.0000 is written 0.0000. Forty thousand points make 200 000
// numbers, which snprintf would spend most of the listing's time on. At most 22
// characters; |x| must be below 9e11 (kMaxFastFixed4).
constexpr double kMaxFastFixed4 = 9e11;
void WriteFixed4(double x, char** cursor) {
  char* out = *cursor;
  long long q = std::llround(x * 1e4);
  if (q < 0) {
    *out++ = '-';
    q = -q;
  }
  char digits[24];
  int n = 0;
  long long whole = q / 10000;
  do {
    digits[n++] = static_cast<char>('0' + whole % 10);
    whole /= 10;
  } while (whole != 0);
  while (n > 0) *out++ = digits[--n];
  const int fraction = static_cast<int>(q % 10000);
  *out++ = '.';
  *out++ = static_cast<char>('0' + fraction / 1000);
  *out++ = static_cast<char>('0' + fraction / 100 % 10);
  *out++ = static_cast<char>('0' + fraction / 10 % 10);
  *out++ = static_cast<char>('0' + fraction % 10);
  *cursor = out;
}

// Appends "<g> X.. Y.. Z.. A.. B..<tail>\n".
void AppendMove(const char* g,
                const HeadAxes& axes,
                const std::string& tail,
                std::string* out) {
  char line[160];
  char* c = line;
  const auto word = [&](char letter, double value) {
    *c++ = ' ';
    *c++ = letter;
    if (std::abs(value) < kMaxFastFixed4) {
      WriteFixed4(value, &c);
    } else {  // a setup far off any machine: snprintf's digits, however many
      out->append(line, c - line);
      c = line;
      *out += Fixed(value, 4);
    }
  };
  c[0] = g[0];
  c[1] = g[1];
  c[2] = g[2];
  c += 3;
  word('X', axes.x_mm);
  word('Y', axes.y_mm);
  word('Z', axes.z_mm);
  word('A', RadToDeg(axes.a_rad));
  word('B', RadToDeg(axes.b_rad));
  out->append(line, c - line);
  out->append(tail);
  out->push_back('\n');
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
    AppendMove("G00", StandBack(pass.points.front().axes), std::string(), &nc);
    for (size_t j = 0; j < pass.points.size(); ++j) {
      AppendMove(
          "G01", pass.points[j].axes, j == 0 ? feed : std::string(), &nc);
    }
    AppendMove("G00", StandBack(pass.points.back().axes), std::string(), &nc);
  }
  nc += "M30\n%\n";
  return nc;
}

}  // namespace gearloop
