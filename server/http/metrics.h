// server/http/metrics.h: the server's Prometheus metrics (text exposition
// format 0.0.4).
//
//   Metrics metrics;
//   metrics.RecordRequest("POST /api/v1/corrections", 201, /*seconds=*/0.004);
//   metrics.RecordSolve(0.003);
//   std::string text = metrics.Render(/*jobs_stored=*/12,
//   /*batch_items_queued=*/0);
//
// Exposed series:
//   gearloop_http_requests_total{route, status}        counter
//   gearloop_http_request_duration_seconds{le}         histogram over all
//   requests gearloop_solver_duration_seconds{le}               histogram of
//   correction solves gearloop_jobs_stored                               gauge
//   (rows in the job history) gearloop_batch_items_queued gauge (batch items
//   waiting for a worker)
// `route` is the route's pattern ("GET /api/v1/corrections/{id}"), never the
// raw path, so the number of series stays bounded whatever clients send;
// unmatched requests count as "unmatched". Thread-safe.
#ifndef GEARLOOP_SERVER_HTTP_METRICS_H_
#define GEARLOOP_SERVER_HTTP_METRICS_H_

#include <array>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <utility>

namespace gearloop {

class Metrics {
 public:
  // Upper bounds of the histogram buckets [s] (the +Inf bucket is implied).
  static constexpr std::array<double, 12> kBucketsSeconds = {
      0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1.0, 2.5, 10.0};

  void RecordRequest(const std::string& route, int status, double seconds);
  void RecordSolve(double seconds);
  std::string Render(int64_t jobs_stored, int64_t batch_items_queued) const;

 private:
  struct Histogram {
    std::array<uint64_t, kBucketsSeconds.size()>
        buckets{};  // non-cumulative counts
    uint64_t count = 0;
    double sum_seconds = 0.0;
    void Add(double seconds);
    void Render(const std::string& name, std::string* out) const;
  };

  mutable std::mutex mutex_;
  std::map<std::pair<std::string, int>, uint64_t> requests_;
  Histogram request_duration_;
  Histogram solver_duration_;
};

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_HTTP_METRICS_H_
