// engine/metrology/iso1328.cc: trace figures by least squares, flank figures,
// ISO 1328-1:2013 tolerances and classes.
//
// The fits work on the abscissa centred and scaled to [-1, 1] so that the
// normal equations stay well conditioned whatever the units; the slope and the
// parabola's curvature are scaled back.
#include "engine/metrology/iso1328.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "engine/core/units.h"
#include "engine/metrology/trace_grid.h"

namespace gearloop {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Least-squares slope of (t, y) [y per mm]; needs 2 distinct t.
double LineSlope(const std::vector<double>& t, const std::vector<double>& y) {
  const double n = static_cast<double>(t.size());
  double mt = 0.0, my = 0.0;
  for (size_t i = 0; i < t.size(); ++i) {
    mt += t[i];
    my += y[i];
  }
  mt /= n;
  my /= n;
  double stt = 0.0, sty = 0.0;
  for (size_t i = 0; i < t.size(); ++i) {
    stt += (t[i] - mt) * (t[i] - mt);
    sty += (t[i] - mt) * (y[i] - my);
  }
  return stt > 0.0 ? sty / stt : 0.0;
}

double Mean(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v) s += x;
  return v.empty() ? kNaN : s / static_cast<double>(v.size());
}

}  // namespace

bool Iso1328Options::IsValid(std::string* error) const {
  auto fail = [&](const std::string& message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (!(profile_evaluation_length_mm >= 0.0) ||
      !std::isfinite(profile_evaluation_length_mm)) {
    return fail(
        "profile evaluation length L_alpha must be >= 0 mm (0 = default), "
        "got " +
        FormatValidationNumber(profile_evaluation_length_mm));
  }
  if (!(helix_evaluation_length_mm >= 0.0) ||
      !std::isfinite(helix_evaluation_length_mm)) {
    return fail(
        "helix evaluation length L_beta must be >= 0 mm (0 = default), got " +
        FormatValidationNumber(helix_evaluation_length_mm));
  }
  if (!(class_resolution_um >= 0.0 && class_resolution_um <= 1.0)) {
    return fail("class_resolution_um must be in [0, 1] um, got " +
                FormatValidationNumber(class_resolution_um));
  }
  return true;
}

TraceFigures ComputeTraceFigures(const std::vector<double>& abscissa_mm,
                                 const std::vector<double>& values_um,
                                 double grid_extent_mm,
                                 double iso_length_mm) {
  TraceFigures f;
  std::vector<double> t, e;
  for (size_t i = 0; i < abscissa_mm.size() && i < values_um.size(); ++i) {
    if (std::isfinite(values_um[i]) && std::isfinite(abscissa_mm[i])) {
      t.push_back(abscissa_mm[i]);
      e.push_back(values_um[i]);
    }
  }
  f.points = static_cast<int>(t.size());
  if (t.size() < 3) {
    f.slope_grid_um = f.slope_iso_um = f.form_um = f.total_um =
        f.crowning_grid_um = f.crowning_iso_um = kNaN;
    return f;
  }
  const auto [t_min, t_max] = std::minmax_element(t.begin(), t.end());
  const double mid = 0.5 * (*t_min + *t_max);
  const double half = 0.5 * (*t_max - *t_min);
  if (!(half > 0.0)) {
    f.slope_grid_um = f.slope_iso_um = f.form_um = f.total_um =
        f.crowning_grid_um = f.crowning_iso_um = kNaN;
    return f;
  }
  std::vector<double> u(t.size());
  for (size_t i = 0; i < t.size(); ++i) u[i] = (t[i] - mid) / half;

  // Mean line e ~ a + s u.
  const double s_u = LineSlope(u, e);
  const double slope_per_mm = s_u / half;
  const double a = Mean(e) - s_u * Mean(u);
  double r_min = 0.0, r_max = 0.0, e_min = e[0], e_max = e[0];
  for (size_t i = 0; i < e.size(); ++i) {
    const double r = e[i] - (a + s_u * u[i]);
    r_min = i == 0 ? r : std::min(r_min, r);
    r_max = i == 0 ? r : std::max(r_max, r);
    e_min = std::min(e_min, e[i]);
    e_max = std::max(e_max, e[i]);
  }
  f.slope_grid_um = slope_per_mm * grid_extent_mm;
  f.slope_iso_um = slope_per_mm * iso_length_mm;
  f.form_um = r_max - r_min;
  f.total_um = e_max - e_min;

  // Least-squares parabola e ~ c0 + c1 u + c2 u^2; its sag below the chord over
  // a length h is -c2' h^2 / 4 with c2' = c2 / half^2 the curvature per mm^2.
  Eigen::MatrixXd design(static_cast<Eigen::Index>(u.size()), 3);
  Eigen::VectorXd rhs(static_cast<Eigen::Index>(u.size()));
  for (size_t i = 0; i < u.size(); ++i) {
    design(i, 0) = 1.0;
    design(i, 1) = u[i];
    design(i, 2) = u[i] * u[i];
    rhs(i) = e[i];
  }
  const Eigen::Vector3d c = design.colPivHouseholderQr().solve(rhs);
  const double curvature_per_mm2 = c(2) / (half * half);
  f.crowning_grid_um =
      -curvature_per_mm2 * grid_extent_mm * grid_extent_mm / 4.0;
  f.crowning_iso_um = -curvature_per_mm2 * iso_length_mm * iso_length_mm / 4.0;
  return f;
}

namespace {

// Checks the options, gear, grid and the sizes of the grid and target; on
// failure sets f->message.
bool CheckFigureInputs(const Iso1328Options& options,
                       const GearData& gear,
                       const GridOptions& grid,
                       const Eigen::VectorXd& deviations_um,
                       const Eigen::VectorXd& target_um,
                       FlankFigures* f) {
  std::string error;
  if (!options.IsValid(&error)) {
    f->message = error;
    return false;
  }
  ValidationIssue issue;
  if (!ValidateGear(gear, &issue) || !ValidateGrid(grid, &issue)) {
    f->message = issue.field + ": " + issue.message;
    return false;
  }
  const int rows = grid.profile_points;
  const int columns = grid.lead_points;
  if (deviations_um.size() != rows * columns) {
    f->message = "the grid has " + std::to_string(deviations_um.size()) +
                 " values, expected " + std::to_string(rows) + " x " +
                 std::to_string(columns);
    return false;
  }
  if (target_um.size() != 0 && target_um.size() != deviations_um.size()) {
    f->message = "the target has " + std::to_string(target_um.size()) +
                 " values, expected " + std::to_string(rows) + " x " +
                 std::to_string(columns);
    return false;
  }
  return true;
}

// The grid extents and the ISO evaluation lengths L_alpha, L_beta.
void SetFigureLengths(const Iso1328Options& options,
                      const GearData& gear,
                      const std::vector<double>& l,
                      const std::vector<double>& x,
                      FlankFigures* f) {
  f->profile_grid_extent_mm = l.back() - l.front();
  f->helix_grid_extent_mm = x.back() - x.front();
  const double b = gear.face_width_mm;
  f->profile_evaluation_length_mm =
      options.profile_evaluation_length_mm > 0.0
          ? options.profile_evaluation_length_mm
          : 0.95 * (gear.TipRollLengthMm() - gear.FormRollLengthMm());
  f->helix_evaluation_length_mm =
      options.helix_evaluation_length_mm > 0.0
          ? options.helix_evaluation_length_mm
          : b - 2.0 * std::min(0.05 * b, gear.normal_module_mm);
}

// The figures of every grid column (profile) and row (helix); fails with
// f->message when one keeps fewer than 3 points.
bool ComputeAllTraceFigures(const std::vector<double>& l,
                            const std::vector<double>& x,
                            const Eigen::VectorXd& deviations_um,
                            const Eigen::VectorXd& target_um,
                            int rows,
                            int columns,
                            FlankFigures* f) {
  auto value = [&](int i, int j) {
    const int p = i * columns + j;
    return target_um.size() != 0 ? deviations_um[p] - target_um[p]
                                 : deviations_um[p];
  };
  for (int j = 0; j < columns; ++j) {
    std::vector<double> e(rows);
    for (int i = 0; i < rows; ++i) e[i] = value(i, j);
    f->profile_traces.push_back(ComputeTraceFigures(
        l, e, f->profile_grid_extent_mm, f->profile_evaluation_length_mm));
  }
  for (int i = 0; i < rows; ++i) {
    std::vector<double> e(columns);
    for (int j = 0; j < columns; ++j) e[j] = value(i, j);
    f->helix_traces.push_back(ComputeTraceFigures(
        x, e, f->helix_grid_extent_mm, f->helix_evaluation_length_mm));
  }
  for (size_t j = 0; j < f->profile_traces.size(); ++j) {
    if (f->profile_traces[j].points < 3) {
      f->message = "grid column " + std::to_string(j) + " has " +
                   std::to_string(f->profile_traces[j].points) +
                   " points; the profile figures need 3";
      return false;
    }
  }
  for (size_t i = 0; i < f->helix_traces.size(); ++i) {
    if (f->helix_traces[i].points < 3) {
      f->message = "grid row " + std::to_string(i) + " has " +
                   std::to_string(f->helix_traces[i].points) +
                   " points; the helix figures need 3";
      return false;
    }
  }
  return true;
}

// The flank's means, worst traces and twists from its trace figures.
void SummarizeTraceFigures(const std::vector<double>& l,
                           const std::vector<double>& x,
                           int rows,
                           int columns,
                           FlankFigures* f) {
  std::vector<double> slopes_a, slopes_b;
  double crown_a = 0.0, crown_b = 0.0;
  for (const TraceFigures& t : f->profile_traces) {
    slopes_a.push_back(t.slope_grid_um);
    f->fHa_max_abs_grid =
        std::max(f->fHa_max_abs_grid, std::abs(t.slope_grid_um));
    f->fHa_max_abs = std::max(f->fHa_max_abs, std::abs(t.slope_iso_um));
    f->ffa_max_abs = std::max(f->ffa_max_abs, std::abs(t.form_um));
    f->Fa_max_abs = std::max(f->Fa_max_abs, std::abs(t.total_um));
    crown_a += t.crowning_grid_um;
  }
  for (const TraceFigures& t : f->helix_traces) {
    slopes_b.push_back(t.slope_grid_um);
    f->fHb_max_abs_grid =
        std::max(f->fHb_max_abs_grid, std::abs(t.slope_grid_um));
    f->fHb_max_abs = std::max(f->fHb_max_abs, std::abs(t.slope_iso_um));
    f->ffb_max_abs = std::max(f->ffb_max_abs, std::abs(t.form_um));
    f->Fb_max_abs = std::max(f->Fb_max_abs, std::abs(t.total_um));
    crown_b += t.crowning_grid_um;
  }
  const double scale_a =
      f->profile_evaluation_length_mm / f->profile_grid_extent_mm;
  const double scale_b =
      f->helix_evaluation_length_mm / f->helix_grid_extent_mm;
  f->fHa_mean_grid = Mean(slopes_a);
  f->fHa_mean = f->fHa_mean_grid * scale_a;
  f->Ca_mean_grid = crown_a / columns;
  f->Ca_mean = f->Ca_mean_grid * scale_a * scale_a;
  f->fHb_mean_grid = Mean(slopes_b);
  f->fHb_mean = f->fHb_mean_grid * scale_b;
  f->Cb_mean_grid = crown_b / rows;
  f->Cb_mean = f->Cb_mean_grid * scale_b * scale_b;
  f->twist_alpha_grid = LineSlope(x, slopes_a) * f->helix_grid_extent_mm;
  f->twist_beta_grid = LineSlope(l, slopes_b) * f->profile_grid_extent_mm;
  f->twist_alpha = f->twist_alpha_grid * scale_a;
  f->twist_beta = f->twist_beta_grid * scale_b;
}

}  // namespace

FlankFigures ComputeFlankFigures(const Iso1328Options& options,
                                 const GearData& gear,
                                 const GridOptions& grid,
                                 const Eigen::VectorXd& deviations_um,
                                 const Eigen::VectorXd& target_um) {
  FlankFigures f;
  if (!CheckFigureInputs(options, gear, grid, deviations_um, target_um, &f))
    return f;
  const int rows = grid.profile_points;
  const int columns = grid.lead_points;
  const std::vector<double> l = GridRollLengthsMm(gear, grid);
  const std::vector<double> x = GridAxialPositionsMm(gear, grid);
  SetFigureLengths(options, gear, l, x, &f);
  if (!ComputeAllTraceFigures(
          l, x, deviations_um, target_um, rows, columns, &f))
    return f;
  SummarizeTraceFigures(l, x, rows, columns, &f);
  f.ok = true;
  return f;
}

double RoundIso1328Tolerance(double tolerance_um) {
  if (tolerance_um > 10.0) return std::round(tolerance_um);
  if (tolerance_um >= 5.0) return std::round(tolerance_um * 2.0) / 2.0;
  return std::round(tolerance_um * 10.0) / 10.0;
}

Iso1328Tolerances ComputeTolerances(const GearData& gear,
                                    int accuracy_class,
                                    bool rounded) {
  const double m = gear.normal_module_mm;
  const double d = 2.0 * gear.PitchRadiusMm();
  const double b = gear.face_width_mm;
  const double fha5 = 0.4 * m + 0.001 * d + 4.0;
  const double ffa5 = 0.55 * m + 5.0;
  const double fhb5 = 0.05 * std::sqrt(d) + 0.35 * std::sqrt(b) + 4.0;
  const double ffb5 = 0.07 * std::sqrt(d) + 0.45 * std::sqrt(b) + 4.0;
  const double k = std::pow(std::sqrt(2.0), accuracy_class - 5);
  Iso1328Tolerances t;
  t.fHa = fha5 * k;
  t.ffa = ffa5 * k;
  t.Fa = std::hypot(fha5, ffa5) * k;
  t.fHb = fhb5 * k;
  t.ffb = ffb5 * k;
  t.Fb = std::hypot(fhb5, ffb5) * k;
  if (rounded) {
    for (double* v : {&t.fHa, &t.ffa, &t.Fa, &t.fHb, &t.ffb, &t.Fb})
      *v = RoundIso1328Tolerance(*v);
  }
  return t;
}

AccuracyClasses ClassifyFlank(const Iso1328Options& options,
                              const GearData& gear,
                              const FlankFigures& figures) {
  AccuracyClasses c;
  const double d = 2.0 * gear.PitchRadiusMm();
  const double beta_deg = std::abs(gear.helix_angle_rad) * kDegPerRad;
  auto outside = [&](bool bad, const std::string& what) {
    if (bad)
      c.warnings.push_back("outside the validity range of ISO 1328-1:2013: " +
                           what);
  };
  outside(gear.teeth < 5 || gear.teeth > 1000,
          "z = " + std::to_string(gear.teeth) + " (5..1000)");
  outside(d < 5.0 || d > 15000.0,
          "d = " + FormatValidationNumber(d) + " mm (5..15000 mm)");
  outside(gear.normal_module_mm < 0.5 || gear.normal_module_mm > 70.0,
          "m_n = " + FormatValidationNumber(gear.normal_module_mm) +
              " mm (0.5..70 mm)");
  outside(
      gear.face_width_mm < 4.0 || gear.face_width_mm > 1200.0,
      "b = " + FormatValidationNumber(gear.face_width_mm) + " mm (4..1200 mm)");
  outside(beta_deg > 45.0 + 1e-9,
          "beta = " + FormatValidationNumber(beta_deg) + " deg (<= 45 deg)");
  if (!figures.ok) return c;

  std::vector<Iso1328Tolerances> tolerances;
  for (int a = 1; a <= 11; ++a)
    tolerances.push_back(ComputeTolerances(gear, a));
  const double resolution = options.class_resolution_um;
  auto classify = [&](double value,
                      double Iso1328Tolerances::*member) -> std::optional<int> {
    if (!std::isfinite(value)) return std::nullopt;
    double v = std::abs(value);
    if (resolution > 0.0) v = std::round(v / resolution) * resolution;
    for (int a = 1; a <= 11; ++a) {
      if (v <= tolerances[a - 1].*member + 1e-9) return a;
    }
    return std::nullopt;
  };
  c.fHa = classify(figures.fHa_max_abs, &Iso1328Tolerances::fHa);
  c.ffa = classify(figures.ffa_max_abs, &Iso1328Tolerances::ffa);
  c.Fa = classify(figures.Fa_max_abs, &Iso1328Tolerances::Fa);
  c.fHb = classify(figures.fHb_max_abs, &Iso1328Tolerances::fHb);
  c.ffb = classify(figures.ffb_max_abs, &Iso1328Tolerances::ffb);
  c.Fb = classify(figures.Fb_max_abs, &Iso1328Tolerances::Fb);
  int overall = 0;
  bool all = true;
  for (const auto& one : {c.fHa, c.ffa, c.Fa, c.fHb, c.ffb, c.Fb}) {
    if (!one) {
      all = false;
      break;
    }
    overall = std::max(overall, *one);
  }
  if (all) c.overall = overall;
  return c;
}

}  // namespace gearloop
