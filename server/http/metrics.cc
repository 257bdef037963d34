#include "server/http/metrics.h"

#include <cstdio>

namespace gearloop {
namespace {

std::string FormatDouble(double value) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.9g", value);
  return buffer;
}

// Label values are route patterns of our own, but escape anyway as the format
// requires.
std::string EscapeLabel(const std::string& value) {
  std::string out;
  for (char c : value) {
    if (c == '\\' || c == '"') out += '\\';
    if (c == '\n') {
      out += "\\n";
      continue;
    }
    out += c;
  }
  return out;
}

}  // namespace

constexpr std::array<double, 12> Metrics::kBucketsSeconds;

void Metrics::Histogram::Add(double seconds) {
  for (size_t i = 0; i < kBucketsSeconds.size(); ++i) {
    if (seconds <= kBucketsSeconds[i]) {
      ++buckets[i];
      break;
    }
  }
  ++count;
  sum_seconds += seconds;
}

void Metrics::Histogram::Render(const std::string& name,
                                std::string* out) const {
  uint64_t cumulative = 0;
  for (size_t i = 0; i < kBucketsSeconds.size(); ++i) {
    cumulative += buckets[i];
    *out += name + "_bucket{le=\"" + FormatDouble(kBucketsSeconds[i]) + "\"} " +
            std::to_string(cumulative) + "\n";
  }
  *out += name + "_bucket{le=\"+Inf\"} " + std::to_string(count) + "\n";
  *out += name + "_sum " + FormatDouble(sum_seconds) + "\n";
  *out += name + "_count " + std::to_string(count) + "\n";
}

void Metrics::RecordRequest(const std::string& route,
                            int status,
                            double seconds) {
  std::lock_guard<std::mutex> lock(mutex_);
  ++requests_[{route, status}];
  request_duration_.Add(seconds);
}

void Metrics::RecordSolve(double seconds) {
  std::lock_guard<std::mutex> lock(mutex_);
  solver_duration_.Add(seconds);
}

std::string Metrics::Render(int64_t jobs_stored,
                            int64_t batch_items_queued) const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::string out;
  out +=
      "# HELP gearloop_http_requests_total HTTP requests answered, by route "
      "pattern and status.\n";
  out += "# TYPE gearloop_http_requests_total counter\n";
  for (const auto& [key, count] : requests_) {
    out += "gearloop_http_requests_total{route=\"" + EscapeLabel(key.first) +
           "\",status=\"" + std::to_string(key.second) + "\"} " +
           std::to_string(count) + "\n";
  }
  out +=
      "# HELP gearloop_http_request_duration_seconds Time from the request "
      "line to the response.\n";
  out += "# TYPE gearloop_http_request_duration_seconds histogram\n";
  request_duration_.Render("gearloop_http_request_duration_seconds", &out);
  out +=
      "# HELP gearloop_solver_duration_seconds Time spent in correction "
      "solves.\n";
  out += "# TYPE gearloop_solver_duration_seconds histogram\n";
  solver_duration_.Render("gearloop_solver_duration_seconds", &out);
  out += "# HELP gearloop_jobs_stored Correction jobs in the history.\n";
  out += "# TYPE gearloop_jobs_stored gauge\n";
  out += "gearloop_jobs_stored " + std::to_string(jobs_stored) + "\n";
  out +=
      "# HELP gearloop_batch_items_queued Batch items waiting for a worker.\n";
  out += "# TYPE gearloop_batch_items_queued gauge\n";
  out += "gearloop_batch_items_queued " + std::to_string(batch_items_queued) +
         "\n";
  return out;
}

}  // namespace gearloop
