#include "server/http/gearloop_server.h"


#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <fstream>
#include <functional>
#include <iomanip>
#include <map>
#include <mutex>
#include <regex>
#include <set>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <vector>

#include "clients/web/web_assets.h"
#include "engine/grinder/flank_grid.h"
#include "engine/grinder/flat_wheel_grinder.h"
#include "engine/grinder/grinding_setup.h"
#include "engine/grinder/grinder_settings.h"
#include "engine/core/sensitivity.h"
#include "server/bevel_codec.h"
#include "server/correction_codec.h"
#include "server/codec/grinder_codec.h"
#include "server/http/metrics.h"
#include "server/simulation_handlers.h"
#include "storage/job_repository.h"
#include "engine/core/units.h"

// Last: <httplib.h> pulls in <resolv.h>, whose `_res` macro breaks Eigen's headers if they come
// after it.
#include <glog/logging.h>
#include <httplib.h>
#include <openssl/crypto.h>
#include <openssl/sha.h>

#ifndef GEARLOOP_VERSION
#define GEARLOOP_VERSION "0.0.0"
#endif

namespace gearloop {

const char* ServerVersion() { return GEARLOOP_VERSION; }

namespace {

using Clock = std::chrono::steady_clock;

// Per-request context. cpp-httplib runs the pre-routing handler, the route handler and the
// logger of one request on the same pool thread, so a thread_local carries the start time and
// the matched route pattern from the first to the last without touching the request object.
struct RequestContext {
  Clock::time_point start;
  bool started = false;
  const char* route = "unmatched";
};
thread_local RequestContext t_request;

std::string Dump(const nlohmann::json& j) {
  // Messages may quote request bytes; never let an invalid UTF-8 byte turn an answer into a 500.
  return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

void RespondJson(httplib::Response& res, int status, const nlohmann::json& body) {
  res.status = status;
  res.set_content(Dump(body), "application/json");
}

void RespondError(httplib::Response& res, const ApiError& error) { RespondJson(res, error.status, ErrorBody(error)); }

const char* CodeForStatus(int status) {
  switch (status) {
    case 400:
      return "invalid_request";
    case 401:
      return "unauthorized";
    case 403:
      return "forbidden";
    case 404:
      return "not_found";
    case 405:
      return "method_not_allowed";
    case 408:
      return "request_timeout";
    case 413:
      return "payload_too_large";
    case 414:
      return "uri_too_long";
    case 422:
      return "invalid_value";
    case 503:
      return "unavailable";
    default:
      return status >= 500 ? "internal_error" : "invalid_request";
  }
}

bool IsLoopbackHost(const std::string& host) {
  return host == "localhost" || host == "::1" || host.rfind("127.", 0) == 0;
}

// A path id ("/api/v1/corrections/17"): digits only (the route's regex), and small enough.
bool ParseId(const std::string& text, int64_t* id) {
  if (text.empty() || text.size() > 18) return false;
  *id = std::stoll(text);
  return *id > 0;
}

std::string Sha256Hex(const std::string& text) {
  unsigned char digest[SHA256_DIGEST_LENGTH];
  SHA256(reinterpret_cast<const unsigned char*>(text.data()), text.size(), digest);
  static const char* kHex = "0123456789abcdef";
  std::string hex;
  for (unsigned char b : digest) {
    hex += kHex[b >> 4];
    hex += kHex[b & 15];
  }
  return hex;
}

enum class Access { kOpen, kRead, kWrite };

struct TokenEntry {
  std::string role;  // "read" or "write"
  std::string sha256_hex;
  std::string name;
};

// The token file of issue 7: "<role> <sha256-hex-of-token> [name]" per line, '#' comments.
std::vector<TokenEntry> LoadTokenFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read token file " + path);
  std::vector<TokenEntry> tokens;
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    std::istringstream fields(line);
    TokenEntry entry;
    if (!(fields >> entry.role) || entry.role[0] == '#') continue;
    fields >> entry.sha256_hex;
    std::getline(fields >> std::ws, entry.name);
    std::transform(entry.sha256_hex.begin(), entry.sha256_hex.end(), entry.sha256_hex.begin(), ::tolower);
    const bool hex_ok = entry.sha256_hex.size() == 64 &&
                        entry.sha256_hex.find_first_not_of("0123456789abcdef") == std::string::npos;
    if ((entry.role != "read" && entry.role != "write") || !hex_ok) {
      throw std::runtime_error("token file " + path + " line " + std::to_string(line_number) +
                               ": expected \"<read|write> <sha256-hex> [name]\"");
    }
    tokens.push_back(entry);
  }
  if (tokens.empty()) throw std::runtime_error("token file " + path + " holds no tokens");
  return tokens;
}

// Query parameters of the history listing.
bool ParseJobFilter(const httplib::Request& req, JobFilter* filter, ApiError* error) {
  static const std::regex kTime(R"(\d{4}-\d{2}-\d{2}(T\d{2}:\d{2}(:\d{2}(\.\d{1,3})?)?Z?)?)");
  auto integer = [&](const char* key, long long min, long long max, long long* out) {
    if (!req.has_param(key)) return true;
    const std::string text = req.get_param_value(key);
    const std::string field = std::string("query.") + key;
    if (text.empty() || text.size() > 12 || text.find_first_not_of("-0123456789") != std::string::npos ||
        text.find('-', 1) != std::string::npos || text == "-") {
      *error = InvalidRequest(field, field + " must be an integer");
      return false;
    }
    const long long value = std::stoll(text);
    if (value < min || value > max) {
      *error = InvalidValue(field, field + " must lie in [" + std::to_string(min) + ", " + std::to_string(max) + "]");
      return false;
    }
    *out = value;
    return true;
  };
  long long limit = 50, offset = 0, teeth = 0;
  if (!integer("limit", 1, 1000, &limit) || !integer("offset", 0, 1000000000, &offset)) return false;
  filter->limit = static_cast<int>(limit);
  filter->offset = static_cast<int>(offset);
  if (req.has_param("teeth")) {
    if (!integer("teeth", 1, 1000000, &teeth)) return false;
    filter->gear_teeth = static_cast<int>(teeth);
  }
  if (req.has_param("module_mm")) {
    const std::string text = req.get_param_value("module_mm");
    char* end = nullptr;
    const double value = std::strtod(text.c_str(), &end);
    if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(value)) {
      *error = InvalidRequest("query.module_mm", "query.module_mm must be a number");
      return false;
    }
    filter->gear_normal_module_mm = value;
  }
  if (req.has_param("flank")) {
    const std::string flank = req.get_param_value("flank");
    if (flank != "left" && flank != "right" && flank != "convex" && flank != "concave") {
      *error = InvalidValue("query.flank",
                            "query.flank must be \"left\" or \"right\" (a gear) or \"convex\" or \"concave\" (a bevel pinion)");
      return false;
    }
    filter->flank = flank;
  }
  if (req.has_param("kind")) filter->kind = req.get_param_value("kind");
  if (req.has_param("status")) filter->status = req.get_param_value("status");
  for (const char* key : {"created_from", "created_to"}) {
    if (!req.has_param(key)) continue;
    const std::string text = req.get_param_value(key);
    if (!std::regex_match(text, kTime)) {
      *error = InvalidRequest(std::string("query.") + key,
                              std::string("query.") + key + " must be an ISO-8601 UTC date or time (2026-11-22T08:00:00Z)");
      return false;
    }
    (std::string(key) == "created_from" ? filter->created_from : filter->created_to) = text;
  }
  if (filter->created_from && filter->created_to && *filter->created_from > *filter->created_to) {
    *error = InvalidValue("query.created_to", "query.created_to lies before query.created_from");
    return false;
  }
  return true;
}

