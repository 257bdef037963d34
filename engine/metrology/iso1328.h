// engine/metrology/iso1328.h: the ISO 1328-1:2013 figures a quality engineer
// judges a flank by, computed from the deviation grid (METROLOGY.md §4), with
// the tolerances and accuracy classes.
//
//   Iso1328Options options;                                  // L_alpha from
//   the file, if given FlankFigures figures = ComputeFlankFigures(options,
//   gear, grid, deviations_um); AccuracyClasses classes =
//   ClassifyFlank(options, gear, figures); figures.fHa_mean;        // mean
//   profile slope over L_alpha [um] classes.overall;         // std::nullopt =
//   worse than class 11
//
// Per trace (a grid column is a profile trace over L, a grid row a helix trace
// over x), values e:
//   mean line  least-squares straight line through the trace;
//   f_H        line value at the tip (+x) end minus at the root (-x) end;
//   f_f        max - min of the residuals from the mean line;
//   F          max - min of e;
//   C          sag of the least-squares parabola below the chord of its end
//   values (> 0 convex).
// `_grid` figures are over the grid's own extent (L_0..L_{n-1}, x_0..x_{m-1});
// the plain ones are referred to the ISO evaluation lengths: f_Halpha = slope *
// L_alpha, f_Hbeta = slope * L_beta, C scaled by (L / extent)^2; form and total
// are not scaled. Lengths mm, deviations um, positive = material above the
// design flank.
#ifndef GEARLOOP_ENGINE_METROLOGY_ISO1328_H_
#define GEARLOOP_ENGINE_METROLOGY_ISO1328_H_

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "engine/grinder/grinding_setup.h"

namespace gearloop {

struct Iso1328Options {
  // Profile evaluation length L_alpha [mm]; 0 = 0.95 (L_a - L_form)
  // (METROLOGY.md §4, "to be confirmed"). A measuring file's own value (mka
  // code 45, GDE) goes here.
  double profile_evaluation_length_mm = 0.0;
  // Helix evaluation length L_beta [mm]; 0 = b - 2 min(0.05 b, m_n) (ISO
  // 1328-1:2013, 3.2.3).
  double helix_evaluation_length_mm = 0.0;
  // A figure is compared with a tolerance after rounding to this resolution
  // [um], the one the figures are reported in: the measured grid carries the
  // file's 0.001 um rounding, which must not push 10.00 um past a 10 um
  // tolerance. 0 = compare unrounded.
  double class_resolution_um = 0.01;

  bool IsValid(std::string* error) const;
};

// The figures of one trace; NaN when it has fewer than 3 points.
struct TraceFigures {
  int points = 0;
  double slope_grid_um = 0.0;     // f_H over the grid extent
  double slope_iso_um = 0.0;      // f_H over the ISO evaluation length
  double form_um = 0.0;           // f_f
  double total_um = 0.0;          // F
  double crowning_grid_um = 0.0;  // C over the grid extent
  double crowning_iso_um = 0.0;   // C referred to the ISO evaluation length
};

// Per flank, named as the API names them (METROLOGY.md §4; a = alpha/profile, b
// = beta/helix).
struct FlankFigures {
  bool ok = false;
  std::string message;

  double profile_evaluation_length_mm = 0.0;  // L_alpha
  double helix_evaluation_length_mm = 0.0;    // L_beta
  double profile_grid_extent_mm = 0.0;        // L_{n-1} - L_0
  double helix_grid_extent_mm = 0.0;          // x_{m-1} - x_0
  std::vector<TraceFigures>
      profile_traces;  // one per grid column, column 0 first
  std::vector<TraceFigures>
      helix_traces;  // one per grid row, row 0 (root) first

