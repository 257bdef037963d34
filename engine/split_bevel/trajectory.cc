#include "engine/split_bevel/trajectory.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <utility>

#include "engine/core/units.h"
#include "engine/split_bevel/flank.h"
#include "engine/split_bevel/nc_program.h"

namespace gearloop {

namespace {

// Range limits compare in radians; a degree bound converted to radians may sit
// an ulp off, so the inclusive bounds (delta <= 90 deg, segment_angle <= 360
// deg) allow this much.
constexpr double kAngleSlackRad = 1e-12;

std::string Number(double x) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.10g", x);
  return buffer;
}

bool Fail(const std::string& field,
          const std::string& message,
          std::string* out_field,
          std::string* out_message) {
  if (out_field != nullptr) *out_field = field;
  if (out_message != nullptr) *out_message = message;
  return false;
}

// n_s-side azimuth difference brought into (-pi, pi].
double AngleDifference(double a, double b) {
  double d = std::remainder(a - b, 2.0 * kPi);
  if (d <= -kPi) d += 2.0 * kPi;
  return d;
}

double SegmentMid(const SplitBevelRequest& request,
                  const SplitBevelGearData& gear) {
  return request.setup.segment_mid_rad
             ? *request.setup.segment_mid_rad
             : SlotAzimuth(gear, request.cut.slot_index);
}

// An angle in radians as a number of degrees for a message.
std::string Deg(double rad) { return Number(RadToDeg(rad)); }

// The request field that names the spiral angle given.
std::string SpiralField(const SplitBevelGear& gear) {
  return gear.mean_spiral_angle_rad ? "gear.mean_spiral_angle_deg"
                                    : "gear.outer_spiral_angle_deg";
}

// The gear's cone distance, face width and spiral angle checks of IsValid.
bool CheckGearSize(const SplitBevelGear& gear,
                   std::string* field,
                   std::string* message) {
  const auto fail = [&](const std::string& f, const std::string& m) {
    return Fail(f, m, field, message);
  };
  const auto finite = [](double x) { return std::isfinite(x); };
  if (gear.outer_cone_distance_mm.has_value() ==
      gear.outer_transverse_module_mm.has_value())
    return fail("gear.outer_cone_distance_mm",
                std::string("give exactly one of gear.outer_cone_distance_mm "
                            "and gear.outer_transverse_module_mm (") +
                    (gear.outer_cone_distance_mm ? "both" : "neither") +
                    " given)");
  if (gear.outer_cone_distance_mm && (!finite(*gear.outer_cone_distance_mm) ||
                                      *gear.outer_cone_distance_mm <= 0.0))
    return fail("gear.outer_cone_distance_mm",
                "gear.outer_cone_distance_mm must be > 0, got " +
                    Number(*gear.outer_cone_distance_mm));
  if (gear.outer_transverse_module_mm &&
      (!finite(*gear.outer_transverse_module_mm) ||
       *gear.outer_transverse_module_mm <= 0.0))
    return fail("gear.outer_transverse_module_mm",
                "gear.outer_transverse_module_mm must be > 0, got " +
                    Number(*gear.outer_transverse_module_mm));
  const double re = gear.outer_cone_distance_mm
                        ? *gear.outer_cone_distance_mm
                        : gear.teeth * *gear.outer_transverse_module_mm /
                              (2.0 * std::sin(gear.pitch_angle_rad));
  if (!finite(gear.face_width_mm) || gear.face_width_mm <= 0.0 ||
      gear.face_width_mm >= re)
    return fail("gear.face_width_mm",
                "gear.face_width_mm must be in (0, Re = " + Number(re) +
                    "), got " + Number(gear.face_width_mm));
  return true;
}

// The gear checks of IsValid, in their order.
bool CheckGear(const SplitBevelGear& gear,
               std::string* field,
               std::string* message) {
  const auto fail = [&](const std::string& f, const std::string& m) {
    return Fail(f, m, field, message);
  };
  const auto finite = [](double x) { return std::isfinite(x); };
  if (gear.teeth < 1)
    return fail("gear.teeth",
                "gear.teeth must be >= 1, got " + std::to_string(gear.teeth));
  if (!finite(gear.pitch_angle_rad) || gear.pitch_angle_rad <= 0.0 ||
      gear.pitch_angle_rad > kPi / 2 + kAngleSlackRad)
    return fail("gear.pitch_angle_deg",
                "gear.pitch_angle_deg must be in (0, 90], got " +
                    Deg(gear.pitch_angle_rad));
  if (!CheckGearSize(gear, field, message)) return false;
  if (gear.mean_spiral_angle_rad.has_value() ==
      gear.outer_spiral_angle_rad.has_value())
    return fail("gear.mean_spiral_angle_deg",
                std::string("give exactly one of gear.mean_spiral_angle_deg "
                            "and gear.outer_spiral_angle_deg (") +
                    (gear.mean_spiral_angle_rad ? "both" : "neither") +
                    " given)");
  const std::string spiral_field = SpiralField(gear);
  const double spiral = gear.mean_spiral_angle_rad
                            ? *gear.mean_spiral_angle_rad
                            : *gear.outer_spiral_angle_rad;
  if (!finite(spiral) || spiral <= 0.0 || spiral >= DegToRad(60.0))
    return fail(spiral_field,
                spiral_field + " must be in (0, 60), got " + Deg(spiral));
  if (!finite(gear.pressure_angle_rad) || gear.pressure_angle_rad <= 0.0 ||
      gear.pressure_angle_rad >= DegToRad(45.0))
    return fail("gear.pressure_angle_deg",
                "gear.pressure_angle_deg must be in (0, 45), got " +
                    Deg(gear.pressure_angle_rad));
  const std::pair<const std::optional<double>*, const char*> proportions[] = {
      {&gear.addendum_mm, "gear.addendum_mm"},
      {&gear.dedendum_mm, "gear.dedendum_mm"},
      {&gear.slot_width_mm, "gear.slot_width_mm"}};
  for (const auto& [value, name] : proportions) {
    if (value->has_value() && (!finite(**value) || **value <= 0.0))
      return fail(name,
                  std::string(name) + " must be > 0, got " + Number(**value));
  }
  return true;
}

// The tool checks of IsValid.
bool CheckTool(const SplitBevelTool& tool,
               std::string* field,
               std::string* message) {
  if (!std::isfinite(tool.radius_mm) || tool.radius_mm <= 0.0)
    return Fail("tool.radius_mm",
                "tool.radius_mm must be > 0, got " + Number(tool.radius_mm),
                field,
                message);
  if (!std::isfinite(tool.stock_mm) || tool.stock_mm <= -tool.radius_mm)
    return Fail("tool.stock_mm",
                "tool.stock_mm must be > -tool.radius_mm = " +
                    Number(-tool.radius_mm) + ", got " + Number(tool.stock_mm),
                field,
                message);
  return true;
}

// The cut checks of IsValid (the slot against the gear's teeth).
bool CheckCut(const SplitBevelCut& cut,
              int teeth,
              std::string* field,
              std::string* message) {
  const auto fail = [&](const std::string& f, const std::string& m) {
    return Fail(f, m, field, message);
  };
  if (std::abs(static_cast<long long>(cut.slot_index)) >= teeth)
    return fail(
        "cut.slot_index",
        "|cut.slot_index| must be < gear.teeth = " + std::to_string(teeth) +
            ", got " + std::to_string(cut.slot_index));
  if (cut.flanks.empty())
    return fail("cut.flanks",
                "cut.flanks must name at least one of convex, concave");
  for (size_t i = 0; i < cut.flanks.size(); ++i) {
    for (size_t j = 0; j < i; ++j) {
      if (cut.flanks[i] == cut.flanks[j])
        return fail("cut.flanks",
                    std::string("cut.flanks names ") +
                        SplitBevelFlankName(cut.flanks[i]) + " more than once");
    }
  }
  if (cut.depth_levels < 1 || cut.depth_levels > kSplitBevelMaxLevels)
    return fail("cut.depth_levels",
                "cut.depth_levels must be in 1..100, got " +
                    std::to_string(cut.depth_levels));
  if (cut.steps && cut.chord_tolerance_mm)
    return fail("cut.steps",
                "give at most one of cut.steps and cut.chord_tolerance_mm "
                "(both given)");
  if (cut.steps && (*cut.steps < 2 || *cut.steps > kSplitBevelMaxSteps))
    return fail(
        "cut.steps",
        "cut.steps must be in 2..20001, got " + std::to_string(*cut.steps));
  if (cut.chord_tolerance_mm &&
      (!std::isfinite(*cut.chord_tolerance_mm) ||
       *cut.chord_tolerance_mm < kSplitBevelMinChordToleranceMm))
    return fail("cut.chord_tolerance_mm",
                "cut.chord_tolerance_mm must be >= 1e-4, got " +
                    Number(*cut.chord_tolerance_mm));
  if (!std::isfinite(cut.feed_mm_per_min) || cut.feed_mm_per_min <= 0.0)
    return fail(
        "cut.feed_mm_per_min",
        "cut.feed_mm_per_min must be > 0, got " + Number(cut.feed_mm_per_min));
  return true;
}

// The machine checks of IsValid.
bool CheckMachine(const SplitBevelMachine& machine,
                  std::string* field,
                  std::string* message) {
  const auto fail = [&](const std::string& f, const std::string& m) {
    return Fail(f, m, field, message);
  };
  const auto finite = [](double x) { return std::isfinite(x); };
  if (!finite(machine.pivot_length_mm) || machine.pivot_length_mm < 0.0)
    return fail("machine.pivot_length_mm",
                "machine.pivot_length_mm must be >= 0, got " +
                    Number(machine.pivot_length_mm));
  const HeadLimits& limits = machine.limits;
  if (!finite(limits.a_min_rad) || !finite(limits.a_max_rad) ||
      limits.a_min_rad >= limits.a_max_rad)
    return fail(
        "machine.a_limits_deg",
        "machine.a_limits_deg must be [min, max] with min < max, got [" +
            Deg(limits.a_min_rad) + ", " + Deg(limits.a_max_rad) + "]");
  if (!finite(limits.b_min_rad) || !finite(limits.b_max_rad) ||
      limits.b_min_rad >= limits.b_max_rad)
    return fail(
        "machine.b_limits_deg",
        "machine.b_limits_deg must be [min, max] with min < max, got [" +
            Deg(limits.b_min_rad) + ", " + Deg(limits.b_max_rad) + "]");
  return true;
}

// The setup checks of IsValid.
bool CheckSetup(const SplitBevelSetup& setup,
                std::string* field,
                std::string* message) {
  const auto fail = [&](const std::string& f, const std::string& m) {
    return Fail(f, m, field, message);
  };
  const auto finite = [](double x) { return std::isfinite(x); };
  if (!setup.apex_mm.allFinite())
    return fail("setup.apex_mm", "setup.apex_mm must be three finite numbers");
  if (setup.segment_mid_rad && !finite(*setup.segment_mid_rad))
    return fail("setup.segment_mid_deg",
                "setup.segment_mid_deg must be finite");
  if (setup.segment_angle_rad &&
      (!finite(*setup.segment_angle_rad) || *setup.segment_angle_rad <= 0.0 ||
       *setup.segment_angle_rad > 2.0 * kPi + kAngleSlackRad))
    return fail("setup.segment_angle_deg",
                "setup.segment_angle_deg must be in (0, 360], got " +
                    Deg(*setup.segment_angle_rad));
  return true;
}

// The checks of the derived gear's slot against the tool: the base circle, the
// root width, the tool's width and the concave flank's curvature.
bool CheckSlotAndTool(const SplitBevelRequest& request,
                      const SplitBevelGearData& d,
                      std::string* field,
                      std::string* message) {
  const auto fail = [&](const std::string& f, const std::string& m) {
    return Fail(f, m, field, message);
  };
  const SplitBevelTool& tool = request.tool;
  const SplitBevelCut& cut = request.cut;
  const std::string spiral_field = SpiralField(request.gear);
  if (!(d.base_radius_mm < d.inner_cone_distance_mm))
    return fail(spiral_field,
                "the base circle r_b = " + Number(d.base_radius_mm) +
                    " mm is not inside the inner cone distance Ri = " +
                    Number(d.inner_cone_distance_mm) + " mm: lower " +
                    spiral_field + " or the face width");
  const double ta = std::tan(d.pressure_angle_rad),
               ca = std::cos(d.pressure_angle_rad),
               sa = std::sin(d.pressure_angle_rad);
  const double root_width = d.slot_width_mm - 2.0 * d.dedendum_mm * ta;
  if (root_width <= 0.0)
    return fail("gear.dedendum_mm",
                "the slot closes above the root: w - 2 h_f tan(alpha) = " +
                    Number(root_width) + " mm <= 0");
  const double r0s = tool.radius_mm + tool.stock_mm;
  const double wide = (2.0 * tool.radius_mm + tool.stock_mm) *
                      std::cos(2.0 * d.pressure_angle_rad);
  const double room = d.slot_width_mm * ca - 2.0 * d.dedendum_mm * sa;
  if (wide > room)
    return fail(
        "tool.radius_mm",
        "the tool is too wide for the slot: (2 r0 + s) cos(2 alpha) = " +
            Number(wide) +
            " mm > w cos(alpha) - 2 h_f sin(alpha) = " + Number(room) + " mm");
  if (std::find(cut.flanks.begin(),
                cut.flanks.end(),
                SplitBevelFlank::kConcave) != cut.flanks.end()) {
    const double bend =
        (d.inner_cone_distance_mm * std::sin(d.inner_spiral_angle_rad) -
         d.dedendum_mm * ta) /
        ca;
    if (r0s >= bend)
      return fail(
          "tool.radius_mm",
          "the concave flank is more curved than the tool allows: r0 + s = " +
              Number(r0s) +
              " mm >= (Ri sin(beta_i) - h_f tan(alpha)) / cos(alpha) = " +
              Number(bend) + " mm");
  }
  return true;
}

// Whether the pitch lines of the cut flanks stay inside the segment, when one
// is given.
bool CheckSegment(const SplitBevelRequest& request,
                  const SplitBevelGearData& d,
                  std::string* field,
                  std::string* message) {
  const SplitBevelCut& cut = request.cut;
  if (!request.setup.segment_angle_rad) return true;
  const double mid = SegmentMid(request, d);
  const double half = 0.5 * *request.setup.segment_angle_rad;
  for (const SplitBevelFlank flank : cut.flanks) {
    // psi_f(R) is monotonic in R: its ends bound the line.
    for (const double r :
         {d.inner_cone_distance_mm, d.outer_cone_distance_mm}) {
      const double off =
          AngleDifference(FlankLineAzimuth(d, cut.slot_index, flank, r), mid);
      if (std::abs(off) > half)
        return Fail("cut.slot_index",
                    std::string("the ") + SplitBevelFlankName(flank) +
                        " pitch line of slot " +
                        std::to_string(cut.slot_index) + " reaches " +
                        Deg(off) +
                        " deg from segment_mid_deg at R = " + Number(r) +
                        " mm, outside the segment's +-" + Deg(half) + " deg",
                    field,
                    message);
    }
  }
  return true;
}

}  // namespace

