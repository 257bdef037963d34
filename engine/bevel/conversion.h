// engine/bevel/conversion.h: conversion of a cradle-type hypoid generator's
// summary into the axis motions of the six-axis free-form generator (Tang
// 2011): the exact axis positions at every instant, then polynomial fits of
// each axis in the roll t.
//
//   BevelPinionJob job = PublishedPinionJob(BevelFlankSide::kConvex);
//   ConversionResult c = ConvertCradleToFreeForm(ConversionOptions(), job);
//   if (c.ok) { c.motion ...; c.fit[i].max_residual; c.flank_max_distance_um; }
//
// At each instant t the two machines must hold the cutter in the same place
// relative to the work: work_from_cutter of the free-form chain
// (engine/bevel/freeform_machine.h) equals the cradle machine's
// (engine/bevel/cradle_machine.h).
//  - Orientation: RotX(-A) RotY(B) RotZ(C) = L(t), nine equations in three
//  angles. Closed form
//    on the branch |B| < 90 deg: B = atan2(L02, hypot(L00, L01)), A =
//    atan2(L12, L22), C = atan2(-L01, L00) (A and C unwrapped continuously in
//    t), then a Ceres polish of the nine residuals (Levenberg-Marquardt,
//    automatic derivatives) so the match is at machine precision.
//  - Position: RotX(-A) RotY(B) [X, Y, -Z] = p(t), a 3 x 3 linear system for X,
//  Y, Z.
// Fits: least squares over num_samples instants evenly spread over the fit
// range (the span of the grid's cradle contacts widened by roll_margin_fraction
// of it on each side), in the variable s = (t - centre) / half width, converted
// to the monomials in t the machine takes.
#ifndef GEARLOOP_ENGINE_BEVEL_CONVERSION_H_
#define GEARLOOP_ENGINE_BEVEL_CONVERSION_H_

#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "engine/bevel/cradle_machine.h"
#include "engine/bevel/freeform_machine.h"

namespace gearloop {

struct InstantConversion {
  FreeFormAxisValues axes;
  // Frobenius norm of RotX(-A) RotY(B) RotZ(C) - L after the closed form and
  // after the polish.
  double closed_form_residual = 0.0;
  double polished_residual = 0.0;
};

// The exact free-form axes at cradle roll t. `a_reference_rad` /
// `c_reference_rad`: A and C are taken on the 2 pi branch nearest these
// (continuity along t). `polish`: run Ceres.
InstantConversion ConvertInstant(const CradleMachineSettings& machine,
                                 double roll_rad,
                                 double a_reference_rad,
                                 double c_reference_rad,
                                 bool polish = true);

struct ConversionOptions {
  // Degree of every axis polynomial (1..12). The default 5 (the published
  // degree) keeps the flank cut by the fitted motions within 0.003 um of the
  // cradle flank on the published pinion's grid (both sides), well under the
  // 0.1 um goal; degree 4 gives 0.03-0.07 um, degree 3 0.6-1.1 um
  // (tests/engine/bevel_conversion_test.cc).
  int polynomial_degree = 5;
  // When true, polynomial_degree is ignored: the smallest degree in [2, 12]
  // whose fitted motions cut the flank within max_flank_distance_um of the
  // cradle flank on the grid is chosen (the highest tried if none reaches it;
  // ConversionResult::motion.degree says which).
  bool choose_degree = false;
  double max_flank_distance_um = 0.1;
  // Instants sampled for the fit (>= degree + 1) and for the checks (>= 2).
  int num_samples = 121;
  int num_check_samples = 401;
  // The fit range is the roll span of the grid's cradle contacts widened on
  // each side by this fraction of the span (>= 0).
  double roll_margin_fraction = 0.1;
  bool polish_with_ceres = true;

  bool IsValid(std::string* error) const;
};

struct AxisFitReport {
  std::string axis;           // "A", "B", "X", "Y", "Z", "C"
  std::string unit;           // "rad" or "mm"
  double max_residual = 0.0;  // max |fit - exact| over the check instants
  double rms_residual = 0.0;
};

struct ConversionResult {
  bool ok = false;
  std::string message;

  FreeFormMotion motion;  // the fitted polynomials (C in motion.c_coefficients)
  BevelFlankGrid grid;    // the cradle flank's grid the conversion serves
  double roll_min_rad = 0.0;  // fit range
  double roll_max_rad = 0.0;

  // The exact instants used for the fit.
  std::vector<double> sample_roll_rad;
  std::vector<FreeFormAxisValues> sample_axes;
  // Exact per-instant solution driven through the free-form chain vs the cradle
  // transform (over the samples): max |rotation entry difference| and max
  // |translation difference| [mm]; worst orientation residual of the closed
  // form and of the polish.
  double exact_max_rotation_difference = 0.0;
  double exact_max_translation_difference_mm = 0.0;
  double max_closed_form_residual = 0.0;
  double max_polished_residual = 0.0;

  // Fit residual per axis (A, B, X, Y, Z, C).
  std::array<AxisFitReport, kNumFreeFormAxes + 1> fit;
  // The fitted motions vs the cradle transform over the check instants.
  double fitted_max_rotation_difference = 0.0;
  double fitted_max_translation_difference_mm = 0.0;
  // Normal distance between the flank cut with the fitted motions and the
  // cradle flank on the grid [um]: max |.| and rms over the points where the
  // contact was found.
  double flank_max_distance_um = 0.0;
  double flank_rms_distance_um = 0.0;
  int flank_points_found = 0;
};

ConversionResult ConvertCradleToFreeForm(const ConversionOptions& options,
                                         const BevelPinionJob& job);

}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_BEVEL_CONVERSION_H_
