// server/http/batch_runner.h: a bounded pool of background workers for batch
// items. Items wait in memory; they are also pending rows in the database, so a
// stop loses nothing: the next start enqueues them again.
//
//   BatchRunner batches(/*workers=*/2, [&](const PendingBatchItem& item) {
//   RunBatchItem(context, item); });
//   batches.Enqueue(repository->ReadPendingBatchItems());
//   ...
//   batches.Stop();   // the items in hand are finished, waiting ones stay
//   pending
#ifndef GEARLOOP_SERVER_HTTP_BATCH_RUNNER_H_
#define GEARLOOP_SERVER_HTTP_BATCH_RUNNER_H_

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

#include "storage/job_repository.h"

namespace gearloop {

class BatchRunner {
 public:
  using Work = std::function<void(const PendingBatchItem&)>;

  // Starts max(1, workers) threads, each running `work` on one item at a time.
  BatchRunner(int workers, Work work);
  ~BatchRunner();
  BatchRunner(const BatchRunner&) = delete;
  BatchRunner& operator=(const BatchRunner&) = delete;

  void Enqueue(std::vector<PendingBatchItem> items);
  // Items waiting for a worker.
  size_t Queued() const;
  // Workers finish the item in hand and leave; waiting items are dropped (they
  // stay pending in the database). Idempotent.
  void Stop();

 private:
  void Loop();

  Work work_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<PendingBatchItem> queue_;
  bool stopping_ = false;
  std::vector<std::thread> threads_;
};

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_HTTP_BATCH_RUNNER_H_
