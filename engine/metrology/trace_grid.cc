// engine/metrology/trace_grid.cc: the Gordon (Boolean-sum) interpolation of a
// measured curve network onto the grid.
//
// Why a Boolean sum and not a surface fit: the profile traces carry the profile
// form f(L) in full and the helix traces the lead form g(x) in full; blending
// each family linearly across its traces and subtracting the doubly counted
// crossing values reproduces every f(L) + g(x) + c L x exactly (the linear
// blends reproduce linear functions, including in the short linear
// extrapolation beyond the outermost trace, and sum to one), which is what the
// modification forms of MODEL.md §7 are made of. Along a trace a local
// quadratic through the three nearest points is exact for slope and crowning
// and never overshoots the way a global polynomial over 480 points would.
#include "engine/metrology/trace_grid.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <utility>

namespace gearloop {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

const char* KindName(TraceKind kind) {
  return kind == TraceKind::kProfile ? "profile" : "helix";
}

// One trace in grid coordinates: `position` is x for a profile trace and L for
// a helix trace; (t, v) are the finite points sorted by abscissa t (L for a
// profile, x for a helix).
struct Curve {
  double position = 0.0;
  std::vector<double> t;
  std::vector<double> v;
  int trace_index = -1;
};

// The trace's value at t by the quadratic through the three nearest points; NaN
// outside its finite range (a small relative slack keeps a grid point that
// coincides with an end point).
double Evaluate(const Curve& c, double t) {
  const size_t n = c.t.size();
  if (n < 3) return kNaN;
  // 1 nm of roll length: a grid point written to a file as a diameter and read
  // back lands within it of the trace's end, and must not fall off.
  const double slack = 1e-6;
  if (t < c.t.front() - slack || t > c.t.back() + slack) return kNaN;
  size_t i = static_cast<size_t>(std::lower_bound(c.t.begin(), c.t.end(), t) -
                                 c.t.begin());
  if (i >= n) i = n - 1;
  if (i > 0 && std::abs(c.t[i - 1] - t) <= std::abs(c.t[i] - t)) --i;
  size_t lo = i;
  size_t hi = i;
  while (hi - lo < 2) {
    if (lo == 0) {
      ++hi;
    } else if (hi == n - 1) {
      --lo;
    } else if (t - c.t[lo - 1] <= c.t[hi + 1] - t) {
      --lo;
    } else {
      ++hi;
    }
  }
  const double t0 = c.t[lo], t1 = c.t[lo + 1], t2 = c.t[lo + 2];
  const double l0 = (t - t1) * (t - t2) / ((t0 - t1) * (t0 - t2));
  const double l1 = (t - t0) * (t - t2) / ((t1 - t0) * (t1 - t2));
  const double l2 = (t - t0) * (t - t1) / ((t2 - t0) * (t2 - t1));
  return l0 * c.v[lo] + l1 * c.v[lo + 1] + l2 * c.v[lo + 2];
}

// Non-zero blending weights at q over the sorted trace positions: piecewise
// linear, linear extrapolation at most `reach` beyond the outermost trace, one
// trace = weight 1. Empty when q lies farther out.
std::vector<std::pair<int, double>> Weights(const std::vector<Curve>& curves,
                                            double q,
                                            double reach) {
  const int m = static_cast<int>(curves.size());
  if (m == 0) return {};
  if (m == 1) return {{0, 1.0}};
  const double first = curves.front().position;
  const double last = curves.back().position;
  const double slack = 1e-9 * std::max(1.0, last - first);
  int a = 0;
  if (q < first) {
    if (first - q > reach + slack) return {};
    a = 0;
  } else if (q > last) {
    if (q - last > reach + slack) return {};
    a = m - 2;
  } else {
    while (a < m - 2 && q > curves[a + 1].position) ++a;
  }
  const double pa = curves[a].position;
  const double pb = curves[a + 1].position;
  const double s = (q - pa) / (pb - pa);
  return {{a, 1.0 - s}, {a + 1, s}};
}

// The grid's axial position x of the file's axial position z from the datum
// face.
double AxialOfZ(DatumFace datum, double face_width_mm, double z) {
  const double b = face_width_mm;
  return datum == DatumFace::kXNegative ? z - b / 2.0 : b / 2.0 - z;
}

// Abscissas of an equal-step trace (roll lengths for a profile, z for a
// helix), or returns a message.
bool EqualStepAbscissas(const MeasuredTrace& trace,
                        const GearData& gear,
                        const std::string& what,
                        std::vector<double>* abscissa,
                        std::string* message) {
  const size_t n = abscissa->size();
  if (!std::isfinite(trace.begin_mm) || !std::isfinite(trace.end_mm) ||
      !(trace.begin_mm < trace.end_mm)) {
    *message = what + " range " + FormatValidationNumber(trace.begin_mm) +
               " .. " + FormatValidationNumber(trace.end_mm) +
               " mm must be finite and increasing";
    return false;
  }
  double t0 = trace.begin_mm;
  double t1 = trace.end_mm;
  if (trace.kind == TraceKind::kProfile) {
    t0 = RollLengthOfDiameterMm(gear, trace.begin_mm);
    t1 = RollLengthOfDiameterMm(gear, trace.end_mm);
    if (!std::isfinite(t0)) {
      *message = "profile range starts at d = " +
                 FormatValidationNumber(trace.begin_mm) +
                 " mm, inside the base circle d_b = " +
                 FormatValidationNumber(2.0 * gear.BaseRadiusMm()) + " mm";
      return false;
    }
  }
  for (size_t i = 0; i < n; ++i)
    (*abscissa)[i] =
        t0 + (t1 - t0) * static_cast<double>(i) / static_cast<double>(n - 1);
  return true;
}

// Abscissas of a listed trace (roll lengths for a profile, z for a helix), or
// returns a message.
bool ListedAbscissas(const MeasuredTrace& trace,
                     const GearData& gear,
                     const std::string& what,
                     std::vector<double>* abscissa,
                     std::string* message) {
  const size_t n = abscissa->size();
  if (trace.abscissa_mm.size() != n) {
    *message = what + " has " + std::to_string(n) + " values but " +
               std::to_string(trace.abscissa_mm.size()) + " abscissas";
    return false;
  }
  for (size_t i = 0; i < n; ++i) {
    const double a = trace.abscissa_mm[i];
    if (!std::isfinite(a)) {
      *message = what + " abscissa " + std::to_string(i + 1) +
                 " is not a finite number";
      return false;
    }
    (*abscissa)[i] =
        trace.kind == TraceKind::kProfile ? RollLengthOfDiameterMm(gear, a) : a;
    if (!std::isfinite((*abscissa)[i])) {
      *message = "profile point at d = " + FormatValidationNumber(a) +
                 " mm lies inside the base circle d_b = " +
                 FormatValidationNumber(2.0 * gear.BaseRadiusMm()) + " mm";
      return false;
    }
  }
  return true;
}

// Converts a helix trace's abscissas to x and sets the curve's grid position,
// or returns a message.
bool PlaceCurve(const MeasuredTrace& trace,
                const GearData& gear,
                DatumFace datum,
                std::vector<double>* abscissa,
                Curve* curve,
                std::string* message) {
  const double b = gear.face_width_mm;
  if (trace.kind == TraceKind::kHelix) {
    for (double& a : *abscissa) a = AxialOfZ(datum, b, a);
    curve->position = RollLengthOfDiameterMm(gear, trace.position_mm);
    if (!std::isfinite(curve->position)) {
      *message =
          "helix trace at d = " + FormatValidationNumber(trace.position_mm) +
          " mm lies inside the base circle d_b = " +
          FormatValidationNumber(2.0 * gear.BaseRadiusMm()) + " mm";
      return false;
    }
  } else {
    curve->position = AxialOfZ(datum, b, trace.position_mm);
  }
  return true;
}

// Fills the curve's finite points, signed and sorted by abscissa, or returns a
// message.
bool FillCurvePoints(const MeasuredTrace& trace,
                     const std::vector<double>& abscissa,
                     double sign,
                     const std::string& what,
                     Curve* curve,
                     std::string* message) {
  const size_t n = trace.values_um.size();
  std::vector<std::pair<double, double>> points;
  points.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    const double v = trace.values_um[i];
    if (std::isnan(v)) continue;  // undefined point
    if (!std::isfinite(v)) {
      *message = what + " value " + std::to_string(i + 1) + " is infinite";
      return false;
    }
    points.emplace_back(abscissa[i], sign * v);
  }
  std::sort(points.begin(), points.end());
  for (size_t i = 1; i < points.size(); ++i) {
    if (!(points[i].first > points[i - 1].first)) {
      *message = what + " has two values at the same abscissa " +
                 FormatValidationNumber(points[i].first) + " mm";
      return false;
    }
  }
  curve->t.clear();
  curve->v.clear();
  for (const auto& p : points) {
    curve->t.push_back(p.first);
    curve->v.push_back(p.second);
  }
  return true;
}