bool SplitBevelRequest::IsValid(std::string* field,
                                std::string* message) const {
  if (!CheckGear(gear, field, message)) return false;
  if (!CheckTool(tool, field, message)) return false;
  if (!CheckCut(cut, gear.teeth, field, message)) return false;
  if (!CheckMachine(machine, field, message)) return false;
  if (!CheckSetup(setup, field, message)) return false;
  // The gear, tool and segment together.
  const SplitBevelGearData d = DeriveSplitBevelGear(gear);
  if (!CheckSlotAndTool(*this, d, field, message)) return false;
  return CheckSegment(*this, d, field, message);
}

Eigen::Vector3d SplitBevelToolCentre(const SplitBevelFlankSurface& flank,
                                     const SplitBevelTool& tool,
                                     double cone_distance_mm,
                                     double height_mm) {
  const FlankSection s = flank.Section(cone_distance_mm);
  return s.Point(height_mm) +
         (tool.radius_mm + tool.stock_mm) * s.Normal(height_mm);
}

double SplitBevelChordDeviation(const SplitBevelFlankSurface& flank,
                                const SplitBevelTool& tool,
                                double height_mm,
                                int stations) {
  const SplitBevelGearData& gear = flank.gear();
  const double total = ArcLengthAt(gear, gear.outer_cone_distance_mm);
  const int halves = 2 * (stations - 1);
  const auto centre = [&](int i) {
    return SplitBevelToolCentre(
        flank, tool, ConeDistanceAtArc(gear, total * i / halves), height_mm);
  };
  double worst = 0.0;
  Eigen::Vector3d a = centre(0);
  for (int j = 0; j + 1 < stations; ++j) {
    const Eigen::Vector3d mid = centre(2 * j + 1);
    const Eigen::Vector3d b = centre(2 * j + 2);
    // Distance from the mid-station's centre to the chord segment [a, b].
    const Eigen::Vector3d ab = b - a;
    const double t = std::clamp((mid - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
    worst = std::max(worst, (a + t * ab - mid).norm());
    a = b;
  }
  return worst;
}

namespace {

// The smallest n >= 2 whose mid-station deviation is within the tolerance; 0
// when even 20001 is not enough. The deviation of a smooth path falls as 1 / (n
// - 1)^2, so n is first estimated from n = 3, then bracketed and bisected (the
// bisection assumes the deviation does not rise with n, which holds for the
// smooth, slowly turning paths of one flank).
int StationsForTolerance(const SplitBevelFlankSurface& flank,
                         const SplitBevelTool& tool,
                         double height_mm,
                         double tolerance_mm) {
  const auto ok = [&](int n) {
    return SplitBevelChordDeviation(flank, tool, height_mm, n) <= tolerance_mm;
  };
  if (ok(2)) return 2;
  const double d3 = SplitBevelChordDeviation(flank, tool, height_mm, 3);
  if (d3 <= tolerance_mm) return 3;
  const double estimate = 1.0 + 2.0 * std::sqrt(d3 / tolerance_mm);
  int lo = 3;  // fails
  int hi = static_cast<int>(
      std::min<double>(std::ceil(1.1 * estimate) + 1.0, kSplitBevelMaxSteps));
  while (!ok(hi)) {
    if (hi >= kSplitBevelMaxSteps) return 0;
    lo = hi;
    hi = std::min(2 * hi, kSplitBevelMaxSteps);
  }
  const int guess_lo = static_cast<int>(std::floor(0.9 * estimate));
  if (guess_lo > lo && guess_lo < hi && !ok(guess_lo)) lo = guess_lo;
  while (hi - lo > 1) {
    const int mid = lo + (hi - lo) / 2;
    (ok(mid) ? hi : lo) = mid;
  }
  return hi;
}

// The head angles of the previous point, which the next one keeps close to.
struct HeadTrack {
  HeadAngles previous;
  bool have_previous = false;
};

// The result of a chord tolerance that needs more than the maximum number of
// stations.
SplitBevelResult ChordToleranceFailure(const SplitBevelGearData& gear,
                                       double chord_tolerance_mm,
                                       SplitBevelFlank flank_side,
                                       int level) {
  SplitBevelResult failed;
  failed.derived = gear;
  failed.field = "cut.chord_tolerance_mm";
  failed.message = "cut.chord_tolerance_mm = " + Number(chord_tolerance_mm) +
                   " mm needs more than " +
                   std::to_string(kSplitBevelMaxSteps) + " stations on the " +
                   SplitBevelFlankName(flank_side) + " flank, level " +
                   std::to_string(level);
  return failed;
}

// The result of a tool axis that no head position within the limits reaches.
SplitBevelResult HeadLimitFailure(const SplitBevelRequest& request,
                                  const SplitBevelGearData& gear,
                                  double cone_distance_mm,
                                  SplitBevelFlank flank_side,
                                  int level) {
  SplitBevelResult failed;
  failed.derived = gear;
  failed.field = "machine.a_limits_deg";
  failed.message =
      std::string(
          "no head position within the axis limits for the tool axis "
          "at R = ") +
      Number(cone_distance_mm) + " mm on the " +
      SplitBevelFlankName(flank_side) + " flank, level " +
      std::to_string(level) + " (A in [" +
      Number(RadToDeg(request.machine.limits.a_min_rad)) + ", " +
      Number(RadToDeg(request.machine.limits.a_max_rad)) + "] deg, B in [" +
      Number(RadToDeg(request.machine.limits.b_min_rad)) + ", " +
      Number(RadToDeg(request.machine.limits.b_max_rad)) + "] deg)";
  return failed;
}

// The n stations' sections and arc lengths along the pass direction, the ends
// exactly at Ri and Re.
void StationSections(const SplitBevelFlankSurface& flank,
                     const SplitBevelGearData& gear,
                     SplitBevelStart from,
                     int n,
                     double total_arc,
                     std::vector<FlankSection>* sections,
                     std::vector<double>* arcs) {
  sections->clear();
  arcs->clear();
  sections->reserve(n);
  arcs->reserve(n);
  for (int j = 0; j < n; ++j) {
    const int i = from == SplitBevelStart::kToe ? j : n - 1 - j;
    // The ends exactly at Ri and Re.
    const double arc = i == n - 1 ? total_arc : total_arc * i / (n - 1);
    const double r = i == 0       ? gear.inner_cone_distance_mm
                     : i == n - 1 ? gear.outer_cone_distance_mm
                                  : ConeDistanceAtArc(gear, arc);
    arcs->push_back(arc);
    sections->push_back(flank.Section(r));
  }
}

// The point's geometry at tip height `tip` of section s: pitch and flank
// point, normal, tool centre and axis.
void SetPointGeometry(const FlankSection& s,
                      double arc,
                      double tip,
                      double offset,
                      SplitBevelPoint* point) {
  point->arc_mm = arc;
  point->cone_distance_mm = s.cone_distance_mm;
  point->spiral_angle_rad = s.spiral_angle_rad;
  point->pitch_point_mm = s.pitch_point_mm;
  point->flank_point_mm = s.Point(tip);
  point->flank_normal = s.Normal(tip);
  point->tool_centre_mm = point->flank_point_mm + offset * point->flank_normal;
  point->tool_axis = s.ruling;
}

// The feet of one station's side lines, as offsets R_foot - R_j per pass and
// height, at the two stations before: the next station's first guesses.
struct FootTrack {
  explicit FootTrack(size_t passes)
      : previous(passes * kSplitBevelDeviationHeights),
        before(passes * kSplitBevelDeviationHeights) {}
  std::vector<double> previous, before;
};

// The pass geometry the side deviation needs.
struct SideLine {
  double tip_height_mm = 0.0;
  double addendum_mm = 0.0;
  double cos_alpha = 1.0;
  double tool_radius_mm = 0.0;
};

// Widens `deviation` by the side deviation along the tool's side line of
// `point` (station `station` of its pass) from the tip height up to the
// addendum. The first guess of each foot point: from the second station on,
// the foot's offset from the station carried over from the stations before
// (linearly from the third on; it changes by some 1e-5 mm from one station to
// the next at 2 000 stations, so one Newton step is enough), and the heights'
// searches run side by side (NearestOfEach); at the first station, one after
// the other from the parabola through the three previous feet of the side line
// (the line through two at the third height). `previous` and `before` hold this
// pass's offsets at the two stations before (kSplitBevelDeviationHeights each).
void AddSideDeviation(const SplitBevelFlankSurface& flank,
                      const SplitBevelPoint& point,
                      const SideLine& line,
                      size_t station,
                      double* previous,
                      double* before,
                      FlankAnchors* anchors,
                      SplitBevelSideDeviation* deviation) {
  constexpr int kHeights = kSplitBevelDeviationHeights;
  const double r = point.cone_distance_mm;
  const double tip = line.tip_height_mm;
  Eigen::Vector3d x[kHeights];
  double guess[kHeights];
  for (int h = 0; h < kHeights; ++h) {
    const double height = tip + (line.addendum_mm - tip) * h / (kHeights - 1);
    x[h] = point.tool_centre_mm +
           ((height - tip) / line.cos_alpha) * point.tool_axis;
    guess[h] =
        station >= 2 ? r + 2.0 * previous[h] - before[h] : r + previous[h];
  }
  SplitBevelFlankSurface::NearestPoint near[kHeights];
  if (station >= 1) {
    flank.NearestOfEach(x, guess, kHeights, anchors, near);
  } else {
    double foot_previous = r, foot_before = r, foot_third = 0.0;
    for (int h = 0; h < kHeights; ++h) {
      const double first =
          h < 2    ? foot_previous
          : h == 2 ? 2.0 * foot_previous - foot_before
                   : 3.0 * (foot_previous - foot_before) + foot_third;
      near[h] = flank.Nearest(x[h], first, anchors);
      foot_third = foot_before;
      foot_before = foot_previous;
      foot_previous = near[h].cone_distance_mm;
    }
  }
  for (int h = 0; h < kHeights; ++h) {
    before[h] = previous[h];
    previous[h] = near[h].cone_distance_mm - r;
    const double gap =
        (x[h] - near[h].point_mm).dot(near[h].normal) - line.tool_radius_mm;
    deviation->min_mm = std::min(deviation->min_mm, gap);
    deviation->max_mm = std::max(deviation->max_mm, gap);
  }
}

// The side deviations of `count` passes of one flank that share the stations
// `sections` (the levels of a flank with the same number of stations), station
// by station: the exact sections the foot points expand from (FlankAnchors)
// serve every level of a station.
void AddSideDeviations(const SplitBevelFlankSurface& flank,
                       const SplitBevelGearData& gear,
                       const SplitBevelTool& tool,
                       const std::vector<FlankSection>& sections,
                       SplitBevelPass* passes,
                       size_t count) {
  SideLine line;
  line.addendum_mm = gear.addendum_mm;
  line.cos_alpha = std::cos(gear.pressure_angle_rad);
  line.tool_radius_mm = tool.radius_mm;
  if (count == 0) return;
  FootTrack feet(count);
  FlankAnchors anchors(flank);
  for (size_t j = 0; j < sections.size(); ++j) {
    anchors.Centre(sections[j]);
    for (size_t p = 0; p < count; ++p) {
      SplitBevelPass& pass = passes[p];
      line.tip_height_mm = pass.tip_height_mm;
      AddSideDeviation(flank,
                       pass.points[j],
                       line,
                       j,
                       &feet.previous[p * kSplitBevelDeviationHeights],
                       &feet.before[p * kSplitBevelDeviationHeights],
                       &anchors,
                       &pass.side_deviation_mm);
    }
  }
}

// The head's two branches for a station's tool axis (machine frame), found at
// the station's first level and kept for the others (the same section gives
// the same axis, bit for bit), unless the axis lies along Y where they depend
// on the previous point's B.
struct AxisBranches {
  bool found = false;
  bool along_y = false;
  std::array<HeadAngles, 2> angles;
};

std::array<HeadAngles, 2> StationBranches(const Eigen::Vector3d& axis_m,
                                          const HeadAngles* previous,
                                          AxisBranches* kept) {
  if (!kept->found) {
    kept->found = true;
    kept->along_y = HeadAxisAlongY(axis_m);
    if (!kept->along_y) kept->angles = HeadInverseBranches(axis_m, 0.0);
  }
  if (kept->along_y)
    return HeadInverseBranches(axis_m, previous ? previous->b_rad : 0.0);
  return kept->angles;
}

// One pass of `flank_side` at depth `level` and tip height `tip` over the
// stations, its side deviation still empty (AddSideDeviations); false with
// *failed set when a point is out of the head's limits.
bool ComputePass(const SplitBevelRequest& request,
                 const SplitBevelGearData& gear,
                 SplitBevelFlank flank_side,
                 int level,
                 double tip,
                 const std::vector<FlankSection>& sections,
                 const std::vector<double>& arcs,
                 const Eigen::Matrix4d& blank_to_machine,
                 HeadTrack* track,
                 std::vector<AxisBranches>* branches,
                 SplitBevelPass* pass,
                 SplitBevelResult* failed) {
  const Eigen::Matrix3d rotation = blank_to_machine.block<3, 3>(0, 0);
  const Eigen::Vector3d apex = request.setup.apex_mm;
  const SplitBevelTool& tool = request.tool;
  const double offset = tool.radius_mm + tool.stock_mm;
  const double pivot = request.machine.pivot_length_mm;
  const int n = static_cast<int>(sections.size());
  pass->slot = request.cut.slot_index;
  pass->flank = flank_side;
  pass->level = level;
  pass->tip_height_mm = tip;
  pass->side_deviation_mm.min_mm = std::numeric_limits<double>::infinity();
  pass->side_deviation_mm.max_mm = -std::numeric_limits<double>::infinity();
  pass->points.resize(n);
  for (int j = 0; j < n; ++j) {
    const FlankSection& s = sections[j];
    SplitBevelPoint& point = pass->points[j];
    SetPointGeometry(s, arcs[j], tip, offset, &point);

    const Eigen::Vector3d axis_m = rotation * point.tool_axis;
    const Eigen::Vector3d centre_m = apex + rotation * point.tool_centre_mm;
    const HeadAngles* previous =
        track->have_previous ? &track->previous : nullptr;
    HeadAngles angles;
    if (!ChooseHeadAnglesFrom(
            StationBranches(axis_m, previous, &(*branches)[j]),
            previous,
            request.machine.limits,
            &angles)) {
      *failed = HeadLimitFailure(
          request, gear, s.cone_distance_mm, flank_side, level);
      return false;
    }
    track->previous = angles;
    track->have_previous = true;
    // The pivot from the requested axis itself (a_m(A, B) equals it to
    // rounding).
    const Eigen::Vector3d pivot_m = centre_m + pivot * axis_m;
    point.axes = HeadAxes{
        pivot_m.x(), pivot_m.y(), pivot_m.z(), angles.a_rad, angles.b_rad};
  }
  return true;
}

}  // namespace

SplitBevelResult ComputeSplitTrajectory(const SplitBevelRequest& request) {
  SplitBevelResult result;
  if (!request.IsValid(&result.field, &result.message)) return result;
  const SplitBevelGearData gear = DeriveSplitBevelGear(request.gear);
  result.derived = gear;
  result.segment_mid_rad = SegmentMid(request, gear);
  result.blank_to_machine =
      SplitBevelBlankToMachine(result.segment_mid_rad, request.setup.apex_mm);

  const SplitBevelCut& cut = request.cut;
  const SplitBevelTool& tool = request.tool;
  const double total_arc = ArcLengthAt(gear, gear.outer_cone_distance_mm);
  const double depth = gear.addendum_mm + gear.dedendum_mm;

  HeadTrack track;
  result.passes.reserve(cut.flanks.size() * cut.depth_levels);
  for (const SplitBevelFlank flank_side : cut.flanks) {
    const SplitBevelFlankSurface flank(gear, cut.slot_index, flank_side);
    // Sections at the stations, shared by the levels that use the same n: the
    // passes from `group` on, whose side deviations are found together.
    std::vector<FlankSection> sections;
    std::vector<double> arcs;
    std::vector<AxisBranches> branches;
    size_t group = result.passes.size();
    const auto side_deviations = [&] {
      AddSideDeviations(flank,
                        gear,
                        tool,
                        sections,
                        result.passes.data() + group,
                        result.passes.size() - group);
      group = result.passes.size();
    };
    for (int level = 0; level < cut.depth_levels; ++level) {
      const double tip =
          gear.addendum_mm - (level + 1) * depth / cut.depth_levels;
      int n = cut.steps.value_or(kSplitBevelDefaultSteps);
      if (cut.chord_tolerance_mm) {
        n = StationsForTolerance(flank, tool, tip, *cut.chord_tolerance_mm);
        if (n == 0)
          return ChordToleranceFailure(
              gear, *cut.chord_tolerance_mm, flank_side, level);
      }
      if (static_cast<int>(sections.size()) != n) {
        side_deviations();
        StationSections(flank, gear, cut.from, n, total_arc, &sections, &arcs);
        branches.assign(n, AxisBranches());
      }

      SplitBevelPass pass;
      SplitBevelResult failed;
      if (!ComputePass(request,
                       gear,
                       flank_side,
                       level,
                       tip,
                       sections,
                       arcs,
                       result.blank_to_machine,
                       &track,
                       &branches,
                       &pass,
                       &failed))
        return failed;
      result.passes.push_back(std::move(pass));
    }
    side_deviations();
  }
  result.ok = true;
  if (request.nc_program)
    result.nc_program = FormatSplitBevelNcProgram(request, result);
  return result;
}

}  // namespace gearloop
