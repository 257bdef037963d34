// clients/cli/report.h: a self-contained printable HTML report of one
// correction job, built from the dashboard's own report page and plotting code
// (clients/web, embedded at build time) with the job's JSON inlined: the file
// opens offline and prints as it shows.
//
//   std::string html, error;
//   if (!RenderJobReport(job, lineage, &html, &error)) { ... }
#ifndef GEARLOOP_CLIENTS_CLI_REPORT_H_
#define GEARLOOP_CLIENTS_CLI_REPORT_H_

#include <nlohmann/json.hpp>
#include <string>

namespace gearloop {

// `job` is the answer of GET /api/v1/corrections/{id}; `lineage` the "jobs"
// array of GET /api/v1/corrections/{id}/lineage (or [job]). False when the
// embedded assets are missing.
bool RenderJobReport(const nlohmann::json& job,
                     const nlohmann::json& lineage,
                     std::string* html,
                     std::string* error);

}  // namespace gearloop

#endif  // GEARLOOP_CLIENTS_CLI_REPORT_H_