nlohmann::json OptionalToJson(const std::optional<double>& value) {
  return value ? nlohmann::json(*value) : nlohmann::json(nullptr);
}
nlohmann::json OptionalToJson(const std::optional<int64_t>& value) {
  return value ? nlohmann::json(*value) : nlohmann::json(nullptr);
}

nlohmann::json JobSummaryJson(const JobRecord& job) {
  nlohmann::json gear = {{"teeth", job.gear_teeth},
                         {"normal_module_mm", job.gear_normal_module_mm},
                         {"helix_angle_deg", job.gear_helix_angle_deg}};
  if (!job.gear_hand.empty()) gear["hand"] = job.gear_hand;
  return {{"id", job.id},
          {"created_utc", job.created_utc},
          {"kind", job.kind},
          {"status", job.status},
          {"gear", gear},
          {"flank", job.flank},
          // Bevel jobs store their flank side (convex / concave) as the flank.
          {"machine_kind", job.flank == "convex" || job.flank == "concave" ? kFreeFormBevelGeneratorKind
                                                                            : "flat-wheel-grinder"},
          {"residual_rms_um", OptionalToJson(job.residual_rms_um)},
          {"best_reachable_rms_um", OptionalToJson(job.best_reachable_rms_um)},
          {"rank", job.rank ? nlohmann::json(*job.rank) : nlohmann::json(nullptr)},
          {"elapsed_ms", job.elapsed_ms},
          {"server_version", job.server_version},
          {"parent_job_id", OptionalToJson(job.parent_job_id)},
          {"settings_source_job_id", OptionalToJson(job.settings_source_job_id)},
          {"location", "/api/v1/corrections/" + std::to_string(job.id)}};
}

// A bounded pool of background workers for batch items. Items wait in memory; they are also
// pending rows in the database, so a stop loses nothing: the next start enqueues them again.
class BatchRunner {
 public:
  using Work = std::function<void(const PendingBatchItem&)>;

  BatchRunner(int workers, Work work) : work_(std::move(work)) {
    for (int i = 0; i < std::max(1, workers); ++i) threads_.emplace_back([this] { Loop(); });
  }
  ~BatchRunner() { Stop(); }

  void Enqueue(std::vector<PendingBatchItem> items) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      for (PendingBatchItem& item : items) queue_.push_back(std::move(item));
    }
    wake_.notify_all();
  }

  size_t Queued() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return queue_.size();
  }

  // Workers finish the item in hand and leave; waiting items are dropped (they stay pending in
  // the database).
  void Stop() {
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

 private:
  void Loop() {
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

  Work work_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<PendingBatchItem> queue_;
  bool stopping_ = false;
  std::vector<std::thread> threads_;
};

}  // namespace

class GearloopServer::Impl {
 public:
  explicit Impl(const ServerOptions& options) : options_(options) {
    if (!options_.token_file.empty()) {
      tokens_ = LoadTokenFile(options_.token_file);
    } else if (!IsLoopbackHost(options_.host)) {
      throw std::runtime_error("refusing to listen on " + options_.host +
                               " without a token file: without --token-file the server listens on loopback only");
    }
    repository_ = OpenJobRepository(options_.database_path);
    ConfigureHttp();
    RegisterRoutes();
    batches_ = std::make_unique<BatchRunner>(options_.batch_workers,
                                             [this](const PendingBatchItem& item) { RunBatchItem(item); });
    // Work acknowledged before the last stop (or crash) resumes now.
    std::vector<PendingBatchItem> pending = repository_->ReadPendingBatchItems();
    if (!pending.empty()) {
      LOG(INFO) << "resuming " << pending.size() << " pending batch items";
      batches_->Enqueue(std::move(pending));
    }
  }

