#include "server/http/gearloop_server.h"

#include <algorithm>
#include <chrono>
#include <functional>
#include <iomanip>
#include <map>
#include <regex>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

#include "clients/web/web_assets.h"
#include "server/http/auth.h"
#include "server/http/batch_runner.h"
#include "server/http/metrics.h"
#include "server/http/openapi_document.h"
#include "server/respond.h"
#include "server/services/bevel_service.h"
#include "server/services/correction_service.h"
#include "server/services/grinder_service.h"
#include "server/services/history_service.h"
#include "server/services/measurement_service.h"
#include "server/services/reach_service.h"
#include "server/services/service_context.h"
#include "server/services/settings_service.h"
#include "server/services/shaving_service.h"
#include "server/services/simulation_service.h"
#include "server/services/split_bevel_service.h"
#include "storage/job_repository.h"

// Last: <httplib.h> pulls in <resolv.h>, whose `_res` macro breaks Eigen's
// headers if they come after it.
#include <glog/logging.h>
#include <httplib.h>
#include <malloc.h>
#include <strings.h>

#include "server/http/bounded_http.h"

#ifndef GEARLOOP_VERSION
#define GEARLOOP_VERSION "0.0.0"
#endif

namespace gearloop {

const char* ServerVersion() { return GEARLOOP_VERSION; }

namespace {

using Clock = std::chrono::steady_clock;

// Per-request context. cpp-httplib runs the pre-routing handler, the route
// handler and the logger of one request on the same pool thread, so a
// thread_local carries the start time and the matched route pattern from the
// first to the last without touching the request object.
struct RequestContext {
  Clock::time_point start;
  bool started = false;
  const char* route = "unmatched";
};
thread_local RequestContext t_request;

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

// A route of the API: a plain handler or a service handler of the context.
struct ApiRoute {
  const char* method;
  const char* pattern;
  const char* route;
  Access access;
  void (*handler)(const httplib::Request&, httplib::Response&);
  void (*service)(const ServiceContext&,
                  const httplib::Request&,
                  httplib::Response&);
};

// The API routes in registration order.
const ApiRoute kApiRoutes[] = {
    {"POST",
     "/api/v1/nominal",
     "POST /api/v1/nominal",
     Access::kRead,
     GrinderNominal,
     nullptr},
    {"POST",
     "/api/v1/evaluate",
     "POST /api/v1/evaluate",
     Access::kRead,
     GrinderEvaluate,
     nullptr},
    {"POST",
     "/api/v1/sensitivity",
     "POST /api/v1/sensitivity",
     Access::kRead,
     GrinderSensitivity,
     nullptr},
    {"POST",
     "/api/v1/corrections",
     "POST /api/v1/corrections",
     Access::kWrite,
     nullptr,
     CreateCorrection},
    {"GET",
     "/api/v1/corrections",
     "GET /api/v1/corrections",
     Access::kRead,
     nullptr,
     ListCorrections},
    {"GET",
     R"(/api/v1/corrections/(\d+))",
     "GET /api/v1/corrections/{id}",
     Access::kRead,
     nullptr,
     GetCorrection},
    {"GET",
     R"(/api/v1/corrections/(\d+)/lineage)",
     "GET /api/v1/corrections/{id}/lineage",
     Access::kRead,
     nullptr,
     GetLineage},
    {"POST",
     R"(/api/v1/corrections/(\d+)/replay)",
     "POST /api/v1/corrections/{id}/replay",
     Access::kWrite,
     nullptr,
     ReplayCorrection},
    {"POST",
     "/api/v1/batches",
     "POST /api/v1/batches",
     Access::kWrite,
     nullptr,
     CreateBatch},
    {"GET",
     R"(/api/v1/batches/(\d+))",
     "GET /api/v1/batches/{id}",
     Access::kRead,
     nullptr,
     GetBatch},
    {"POST",
     "/api/v1/simulations/measurement",
     "POST /api/v1/simulations/measurement",
     Access::kRead,
     nullptr,
     SimulateMeasurement},
    {"POST",
     "/api/v1/bevel/conversions",
     "POST /api/v1/bevel/conversions",
     Access::kRead,
     BevelConversion,
     nullptr},
    {"POST",
     "/api/v1/bevel/evaluate",
     "POST /api/v1/bevel/evaluate",
     Access::kRead,
     BevelEvaluate,
     nullptr},
    {"POST",
     "/api/v1/bevel/axis-sensitivity",
     "POST /api/v1/bevel/axis-sensitivity",
     Access::kRead,
     BevelAxisSensitivity,
     nullptr},
    {"POST",
     "/api/v1/simulations/closed-loop",
     "POST /api/v1/simulations/closed-loop",
     Access::kWrite,
     nullptr,
     SimulateClosedLoop},
    {"POST",
     "/api/v1/measurements/import",
     "POST /api/v1/measurements/import",
     Access::kRead,
     ImportMeasurement,
     nullptr},
    {"GET",
     R"(/api/v1/corrections/(\d+)/export)",
     "GET /api/v1/corrections/{id}/export",
     Access::kRead,
     nullptr,
     ExportCorrection},
    {"POST",
     "/api/v1/targets/reach",
     "POST /api/v1/targets/reach",
     Access::kRead,
     nullptr,
     ReachTarget},
    {"GET",
     "/api/v1/openapi.yaml",
     "GET /api/v1/openapi.yaml",
     Access::kOpen,
     ServeOpenApiDocument,
     nullptr},
    {"GET",
     R"(/api/v1/corrections/(\d+)/settings)",
     "GET /api/v1/corrections/{id}/settings",
     Access::kRead,
     nullptr,
     GetCorrectionSettings},
    {"POST",
     "/api/v1/shaving/cutter-target",
     "POST /api/v1/shaving/cutter-target",
     Access::kRead,
     ShavingCutterTarget,
     nullptr},
    {"POST",
     "/api/v1/bevel/split-trajectory",
     "POST /api/v1/bevel/split-trajectory",
     Access::kWrite,
     nullptr,
     CreateSplitTrajectory},
    {"GET",
     R"(/api/v1/bevel/split-trajectory/(\d+)/nc)",
     "GET /api/v1/bevel/split-trajectory/{id}/nc",
     Access::kRead,
     nullptr,
     GetSplitTrajectoryNc},
};

}  // namespace

class GearloopServer::Impl {
 public:
  explicit Impl(const ServerOptions& options)
      : options_(options), http_(LimitsFor(options)) {
    if (!options_.token_file.empty()) {
      tokens_ = LoadTokenFile(options_.token_file);
    } else if (!IsLoopbackHost(options_.host)) {
      throw std::runtime_error("refusing to listen on " + options_.host +
                               " without a token file: without --token-file "
                               "the server listens on loopback only");
    }
    repository_ = OpenJobRepository(options_.database_path);
    ReleaseLargeBuffers();
    ConfigureContext();
    ConfigureHttp();
    RegisterRoutes();
    batches_ = std::make_unique<BatchRunner>(
        options_.batch_workers,
        [this](const PendingBatchItem& item) { RunBatchItem(context_, item); });
    // Work acknowledged before the last stop (or crash) resumes now.
    std::vector<PendingBatchItem> pending =
        repository_->ReadPendingBatchItems();
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
    port_ = http_.BindExclusive(options_.host, options_.port);
    return port_;
  }
  const std::string& bind_error() const { return http_.bind_error(); }

