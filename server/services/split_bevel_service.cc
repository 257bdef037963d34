#include "server/services/split_bevel_service.h"

#include <chrono>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

#include "engine/core/units.h"
#include "engine/split_bevel/trajectory.h"
#include "server/codec/job_codec.h"
#include "server/codec/request_keys.h"
#include "server/codec/split_bevel_codec.h"
#include "server/services/stored_job.h"

// Last: see server/respond.h.
#include <glog/logging.h>
#include <httplib.h>

namespace gearloop {
namespace {

// The history columns of a computed trajectory: the gear (its normal module
// and mean spiral angle stand for the module and helix angle of a cylindrical
// gear), the flank or "both".
JobRecord SplitTrajectoryJob(const ServiceContext& context,
                             const SplitBevelRequest& request,
                             const SplitBevelResult& result,
                             double elapsed_ms) {
  JobRecord job;
  job.kind = kSplitTrajectoryJobKind;
  job.status = "computed";
  job.machine_kind = kHeadHead5AxisMillKind;
  job.created_utc = CurrentUtcIso8601();
  job.gear_teeth = result.derived.teeth;
  job.gear_normal_module_mm = result.derived.normal_module_mm;
  job.gear_helix_angle_deg = RadToDeg(result.derived.mean_spiral_angle_rad);
  job.gear_hand = SplitBevelHandName(result.derived.hand);
  job.flank = SplitBevelJobFlank(request);
  job.elapsed_ms = elapsed_ms;
  job.server_version = context.server_version;
  return job;
}

// The answer of the stored `job` again: its request through the engine (which
// is deterministic), the points written as the POST answered them and the
// stored listing appended. An empty string, or why the points are not this
// job's: the request does not compute any more, or the listing computed now
// differs from the stored one (another engine).
std::string RecomputeSplitTrajectory(const JobRecord& job,
                                     const std::string& nc_program,
                                     std::string* text) {
  const nlohmann::json body =
      nlohmann::json::parse(job.request_json, nullptr, false);
  SplitBevelRequest request;
  ApiError error;
  if (!ParseSplitBevelRequest(body, &request, &error) ||
      !CheckSplitBevelRequest(request, &error))
    return "the stored request is refused now: " + error.message;
  request.nc_program = true;
  const SplitBevelResult result = ComputeSplitTrajectory(request);
  if (!result.ok) return "the stored request is refused now: " + result.message;
  if (result.nc_program != nc_program)
    return "the NC program computed now differs from the stored one";
  SplitBevelTextOptions options;
  options.nc_program = &nc_program;
  *text = SplitBevelResultJsonText(result, options);
  return "";
}

}  // namespace

std::string SplitTrajectoryNcLocation(int64_t job_id) {
  return "/api/v1/bevel/split-trajectory/" + std::to_string(job_id) + "/nc";
}

void CreateSplitTrajectory(const ServiceContext& context,
                           const httplib::Request& req,
                           httplib::Response& res) {
  nlohmann::json body;
  ApiError error;
  SplitBevelRequest request;
  if (!ParseJsonBody(req.body, &body, &error) ||
      !CheckRequestKeys(RequestSchema::kSplitTrajectory, body, "", &error) ||
      !ParseSplitBevelRequest(body, &request, &error) ||
      !CheckSplitBevelRequest(request, &error))
    return RespondError(res, error);
  const bool answer_nc = request.nc_program;
  // The job keeps the NC program whether or not the answer carries it.
  request.nc_program = true;
  const auto start = std::chrono::steady_clock::now();
  const SplitBevelResult result = ComputeSplitTrajectory(request);
  const double elapsed_ms = std::chrono::duration<double, std::milli>(
                                std::chrono::steady_clock::now() - start)
                                .count();
  if (!result.ok) return RespondError(res, SplitBevelResultError(result));
  // The points make the answer large (40 000 points are ~25 MB): the job keeps
  // the request, the per-pass summaries and the listing, and GET
  // /api/v1/corrections/{id} computes the points again.
  JobRecord job = SplitTrajectoryJob(context, request, result, elapsed_ms);
  job.request_json = Dump(body);
  SplitBevelTextOptions stored;
  stored.points = false;
  stored.members = {{"points_stored", false}};
  stored.nc_program = &result.nc_program;
  job.result_json = SplitBevelResultJsonText(result, stored);
  job.id = context.repository->WriteJob(job);
  if (context.log_solves)
    LOG(INFO) << "job " << job.id << " (" << job.kind
              << "): " << result.passes.size() << " passes in " << elapsed_ms
              << " ms";
  SplitBevelTextOptions answer;
  answer.members = {{"job_id", job.id},
                    {"location", JobLocation(job.id)},
                    {"nc_location", SplitTrajectoryNcLocation(job.id)}};
  if (answer_nc) answer.nc_program = &result.nc_program;
  res.status = 200;
  res.set_header("Location", JobLocation(job.id));
  // Moved, not copied as set_content would.
  res.body = SplitBevelResultJsonText(result, answer);
  res.set_header("Content-Type", "application/json");
}

bool RespondStoredSplitTrajectory(const ServiceContext& context,
                                  const JobRecord& job,
                                  httplib::Response& res) {
  const nlohmann::json stored =
      nlohmann::json::parse(job.result_json, nullptr, false);
  if (!stored.is_object() || stored.value("points_stored", true) ||
      !stored.contains("nc_program") || !stored["nc_program"].is_string())
    return false;
  const std::string& nc_program =
      stored["nc_program"].get_ref<const std::string&>();
  nlohmann::json summary = JobSummaryJson(job);
  std::string result_text;
  const std::string problem =
      RecomputeSplitTrajectory(job, nc_program, &result_text);
  nlohmann::json& note = summary["points_recomputed"];
  note["server_version"] = context.server_version;
  if (problem.empty()) {
    note["nc_program_matches"] = true;
  } else {
    // Not the points of this job: its stored summaries and listing only.
    note["error"] = problem;
    result_text = job.result_json;
  }
  std::string text = Dump(summary);
  text.pop_back();
  text += ",\"request\":";
  // As the generic show: a stored request that is not JSON shows as null.
  const bool request_is_json =
      !nlohmann::json::parse(job.request_json, nullptr, false).is_discarded();
  text += request_is_json ? job.request_json : "null";
  text += ",\"result\":";
  text += result_text;
  text += '}';
  res.status = 200;
  res.body = std::move(text);
  res.set_header("Content-Type", "application/json");
  return true;
}

void GetSplitTrajectoryNc(const ServiceContext& context,
                          const httplib::Request& req,
                          httplib::Response& res) {
  const std::optional<JobRecord> job = ReadPathJob(context, req);
  if (!job || job->kind != kSplitTrajectoryJobKind) {
    return RespondError(
        res,
        ApiError{404,
                 "not_found",
                 "no stored split-trajectory job " + req.matches[1].str(),
                 ""});
  }
  const nlohmann::json result =
      nlohmann::json::parse(job->result_json, nullptr, false);
  if (!result.is_object() || !result.contains("nc_program") ||
      !result["nc_program"].is_string())
    throw std::runtime_error("stored result of job " + std::to_string(job->id) +
                             " has no nc_program");
  res.status = 200;
  res.set_content(result["nc_program"].get<std::string>(),
                  "text/plain; charset=utf-8");
}

}  // namespace gearloop
