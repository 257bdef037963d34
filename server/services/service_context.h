// server/services/service_context.h: what the services need of the server
// around them: the job history, the batch queue, the solver metrics and the
// version stamped on every job. Filled once by server/http/gearloop_server.cc;
// a test fills it with a ":memory:" repository and no queue.
//
//   ServiceContext context;
//   context.repository = repository.get();
//   CreateCorrection(context, req, res);
#ifndef GEARLOOP_SERVER_SERVICES_SERVICE_CONTEXT_H_
#define GEARLOOP_SERVER_SERVICES_SERVICE_CONTEXT_H_

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "engine/correction/correction.h"
#include "storage/job_repository.h"

namespace gearloop {

struct ServiceContext {
  // The job history; not owned, must outlive the services' calls.
  JobRepository* repository = nullptr;
  // Stamped on every stored job.
  std::string server_version;
  // Called with the duration of every correction solve [s] (the solver
  // histogram); may be empty.
  std::function<void(double seconds)> record_solve_seconds;
  // The correction solver: the engine's ComputeCorrection. A test may put a
  // stub here to check a service's mapping of every outcome (statuses,
  // refusals, what is stored) without the engine's numerics (as OSRM's
  // request_handler test stubs its services).
  std::function<CorrectionResult(const CorrectionOptions&,
                                 const CorrectionInput&)>
      compute_correction = ComputeCorrection;
  // One log line per solve (the engine is silent; STYLE.md).
  bool log_solves = true;
  // The batch queue: items waiting for a worker, and how to hand new ones over;
  // may be empty (then no batch is accepted beyond max_queued_batch_items, and
  // accepted ones only wait).
  std::function<size_t()> queued_batch_items;
  std::function<void(std::vector<PendingBatchItem> items)> enqueue_batch_items;
  // The name of the token in a request's Authorization header ("" for none),
  // stored as the submitter of its jobs and batches; may be empty.
  std::function<std::string(const std::string& authorization_header)>
      token_name;
  // Most items in one batch, and most batch items waiting at once (503 beyond).
  int max_batch_items = 1000;
  int max_queued_batch_items = 20000;
};

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_SERVICES_SERVICE_CONTEXT_H_