  ~Impl() {
    http_.stop();
    batches_->Stop();
  }

  int Bind() {
    if (options_.port == 0) {
      port_ = http_.bind_to_any_port(options_.host);
    } else {
      port_ = http_.bind_to_port(options_.host, options_.port) ? options_.port : -1;
    }
    return port_;
  }

  void Serve() {
    http_.listen_after_bind();
    // listen_after_bind returns once the pool has answered every request in flight.
    batches_->Stop();
  }

  void Stop() { http_.stop(); }
  int port() const { return port_; }
  bool IsRunning() const { return http_.is_running(); }
  long long QueuedBatchItems() const { return static_cast<long long>(batches_->Queued()); }

 private:
  using Handler = std::function<void(const httplib::Request&, httplib::Response&)>;

  void ConfigureHttp() {
    const int threads =
        options_.threads > 0 ? options_.threads : std::max(16, 4 * static_cast<int>(std::thread::hardware_concurrency()));
    http_.new_task_queue = [threads] { return new httplib::ThreadPool(threads); };
    http_.set_payload_max_length(options_.payload_max_bytes);
    http_.set_read_timeout(options_.read_timeout_seconds, 0);
    http_.set_write_timeout(10, 0);
    http_.set_keep_alive_max_count(10000);
    http_.set_keep_alive_timeout(5);
    // cpp-httplib writes the head and the body of a response separately; with Nagle on, the
    // body waits for the client's delayed ACK (~40 ms per request on Linux).
    http_.set_tcp_nodelay(true);

    const size_t payload_max_bytes = options_.payload_max_bytes;
    httplib::Server::HandlerWithResponse pre_routing = [this, payload_max_bytes](const httplib::Request& req,
                                                                                 httplib::Response& res) {
      t_request.start = Clock::now();
      t_request.started = true;
      t_request.route = "unmatched";
      // cpp-httplib routes GET, HEAD (to the GET handlers), POST, PUT, PATCH, DELETE and
      // OPTIONS, and answers any other method it parses (TRACE, CONNECT) 400 without looking
      // at the path. On one of our paths that is a method the resource does not serve: 405.
      static const std::set<std::string> kRouted = {"GET", "HEAD", "POST", "PUT", "PATCH", "DELETE", "OPTIONS"};
      if (!kRouted.count(req.method)) {
        for (const auto& [route, allow] : allow_by_route_) {
          if (!std::regex_match(req.path, route)) continue;
          t_request.route = "method_not_allowed";
          res.set_header("Allow", allow);
          RespondError(res, ApiError{405, "method_not_allowed", req.method + " is not allowed here; use " + allow, ""});
          return httplib::Server::HandlerResponse::Handled;
        }
      }
      // Refuse an announced oversized body before reading it (cpp-httplib would first read and
      // discard it all, holding a worker for as long as the client cares to send), and close.
      const std::string length = req.get_header_value("Content-Length");
      if (!length.empty()) {
        char* end = nullptr;
        const unsigned long long bytes = std::strtoull(length.c_str(), &end, 10);
        if (end == length.c_str() || *end != '\0') {
          res.set_header("Connection", "close");
          RespondError(res, InvalidRequest("", "Content-Length is not a number"));
          return httplib::Server::HandlerResponse::Handled;
        }
        if (bytes > payload_max_bytes) {
          res.set_header("Connection", "close");
          RespondError(res, ApiError{413, "payload_too_large",
                                     "the request body is larger than the server accepts (" +
                                         std::to_string(payload_max_bytes) + " bytes)",
                                     ""});
          return httplib::Server::HandlerResponse::Handled;
        }
      }
      return httplib::Server::HandlerResponse::Unhandled;
    };
    http_.set_pre_routing_handler(pre_routing);

    // Errors cpp-httplib raises itself (404 without a route, 413, 400 for a broken request
    // line, ...) get the same JSON body as ours; our own error bodies pass unchanged.
    httplib::Server::HandlerWithResponse error_handler = [](const httplib::Request&, httplib::Response& res) {
      if (!res.body.empty()) return httplib::Server::HandlerResponse::Unhandled;
      ApiError error;
      error.status = res.status;
      error.code = CodeForStatus(res.status);
      switch (res.status) {
        case 404:
          error.message = "no such resource";
          break;
        case 413:
          error.message = "the request body is larger than the server accepts";
          break;
        default:
          error.message = "request refused (HTTP " + std::to_string(res.status) + ")";
      }
      res.set_content(Dump(ErrorBody(error)), "application/json");
      return httplib::Server::HandlerResponse::Handled;
    };
    http_.set_error_handler(error_handler);

    http_.set_exception_handler([](const httplib::Request& req, httplib::Response& res, std::exception_ptr ep) {
      // Only reached for exceptions our wrapper could not see (e.g. inside cpp-httplib).
      std::string what = "unknown";
      try {
        if (ep) std::rethrow_exception(ep);
      } catch (const std::exception& e) {
        what = e.what();
      } catch (...) {
      }
      LOG(ERROR) << "unhandled exception on " << req.method << " " << req.path << ": " << what;
      RespondError(res, ApiError{500, "internal_error", "internal error; nothing was stored", ""});
    });

    http_.set_logger([this](const httplib::Request& req, const httplib::Response& res) {
      const double seconds =
          t_request.started ? std::chrono::duration<double>(Clock::now() - t_request.start).count() : 0.0;
      t_request.started = false;
      metrics_.RecordRequest(t_request.route, res.status, seconds);
      if (options_.access_log) {
        LOG(INFO) << req.method << " " << req.path << " " << res.status << " " << std::fixed
                  << std::setprecision(2) << seconds * 1e3 << " ms";
      }
    });
  }