  void Serve() {
    http_.listen_after_bind();
    // listen_after_bind returns once the pool has answered every request in
    // flight.
    batches_->Stop();
  }

  void Stop() { http_.stop(); }
  int port() const { return port_; }
  bool IsRunning() const { return http_.is_running(); }
  int OpenConnections() const { return http_.OpenConnections(); }
  long long QueuedBatchItems() const {
    return static_cast<long long>(batches_->Queued());
  }

 private:
  using Handler =
      std::function<void(const httplib::Request&, httplib::Response&)>;

  // glibc raises its mmap threshold to the largest block freed so far (up to
  // 32 MiB), after which a body-sized buffer is carved from the thread's
  // arena, and the top of a thread's arena is never trimmed (malloc_trim
  // trims the main arena's only): every connection thread kept ~8 MB after
  // one large request. Fixed thresholds keep blocks of 256 KiB and more in
  // their own mappings, given back on free.
  static void ReleaseLargeBuffers() {
    mallopt(M_MMAP_THRESHOLD, 256 << 10);
    mallopt(M_TRIM_THRESHOLD, 512 << 10);
  }

  static ConnectionLimits LimitsFor(const ServerOptions& options) {
    ConnectionLimits limits;
    limits.max_connections = options.threads > 0 ? options.threads : 256;
    limits.max_connections_per_client = options.max_connections_per_client;
    limits.request_deadline_seconds = options.request_deadline_seconds;
    limits.read_timeout_seconds = options.read_timeout_seconds;
    limits.idle_timeout_seconds = options.idle_timeout_seconds;
    return limits;
  }

