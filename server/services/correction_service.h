// server/services/correction_service.h: POST /api/v1/corrections, POST
// /corrections/{id}/replay and the items of a batch, all through ONE
// RunCorrection for every machine family: parse (family via machine_family.h,
// the rest via codec/correction_codec.h) -> lineage check -> ComputeCorrection
// -> result and job record. The handlers persist and respond (OSRM
// route_service.cpp).
//
//   CorrectionRun run;
//   ApiError error;
//   if (!RunCorrection(context, body, &run, &error)) return RespondError(res,
//   error);
//   // run.result_json, run.job (kind, time, request and links still to set)
#ifndef GEARLOOP_SERVER_SERVICES_CORRECTION_SERVICE_H_
#define GEARLOOP_SERVER_SERVICES_CORRECTION_SERVICE_H_

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <optional>

#include "engine/correction/correction.h"
#include "server/respond.h"
#include "server/services/machine_family.h"
#include "server/services/service_context.h"
#include "storage/job_repository.h"

namespace gearloop {

struct CorrectionRun {
  // The request as it is stored: the body with a shaving target resolved
  // (target.stock_target_um written in), so that a replay recomputes nothing.
  nlohmann::json request;
  CorrectionResult result;
  nlohmann::json result_json;
  // Filled except id, created_utc, kind, request_json, server_version and
  // parent_job_id.
  JobRecord job;
  double solve_seconds = 0.0;
};

// Parses `body`, checks that its settings_source_job_id names a stored job,
// solves and renders. A request the engine refuses as invalid input is a 422
// (false); a valid solve that does not converge is a normal run with its
// status.
bool RunCorrection(const ServiceContext& context,
                   const nlohmann::json& body,
                   CorrectionRun* run,
                   ApiError* error);

// The corrected parameters of a part and the change that leads to them, and
// the parameters the correction was linearised at (the estimated machine
// state, or the commanded settings; empty when not told).
struct CorrectionStep {
  Eigen::VectorXd parameters;
  Eigen::VectorXd delta;
  Eigen::VectorXd linearised_at;
};

// A correction's result as the API answers and the history stores it: the
// summary, the family's header, with a step the corrected parameters (under
// problem.parameters_key), "delta" and "axis_motion" (and, where the machine
// state was used, machine_state.estimated_errors: linearised_at - commanded
// in the form of "delta"), and the grids
// predicted_residual_um, predicted_change_um, measured_um, target_um.
nlohmann::json CorrectionResultJson(
    const CorrectionProblem& problem,
    const CorrectionSummary& summary,
    const Eigen::VectorXd& commanded,
    const std::optional<CorrectionStep>& step,
    const Eigen::VectorXd& predicted_residual_um,
    const Eigen::VectorXd& predicted_change_um,
    const Eigen::VectorXd& measured_um,
    const Eigen::VectorXd& target_um);

// "iso1328" of a result: the ISO 1328-1 figures and classes of the measured
// flank, of measured - target and of the predicted residual, with a measuring
// file's profile evaluation length (0 = the default). Needs
// problem.flank_quality_json.
nlohmann::json CorrectionIso1328Json(
    const CorrectionProblem& problem,
    const Eigen::VectorXd& measured_um,
    const Eigen::VectorXd& target_um,
    const Eigen::VectorXd& predicted_residual_um,
    double profile_evaluation_length_mm);

// The axis motion of a correction `delta` over the roll range of `summary`
// (AxisMotionToJson).
nlohmann::json CorrectionAxisMotionJson(const CorrectionProblem& problem,
                                        const Eigen::VectorXd& delta,
                                        const CorrectionSummary& summary);

// The name of the token that sent `req` ("" for none): the submitter stored
// with its jobs.
std::string SubmitterOf(const ServiceContext& context,
                        const httplib::Request& req);

// POST /api/v1/corrections: 201 with the stored job and its result.
void CreateCorrection(const ServiceContext& context,
                      const httplib::Request& req,
                      httplib::Response& res);
// POST /api/v1/corrections/{id}/replay: the stored request with "options"
// merged (RFC 7396), "target" replaced and "tolerance" replaced (null removes
// it), solved again and stored as a child of job {id}.
void ReplayCorrection(const ServiceContext& context,
                      const httplib::Request& req,
                      httplib::Response& res);
// One batch item: stored as done (with its job) or failed (with the error it
// would have answered).
void RunBatchItem(const ServiceContext& context, const PendingBatchItem& item);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_SERVICES_CORRECTION_SERVICE_H_