  // Wraps a handler: records the route pattern for the metrics, checks the token, and catches
  // every exception once, at the top (500 and one log line; OSRM request_handler.cpp).
  Handler Route(const char* route, Access access, Handler handler) {
    return [this, route, access, handler](const httplib::Request& req, httplib::Response& res) {
      t_request.route = route;
      try {
        ApiError error;
        if (!Authorize(req, access, &error)) return RespondError(res, error);
        handler(req, res);
      } catch (const std::exception& e) {
        LOG(ERROR) << "internal error on " << req.method << " " << req.path << ": " << e.what();
        res.headers.erase("Location");
        RespondError(res, ApiError{500, "internal_error", "internal error; nothing was stored", ""});
      }
    };
  }

  bool Authorize(const httplib::Request& req, Access access, ApiError* error) const {
    if (tokens_.empty() || access == Access::kOpen) return true;
    const std::string header = req.get_header_value("Authorization");
    const std::string prefix = "Bearer ";
    if (header.size() <= prefix.size() || header.compare(0, prefix.size(), prefix) != 0) {
      *error = ApiError{401, "unauthorized", "send a token as \"Authorization: Bearer <token>\"", ""};
      return false;
    }
    const std::string hash = Sha256Hex(header.substr(prefix.size()));
    const TokenEntry* match = nullptr;
    // Compare with every entry, in constant time each, so timing tells nothing about the hashes.
    for (const TokenEntry& entry : tokens_) {
      if (CRYPTO_memcmp(entry.sha256_hex.data(), hash.data(), hash.size()) == 0) match = &entry;
    }
    if (match == nullptr) {
      *error = ApiError{401, "unauthorized", "unknown token", ""};
      return false;
    }
    if (access == Access::kWrite && match->role != "write") {
      *error = ApiError{403, "forbidden", "this token may read but not submit", ""};
      return false;
    }
    return true;
  }

  void Register(const std::string& method, const std::string& pattern, const char* route, Access access,
                Handler handler) {
    Handler wrapped = Route(route, access, std::move(handler));
    if (method == "GET") {
      http_.Get(pattern, wrapped);
    } else {
      http_.Post(pattern, wrapped);
    }
    allowed_methods_[pattern].insert(method);
  }

