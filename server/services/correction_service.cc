#include "server/services/correction_service.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#include "engine/core/axis_motion.h"
#include "server/codec/correction_codec.h"
#include "server/codec/job_codec.h"
#include "server/codec/machine_kind.h"
#include "server/codec/measurement_codec.h"
#include "server/codec/request_keys.h"
#include "server/codec/shaving_codec.h"
#include "server/codec/tolerance_codec.h"
#include "server/codec/trace_codec.h"
#include "server/services/measurement_service.h"
#include "server/services/reach_service.h"
#include "server/services/shaving_service.h"
#include "server/services/stored_job.h"

// Last: see server/respond.h.
#include <glog/logging.h>
#include <httplib.h>

namespace gearloop {
namespace {

// A target {"shaving": ...}: fitted to the machine's gear and grid,
// validated, and either taken as resolved (target.stock_target_um of a stored
// request) or computed by the engine and written into `stored` as
// target.stock_target_um. Points the work gear does not generate (outside its
// flank, not converged) get target 0 and weight 0.
bool ResolveCorrectionShavingTarget(const CorrectionProblem& problem,
                                    CorrectionRequest* request,
                                    nlohmann::json* stored,
                                    ApiError* error) {
  if (!problem.fit_shaving_target) {
    *error = InvalidValue("target.shaving",
                          "a shaving target is the flat-wheel grinder's "
                          "(the plunge-shaving cutter's flank)");
    return false;
  }
  ShavingInput& input = *request->target_shaving;
  if (!problem.fit_shaving_target(
          request->target_shaving_grid_given, &input, error) ||
      !ValidateShavingInput(input, "target.shaving", error))
    return false;
  const int points = problem.rows * problem.columns;
  if (!request->target_shaving_resolved_um) {
    ShavingResult result;
    if (!ResolveShavingTarget(input, "target.shaving", &result, error))
      return false;
    request->target_shaving_generated = ShavingGeneratedPoints(result);
    request->target_shaving_resolved_um = result.stock_target_um;
    (*stored)["target"]["stock_target_um"] =
        GridToJson(result.stock_target_um,
                   request->target_shaving_generated,
                   problem.rows,
                   problem.columns);
  }
  const Eigen::VectorXd& resolved = *request->target_shaving_resolved_um;
  const std::vector<bool>& generated = request->target_shaving_generated;
  bool any_generated = false;
  for (int i = 0; i < points; ++i)
    any_generated = any_generated || generated[i];
  if (!any_generated) {
    *error = InvalidValue("target.stock_target_um",
                          "the stored shaving target has no point generated "
                          "by the work gear (all null)");
    return false;
  }
  Eigen::VectorXd& weights = request->options.point_weights;
  if (weights.size() == 0) weights.setOnes(points);
  request->target_um.setZero(points);
  for (int i = 0; i < points; ++i) {
    if (generated[i] && std::isfinite(resolved(i))) {
      request->target_um(i) = resolved(i);
    } else {
      weights(i) = 0.0;
    }
  }
  return true;
}

// Parses the whole request: the machine (its family decides which fields), then
// measurement, target, options and the lineage link. Target modifications are
// evaluated on the family's flank; a shaving target is resolved (and written
// into `stored`).
bool ParseCorrection(const nlohmann::json& body,
                     CorrectionProblem* problem,
                     CorrectionRequest* request,
                     nlohmann::json* stored,
                     ApiError* error) {
  if (!CorrectionProblemFor(body, problem, error) ||
      !ParseCorrectionRequest(
          body,
          problem->rows,
          problem->columns,
          /*target_modifications_allowed=*/
          static_cast<bool>(problem->evaluate_modifications),
          request,
          error)) {
    return false;
  }
  if (request->target_modifications)
    request->target_um =
        problem->evaluate_modifications(*request->target_modifications);
  if (request->target_shaving)
    return ResolveCorrectionShavingTarget(*problem, request, stored, error);
  return true;
}

// Every block named in options.max_order and options.block_scales must be
// one of the machine's parameter blocks: a 422 naming the entry as sent, and
// the nearest block name.
bool CheckBlockNames(const CorrectionProblem& problem,
                     const CorrectionOptions& options,
                     ApiError* error) {
  std::vector<std::string> names;
  for (const ParameterBlock& block : problem.model->ParameterBlocks())
    names.push_back(block.name);
  std::vector<std::pair<std::string, std::string>> used;
  for (const auto& entry : options.max_order)
    used.emplace_back("options.max_order", entry.first);
  for (const auto& entry : options.block_scales)
    used.emplace_back("options.block_scales", entry.first);
  for (const auto& [path, name] : used) {
    if (std::find(names.begin(), names.end(), name) != names.end()) continue;
    std::string list;
    for (const std::string& n : names) list += (list.empty() ? "" : ", ") + n;
    std::string message = "unknown parameter block " + JoinPath(path, name);
    const std::string nearest = NearestName(name, names);
    if (!nearest.empty()) message += "; did you mean " + nearest + "?";
    *error = InvalidValue(JoinPath(path, name),
                          message + " (the blocks are " + list + ")");
    return false;
  }
  return true;
}

// The engine call and its result as answered and stored.
bool Solve(const ServiceContext& context,
           const CorrectionProblem& problem,
           const CorrectionRequest& request,
           CorrectionRun* run,
           ApiError* error) {
  if (!CheckBlockNames(problem, request.options, error)) return false;
  const auto start = std::chrono::steady_clock::now();
  CorrectionInput input;
  input.model = problem.model.get();
  input.current_parameters = problem.current_parameters;
  input.measured_um = request.measured_um;
  input.measured_teeth_um = request.measured_teeth_um;
  input.target_um = request.target_um;
  run->result = context.compute_correction(request.options, input);
  run->solve_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
          .count();
  const CorrectionSummary& s = run->result.summary;
  if (s.status == CorrectionStatus::kInvalidInput) {
    *error = InvalidValue("measurement",
                          "the correction cannot be computed: " + s.message);
    return false;
  }
  // The answer shows the grid the solver corrected: several teeth as their
  // point-wise mean.
  const Eigen::VectorXd measured_um =
      request.measured_teeth_um.empty()
          ? request.measured_um
          : AverageTeeth(request.measured_teeth_um);
  // A shaving target shows its points not generated by the work gear as null.
  Eigen::VectorXd target_um = request.target_um;
  if (request.target_shaving) {
    for (int i = 0; i < target_um.size(); ++i) {
      if (!request.target_shaving_generated[i])
        target_um(i) = std::numeric_limits<double>::quiet_NaN();
    }
  }
  run->result_json = CorrectionResultJson(
      problem,
      s,
      problem.current_parameters,
      CorrectionStep{
          run->result.parameters, run->result.delta, run->result.linearised_at},
      run->result.predicted_residual_um,
      run->result.predicted_change_um,
      measured_um,
      target_um);
  JobRecord& job = run->job;
  job.status = CorrectionStatusName(s.status);
  problem.job_summary_columns(&job);
  job.result_json = run->result_json.dump();
  if (std::isfinite(s.residual_rms_um)) job.residual_rms_um = s.residual_rms_um;
  if (std::isfinite(s.best_reachable_rms_um))
    job.best_reachable_rms_um = s.best_reachable_rms_um;
  job.rank = s.rank;
  job.elapsed_ms = run->solve_seconds * 1e3;
  job.settings_source_job_id = request.settings_source_job_id;
  return true;
}

// Stores a solved job of `kind` for `request_json` and answers 201 with it.
void StoreAndRespond(const ServiceContext& context,
                     const char* kind,
                     std::string request_json,
                     std::optional<int64_t> parent_job_id,
                     CorrectionRun* run,
                     httplib::Response& res) {
  JobRecord& job = run->job;
  job.kind = kind;
  job.created_utc = CurrentUtcIso8601();
  job.request_json = std::move(request_json);
  job.server_version = context.server_version;
  job.parent_job_id = parent_job_id;
  job.id = context.repository->WriteJob(job);
  // The engine is silent; the server tells what the solver did (STYLE.md).
  if (context.log_solves)
    LOG(INFO) << "job " << job.id << " (" << job.kind
              << "): " << run->result.summary.BriefReport();
  res.set_header("Location", JobLocation(job.id));
  RespondJson(res, 201, CreatedJobJson(job, run->result_json));
}

// The overall ISO 1328-1 class of result.iso1328.<which> (null when none).
nlohmann::json OverallIsoClass(const nlohmann::json& result,
                               const char* which) {
  return result.value("iso1328", nlohmann::json::object())
      .value(which, nlohmann::json::object())
      .value("classes", nlohmann::json::object())
      .value("overall", nlohmann::json());
}

// result.verdict of a job with a tolerance: the measured part (against the
// target) and the predicted next part. A solve that converged but whose
// predicted part misses the tolerance is "target_partly_reachable", never
// "converged": the machine configuration cannot make the rest of the target
// (best_reachable_rms_um says how much of it stays).
void ApplyTolerance(const Tolerance& tolerance, CorrectionRun* run) {
  const CorrectionSummary& s = run->result.summary;
  nlohmann::json& result = run->result_json;
  const nlohmann::json measured =
      PartVerdictJson(tolerance,
                      {s.initial_rms_um,
                       s.initial_max_um,
                       OverallIsoClass(result, "target_relative")});
  const nlohmann::json predicted =
      PartVerdictJson(tolerance,
                      {s.residual_rms_um,
                       s.residual_max_um,
                       OverallIsoClass(result, "predicted")});
  result["verdict"] = {{"tolerance", ToleranceToJson(tolerance)},
                       {"measured", measured},
                       {"predicted", predicted}};
  if (predicted["verdict"] == "PASS" ||
      s.status != CorrectionStatus::kConverged)
    return;
  char best[64];
  std::snprintf(best, sizeof(best), "%.2f", s.best_reachable_rms_um);
  result["status"] = "target_partly_reachable";
  result["message"] =
      "the predicted part misses the tolerance (" +
      MissedLimitsText(tolerance, predicted) +
      "): the solve converged, but this machine configuration reaches at "
      "best " +
      best +
      (s.axis_orders_held_below_highest
           ? " um rms of the target at the allowed orders; allow higher "
             "orders, more axes or the wheel's profile"
           : " um rms of the target with every axis order 0-6 open; free more "
             "axes or the wheel's profile") +
      " (options.max_order: for target modifications result.reach computes "
      "which makes the rest), or relax the tolerance";
  run->job.status = "target_partly_reachable";
}

}  // namespace

std::string SubmitterOf(const ServiceContext& context,
                        const httplib::Request& req) {
  return context.token_name
             ? context.token_name(req.get_header_value("Authorization"))
             : std::string();
}

nlohmann::json CorrectionAxisMotionJson(const CorrectionProblem& problem,
                                        const Eigen::VectorXd& delta,
                                        const CorrectionSummary& summary) {
  return AxisMotionToJson(ComputeAxisMotion(problem.model->ParameterBlocks(),
                                            delta,
                                            summary.roll_min_rad,
                                            summary.roll_max_rad));
}

nlohmann::json CorrectionIso1328Json(
    const CorrectionProblem& problem,
    const Eigen::VectorXd& measured_um,
    const Eigen::VectorXd& target_um,
    const Eigen::VectorXd& predicted_residual_um,
    double profile_evaluation_length_mm) {
  // ISO 1328-1 (METROLOGY.md §4): the measured flank against the design
  // flank, against the target, and the predicted next part against the target
  // (the predicted residual is already relative to it).
  const double l = profile_evaluation_length_mm;
  return {
      {"measured", problem.flank_quality_json(measured_um, {}, l)},
      {"target_relative",
       problem.flank_quality_json(measured_um, target_um, l)},
      {"predicted", problem.flank_quality_json(predicted_residual_um, {}, l)}};
}

nlohmann::json CorrectionResultJson(
    const CorrectionProblem& problem,
    const CorrectionSummary& summary,
    const Eigen::VectorXd& commanded,
    const std::optional<CorrectionStep>& step,
    const Eigen::VectorXd& predicted_residual_um,
    const Eigen::VectorXd& predicted_change_um,
    const Eigen::VectorXd& measured_um,
    const Eigen::VectorXd& target_um) {
  const int rows = problem.rows;
  const int columns = problem.columns;
  nlohmann::json result = CorrectionSummaryToJson(summary, columns);
  const nlohmann::json header = problem.result_header(commanded);
  for (const auto& item : header.items()) result[item.key()] = item.value();
  if (step) {
    result[problem.parameters_key] =
        problem.parameters_to_json(step->parameters);
    result["delta"] = problem.delta_to_json(step->delta);
    result["axis_motion"] =
        CorrectionAxisMotionJson(problem, step->delta, summary);
    // What the measurement says the machine runs besides its commanded
    // settings (the errors the correction compensates), where it was used.
    if (summary.machine_state_estimated &&
        step->linearised_at.size() == commanded.size()) {
      result["machine_state"]["estimated_errors"] =
          problem.delta_to_json(step->linearised_at - commanded);
    }
  }
  result["predicted_residual_um"] =
      GridToJson(predicted_residual_um, {}, rows, columns);
  result["predicted_change_um"] =
      GridToJson(predicted_change_um, {}, rows, columns);
  result["measured_um"] = GridToJson(measured_um, {}, rows, columns);
  result["target_um"] = GridToJson(target_um, {}, rows, columns);
  if (problem.flank_quality_json) {
    result["iso1328"] = CorrectionIso1328Json(
        problem, measured_um, target_um, predicted_residual_um, 0.0);
  }
  return result;
}

bool RunCorrection(const ServiceContext& context,
                   const nlohmann::json& body,
                   CorrectionRun* run,
                   ApiError* error) {
  // A measuring-machine file is read onto the request's grid first; the stored
  // request keeps the file, so that a replay reads it again.
  nlohmann::json resolved;
  nlohmann::json file_report;
  if (HasMeasurementFile(body) &&
      !ResolveMeasurementFile(body, &resolved, &file_report, error))
    return false;
  const nlohmann::json& parsed = file_report.is_null() ? body : resolved;
  std::optional<Tolerance> tolerance;
  if (!ParseJobTrace(body, &run->job, error) ||
      !ParseTolerance(body, &tolerance, error))
    return false;
  CorrectionProblem problem;
  CorrectionRequest request;
  // The stored request is the body as sent (a file stays a file); a shaving
  // target's resolved grid is written into it (ParseCorrection).
  run->request = body;
  if (!ParseCorrection(parsed, &problem, &request, &run->request, error))
    return false;
  if (tolerance && tolerance->iso_class && !problem.flank_quality_json) {
    *error = InvalidValue("tolerance.iso_class",
                          "ISO 1328-1 classes are computed for an involute "
                          "gear's flank (flat-wheel grinder) only; give "
                          "rms_um or max_um");
    return false;
  }
  if (request.settings_source_job_id &&
      !context.repository->JobExists(*request.settings_source_job_id)) {
    *error = InvalidValue(
        "settings_source_job_id",
        "no stored job " + std::to_string(*request.settings_source_job_id));
    return false;
  }
  if (!Solve(context, problem, request, run, error)) return false;
  if (!file_report.is_null()) {
    run->result_json["measurement_file"] = file_report;
    // The figures with the file's own L_alpha, as its import gives them.
    const nlohmann::json& length = file_report["profile_evaluation_length_mm"];
    if (length.is_number() && problem.flank_quality_json) {
      run->result_json["iso1328"] =
          CorrectionIso1328Json(problem,
                                request.measured_um,
                                request.target_um,
                                run->result.predicted_residual_um,
                                length.get<double>());
    }
    run->job.result_json = run->result_json.dump();
  }
  if (tolerance) {
    ApplyTolerance(*tolerance, run);
    // What the machine can make of the target, and what would make the rest:
    // only for a job that misses its tolerance (a reach solves again per
    // modification and remedy).
    if (run->job.status == "target_partly_reachable") {
      const nlohmann::json reach = CorrectionReachJson(context, body);
      if (!reach.is_null()) run->result_json["reach"] = reach;
    }
    run->job.result_json = run->result_json.dump();
  }
  if (context.record_solve_seconds)
    context.record_solve_seconds(run->solve_seconds);
  return true;
}

void CreateCorrection(const ServiceContext& context,
                      const httplib::Request& req,
                      httplib::Response& res) {
  nlohmann::json body;
  ApiError error;
  CorrectionRun run;
  // Strict input where the client's body enters; a replay re-runs a stored
  // request as it was stored (request_keys.h).
  if (!ParseJsonBody(req.body, &body, &error) ||
      !CheckRequestKeys(RequestSchema::kCorrection, body, "", &error) ||
      !RunCorrection(context, body, &run, &error)) {
    return RespondError(res, error);
  }
  run.job.submitted_by = SubmitterOf(context, req);
  StoreAndRespond(
      context, "correction", Dump(run.request), std::nullopt, &run, res);
}

void ReplayCorrection(const ServiceContext& context,
                      const httplib::Request& req,
                      httplib::Response& res) {
  const std::optional<JobRecord> parent = ReadPathJob(context, req);
  if (!parent) return RespondError(res, NoStoredJob(req.matches[1].str()));
  const int64_t id = parent->id;
  if (parent->machine_kind == kHeadHead5AxisMillKind) {
    // A trajectory, not a correction: nothing was measured to solve again.
    return RespondError(
        res,
        InvalidValue("",
                     "job " + std::to_string(id) +
                         " is a split-bevel trajectory, not a correction; post "
                         "its request (GET /api/v1/corrections/" +
                         std::to_string(id) +
                         ") to /api/v1/bevel/split-trajectory again"));
  }
  nlohmann::json changes = nlohmann::json::object();
  ApiError error;
  // The changes are the client's body: strict. The stored request they
  // change is not checked again (request_keys.h).
  if (!req.body.empty() &&
      (!ParseJsonBody(req.body, &changes, &error) ||
       !CheckRequestKeys(RequestSchema::kReplay, changes, "", &error)))
    return RespondError(res, error);
  nlohmann::json request =
      nlohmann::json::parse(parent->request_json, nullptr, false);
  if (!request.is_object())
    throw std::runtime_error("stored request of job " + std::to_string(id) +
                             " is not JSON");
  if (changes.contains("options")) {
    if (!changes["options"].is_object())
      return RespondError(
          res, InvalidRequest("options", "options must be an object"));
    // Changed options are merged into the stored ones (RFC 7396: null removes a
    // field).
    if (!request.contains("options") || !request["options"].is_object())
      request["options"] = nlohmann::json::object();
    request["options"].merge_patch(changes["options"]);
  }
  if (changes.contains("target")) request["target"] = changes["target"];
  // A new tolerance replaces the stored one; null removes it.
  if (changes.contains("tolerance")) {
    if (changes["tolerance"].is_null()) {
      request.erase("tolerance");
    } else {
      request["tolerance"] = changes["tolerance"];
    }
  }
  CorrectionRun run;
  if (!RunCorrection(context, request, &run, &error))
    return RespondError(res, error);
  run.job.submitted_by = SubmitterOf(context, req);
  StoreAndRespond(context, "replay", Dump(run.request), id, &run, res);
}

void RunBatchItem(const ServiceContext& context, const PendingBatchItem& item) {
  ApiError error;
  try {
    nlohmann::json body;
    CorrectionRun run;
    if (ParseJsonBody(item.request_json, &body, &error) &&
        RunCorrection(context, body, &run, &error)) {
      JobRecord& job = run.job;
      job.kind = "batch_item";
      job.created_utc = CurrentUtcIso8601();
      job.request_json = Dump(run.request);
      job.server_version = context.server_version;
      job.batch_id = item.batch_id;
      job.submitted_by = item.submitted_by;
      context.repository->CompleteBatchItem(item.batch_id, item.index, job);
      return;
    }
  } catch (const std::exception& e) {
    LOG(ERROR) << "batch " << item.batch_id << " item " << item.index
               << " failed: " << e.what();
    error = ApiError{
        500, "internal_error", "internal error while running this item", ""};
  }
  BatchItemRecord failure;
  failure.error_status = error.status;
  failure.error_code = error.code;
  failure.error_message = error.message;
  failure.error_field = error.field;
  try {
    context.repository->FailBatchItem(item.batch_id, item.index, failure);
  } catch (const std::exception& e) {
    LOG(ERROR) << "cannot record failure of batch " << item.batch_id << " item "
               << item.index << ": " << e.what();
  }
}

}  // namespace gearloop
