// engine/core/machine_model.h: the abstract machine model the correction solver
// works against: a parameter vector in, the normal deviations on the
// measurement grid and their Jacobian out. The flat-wheel grinder
// (engine/grinder/flat_wheel_grinder.h) is one implementation; a free-form
// spiral-bevel generator will be another.
//
//   const MachineModel& model = grinder;
//   ModelEvaluation eval;
//   model.Evaluate(zeta, /*with_jacobian=*/true, &eval);
//   // eval.deviations_um(i), eval.status[i], eval.jacobian_um.row(i)
#ifndef GEARLOOP_ENGINE_CORE_MACHINE_MODEL_H_
#define GEARLOOP_ENGINE_CORE_MACHINE_MODEL_H_

#include <Eigen/Core>
#include <string>
#include <vector>

namespace gearloop {

enum class PointStatus {
  kOk,            // the envelope was found; the deviation is a number
  kNotReached,    // the contact lies outside the real wheel (the rim does not
                  // reach it)
  kNotConverged,  // no trustworthy envelope point (Newton failed, or landed on
                  // another branch far from the nominal contact); no number is
                  // reported
};

const char* PointStatusName(PointStatus status);

struct ModelEvaluation {
  // Normal deviation at each grid point (row-major) [um], positive = material
  // left on. 0 where status is not kOk (never use those entries as numbers).
  Eigen::VectorXd deviations_um;
  std::vector<PointStatus> status;
  // d deviation_i / d parameter_j [um per parameter unit]; zero rows where
  // status is not kOk. Filled only when requested.
  Eigen::MatrixXd jacobian_um;
  // The roll angle phi1 of each point's contact [rad] (NaN where status is not
  // kOk).
  std::vector<double> contact_roll_rad;
  // How far inside the tool's working surface each point's contact lies [mm]
  // (the flat wheel: inward from the rim, or from the centre, the nearer);
  // negative for a contact the tool does not reach (kNotReached), NaN where
  // no contact was found. Empty when the model does not say. A small margin
  // is a point a small machine error can lose.
  std::vector<double> contact_margin_mm;
  // Each point's contact in the model's own unknowns (row i; the flat-wheel
  // grinder: u_w [mm], phi_w [rad], phi1 [rad]), kept so that
  // MachineModel::AddJacobian can differentiate there without solving for the
  // contact again. Empty when the model keeps none; not for reports.
  Eigen::MatrixXd contact_unknowns;

  int NumReached() const;
  bool AllReached() const;
};

// A group of parameters with one meaning. Axis motions are polynomial blocks:
// coefficient k multiplies phi1^k, and the size of a change is the axis motion
// it causes over the roll range actually used (MODEL.md §6). Other blocks are
// single scalars.
struct ParameterBlock {
  std::string name;  // "X", "C", "cone_angle", ...
  std::string unit;  // unit of the value (of the axis motion for a polynomial):
                     // "mm", "rad", "1/mm"
  int first_index =
      0;  // index of the first coefficient in the parameter vector
  int num_coefficients = 1;
  bool is_polynomial = false;
  // The change that counts as one unit of correction size (MODEL.md §6), in
  // `unit`.
  double default_scale = 1.0;
  // A scalar block the correction leaves unchanged unless options.max_order
  // names it: its effect on the flank hinges on a machine state the
  // measurement cannot tell (the wheel parabola's vertex while a_w is small).
  bool fixed_by_default = false;
};

class MachineModel {
 public:
  virtual ~MachineModel() = default;

  virtual int NumParameters() const = 0;
  virtual int GridRows() const = 0;
  virtual int GridColumns() const = 0;
  int NumPoints() const { return GridRows() * GridColumns(); }

  // Name of parameter j ("X0".."C6", "cone_angle", ...), for reports.
  virtual std::string ParameterName(int j) const = 0;
  // The parameter blocks in order; together they cover every parameter once.
  virtual std::vector<ParameterBlock> ParameterBlocks() const = 0;

  // Deviations of the flank produced by `parameters` from the theoretical flank
  // on the grid. `parameters` must have NumParameters() entries.
  virtual void Evaluate(const Eigen::VectorXd& parameters,
                        bool with_jacobian,
                        ModelEvaluation* evaluation) const = 0;

  // Adds the Jacobian to an evaluation Evaluate(parameters, false, evaluation)
  // made at the same parameters: afterwards *evaluation is what
  // Evaluate(parameters, true, evaluation) gives, number for number. The
  // default evaluates again; a model that keeps its contacts
  // (ModelEvaluation::contact_unknowns) differentiates at them instead.
  virtual void AddJacobian(const Eigen::VectorXd& parameters,
                           ModelEvaluation* evaluation) const {
    Evaluate(parameters, true, evaluation);
  }

  // The span of the roll angle over the grid's nominal contacts [rad], where
  // the model has one (the range a machine's generating roll is programmed
  // over); false when it has none.
  virtual bool NominalRollRange(double* roll_min_rad,
                                double* roll_max_rad) const {
    (void)roll_min_rad;
    (void)roll_max_rad;
    return false;
  }
};

}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_CORE_MACHINE_MODEL_H_