  void RegisterRoutes() {
    Register("GET", "/healthz", "GET /healthz", Access::kOpen, [](const httplib::Request&, httplib::Response& res) {
      RespondJson(res, 200, {{"status", "ok"}, {"version", ServerVersion()}});
    });
    Register("GET", "/metrics", "GET /metrics", Access::kOpen, [this](const httplib::Request&, httplib::Response& res) {
      res.status = 200;
      res.set_content(metrics_.Render(repository_->CountJobs(), static_cast<int64_t>(batches_->Queued())),
                      "text/plain; version=0.0.4");
    });
    Register("POST", "/api/v1/nominal", "POST /api/v1/nominal", Access::kRead,
             [this](const httplib::Request& req, httplib::Response& res) { HandleNominal(req, res); });
    Register("POST", "/api/v1/evaluate", "POST /api/v1/evaluate", Access::kRead,
             [this](const httplib::Request& req, httplib::Response& res) { HandleEvaluate(req, res); });
    Register("POST", "/api/v1/sensitivity", "POST /api/v1/sensitivity", Access::kRead,
             [this](const httplib::Request& req, httplib::Response& res) { HandleSensitivity(req, res); });
    Register("POST", "/api/v1/corrections", "POST /api/v1/corrections", Access::kWrite,
             [this](const httplib::Request& req, httplib::Response& res) { HandleCreateCorrection(req, res); });
    Register("GET", "/api/v1/corrections", "GET /api/v1/corrections", Access::kRead,
             [this](const httplib::Request& req, httplib::Response& res) { HandleListCorrections(req, res); });
    Register("GET", R"(/api/v1/corrections/(\d+))", "GET /api/v1/corrections/{id}", Access::kRead,
             [this](const httplib::Request& req, httplib::Response& res) { HandleGetCorrection(req, res); });
    Register("GET", R"(/api/v1/corrections/(\d+)/lineage)", "GET /api/v1/corrections/{id}/lineage", Access::kRead,
             [this](const httplib::Request& req, httplib::Response& res) { HandleLineage(req, res); });
    Register("POST", R"(/api/v1/corrections/(\d+)/replay)", "POST /api/v1/corrections/{id}/replay", Access::kWrite,
             [this](const httplib::Request& req, httplib::Response& res) { HandleReplay(req, res); });
    Register("POST", "/api/v1/batches", "POST /api/v1/batches", Access::kWrite,
             [this](const httplib::Request& req, httplib::Response& res) { HandleCreateBatch(req, res); });
    Register("GET", R"(/api/v1/batches/(\d+))", "GET /api/v1/batches/{id}", Access::kRead,
             [this](const httplib::Request& req, httplib::Response& res) { HandleGetBatch(req, res); });
    Register("POST", "/api/v1/simulations/measurement", "POST /api/v1/simulations/measurement", Access::kRead,
             [](const httplib::Request& req, httplib::Response& res) {
               nlohmann::json body;
               ApiError error;
               if (!ParseJsonBody(req.body, &body, &error)) return RespondError(res, error);
               nlohmann::json answer;
               const bool ok = IsBevelCorrectionRequest(body) ? BevelSimulateMeasurement(body, &answer, &error)
                                                              : SimulateMeasurement(body, &answer, &error);
               if (!ok) return RespondError(res, error);
               RespondJson(res, 200, answer);
             });
    Register("POST", "/api/v1/bevel/conversions", "POST /api/v1/bevel/conversions", Access::kRead,
             [](const httplib::Request& req, httplib::Response& res) { HandleBevel(req, res, BevelConversion); });
    Register("POST", "/api/v1/bevel/evaluate", "POST /api/v1/bevel/evaluate", Access::kRead,
             [](const httplib::Request& req, httplib::Response& res) { HandleBevel(req, res, BevelEvaluate); });
    Register("POST", "/api/v1/bevel/axis-sensitivity", "POST /api/v1/bevel/axis-sensitivity", Access::kRead,
             [](const httplib::Request& req, httplib::Response& res) { HandleBevel(req, res, BevelAxisSensitivity); });
    Register("POST", "/api/v1/simulations/closed-loop", "POST /api/v1/simulations/closed-loop", Access::kWrite,
             [this](const httplib::Request& req, httplib::Response& res) { HandleClosedLoop(req, res); });

    // The dashboard (clients/web, embedded in the binary). Its pages hold no data: the API
    // calls they make carry the token.
    Register("GET", R"(/|/jobs/\d+/report|/static/[A-Za-z0-9._-]+)", "GET dashboard", Access::kOpen,
             [](const httplib::Request& req, httplib::Response& res) {
               std::string body;
               std::string content_type;
               if (!FindWebAsset(req.path, &body, &content_type)) {
                 return RespondError(res, ApiError{404, "not_found", "no such resource", ""});
               }
               res.status = 200;
               res.set_content(body, content_type.c_str());
             });

    // A known path with a method it does not serve: 405 with Allow (cpp-httplib alone says 404).
    for (const auto& [pattern, methods] : allowed_methods_) {
      std::string allow;
      for (const std::string& m : methods) allow += (allow.empty() ? "" : ", ") + m;
      allow_by_route_.emplace_back(std::regex(pattern), allow);
      Handler not_allowed = Route("method_not_allowed", Access::kOpen,
                                  [allow](const httplib::Request& req, httplib::Response& res) {
                                    res.set_header("Allow", allow);
                                    RespondError(res, ApiError{405, "method_not_allowed",
                                                               req.method + " is not allowed here; use " + allow, ""});
                                  });
      if (!methods.count("GET")) http_.Get(pattern, not_allowed);
      if (!methods.count("POST")) http_.Post(pattern, not_allowed);
      http_.Put(pattern, not_allowed);
      http_.Patch(pattern, not_allowed);
      http_.Delete(pattern, not_allowed);
      http_.Options(pattern, not_allowed);
    }
  }

  // --- Handlers ------------------------------------------------------------------------------
  // Reads the body, the setup and (optionally) the settings common to nominal/evaluate/sensitivity.
  bool ParseSetupAndSettings(const httplib::Request& req, GrindingSetup* setup, MachineSettings* settings,
                             ApiError* error) {
    nlohmann::json body;
    if (!ParseJsonBody(req.body, &body, error) || !ParseGrindingSetup(body, setup, error)) return false;
    if (body.contains("settings") && !body.at("settings").is_null()) {
      return ParseMachineSettings(body.at("settings"), "settings", settings, error);
    }
    *settings = NominalSettings(*setup);
    return true;
  }

  void HandleNominal(const httplib::Request& req, httplib::Response& res) {
    GrindingSetup setup;
    MachineSettings settings;
    ApiError error;
    if (!ParseSetupAndSettings(req, &setup, &settings, &error)) return RespondError(res, error);
    const FlatWheelGrinder grinder(setup);
    const GearData& g = setup.gear;
    RespondJson(res, 200,
                {{"settings", MachineSettingsToJson(grinder.nominal())},
                 {"gear", GearToJson(g)},
                 {"flank", FlankName(setup.flank)},
                 {"pitch_radius_mm", g.PitchRadiusMm()},
                 {"base_radius_mm", g.BaseRadiusMm()},
                 {"transverse_pressure_angle_deg", g.TransversePressureAngleRad() * kDegPerRad},
                 {"form_roll_length_mm", g.FormRollLengthMm()},
                 {"tip_roll_length_mm", g.TipRollLengthMm()},
                 {"roll_range_deg", {grinder.roll_min_rad() * kDegPerRad, grinder.roll_max_rad() * kDegPerRad}}});
  }

  void HandleEvaluate(const httplib::Request& req, httplib::Response& res) {
    GrindingSetup setup;
    MachineSettings settings;
    ApiError error;
    if (!ParseSetupAndSettings(req, &setup, &settings, &error)) return RespondError(res, error);
    const FlatWheelGrinder grinder(setup);
    ModelEvaluation evaluation;
    grinder.Evaluate(settings.ToVector(), /*with_jacobian=*/false, &evaluation);
    RespondJson(res, 200, EvaluationToJson(grinder.grid(), evaluation));
  }

