#include "server/services/simulation_service.h"

#include <cmath>
#include <optional>
#include <string>

#include "engine/simulation/measurement_simulator.h"
#include "server/codec/correction_codec.h"
#include "server/codec/request_keys.h"
#include "server/codec/simulation_codec.h"
#include "server/services/correction_service.h"
#include "server/services/machine_family.h"

// Last: see server/respond.h.
#include <httplib.h>

namespace gearloop {
namespace {

// A closed loop as the request describes it.
struct ClosedLoopRequest {
  SimulationProblem simulation;
  Eigen::VectorXd target_um;
  ClosedLoopOptions loop;
  nlohmann::json options_body;  // the options as used, stored with each job
  bool store = false;
  bool allow_large_deviations = false;
};

bool ParseClosedLoopRequest(const nlohmann::json& body,
                            ClosedLoopRequest* request,
                            ApiError* error) {
  if (!SimulationProblemFor(body, &request->simulation, error)) return false;
  const CorrectionProblem& problem = request->simulation.problem;
  if (!problem.evaluate_modifications && HasTargetModifications(body)) {
    *error = InvalidValue("target.modifications",
                          "give a bevel target as target.deviations_um");
    return false;
  }
  std::optional<std::vector<TargetModification>> modifications;
  if (!ParseCorrectionTarget(body,
                             problem.rows,
                             problem.columns,
                             &request->target_um,
                             &modifications,
                             error)) {
    return false;
  }
  request->loop.measurement = request->simulation.measurement;
  if (!ParseClosedLoop(body,
                       problem.rows,
                       problem.columns,
                       &request->loop,
                       &request->options_body,
                       error) ||
      !ReadBool(body, "", "store", false, &request->store, error) ||
      !ReadBool(body,
                "",
                "allow_large_deviations",
                false,
                &request->allow_large_deviations,
                error)) {
    return false;
  }
  if (modifications)
    request->target_um = problem.evaluate_modifications(*modifications);
  return true;
}

// The job of a usable correction of part `k`: the request a client would have
// sent for that part (replayable), with the grid the simulated machine
// measured, and the result as a correction answers it.
JobRecord ClosedLoopJob(const ClosedLoopRequest& request,
                        const ClosedLoopResult& result,
                        size_t k) {
  const CorrectionProblem& problem = request.simulation.problem;
  const ClosedLoopIteration& it = result.iterations[k];
  const int rows = problem.rows;
  const int columns = problem.columns;
  nlohmann::json part_request =
      problem.request_setup_json(it.commanded_parameters);
  part_request["measurement"] = {
      {"deviations_um", GridToJson(it.measured_um, {}, rows, columns)}};
  part_request["target"] = {
      {"deviations_um", GridToJson(request.target_um, {}, rows, columns)}};
  part_request["options"] = request.options_body;
  // A stored part replays as it ran: its grids beyond the 500 um rule (a
  // large target the client allowed, a large simulated error) are allowed.
  const auto beyond = [](const Eigen::VectorXd& grid) {
    for (int i = 0; i < grid.size(); ++i) {
      if (std::abs(grid(i)) > kMaxPlausibleDeviationUm) return true;
    }
    return false;
  };
  if (request.allow_large_deviations || beyond(it.measured_um) ||
      beyond(request.target_um))
    part_request["allow_large_deviations"] = true;
  // The step to the next part's parameters (none after the last part).
  std::optional<CorrectionStep> step;
  if (k + 1 < result.iterations.size()) {
    const Eigen::VectorXd& next = result.iterations[k + 1].commanded_parameters;
    step =
        CorrectionStep{next, next - it.commanded_parameters, it.linearised_at};
  }
  const nlohmann::json result_json =
      CorrectionResultJson(problem,
                           it.correction,
                           it.commanded_parameters,
                           step,
                           it.predicted_residual_um,
                           it.predicted_change_um,
                           it.measured_um,
                           request.target_um);
  JobRecord job;
  job.status = CorrectionStatusName(it.correction.status);
  problem.job_summary_columns(&job);
  job.request_json = Dump(part_request);
  job.result_json = Dump(result_json);
  if (std::isfinite(it.correction.residual_rms_um))
    job.residual_rms_um = it.correction.residual_rms_um;
  if (std::isfinite(it.correction.best_reachable_rms_um))
    job.best_reachable_rms_um = it.correction.best_reachable_rms_um;
  job.rank = it.correction.rank;
  job.elapsed_ms = it.correction.elapsed_ms;
  return job;
}

}  // namespace

void SimulateMeasurement(const ServiceContext&,
                         const httplib::Request& req,
                         httplib::Response& res) {
  nlohmann::json body;
  ApiError error;
  SimulationProblem simulation;
  if (!ParseJsonBody(req.body, &body, &error) ||
      !CheckRequestKeys(
          RequestSchema::kMeasurementSimulation, body, "", &error) ||
      !SimulationProblemFor(body, &simulation, &error)) {
    return RespondError(res, error);
  }
  const CorrectionProblem& problem = simulation.problem;
  const SimulatedMeasurement cmm =
      SimulateMeasurement(*problem.model,
                          problem.current_parameters,
                          simulation.hidden_errors,
                          simulation.measurement);
  nlohmann::json answer =
      SimulatedMeasurementToJson(cmm, problem.rows, problem.columns);
  for (const auto& item : problem.answer_header.items())
    answer[item.key()] = item.value();
  answer["hidden_errors"] = problem.delta_to_json(simulation.hidden_errors);
  answer[problem.parameters_key] =
      problem.parameters_to_json(problem.current_parameters);
  RespondJson(res, 200, answer);
}

void SimulateClosedLoop(const ServiceContext& context,
                        const httplib::Request& req,
                        httplib::Response& res) {
  nlohmann::json body;
  ApiError error;
  ClosedLoopRequest request;
  if (!ParseJsonBody(req.body, &body, &error) ||
      !CheckRequestKeys(RequestSchema::kClosedLoop, body, "", &error) ||
      !ParseClosedLoopRequest(body, &request, &error)) {
    return RespondError(res, error);
  }
  const CorrectionProblem& problem = request.simulation.problem;
  const ClosedLoopResult result =
      SimulateClosedLoop(*problem.model,
                         problem.current_parameters,
                         request.simulation.hidden_errors,
                         request.target_um,
                         request.loop);
  nlohmann::json iterations = nlohmann::json::array();
  std::optional<int64_t> previous;
  for (size_t k = 0; k < result.iterations.size(); ++k) {
    const ClosedLoopIteration& it = result.iterations[k];
    nlohmann::json item = ClosedLoopIterationToJson(
        it,
        problem.parameters_key,
        problem.parameters_to_json(it.commanded_parameters),
        problem.rows,
        problem.columns);
    const bool usable = it.corrected && it.correction.IsSolutionUsable();
    std::optional<JobRecord> job;
    if (usable) job = ClosedLoopJob(request, result, k);
    if (it.corrected && k + 1 < result.iterations.size()) {
      // The correction's axis motion is the step to the next part's parameters.
      const Eigen::VectorXd delta =
          result.iterations[k + 1].commanded_parameters -
          it.commanded_parameters;
      item["correction"]["axis_motion"] =
          CorrectionAxisMotionJson(problem, delta, it.correction);
    }
    if (job && request.store) {
      job->kind = "closed_loop";
      job->created_utc = CurrentUtcIso8601();
      job->server_version = context.server_version;
      // Part k was ground with the settings job k-1 computed.
      job->settings_source_job_id = previous;
      previous = context.repository->WriteJob(*job);
      item["job_id"] = *previous;
    }
    iterations.push_back(item);
  }
  nlohmann::json answer = problem.answer_header;
  answer["completed"] = result.completed;
  answer["message"] = result.message;
  answer["hidden_errors"] =
      problem.delta_to_json(request.simulation.hidden_errors);
  answer["iterations"] = iterations;
  RespondJson(res, 200, answer);
}

}  // namespace gearloop