  void ConfigureHttp() {
    // Bodies are read by the POST routes themselves (ReadBody), counted as
    // they arrive; this is cpp-httplib's own backstop for the rest.
    http_.set_payload_max_length(options_.payload_max_bytes);
    // cpp-httplib writes the head and the body of a response separately; with
    // Nagle on, the body waits for the client's delayed ACK (~40 ms per request
    // on Linux).
    http_.set_tcp_nodelay(true);
    SetPreRoutingHandler();
    SetErrorHandlers();
    SetLogger();
  }

  // A path of the API with the methods it serves and the access each needs.
  struct KnownPath {
    std::string source;
    std::regex pattern;
    std::map<std::string, Access> access;  // by method
    std::string allow;                     // "GET, POST"
  };

  const KnownPath* FindPath(const std::string& path) const {
    for (const KnownPath& known : known_paths_) {
      if (std::regex_match(path, known.pattern)) return &known;
    }
    return nullptr;
  }

  // What the head of a request says about its body: a Content-Length that is
  // a plain number within the limit, or chunked transfer coding (counted as it
  // arrives by ReadBody), never both.
  bool CheckFraming(const httplib::Request& req, ApiError* error) const {
    const bool has_length = req.has_header("Content-Length");
    const std::string coding = req.get_header_value("Transfer-Encoding");
    if (req.has_header("Transfer-Encoding")) {
      if (strcasecmp(coding.c_str(), "chunked") != 0) {
        *error = InvalidRequest("",
                                "Transfer-Encoding \"" + coding +
                                    "\" is not supported (only "
                                    "chunked)");
        return false;
      }
      if (has_length) {
        *error =
            InvalidRequest("",
                           "a request may not carry both Content-Length and "
                           "Transfer-Encoding");
        return false;
      }
      return true;
    }
    if (!has_length) return true;
    const std::string length = req.get_header_value("Content-Length");
    if (length.empty() || length.size() > 19 ||
        length.find_first_not_of("0123456789") != std::string::npos) {
      *error = InvalidRequest(
          "", "Content-Length \"" + length + "\" is not a non-negative number");
      return false;
    }
    if (std::stoull(length) > options_.payload_max_bytes) {
      *error = TooLarge();
      return false;
    }
    return true;
  }

  ApiError TooLarge() const {
    return ApiError{413,
                    "payload_too_large",
                    "the request body is larger than the server accepts (" +
                        std::to_string(options_.payload_max_bytes) + " bytes)",
                    ""};
  }