  // The bevel endpoints: parse, then one codec call that validates, runs the engine and renders.
  static void HandleBevel(const httplib::Request& req, httplib::Response& res,
                          bool (*run)(const nlohmann::json&, nlohmann::json*, ApiError*)) {
    nlohmann::json body;
    nlohmann::json answer;
    ApiError error;
    if (!ParseJsonBody(req.body, &body, &error) || !run(body, &answer, &error)) return RespondError(res, error);
    RespondJson(res, 200, answer);
  }

  void HandleSensitivity(const httplib::Request& req, httplib::Response& res) {
    GrindingSetup setup;
    MachineSettings settings;
    ApiError error;
    if (!ParseSetupAndSettings(req, &setup, &settings, &error)) return RespondError(res, error);
    const FlatWheelGrinder grinder(setup);
    ModelEvaluation evaluation;
    grinder.Evaluate(settings.ToVector(), /*with_jacobian=*/true, &evaluation);
    // The API quotes the cone-angle column per degree (API.md); the engine per radian.
    Eigen::MatrixXd matrix = evaluation.jacobian_um;
    matrix.col(kConeAngleIndex) /= kDegPerRad;
    const SensitivitySummary raw = AnalyzeSensitivity(matrix, Eigen::VectorXd());
    const SensitivitySummary normalised = AnalyzeSensitivity(matrix, UnitColumnScales(matrix));
    nlohmann::json rows = nlohmann::json::array();
    for (int i = 0; i < matrix.rows(); ++i) {
      nlohmann::json row = nlohmann::json::array();
      for (int j = 0; j < matrix.cols(); ++j) row.push_back(matrix(i, j));
      rows.push_back(row);
    }
    nlohmann::json names = nlohmann::json::array();
    nlohmann::json units = nlohmann::json::array();
    for (int j = 0; j < kNumGrinderParameters; ++j) {
      names.push_back(GrinderParameterName(j));
      std::string unit = j == kConeAngleIndex ? "deg" : GrinderParameterUnit(j);
      units.push_back("um/" + unit);
    }
    auto summary_json = [](const SensitivitySummary& s) {
      nlohmann::json values = nlohmann::json::array();
      for (int i = 0; i < s.singular_values.size(); ++i) values.push_back(s.singular_values(i));
      return nlohmann::json{{"singular_values", values},
                            {"rank", s.rank},
                            {"condition_number", std::isfinite(s.condition_number) ? nlohmann::json(s.condition_number)
                                                                                    : nlohmann::json(nullptr)}};
    };
    nlohmann::json answer = summary_json(raw);
    nlohmann::json evaluated = EvaluationToJson(grinder.grid(), evaluation);
    answer["matrix"] = rows;
    answer["parameters"] = names;
    answer["units"] = units;
    answer["normalised"] = summary_json(normalised);
    answer["rows"] = grinder.GridRows() * grinder.GridColumns();
    answer["columns"] = kNumGrinderParameters;
    answer["not_reached"] = evaluated["not_reached"];
    RespondJson(res, 200, answer);
  }

  // Parses, checks the lineage link, solves. On failure `error` holds the 4xx.
  bool SolveCorrection(const nlohmann::json& body, CorrectionRun* run, ApiError* error) {
    if (IsBevelCorrectionRequest(body)) {
      // A spiral-bevel pinion on the free-form generator (server/bevel_codec.h).
      if (!RunBevelCorrection(body, run, error)) return false;
      if (run->job.settings_source_job_id && !repository_->JobExists(*run->job.settings_source_job_id)) {
        *error = InvalidValue("settings_source_job_id",
                              "no stored job " + std::to_string(*run->job.settings_source_job_id));
        return false;
      }
      metrics_.RecordSolve(run->solve_seconds);
      return true;
    }
    CorrectionRequest request;
    if (!ParseCorrectionRequest(body, &request, error)) return false;
    if (request.settings_source_job_id && !repository_->JobExists(*request.settings_source_job_id)) {
      *error = InvalidValue("settings_source_job_id",
                            "no stored job " + std::to_string(*request.settings_source_job_id));
      return false;
    }
    if (!RunCorrection(request, run, error)) return false;
    metrics_.RecordSolve(run->solve_seconds);
    return true;
  }

  void RespondCreatedJob(httplib::Response& res, const JobRecord& job, const CorrectionRun& run) {
    res.set_header("Location", "/api/v1/corrections/" + std::to_string(job.id));
    RespondJson(res, 201,
                {{"id", job.id},
                 {"created_utc", job.created_utc},
                 {"kind", job.kind},
                 {"status", job.status},
                 {"parent_job_id", OptionalToJson(job.parent_job_id)},
                 {"settings_source_job_id", OptionalToJson(job.settings_source_job_id)},
                 {"result", run.result_json}});
  }

  void HandleCreateCorrection(const httplib::Request& req, httplib::Response& res) {
    nlohmann::json body;
    ApiError error;
    CorrectionRun run;
    if (!ParseJsonBody(req.body, &body, &error) || !SolveCorrection(body, &run, &error)) {
      return RespondError(res, error);
    }
    JobRecord& job = run.job;
    job.kind = "correction";
    job.created_utc = CurrentUtcIso8601();
    job.request_json = Dump(body);
    job.server_version = ServerVersion();
    job.id = repository_->WriteJob(job);
    LogSolve(job, run);
    RespondCreatedJob(res, job, run);
  }

  // The engine is silent; the server tells what the solver did (STYLE.md).
  void LogSolve(const JobRecord& job, const CorrectionRun& run) const {
    if (options_.access_log) LOG(INFO) << "job " << job.id << " (" << job.kind << "): " << run.result.summary.BriefReport();
  }