// Builds the curve of `trace` in grid coordinates, or returns a message.
bool MakeCurve(const MeasuredTrace& trace,
               const GearData& gear,
               DatumFace datum,
               double sign,
               int index,
               Curve* curve,
               std::string* message) {
  const std::string what = std::string(KindName(trace.kind)) + " trace";
  const size_t n = trace.values_um.size();
  if (n < 2) {
    *message =
        what + " has " + std::to_string(n) + " values (at least 2 needed)";
    return false;
  }
  if (!std::isfinite(trace.position_mm)) {
    *message = what + " position is not a finite number";
    return false;
  }
  std::vector<double> abscissa(n);
  const bool have_abscissas =
      trace.spacing == TraceSpacing::kEqualSteps
          ? EqualStepAbscissas(trace, gear, what, &abscissa, message)
          : ListedAbscissas(trace, gear, what, &abscissa, message);
  if (!have_abscissas) return false;
  if (!PlaceCurve(trace, gear, datum, &abscissa, curve, message)) return false;
  if (!FillCurvePoints(trace, abscissa, sign, what, curve, message))
    return false;
  curve->trace_index = index;
  return true;
}

struct ToothGrid {
  Eigen::VectorXd values;
  double mismatch = kNaN;
};

// Profile and helix curves of one tooth.
using ToothCurves = std::pair<std::vector<Curve>, std::vector<Curve>>;