  // Decides every request from its head before a byte of its body is read:
  // the path (404), the method (405), the framing of the body (400, 413) and
  // the token (401, 403). A refused request's body is never read: the
  // connection is closed after the answer.
  void SetPreRoutingHandler() {
    http_.set_pre_routing_handler([this](const httplib::Request& req,
                                         httplib::Response& res) {
      t_request.start = Clock::now();
      t_request.started = true;
      t_request.route = "unmatched";
      ApiError error;
      const KnownPath* known = FindPath(req.path);
      const std::string method = req.method == "HEAD" ? "GET" : req.method;
      if (known == nullptr) {
        error = ApiError{404, "not_found", "no such resource", ""};
      } else if (!known->access.count(method)) {
        t_request.route = "method_not_allowed";
        res.set_header("Allow", known->allow);
        error =
            ApiError{405,
                     "method_not_allowed",
                     req.method + " is not allowed here; use " + known->allow,
                     ""};
      } else if (CheckFraming(req, &error) &&
                 Authorize(tokens_, req, known->access.at(method), &error)) {
        if (method == "POST" && !req.has_header("Content-Length") &&
            !req.has_header("Transfer-Encoding")) {
          // HTTP/1.1: no length and no coding means no body (cpp-httplib
          // would read until the client closes).
          const_cast<httplib::Request&>(req).set_header("Content-Length", "0");
        }
        return httplib::Server::HandlerResponse::Unhandled;
      }
      BoundedHttpServer::CloseAfterResponse();
      RespondError(res, error);
      return httplib::Server::HandlerResponse::Handled;
    });
  }

  // Reads a POST body through `reader`, counting it as it arrives (chunked or
  // not) and stopping at the limit. False with the error (413, 408, 400) when
  // the body is refused; the connection is then closed.
  bool ReadBody(const httplib::ContentReader& reader,
                std::string* body,
                ApiError* error) const {
    const size_t limit = options_.payload_max_bytes;
    bool too_large = false;
    const bool read = reader([&](const char* data, size_t size) {
      if (body->size() + size > limit) {
        too_large = true;
        return false;
      }
      body->append(data, size);
      return true;
    });
    if (read) return true;
    BoundedHttpServer::CloseAfterResponse();
    if (too_large) {
      *error = TooLarge();
    } else if (BoundedHttpServer::DeadlinePassed()) {
      *error = ApiError{408,
                        "request_timeout",
                        "the request body did not arrive in time",
                        ""};
    } else {
      *error = InvalidRequest(
          "",
          "the request body could not be read (broken chunked coding, or "
          "the connection ended early)");
    }
    return false;
  }

  void SetErrorHandlers() {
    // Errors cpp-httplib raises itself (404 without a route, 413, 400 for a
    // broken request line, ...) get the same JSON body as ours; our own error
    // bodies pass unchanged.
    httplib::Server::HandlerWithResponse error_handler =
        [](const httplib::Request&, httplib::Response& res) {
          if (!res.body.empty())
            return httplib::Server::HandlerResponse::Unhandled;
          // cpp-httplib's own refusals (a broken head, a head that did not
          // arrive in time) leave the rest of the request unread: close.
          BoundedHttpServer::CloseAfterResponse();
          if (BoundedHttpServer::DeadlinePassed()) res.status = 408;
          ApiError error;
          error.status = res.status;
          error.code = CodeForStatus(res.status);
          switch (res.status) {
            case 404:
              error.message = "no such resource";
              break;
            case 408:
              error.message = "the request did not arrive in time";
              break;
            case 413:
              error.message =
                  "the request body is larger than the server accepts";
              break;
            default:
              error.message =
                  "request refused (HTTP " + std::to_string(res.status) + ")";
          }
          res.set_content(Dump(ErrorBody(error)), "application/json");
          return httplib::Server::HandlerResponse::Handled;
        };
    http_.set_error_handler(error_handler);

    http_.set_exception_handler([](const httplib::Request& req,
                                   httplib::Response& res,
                                   std::exception_ptr ep) {
      // Only reached for exceptions our wrapper could not see (e.g. inside
      // cpp-httplib).
      std::string what = "unknown";
      try {
        if (ep) std::rethrow_exception(ep);
      } catch (const std::exception& e) {
        what = e.what();
      } catch (...) {
      }
      LOG(ERROR) << "unhandled exception on " << req.method << " " << req.path
                 << ": " << what;
      RespondError(
          res,
          ApiError{
              500, "internal_error", "internal error; nothing was stored", ""});
    });
  }