  void HandleListCorrections(const httplib::Request& req, httplib::Response& res) {
    JobFilter filter;
    ApiError error;
    if (!ParseJobFilter(req, &filter, &error)) return RespondError(res, error);
    const JobPage page = repository_->ListJobs(filter);
    nlohmann::json jobs = nlohmann::json::array();
    for (const JobRecord& job : page.jobs) jobs.push_back(JobSummaryJson(job));
    RespondJson(res, 200, {{"jobs", jobs}, {"total", page.total}, {"limit", filter.limit}, {"offset", filter.offset}});
  }

  void HandleGetCorrection(const httplib::Request& req, httplib::Response& res) {
    int64_t id = 0;
    std::optional<JobRecord> job;
    if (ParseId(req.matches[1], &id)) job = repository_->ReadJob(id);
    if (!job) return RespondError(res, ApiError{404, "not_found", "no stored correction job " + req.matches[1].str(), ""});
    nlohmann::json answer = JobSummaryJson(*job);
    answer["request"] = nlohmann::json::parse(job->request_json, nullptr, false);
    answer["result"] = nlohmann::json::parse(job->result_json, nullptr, false);
    RespondJson(res, 200, answer);
  }

  void HandleLineage(const httplib::Request& req, httplib::Response& res) {
    int64_t id = 0;
    std::vector<JobRecord> lineage;
    if (ParseId(req.matches[1], &id)) lineage = repository_->ReadLineage(id);
    if (lineage.empty()) {
      return RespondError(res, ApiError{404, "not_found", "no stored correction job " + req.matches[1].str(), ""});
    }
    nlohmann::json jobs = nlohmann::json::array();
    for (const JobRecord& job : lineage) jobs.push_back(JobSummaryJson(job));
    RespondJson(res, 200, {{"id", id}, {"jobs", jobs}});
  }

  void HandleReplay(const httplib::Request& req, httplib::Response& res) {
    int64_t id = 0;
    std::optional<JobRecord> parent;
    if (ParseId(req.matches[1], &id)) parent = repository_->ReadJob(id);
    if (!parent) return RespondError(res, ApiError{404, "not_found", "no stored correction job " + req.matches[1].str(), ""});
    nlohmann::json changes = nlohmann::json::object();
    ApiError error;
    if (!req.body.empty() && !ParseJsonBody(req.body, &changes, &error)) return RespondError(res, error);
    for (const auto& item : changes.items()) {
      if (item.key() != "options" && item.key() != "target") {
        return RespondError(res, InvalidRequest(item.key(), "a replay may change only \"options\" and \"target\""));
      }
    }
    nlohmann::json request = nlohmann::json::parse(parent->request_json, nullptr, false);
    if (!request.is_object()) throw std::runtime_error("stored request of job " + std::to_string(id) + " is not JSON");
    if (changes.contains("options")) {
      if (!changes["options"].is_object()) {
        return RespondError(res, InvalidRequest("options", "options must be an object"));
      }
      // Changed options are merged into the stored ones (RFC 7396: null removes a field).
      if (!request.contains("options") || !request["options"].is_object()) request["options"] = nlohmann::json::object();
      request["options"].merge_patch(changes["options"]);
    }
    if (changes.contains("target")) request["target"] = changes["target"];
    CorrectionRun run;
    if (!SolveCorrection(request, &run, &error)) return RespondError(res, error);
    JobRecord& job = run.job;
    job.kind = "replay";
    job.created_utc = CurrentUtcIso8601();
    job.request_json = Dump(request);
    job.server_version = ServerVersion();
    job.parent_job_id = id;
    job.id = repository_->WriteJob(job);
    LogSolve(job, run);
    RespondCreatedJob(res, job, run);
  }

  void HandleCreateBatch(const httplib::Request& req, httplib::Response& res) {
    nlohmann::json body;
    ApiError error;
    if (!ParseJsonBody(req.body, &body, &error)) return RespondError(res, error);
    if (!body.contains("items")) return RespondError(res, InvalidRequest("items", "missing required field items"));
    const nlohmann::json& items = body.at("items");
    if (!items.is_array()) return RespondError(res, InvalidRequest("items", "items must be an array of correction requests"));
    if (items.empty() || items.size() > static_cast<size_t>(options_.max_batch_items)) {
      return RespondError(res, InvalidValue("items", "a batch holds 1 to " + std::to_string(options_.max_batch_items) +
                                                         " items, got " + std::to_string(items.size())));
    }
    std::vector<std::string> texts;
    for (size_t i = 0; i < items.size(); ++i) {
      if (!items[i].is_object()) {
        return RespondError(res, InvalidRequest("items[" + std::to_string(i) + "]",
                                                "items[" + std::to_string(i) + "] must be a correction request object"));
      }
      texts.push_back(Dump(items[i]));
    }
    if (batches_->Queued() + texts.size() > static_cast<size_t>(options_.max_queued_batch_items)) {
      res.set_header("Retry-After", "10");
      return RespondError(res, ApiError{503, "unavailable", "too many batch items are waiting; try again later", ""});
    }
    const int64_t batch_id = repository_->CreateBatch(texts);
    std::vector<PendingBatchItem> pending(texts.size());
    for (size_t i = 0; i < texts.size(); ++i) pending[i] = {batch_id, static_cast<int>(i), std::move(texts[i])};
    batches_->Enqueue(std::move(pending));
    res.set_header("Location", "/api/v1/batches/" + std::to_string(batch_id));
    RespondJson(res, 202,
                {{"id", batch_id},
                 {"status", "running"},
                 {"total", items.size()},
                 {"done", 0},
                 {"failed", 0},
                 {"location", "/api/v1/batches/" + std::to_string(batch_id)}});
  }