  // Profile: mean slope (what a correction acts on), worst trace of slope, form
  // and total, mean crowning.
  double fHa_mean = 0.0;
  double fHa_mean_grid = 0.0;
  double fHa_max_abs = 0.0;
  double fHa_max_abs_grid = 0.0;
  double ffa_max_abs = 0.0;
  double Fa_max_abs = 0.0;
  double Ca_mean = 0.0;
  double Ca_mean_grid = 0.0;
  // Helix: the same.
  double fHb_mean = 0.0;
  double fHb_mean_grid = 0.0;
  double fHb_max_abs = 0.0;
  double fHb_max_abs_grid = 0.0;
  double ffb_max_abs = 0.0;
  double Fb_max_abs = 0.0;
  double Cb_mean = 0.0;
  double Cb_mean_grid = 0.0;
  // Twist: S_alpha = change of the profile slope from the -x to the +x end of
  // the grid (least- squares line through the column values), S_beta = change
  // of the helix slope from the root row to the tip row. `_grid`: slopes over
  // the grid extent (METROLOGY.md §4's worked twist numbers); plain: slopes
  // referred to L_alpha, L_beta.
  double twist_alpha_grid = 0.0;
  double twist_beta_grid = 0.0;
  double twist_alpha = 0.0;
  double twist_beta = 0.0;
};

// The figures of one trace with values e at abscissas t [mm] (NaN values
// skipped), its slope and crowning referred to `grid_extent_mm` and
// `iso_length_mm`.
TraceFigures ComputeTraceFigures(const std::vector<double>& abscissa_mm,
                                 const std::vector<double>& values_um,
                                 double grid_extent_mm,
                                 double iso_length_mm);

// The figures of a rows x columns grid (row-major, NaN = missing) on `grid` of
// `gear`; on measured - target when `target_um` is non-empty. Fails (ok =
// false) when a trace keeps fewer than 3 points or the shapes do not match.
FlankFigures ComputeFlankFigures(
    const Iso1328Options& options,
    const GearData& gear,
    const GridOptions& grid,
    const Eigen::VectorXd& deviations_um,
    const Eigen::VectorXd& target_um = Eigen::VectorXd());

// Tolerances of ISO 1328-1:2013 for one class A = 1..11 [um]: the unrounded
// class-5 value times sqrt(2)^(A - 5), rounded at the end (> 10 um to 1
// um, 5..10 um to 0.5 um, < 5 um to 0.1 um) unless `rounded` is false.
struct Iso1328Tolerances {
  double fHa = 0.0;  // f_HalphaT = 0.4 m_n + 0.001 d + 4
  double ffa = 0.0;  // f_falphaT = 0.55 m_n + 5
  double Fa = 0.0;   // F_alphaT = sqrt(f_HalphaT^2 + f_falphaT^2)
  double fHb = 0.0;  // f_HbetaT = 0.05 sqrt(d) + 0.35 sqrt(b) + 4
  double ffb = 0.0;  // f_fbetaT = 0.07 sqrt(d) + 0.45 sqrt(b) + 4
  double Fb = 0.0;   // F_betaT = sqrt(f_HbetaT^2 + f_fbetaT^2)
};
Iso1328Tolerances ComputeTolerances(const GearData& gear,
                                    int accuracy_class,
                                    bool rounded = true);
// The rounding rule above.
double RoundIso1328Tolerance(double tolerance_um);

// Accuracy class per figure: the smallest A in 1..11 with |worst trace value|
// <= the rounded tolerance; std::nullopt when worse than 11 (or not computed).
// Overall = the largest.
struct AccuracyClasses {
  std::optional<int> fHa;
  std::optional<int> ffa;
  std::optional<int> Fa;
  std::optional<int> fHb;
  std::optional<int> ffb;
  std::optional<int> Fb;
  std::optional<int> overall;
  // The gear outside the validity range of ISO 1328-1 (5 <= z <= 1000, 5 <= d
  // <= 15000 mm, 0.5 <= m_n <= 70 mm, 4 <= b <= 1200 mm, |beta| <= 45 deg):
  // classes are still given.
  std::vector<std::string> warnings;
};
AccuracyClasses ClassifyFlank(const Iso1328Options& options,
                              const GearData& gear,
                              const FlankFigures& figures);

}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_METROLOGY_ISO1328_H_