// Checks the options, the gear and the grid, and that the gear has an involute
// to measure; on failure sets result->message.
bool CheckInterpolationInputs(const TraceGridOptions& options,
                              const GearData& gear,
                              const GridOptions& grid,
                              TraceGridResult* result) {
  std::string error;
  if (!options.IsValid(&error)) {
    result->message = error;
    return false;
  }
  ValidationIssue issue;
  if (!ValidateGear(gear, &issue) || !ValidateGrid(grid, &issue)) {
    result->message = issue.field + ": " + issue.message;
    return false;
  }
  const double l_form = gear.FormRollLengthMm();
  const double l_a = gear.TipRollLengthMm();
  if (!(l_a > l_form)) {
    result->message =
        "the tip roll length does not exceed the form roll length: no involute "
        "to measure";
    return false;
  }
  return true;
}

// The curves of the requested flank and tooth, per tooth; on failure sets
// result->message (and trace_index).
bool CollectCurves(const TraceGridOptions& options,
                   const GearData& gear,
                   const std::vector<MeasuredTrace>& traces,
                   std::map<int, ToothCurves>* by_tooth,
                   TraceGridResult* result) {
  // The file's flank that lands on the requested grid flank (the datum face
  // swaps them).
  Flank file_flank = options.flank;
  if (options.datum_face == DatumFace::kXPositive) {
    file_flank = options.flank == Flank::kRight ? Flank::kLeft : Flank::kRight;
  }
  std::string error;
  for (size_t index = 0; index < traces.size(); ++index) {
    const MeasuredTrace& trace = traces[index];
    if (trace.flank != file_flank) continue;
    if (options.tooth != 0 && trace.tooth != options.tooth) continue;
    const bool right = trace.flank == Flank::kRight;
    const double sign =
        trace.kind == TraceKind::kProfile
            ? (right ? options.sign.profile_right : options.sign.profile_left)
            : (right ? options.sign.helix_right : options.sign.helix_left);
    Curve curve;
    if (!MakeCurve(trace,
                   gear,
                   options.datum_face,
                   sign,
                   static_cast<int>(index),
                   &curve,
                   &error)) {
      result->message = error;
      result->trace_index = static_cast<int>(index);
      return false;
    }
    if (static_cast<int>(curve.t.size()) < options.min_trace_points) {
      result->message = std::string(KindName(trace.kind)) + " trace has " +
                        std::to_string(curve.t.size()) +
                        " defined values, at least " +
                        std::to_string(options.min_trace_points) + " needed";
      result->trace_index = static_cast<int>(index);
      return false;
    }
    auto& family = trace.kind == TraceKind::kProfile
                       ? (*by_tooth)[trace.tooth].first
                       : (*by_tooth)[trace.tooth].second;
    family.push_back(std::move(curve));
  }
  const char* flank_name = options.flank == Flank::kRight ? "right" : "left";
  if (by_tooth->empty()) {
    result->message =
        std::string("no trace of the ") + flank_name + " flank" +
        (options.tooth != 0 ? " of tooth " + std::to_string(options.tooth)
                            : std::string()) +
        " in the file";
    return false;
  }
  return true;
}