  void RunBatchItem(const PendingBatchItem& item) {
    ApiError error;
    try {
      nlohmann::json body;
      CorrectionRun run;
      if (ParseJsonBody(item.request_json, &body, &error) && SolveCorrection(body, &run, &error)) {
        JobRecord& job = run.job;
        job.kind = "batch_item";
        job.created_utc = CurrentUtcIso8601();
        job.request_json = item.request_json;
        job.server_version = ServerVersion();
        repository_->CompleteBatchItem(item.batch_id, item.index, job);
        return;
      }
    } catch (const std::exception& e) {
      LOG(ERROR) << "batch " << item.batch_id << " item " << item.index << " failed: " << e.what();
      error = ApiError{500, "internal_error", "internal error while running this item", ""};
    }
    BatchItemRecord failure;
    failure.error_status = error.status;
    failure.error_code = error.code;
    failure.error_message = error.message;
    failure.error_field = error.field;
    try {
      repository_->FailBatchItem(item.batch_id, item.index, failure);
    } catch (const std::exception& e) {
      LOG(ERROR) << "cannot record failure of batch " << item.batch_id << " item " << item.index << ": " << e.what();
    }
  }

  void HandleGetBatch(const httplib::Request& req, httplib::Response& res) {
    int64_t id = 0;
    std::optional<BatchRecord> batch;
    if (ParseId(req.matches[1], &id)) batch = repository_->ReadBatch(id, /*with_items=*/true);
    if (!batch) return RespondError(res, ApiError{404, "not_found", "no batch " + req.matches[1].str(), ""});
    nlohmann::json items = nlohmann::json::array();
    for (const BatchItemRecord& item : batch->items) {
      nlohmann::json j = {{"index", item.index}, {"state", BatchItemStateName(item.state)}};
      if (item.job_id) {
        j["job_id"] = *item.job_id;
        j["location"] = "/api/v1/corrections/" + std::to_string(*item.job_id);
      }
      if (item.state == BatchItemState::kFailed) {
        j["error_status"] = item.error_status;
        j["error"] = {{"code", item.error_code}, {"message", item.error_message}, {"field", item.error_field}};
      }
      items.push_back(j);
    }
    RespondJson(res, 200,
                {{"id", batch->id},
                 {"status", batch->status},
                 {"created_utc", batch->created_utc},
                 {"finished_utc", batch->finished_utc.empty() ? nlohmann::json(nullptr) : nlohmann::json(batch->finished_utc)},
                 {"total", batch->total},
                 {"done", batch->done},
                 {"failed", batch->failed},
                 {"pending", batch->total - batch->done - batch->failed},
                 {"items", items}});
  }

  void HandleClosedLoop(const httplib::Request& req, httplib::Response& res) {
    nlohmann::json body;
    ApiError error;
    if (!ParseJsonBody(req.body, &body, &error)) return RespondError(res, error);
    ClosedLoopRun run;
    const bool ok = IsBevelCorrectionRequest(body) ? BevelSimulateClosedLoop(body, &run, &error)
                                                   : SimulateClosedLoop(body, &run, &error);
    if (!ok) return RespondError(res, error);
    // Optionally keep each iteration's correction as a job, linked revision after revision.
    bool store = false;
    if (!ReadBool(body, "", "store", false, &store, &error)) return RespondError(res, error);
    std::optional<int64_t> previous;
    for (nlohmann::json& iteration : run.answer["iterations"]) {
      if (!iteration.contains("job_index")) continue;
      const int index = iteration["job_index"].get<int>();
      iteration.erase("job_index");
      if (!store) continue;
      JobRecord job = run.jobs[index];
      job.kind = "closed_loop";
      job.created_utc = CurrentUtcIso8601();
      job.server_version = ServerVersion();
      // Part k was ground with the settings job k-1 computed.
      job.settings_source_job_id = previous;
      previous = repository_->WriteJob(job);
      iteration["job_id"] = *previous;
    }
    RespondJson(res, 200, run.answer);
  }

  ServerOptions options_;
  std::vector<TokenEntry> tokens_;
  std::unique_ptr<JobRepository> repository_;
  Metrics metrics_;
  httplib::Server http_;
  std::unique_ptr<BatchRunner> batches_;
  std::map<std::string, std::set<std::string>> allowed_methods_;
  // Each route pattern with its Allow header, for the methods cpp-httplib has no handler table
  // for (TRACE, CONNECT): the pre-routing handler answers those 405 itself. Filled once by
  // RegisterRoutes before the server runs; read-only afterwards.
  std::vector<std::pair<std::regex, std::string>> allow_by_route_;
  int port_ = -1;
};

GearloopServer::GearloopServer(const ServerOptions& options) : impl_(std::make_unique<Impl>(options)) {}
GearloopServer::~GearloopServer() = default;
int GearloopServer::Bind() { return impl_->Bind(); }
void GearloopServer::Serve() { impl_->Serve(); }
void GearloopServer::Stop() { impl_->Stop(); }
int GearloopServer::port() const { return impl_->port(); }
bool GearloopServer::IsRunning() const { return impl_->IsRunning(); }
long long GearloopServer::QueuedBatchItems() const { return impl_->QueuedBatchItems(); }

}  // namespace gearloop
