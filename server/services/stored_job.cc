#include "server/services/stored_job.h"

#include <cstdint>
#include <stdexcept>

// Last: <httplib.h> pulls in <resolv.h>, whose `_res` breaks Eigen after it.
#include <httplib.h>

namespace gearloop {

std::optional<JobRecord> ReadPathJob(const ServiceContext& context,
                                     const httplib::Request& req) {
  int64_t id = 0;
  if (!ParseId(req.matches[1], &id)) return std::nullopt;
  return context.repository->ReadJob(id);
}

ApiError NoStoredJob(const std::string& id_text) {
  return ApiError{404, "not_found", "no stored correction job " + id_text, ""};
}

void ParseStoredJob(const JobRecord& job,
                    nlohmann::json* request,
                    nlohmann::json* result) {
  *request = nlohmann::json::parse(job.request_json, nullptr, false);
  *result = nlohmann::json::parse(job.result_json, nullptr, false);
  if (!request->is_object() || !result->is_object())
    throw std::runtime_error("stored job " + std::to_string(job.id) +
                             " is not JSON");
}

}  // namespace gearloop