  void SetLogger() {
    http_.set_logger([this](const httplib::Request& req,
                            const httplib::Response& res) {
      const double seconds =
          t_request.started
              ? std::chrono::duration<double>(Clock::now() - t_request.start)
                    .count()
              : 0.0;
      t_request.started = false;
      metrics_.RecordRequest(t_request.route, res.status, seconds);
      if (options_.access_log) {
        LOG(INFO) << req.method << " " << req.path << " " << res.status << " "
                  << std::fixed << std::setprecision(2) << seconds * 1e3
                  << " ms";
      }
    });
  }

  // Wraps a handler: records the route pattern for the metrics and catches
  // every exception once, at the top (500 and one log line; OSRM
  // request_handler.cpp). The token was checked before routing.
  static Handler Route(const char* route, Handler handler) {
    return
        [route, handler](const httplib::Request& req, httplib::Response& res) {
          t_request.route = route;
          try {
            handler(req, res);
          } catch (const std::exception& e) {
            LOG(ERROR) << "internal error on " << req.method << " " << req.path
                       << ": " << e.what();
            res.headers.erase("Location");
            RespondError(res,
                         ApiError{500,
                                  "internal_error",
                                  "internal error; nothing was stored",
                                  ""});
          }
        };
  }

  void Register(const std::string& method,
                const std::string& pattern,
                const char* route,
                Access access,
                Handler handler) {
    Handler wrapped = Route(route, std::move(handler));
    if (method == "GET") {
      http_.Get(pattern, wrapped);
    } else {
      http_.Post(pattern,
                 [this, route, wrapped](const httplib::Request& req,
                                        httplib::Response& res,
                                        const httplib::ContentReader& reader) {
                   ReadBodyAndHandle(route, wrapped, req, res, reader);
                 });
    }
    auto known = std::find_if(
        known_paths_.begin(), known_paths_.end(), [&](const KnownPath& k) {
          return k.source == pattern;
        });
    if (known == known_paths_.end()) {
      known_paths_.push_back(KnownPath{pattern, std::regex(pattern), {}, ""});
      known = known_paths_.end() - 1;
    }
    known->access[method] = access;
  }

  // A POST route: the body is read here (ReadBody), then the handler runs on
  // it. Memory a large body took is handed back to the system afterwards, so
  // that no thread keeps a plateau as large as the body limit.
  void ReadBodyAndHandle(const char* route,
                         const Handler& handler,
                         const httplib::Request& req,
                         httplib::Response& res,
                         const httplib::ContentReader& reader) const {
    t_request.route = route;
    std::string body;
    ApiError error;
    const bool read = ReadBody(reader, &body, &error);
    const bool large = body.size() > (1u << 20);
    if (!read) {
      RespondError(res, error);
    } else {
      // cpp-httplib hands content-reader routes a const request whose body it
      // has not filled; the request object itself is not const
      // (process_request owns it), and the handlers read req.body.
      const_cast<httplib::Request&>(req).body = std::move(body);
      handler(req, res);
      const_cast<httplib::Request&>(req).body = std::string();
    }
    body = std::string();
    if (large) malloc_trim(0);
  }

  // A service handler of the context (server/services/).
  void RegisterService(const std::string& method,
                       const std::string& pattern,
                       const char* route,
                       Access access,
                       void (*service)(const ServiceContext&,
                                       const httplib::Request&,
                                       httplib::Response&)) {
    Register(
        method,
        pattern,
        route,
        access,
        [this, service](const httplib::Request& req, httplib::Response& res) {
          service(context_, req, res);
        });
  }

