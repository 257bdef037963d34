// server/services/history_service.h: the job history and the batches: GET
// /api/v1/corrections (filtered, paged), /corrections/{id},
// /corrections/{id}/lineage, POST /api/v1/batches and GET /batches/{id}. Reads
// the store (storage/job_repository.h) and renders (codec/job_codec.h); a new
// batch is stored as pending and handed to the context's queue.
//
//   ListCorrections(context, req, res);   // 200 {jobs, total, limit, offset}
#ifndef GEARLOOP_SERVER_SERVICES_HISTORY_SERVICE_H_
#define GEARLOOP_SERVER_SERVICES_HISTORY_SERVICE_H_

#include "server/respond.h"
#include "server/services/service_context.h"
#include "storage/job_repository.h"

namespace gearloop {

// The query of the history listing: limit, offset, teeth, module_mm, flank,
// kind, status, created_from, created_to, and the trace: part_number, serial,
// tooth, machine_id, batch_id, submitted_by, file_name.
bool ParseJobFilter(const httplib::Request& req,
                    JobFilter* filter,
                    ApiError* error);

void ListCorrections(const ServiceContext& context,
                     const httplib::Request& req,
                     httplib::Response& res);
void GetCorrection(const ServiceContext& context,
                   const httplib::Request& req,
                   httplib::Response& res);
void GetLineage(const ServiceContext& context,
                const httplib::Request& req,
                httplib::Response& res);
// 202 once every item is stored as pending; 503 (Retry-After) when the queue is
// full.
void CreateBatch(const ServiceContext& context,
                 const httplib::Request& req,
                 httplib::Response& res);
void GetBatch(const ServiceContext& context,
              const httplib::Request& req,
              httplib::Response& res);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_SERVICES_HISTORY_SERVICE_H_
