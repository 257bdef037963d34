// server/services/stored_job.h: the stored job a path names, for the services
// that read one back (GET, replay, export, settings listing, NC program).
//
//   std::optional<JobRecord> job = ReadPathJob(context, req);
//   if (!job) return RespondError(res, NoStoredJob(req.matches[1].str()));
//   nlohmann::json request, result;
//   ParseStoredJob(*job, &request, &result);
#ifndef GEARLOOP_SERVER_SERVICES_STORED_JOB_H_
#define GEARLOOP_SERVER_SERVICES_STORED_JOB_H_

#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "server/respond.h"
#include "server/services/service_context.h"
#include "storage/job_repository.h"

namespace gearloop {

// The job whose id is the route's first capture (req.matches[1]); nullopt when
// the id is malformed or no job has it.
std::optional<JobRecord> ReadPathJob(const ServiceContext& context,
                                     const httplib::Request& req);

// 404 not_found "no stored correction job <id>".
ApiError NoStoredJob(const std::string& id_text);

// The stored request and result of `job` as JSON objects. A stored job that
// is not JSON is a corrupted history: std::runtime_error (answered 500).
void ParseStoredJob(const JobRecord& job,
                    nlohmann::json* request,
                    nlohmann::json* result);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_SERVICES_STORED_JOB_H_