// Sorts both families of a tooth by position; fails (result->message and
// trace_index) when two traces of a family share a position.
bool SortFamilies(int tooth,
                  std::vector<Curve>* profiles,
                  std::vector<Curve>* helices,
                  TraceGridResult* result) {
  auto by_position = [](const Curve& a, const Curve& b) {
    return a.position < b.position;
  };
  std::sort(profiles->begin(), profiles->end(), by_position);
  std::sort(helices->begin(), helices->end(), by_position);
  for (const auto* family : {profiles, helices}) {
    for (size_t i = 1; i < family->size(); ++i) {
      if (!((*family)[i].position > (*family)[i - 1].position)) {
        result->message = std::string("two ") +
                          (family == profiles ? "profile" : "helix") +
                          " traces of tooth " + std::to_string(tooth) +
                          " at the same position";
        result->trace_index = (*family)[i].trace_index;
        return false;
      }
    }
  }
  return true;
}

// Crossing values C_km = mean of P_m(L_k) and H_k(x_m) (either one where the
// other is undefined), and the largest disagreement between the two into
// *mismatch.
Eigen::MatrixXd CrossingValues(const std::vector<Curve>& profiles,
                               const std::vector<Curve>& helices,
                               double* mismatch) {
  const size_t m = profiles.size();
  const size_t k = helices.size();
  Eigen::MatrixXd crossing = Eigen::MatrixXd::Constant(
      static_cast<Eigen::Index>(k), static_cast<Eigen::Index>(m), kNaN);
  for (size_t a = 0; a < k; ++a) {
    for (size_t b = 0; b < m; ++b) {
      const double p = Evaluate(profiles[b], helices[a].position);
      const double h = Evaluate(helices[a], profiles[b].position);
      if (std::isfinite(p) && std::isfinite(h)) {
        crossing(a, b) = 0.5 * (p + h);
        const double d = std::abs(p - h);
        *mismatch = std::isnan(*mismatch) ? d : std::max(*mismatch, d);
      } else if (std::isfinite(p)) {
        crossing(a, b) = p;
      } else if (std::isfinite(h)) {
        crossing(a, b) = h;
      }
    }
  }
  return crossing;
}

// The Boolean sum at (l, x) with helix weights v and profile weights w into
// *g; false when a term it needs is undefined.
bool BooleanSum(const std::vector<Curve>& profiles,
                const std::vector<Curve>& helices,
                const Eigen::MatrixXd& crossing,
                const std::vector<std::pair<int, double>>& v,
                const std::vector<std::pair<int, double>>& w,
                double l,
                double x,
                double* sum) {
  double g = 0.0;
  bool defined = true;
  for (const auto& [index, weight] : w) {
    if (weight == 0.0) continue;
    const double p = Evaluate(profiles[index], l);
    defined = defined && std::isfinite(p);
    g += weight * p;
  }
  for (const auto& [index, weight] : v) {
    if (weight == 0.0) continue;
    const double h = Evaluate(helices[index], x);
    defined = defined && std::isfinite(h);
    g += weight * h;
  }
  for (const auto& [ki, vk] : v) {
    for (const auto& [mi, wm] : w) {
      if (vk == 0.0 || wm == 0.0) continue;
      const double c = crossing(ki, mi);
      defined = defined && std::isfinite(c);
      g -= vk * wm * c;
    }
  }
  *sum = g;
  return defined;
}

