#include "server/http/batch_runner.h"

#include <algorithm>
#include <utility>

namespace gearloop {

BatchRunner::BatchRunner(int workers, Work work) : work_(std::move(work)) {
  for (int i = 0; i < std::max(1, workers); ++i)
    threads_.emplace_back([this] { Loop(); });
}

BatchRunner::~BatchRunner() { Stop(); }

void BatchRunner::Enqueue(std::vector<PendingBatchItem> items) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (PendingBatchItem& item : items) queue_.push_back(std::move(item));
  }
  wake_.notify_all();
}

size_t BatchRunner::Queued() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return queue_.size();
}

void BatchRunner::Stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_ && threads_.empty()) return;
    stopping_ = true;
  }
  wake_.notify_all();
  for (std::thread& thread : threads_) {
    if (thread.joinable()) thread.join();
  }
  threads_.clear();
}

void BatchRunner::Loop() {
  while (true) {
    PendingBatchItem item;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
      if (stopping_) return;
      item = std::move(queue_.front());
      queue_.pop_front();
    }
    work_(item);
  }
}

}  // namespace gearloop
