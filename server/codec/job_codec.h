// server/codec/job_codec.h: the stored jobs and batches of the history (GET
// /api/v1/corrections, /corrections/{id}, /lineage, /batches/{id}) and the
// answers that acknowledge new ones, written as JSON. Pure mapping of storage
// records; nothing here reads or writes the store.
//
//   nlohmann::json jobs = nlohmann::json::array();
//   for (const JobRecord& job : page.jobs) jobs.push_back(JobSummaryJson(job));
#ifndef GEARLOOP_SERVER_CODEC_JOB_CODEC_H_
#define GEARLOOP_SERVER_CODEC_JOB_CODEC_H_

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>

#include "storage/job_repository.h"

namespace gearloop {

// The value, or null.
nlohmann::json OptionalToJson(const std::optional<double>& value);
nlohmann::json OptionalToJson(const std::optional<int64_t>& value);

// A job as the history lists it: id, created_utc, kind, status, gear {teeth,
// normal_module_mm, helix_angle_deg, hand}, flank, machine_kind, the solver
// figures, the links, the trace (trace_codec.h) and its location.
nlohmann::json JobSummaryJson(const JobRecord& job);

// The 201 answer to a new correction job: id, created_utc, kind, status, the
// links, the trace and `result`.
nlohmann::json CreatedJobJson(const JobRecord& job,
                              const nlohmann::json& result);

// The 202 answer to a new batch of `total` items.
nlohmann::json BatchAcceptedJson(int64_t batch_id, size_t total);

// A batch with its items (state, job location or error).
nlohmann::json BatchToJson(const BatchRecord& batch);

// "/api/v1/corrections/<id>" and "/api/v1/batches/<id>".
std::string JobLocation(int64_t job_id);
std::string BatchLocation(int64_t batch_id);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_CODEC_JOB_CODEC_H_