// One tooth's grid (row-major, rows x columns at rows_l x columns_x, NaN where
// the traces do not reach) and crossing mismatch.
ToothGrid InterpolateTooth(const std::vector<Curve>& profiles,
                           const std::vector<Curve>& helices,
                           const std::vector<double>& rows_l,
                           const std::vector<double>& columns_x,
                           double reach_l,
                           double reach_x,
                           int rows,
                           int columns) {
  const size_t m = profiles.size();
  const size_t k = helices.size();
  ToothGrid out;
  const Eigen::MatrixXd crossing =
      CrossingValues(profiles, helices, &out.mismatch);
  out.values = Eigen::VectorXd::Constant(rows * columns, kNaN);
  for (int i = 0; i < rows; ++i) {
    const auto v = Weights(helices, rows_l[i], reach_l);
    if (k > 0 && v.empty()) continue;
    for (int j = 0; j < columns; ++j) {
      const auto w = Weights(profiles, columns_x[j], reach_x);
      if (m > 0 && w.empty()) continue;
      double g = 0.0;
      if (BooleanSum(
              profiles, helices, crossing, v, w, rows_l[i], columns_x[j], &g))
        out.values[i * columns + j] = g;
    }
  }
  return out;
}

// Pointwise mean over the teeth that have the point, the spread over them, the
// not measured points and the largest crossing mismatch, into *result.
void AverageTeeth(const std::vector<ToothGrid>& tooth_grids,
                  int num_points,
                  TraceGridResult* result) {
  result->deviations_um = Eigen::VectorXd::Constant(num_points, kNaN);
  result->tooth_spread_um = Eigen::VectorXd::Constant(num_points, kNaN);
  result->max_crossing_mismatch_um = kNaN;
  for (const ToothGrid& t : tooth_grids) {
    if (std::isfinite(t.mismatch)) {
      result->max_crossing_mismatch_um =
          std::isnan(result->max_crossing_mismatch_um)
              ? t.mismatch
              : std::max(result->max_crossing_mismatch_um, t.mismatch);
    }
  }
  for (int p = 0; p < num_points; ++p) {
    double sum = 0.0, lo = 0.0, hi = 0.0;
    int count = 0;
    for (const ToothGrid& t : tooth_grids) {
      const double v = t.values[p];
      if (!std::isfinite(v)) continue;
      lo = count == 0 ? v : std::min(lo, v);
      hi = count == 0 ? v : std::max(hi, v);
      sum += v;
      ++count;
    }
    if (count > 0) {
      result->deviations_um[p] = sum / count;
      result->tooth_spread_um[p] = hi - lo;
    } else {
      result->not_measured.push_back(
          {p / result->columns, p % result->columns});
    }
  }
}

// Whether every grid row and column keeps the 3 points the ISO figures need;
// otherwise sets result->message.
bool CheckCoverage(const std::vector<double>& rows_l,
                   const std::vector<double>& columns_x,
                   TraceGridResult* result) {
  for (int i = 0; i < result->rows; ++i) {
    int count = 0;
    for (int j = 0; j < result->columns; ++j)
      count += std::isfinite(result->deviations_um[i * result->columns + j]);
    if (count < 3) {
      result->message =
          "grid row " + std::to_string(i) +
          " (a helix trace at L = " + FormatValidationNumber(rows_l[i]) +
          " mm) keeps " + std::to_string(count) +
          " points after interpolation; the figures need 3 (do "
          "the traces cover the grid?)";
      return false;
    }
  }
  for (int j = 0; j < result->columns; ++j) {
    int count = 0;
    for (int i = 0; i < result->rows; ++i)
      count += std::isfinite(result->deviations_um[i * result->columns + j]);
    if (count < 3) {
      result->message =
          "grid column " + std::to_string(j) +
          " (a profile trace at x = " + FormatValidationNumber(columns_x[j]) +
          " mm) keeps " + std::to_string(count) +
          " points after interpolation; the figures need 3 (do "
          "the traces cover the grid?)";
      return false;
    }
  }
  return true;
}

}  // namespace

bool TraceGridOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (tooth < 0)
    return fail("tooth must be >= 0 (0 = mean of all teeth), got " +
                std::to_string(tooth));
  if (!(max_extrapolation_fraction >= 0.0 &&
        max_extrapolation_fraction <= 1.0)) {
    return fail("max_extrapolation_fraction must be in [0, 1], got " +
                FormatValidationNumber(max_extrapolation_fraction));
  }
  if (min_trace_points < 3)
    return fail("min_trace_points must be >= 3, got " +
                std::to_string(min_trace_points));
  for (double s : {sign.profile_right,
                   sign.profile_left,
                   sign.helix_right,
                   sign.helix_left}) {
    if (s != 1.0 && s != -1.0)
      return fail("sign factors must be +1 or -1, got " +
                  FormatValidationNumber(s));
  }
  return true;
}