  void ConfigureContext() {
    context_.repository = repository_.get();
    context_.server_version = ServerVersion();
    context_.record_solve_seconds = [this](double seconds) {
      metrics_.RecordSolve(seconds);
    };
    context_.log_solves = options_.access_log;
    context_.queued_batch_items = [this] { return batches_->Queued(); };
    context_.enqueue_batch_items = [this](std::vector<PendingBatchItem> items) {
      batches_->Enqueue(std::move(items));
    };
    context_.token_name = [this](const std::string& header) {
      return TokenName(tokens_, header);
    };
    context_.max_batch_items = options_.max_batch_items;
    context_.max_queued_batch_items = options_.max_queued_batch_items;
  }

  void RegisterRoutes() {
    Register("GET",
             "/healthz",
             "GET /healthz",
             Access::kOpen,
             [](const httplib::Request&, httplib::Response& res) {
               RespondJson(
                   res, 200, {{"status", "ok"}, {"version", ServerVersion()}});
             });
    Register("GET",
             "/metrics",
             "GET /metrics",
             Access::kOpen,
             [this](const httplib::Request&, httplib::Response& res) {
               res.status = 200;
               res.set_content(
                   metrics_.Render(repository_->CountJobs(),
                                   static_cast<int64_t>(batches_->Queued())),
                   "text/plain; version=0.0.4");
             });
    for (const ApiRoute& r : kApiRoutes) {
      if (r.service != nullptr) {
        RegisterService(r.method, r.pattern, r.route, r.access, r.service);
      } else {
        Register(r.method, r.pattern, r.route, r.access, r.handler);
      }
    }
    RegisterDashboard();
    FinishKnownPaths();
  }

  // The dashboard (clients/web, embedded in the binary). Its pages hold no
  // data: the API calls they make carry the token.
  void RegisterDashboard() {
    Register("GET",
             R"(/|/jobs/\d+/report|/static/[A-Za-z0-9._-]+)",
             "GET dashboard",
             Access::kOpen,
             [](const httplib::Request& req, httplib::Response& res) {
               std::string body;
               std::string content_type;
               if (!FindWebAsset(req.path, &body, &content_type)) {
                 return RespondError(
                     res, ApiError{404, "not_found", "no such resource", ""});
               }
               res.status = 200;
               res.set_content(body, content_type.c_str());
             });
  }

  // The Allow header of each known path (405 answers).
  void FinishKnownPaths() {
    for (KnownPath& known : known_paths_) {
      known.allow.clear();
      for (const auto& [method, access] : known.access)
        known.allow += (known.allow.empty() ? "" : ", ") + method;
    }
  }

  ServerOptions options_;
  std::vector<TokenEntry> tokens_;
  std::unique_ptr<JobRepository> repository_;
  ServiceContext context_;
  Metrics metrics_;
  BoundedHttpServer http_;
  std::unique_ptr<BatchRunner> batches_;
  // Every route pattern with its methods: the pre-routing handler answers 404
  // and 405 from it. Filled once by RegisterRoutes before the server runs;
  // read-only afterwards.
  std::vector<KnownPath> known_paths_;
  int port_ = -1;
};

GearloopServer::GearloopServer(const ServerOptions& options)
    : impl_(std::make_unique<Impl>(options)) {}
GearloopServer::~GearloopServer() = default;
int GearloopServer::Bind() { return impl_->Bind(); }
const std::string& GearloopServer::bind_error() const {
  return impl_->bind_error();
}
void GearloopServer::Serve() { impl_->Serve(); }
void GearloopServer::Stop() { impl_->Stop(); }
int GearloopServer::port() const { return impl_->port(); }
bool GearloopServer::IsRunning() const { return impl_->IsRunning(); }
int GearloopServer::OpenConnections() const { return impl_->OpenConnections(); }
long long GearloopServer::QueuedBatchItems() const {
  return impl_->QueuedBatchItems();
}

}  // namespace gearloop
