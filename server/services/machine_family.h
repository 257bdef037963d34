// server/services/machine_family.h: the machine a correction or simulation
// request is about, found ONCE from body.machine.kind (like ceres
// LinearSolver::Create: one switch, one make_unique) and handed on as a
// MachineModel plus the family's own mapping of parameters to JSON and to the
// job history. Every other file of the server is family-blind.
//
//   CorrectionProblem problem;
//   ApiError error;
//   if (!CorrectionProblemFor(body, &problem, &error)) return RespondError(res,
//   error); input.model = problem.model.get(); input.current_parameters =
//   problem.current_parameters;
//
// Families (machine.kind):
//   "flat-wheel-grinder" (or absent)  gear, wheel, machine, grid, flank,
//   settings (default nominal) "free-form-bevel-generator"       job, motion
//   (default: converted from the cradle summary)
#ifndef GEARLOOP_SERVER_SERVICES_MACHINE_FAMILY_H_
#define GEARLOOP_SERVER_SERVICES_MACHINE_FAMILY_H_

#include <Eigen/Core>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "engine/bevel/cradle_machine.h"
#include "engine/bevel/freeform_machine.h"
#include "engine/core/machine_model.h"
#include "engine/grinder/target_modification.h"
#include "engine/shaving/cutter_target.h"
#include "engine/simulation/measurement_simulator.h"
#include "server/codec/json_read.h"
#include "server/codec/machine_kind.h"
#include "storage/job_repository.h"

namespace gearloop {

// The machine of one request, ready for the engine, with the family's
// renderings.
struct CorrectionProblem {
  std::unique_ptr<MachineModel> model;
  // The parameters the part was (or is to be) ground with: the request's
  // settings or motion.
  Eigen::VectorXd current_parameters;
  int rows = 0;
  int columns = 0;
  // Where answers put the machine's parameters: "settings" (grinder) or
  // "motion" (bevel).
  std::string parameters_key;
  // Keys every simulation answer of the family carries: {} or {"machine_kind":
  // ...}.
  nlohmann::json answer_header = nlohmann::json::object();
  // The parameters (commanded or corrected) as the API shows them.
  std::function<nlohmann::json(const Eigen::VectorXd& parameters)>
      parameters_to_json;
  // A change of the parameters (a correction's delta, hidden errors) as the API
  // shows it.
  std::function<nlohmann::json(const Eigen::VectorXd& delta)> delta_to_json;
  // Keys a correction result carries besides the summary for a part ground with
  // `commanded`.
  std::function<nlohmann::json(const Eigen::VectorXd& commanded)> result_header;
  // The machine part of a request a client would send for a part ground with
  // `commanded` (the stored request of a closed-loop job, replayable).
  std::function<nlohmann::json(const Eigen::VectorXd& commanded)>
      request_setup_json;
  // Fills the job history's summary columns (gear, flank, machine kind) of a
  // job of this machine.
  std::function<void(JobRecord* job)> job_summary_columns;
  // Evaluates target modifications on the family's flank; empty for a family
  // without them.
  std::function<Eigen::VectorXd(const std::vector<TargetModification>&)>
      evaluate_modifications;
  // The ISO 1328-1 figures and classes of a grid on the family's flank, on
  // deviations - target when `target_um` is non-empty ({"figures", "classes"},
  // codec FlankQualityToJson), with a measuring file's profile evaluation
  // length (0 = the default); empty for a family without an involute gear.
  std::function<nlohmann::json(const Eigen::VectorXd& deviations_um,
                               const Eigen::VectorXd& target_um,
                               double profile_evaluation_length_mm)>
      flank_quality_json;
  // Fits a shaving target (target.shaving, SHAVING.md) to the machine: the
  // cutter must be the gear being ground, on the right flank; an absent grid
  // (grid_given false) becomes the problem's, a given one must equal it. 422
  // naming the field otherwise. Empty for a family without an involute cutter.
  std::function<bool(bool grid_given, ShavingInput* input, ApiError* error)>
      fit_shaving_target;
};

// A simulated machine: the problem (commanded = current_parameters), its hidden
// errors and the simulated measuring machine.
struct SimulationProblem {
  CorrectionProblem problem;
  Eigen::VectorXd hidden_errors;
  MeasurementSimulationOptions measurement;
};

// Reads the machine of a correction request (the family's fields, validated)
// and builds its model. 400/422 in `error` when the request does not describe a
// machine of its family.
bool CorrectionProblemFor(const nlohmann::json& body,
                          CorrectionProblem* problem,
                          ApiError* error);

// The same for a simulation request, plus hidden errors and the measuring
// machine's options.
bool SimulationProblemFor(const nlohmann::json& body,
                          SimulationProblem* simulation,
                          ApiError* error);

// A bevel request's job, its cradle grid and the motion to use (given, or
// converted from the summary): the engine calls the bevel endpoints and the
// bevel family share.
struct BevelSetup {
  BevelPinionJob job;
  BevelFlankGrid grid;
  FreeFormMotion
      nominal;  // converted from the summary (the generator's reference)
  FreeFormMotion motion;  // the request's motion, or `nominal`
  bool motion_given = false;
};
bool PrepareBevel(const nlohmann::json& body,
                  BevelSetup* setup,
                  ApiError* error);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_SERVICES_MACHINE_FAMILY_H_