std::vector<double> GridRollLengthsMm(const GearData& gear,
                                      const GridOptions& grid) {
  const double l_form = gear.FormRollLengthMm();
  const double l_a = gear.TipRollLengthMm();
  std::vector<double> out(std::max(0, grid.profile_points));
  for (int i = 0; i < grid.profile_points; ++i) {
    const double f =
        grid.profile_points == 1
            ? grid.profile_begin
            : grid.profile_begin + (grid.profile_end - grid.profile_begin) * i /
                                       (grid.profile_points - 1);
    out[i] = l_form + f * (l_a - l_form);
  }
  return out;
}

std::vector<double> GridAxialPositionsMm(const GearData& gear,
                                         const GridOptions& grid) {
  std::vector<double> out(std::max(0, grid.lead_points));
  for (int j = 0; j < grid.lead_points; ++j) {
    const double l = grid.lead_points == 1
                         ? grid.lead_begin
                         : grid.lead_begin + (grid.lead_end - grid.lead_begin) *
                                                 j / (grid.lead_points - 1);
    out[j] = l * gear.face_width_mm;
  }
  return out;
}

double RollLengthOfDiameterMm(const GearData& gear, double diameter_mm) {
  const double r = diameter_mm / 2.0;
  const double r_b = gear.BaseRadiusMm();
  if (!(r >= r_b)) return kNaN;
  return std::sqrt(r * r - r_b * r_b);
}

double DiameterOfRollLengthMm(const GearData& gear, double roll_length_mm) {
  const double r_b = gear.BaseRadiusMm();
  return 2.0 * std::sqrt(roll_length_mm * roll_length_mm + r_b * r_b);
}

TraceGridResult InterpolateTraces(const TraceGridOptions& options,
                                  const GearData& gear,
                                  const GridOptions& grid,
                                  const std::vector<MeasuredTrace>& traces) {
  TraceGridResult result;
  if (!CheckInterpolationInputs(options, gear, grid, &result)) return result;
  const double l_form = gear.FormRollLengthMm();
  const double l_a = gear.TipRollLengthMm();
  const std::vector<double> rows_l = GridRollLengthsMm(gear, grid);
  const std::vector<double> columns_x = GridAxialPositionsMm(gear, grid);
  result.rows = grid.profile_points;
  result.columns = grid.lead_points;
  const int num_points = result.rows * result.columns;

  std::map<int, ToothCurves> by_tooth;  // profiles, helices
  if (!CollectCurves(options, gear, traces, &by_tooth, &result)) return result;

  const double reach_x =
      options.max_extrapolation_fraction * gear.face_width_mm;
  const double reach_l = options.max_extrapolation_fraction * (l_a - l_form);
  std::vector<ToothGrid> tooth_grids;
  for (auto& [tooth, families] : by_tooth) {
    auto& [profiles, helices] = families;
    if (!SortFamilies(tooth, &profiles, &helices, &result)) return result;
    const size_t m = profiles.size();
    const size_t k = helices.size();
    ToothGrid out = InterpolateTooth(profiles,
                                     helices,
                                     rows_l,
                                     columns_x,
                                     reach_l,
                                     reach_x,
                                     result.rows,
                                     result.columns);
    result.teeth.push_back(tooth);
    result.profile_traces =
        std::max(result.profile_traces, static_cast<int>(m));
    result.helix_traces = std::max(result.helix_traces, static_cast<int>(k));
    tooth_grids.push_back(std::move(out));
  }

  AverageTeeth(tooth_grids, num_points, &result);
  if (std::isfinite(result.max_crossing_mismatch_um) &&
      result.max_crossing_mismatch_um > 2.0) {
    result.warnings.push_back(
        "profile and helix traces disagree by up to " +
        FormatValidationNumber(result.max_crossing_mismatch_um) +
        " um where they cross (more than 2 um usually "
        "means a wrong sign, tooth or flank)");
  }
  if (!CheckCoverage(rows_l, columns_x, &result)) return result;
  result.ok = true;
  return result;
}

}  // namespace gearloop
