#include "server/codec/job_codec.h"

#include <string>

#include "server/codec/bevel_codec.h"
#include "server/codec/trace_codec.h"

namespace gearloop {

nlohmann::json OptionalToJson(const std::optional<double>& value) {
  return value ? nlohmann::json(*value) : nlohmann::json(nullptr);
}
nlohmann::json OptionalToJson(const std::optional<int64_t>& value) {
  return value ? nlohmann::json(*value) : nlohmann::json(nullptr);
}

std::string JobLocation(int64_t job_id) {
  return "/api/v1/corrections/" + std::to_string(job_id);
}
std::string BatchLocation(int64_t batch_id) {
  return "/api/v1/batches/" + std::to_string(batch_id);
}

nlohmann::json JobSummaryJson(const JobRecord& job) {
  nlohmann::json gear = {{"teeth", job.gear_teeth},
                         {"normal_module_mm", job.gear_normal_module_mm},
                         {"helix_angle_deg", job.gear_helix_angle_deg}};
  if (!job.gear_hand.empty()) gear["hand"] = job.gear_hand;
  return {
      {"id", job.id},
      {"created_utc", job.created_utc},
      {"kind", job.kind},
      {"status", job.status},
      {"gear", gear},
      {"flank", job.flank},
      {"machine_kind", job.machine_kind},
      {"residual_rms_um", OptionalToJson(job.residual_rms_um)},
      {"best_reachable_rms_um", OptionalToJson(job.best_reachable_rms_um)},
      {"rank", job.rank ? nlohmann::json(*job.rank) : nlohmann::json(nullptr)},
      {"elapsed_ms", job.elapsed_ms},
      {"server_version", job.server_version},
      {"parent_job_id", OptionalToJson(job.parent_job_id)},
      {"settings_source_job_id", OptionalToJson(job.settings_source_job_id)},
      {"trace", JobTraceJson(job)},
      {"location", JobLocation(job.id)}};
}

nlohmann::json CreatedJobJson(const JobRecord& job,
                              const nlohmann::json& result) {
  return {
      {"id", job.id},
      {"created_utc", job.created_utc},
      {"kind", job.kind},
      {"status", job.status},
      {"parent_job_id", OptionalToJson(job.parent_job_id)},
      {"settings_source_job_id", OptionalToJson(job.settings_source_job_id)},
      {"trace", JobTraceJson(job)},
      {"result", result}};
}

nlohmann::json BatchAcceptedJson(int64_t batch_id, size_t total) {
  return {{"id", batch_id},
          {"status", "running"},
          {"total", total},
          {"done", 0},
          {"failed", 0},
          {"location", BatchLocation(batch_id)}};
}

nlohmann::json BatchToJson(const BatchRecord& batch) {
  nlohmann::json items = nlohmann::json::array();
  for (const BatchItemRecord& item : batch.items) {
    nlohmann::json j = {{"index", item.index},
                        {"state", BatchItemStateName(item.state)}};
    if (item.job_id) {
      j["job_id"] = *item.job_id;
      j["location"] = JobLocation(*item.job_id);
    }
    if (item.state == BatchItemState::kFailed) {
      j["error_status"] = item.error_status;
      j["error"] = {{"code", item.error_code},
                    {"message", item.error_message},
                    {"field", item.error_field}};
    }
    items.push_back(j);
  }
  nlohmann::json answer = {
      {"id", batch.id},
      {"status", batch.status},
      {"created_utc", batch.created_utc},
      {"finished_utc",
       batch.finished_utc.empty() ? nlohmann::json(nullptr)
                                  : nlohmann::json(batch.finished_utc)},
      {"total", batch.total},
      {"done", batch.done},
      {"failed", batch.failed},
      {"pending", batch.total - batch.done - batch.failed},
      {"items", items}};
  if (!batch.submitted_by.empty()) answer["submitted_by"] = batch.submitted_by;
  return answer;
}

}  // namespace gearloop
