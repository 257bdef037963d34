// engine/bevel/freeform_generator.h: the free-form spiral-bevel generator as a
// MachineModel: the pinion flank cut by the free-form axis polynomials, its
// normal deviations from the cradle machine's flank on the 5 x 9 grid and their
// exact Jacobian, plus the axis-error sensitivity table.
//
//   CradleGenerator cradle(job);
//   BevelFlankGrid grid = cradle.BuildGrid();
//   ConversionResult conversion = ConvertCradleToFreeForm(ConversionOptions(),
//   job); BevelFreeFormGenerator generator(job, grid, conversion.motion);
//   ModelEvaluation eval;
//   generator.Evaluate(conversion.motion.ToVector(), /*with_jacobian=*/true,
//   &eval);
//   // the same CorrectionInput / ComputeCorrection as the grinder
//   (engine/correction/correction.h)
//
// Parameters: the coefficients of the five flank-moving axes A, B, X, Y, Z,
// each a polynomial of degree d in the roll t [rad] (FreeFormMotion::ToVector
// order A0..Ad, B0..Bd, X0.., Y0.., Z0..Zd; A, B in rad, X, Y, Z in mm). The
// cutter spindle C is not a parameter: the cutter is a surface of revolution
// and C has no effect on the flank.
//
// Deviation at grid point P (outward normal n): solve R1(u, theta, t) - P -
// lambda n = 0 and f(u, theta, t) = 0 (f = n_cutter . v, v the velocity of the
// cutter point relative to the work per unit t) by Newton from the cradle
// contact; lambda [um] is the deviation, positive = material left on. The
// Jacobian d lambda / d coefficient is exact, by the implicit function theorem
// on that 4 x 4 system with forward-mode automatic differentiation in the .cc.
#ifndef GEARLOOP_ENGINE_BEVEL_FREEFORM_GENERATOR_H_
#define GEARLOOP_ENGINE_BEVEL_FREEFORM_GENERATOR_H_

#include <Eigen/Core>
#include <string>
#include <vector>

#include "engine/bevel/cradle_machine.h"
#include "engine/bevel/freeform_machine.h"
#include "engine/core/machine_model.h"
#include "engine/core/units.h"

namespace gearloop {

class BevelFreeFormGenerator : public MachineModel {
 public:
  // `grid` is the cradle flank's grid (CradleGenerator::BuildGrid, grid.ok);
  // `nominal` the free-form motion that reproduces the cradle machine (its
  // degree fixes the parameter count).
  BevelFreeFormGenerator(
      const BevelPinionJob& job,
      const BevelFlankGrid& grid,
      const FreeFormMotion& nominal,
      const BevelEnvelopeOptions& options = BevelEnvelopeOptions());

  const BevelPinionJob& job() const { return job_; }
  const BevelFlankGrid& grid() const { return grid_; }
  const FreeFormMotion& nominal() const { return nominal_; }
  int degree() const { return nominal_.degree; }
  // The span of t over the grid's cradle contacts [rad].
  double roll_min_rad() const { return grid_.roll_min_rad; }
  double roll_max_rad() const { return grid_.roll_max_rad; }
  bool NominalRollRange(double* roll_min_rad,
                        double* roll_max_rad) const override {
    *roll_min_rad = this->roll_min_rad();
    *roll_max_rad = this->roll_max_rad();
    return *roll_min_rad < *roll_max_rad;
  }

  // MachineModel.
  int NumParameters() const override { return nominal_.NumParameters(); }
  int GridRows() const override { return grid_.rows; }
  int GridColumns() const override { return grid_.columns; }
  std::string ParameterName(int j) const override {
    return FreeFormParameterName(j, nominal_.degree);
  }
  // Blocks "A", "B" (rad), "X", "Y", "Z" (mm), polynomial. Default scales (one
  // unit of correction size): 1 um for X, Y, Z; 1 um / r_m for A (r_m the mean
  // radius of the grid points from the pinion axis); 1 um / L_m for B (L_m the
  // mean cone distance of the grid points).
  std::vector<ParameterBlock> ParameterBlocks() const override;
  void Evaluate(const Eigen::VectorXd& parameters,
                bool with_jacobian,
                ModelEvaluation* evaluation) const override;

  // The contact at grid point `index` for `motion`, by Newton from the cradle
  // contact.
  BevelContact SolveContact(const FreeFormMotion& motion, int index) const;
  // d lambda / d parameters at a converged contact [mm per parameter unit].
  Eigen::RowVectorXd ContactSensitivity(const FreeFormMotion& motion,
                                        int index,
                                        const BevelContact& contact) const;
  // The cutter point in S1 at (u, theta, t) for `motion`, its normal (into the
  // work) and f.
  Eigen::Vector3d SurfacePoint(const FreeFormMotion& motion,
                               double blade_u_mm,
                               double cutter_theta_rad,
                               double roll_rad,
                               Eigen::Vector3d* normal,
                               double* meshing) const;

 private:
  BevelPinionJob job_;
  BevelFlankGrid grid_;
  FreeFormMotion nominal_;
  BevelEnvelopeOptions options_;
};

struct AxisSensitivityOptions {
  // The axis error applied to each axis, as in Tang 2011 Table 2: 0.01 mm for
  // X, Y, Z and 0.01 deg for A, B.
  double linear_error_mm = 0.01;
  double angular_error_rad = 0.01 * kPi / 180.0;
  // Also re-evaluate the exact model with each offset applied (else only S
  // times the offset).
  bool exact = true;

  // Both errors finite and > 0; else false with the reason.
  bool IsValid(std::string* error) const;
};

// The flank error on the grid caused by one axis error [um] (positive =
// material left on).
struct AxisSensitivityEntry {
  std::string parameter;  // "X0" (offset), "B3", ...
  std::string axis;       // "X"
  int order = 0;          // the polynomial coefficient perturbed
  double error = 0.0;  // the coefficient change applied [mm or rad per t^order]
  double max_abs_um = 0.0;
  double mean_abs_um = 0.0;
  double rms_um = 0.0;
  double min_um = 0.0;
  double max_um = 0.0;
  double exact_max_abs_um =
      0.0;  // from the re-evaluated model (offsets only, when exact)
  Eigen::VectorXd grid_um;  // the linear flank error per grid point (row-major)
};

struct AxisSensitivityTable {
  // One entry per axis: a constant offset of the published size (order 0).
  std::vector<AxisSensitivityEntry> offsets;
  // One entry per coefficient: coefficient k changed by error / h^k, h = max
  // |t| over the roll range, so that the axis error reaches the published size
  // at the end of the range.
  std::vector<AxisSensitivityEntry> coefficients;
  // Indices into `offsets` and `coefficients`, largest rms flank error first.
  std::vector<int> offset_ranking;
  std::vector<int> coefficient_ranking;
};

AxisSensitivityTable ComputeAxisSensitivity(
    const BevelFreeFormGenerator& generator,
    const Eigen::VectorXd& parameters,
    const AxisSensitivityOptions& options = AxisSensitivityOptions());

}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_BEVEL_FREEFORM_GENERATOR_H_
