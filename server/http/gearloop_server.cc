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
  explicit Impl(const ServerOptions& options) : options_(options) {
    if (!options_.token_file.empty()) {
      tokens_ = LoadTokenFile(options_.token_file);
    } else if (!IsLoopbackHost(options_.host)) {
      throw std::runtime_error("refusing to listen on " + options_.host +
                               " without a token file: without --token-file "
                               "the server listens on loopback only");
    }
    repository_ = OpenJobRepository(options_.database_path);
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
    if (options_.port == 0) {
      port_ = http_.bind_to_any_port(options_.host);
    } else {
      port_ =
          http_.bind_to_port(options_.host, options_.port) ? options_.port : -1;
    }
    return port_;
  }

  void Serve() {
    http_.listen_after_bind();
    // listen_after_bind returns once the pool has answered every request in
    // flight.
    batches_->Stop();
  }

  void Stop() { http_.stop(); }
  int port() const { return port_; }
  bool IsRunning() const { return http_.is_running(); }
  long long QueuedBatchItems() const {
    return static_cast<long long>(batches_->Queued());
  }

 private:
  using Handler =
      std::function<void(const httplib::Request&, httplib::Response&)>;

  void ConfigureHttp() {
    const int threads =
        options_.threads > 0
            ? options_.threads
            : std::max(
                  16,
                  4 * static_cast<int>(std::thread::hardware_concurrency()));
    http_.new_task_queue = [threads] {
      return new httplib::ThreadPool(threads);
    };
    http_.set_payload_max_length(options_.payload_max_bytes);
    http_.set_read_timeout(options_.read_timeout_seconds, 0);
    http_.set_write_timeout(10, 0);
    http_.set_keep_alive_max_count(10000);
    http_.set_keep_alive_timeout(5);
    // cpp-httplib writes the head and the body of a response separately; with
    // Nagle on, the body waits for the client's delayed ACK (~40 ms per request
    // on Linux).
    http_.set_tcp_nodelay(true);
    SetPreRoutingHandler();
    SetErrorHandlers();
    SetLogger();
  }

  // Answers what no route should see: a method cpp-httplib does not route (405
  // on our paths) and an announced body larger than the server accepts (413,
  // before reading it).
  void SetPreRoutingHandler() {
    const size_t payload_max_bytes = options_.payload_max_bytes;
    httplib::Server::HandlerWithResponse pre_routing =
        [this, payload_max_bytes](const httplib::Request& req,
                                  httplib::Response& res) {
          t_request.start = Clock::now();
          t_request.started = true;
          t_request.route = "unmatched";
          // cpp-httplib routes GET, HEAD (to the GET handlers), POST, PUT,
          // PATCH, DELETE and OPTIONS, and answers any other method it parses
          // (TRACE, CONNECT) 400 without looking at the path. On one of our
          // paths that is a method the resource does not serve: 405.
          static const std::set<std::string> kRouted = {
              "GET", "HEAD", "POST", "PUT", "PATCH", "DELETE", "OPTIONS"};
          if (!kRouted.count(req.method)) {
            for (const auto& [route, allow] : allow_by_route_) {
              if (!std::regex_match(req.path, route)) continue;
              t_request.route = "method_not_allowed";
              res.set_header("Allow", allow);
              RespondError(
                  res,
                  ApiError{405,
                           "method_not_allowed",
                           req.method + " is not allowed here; use " + allow,
                           ""});
              return httplib::Server::HandlerResponse::Handled;
            }
          }
          // Refuse an announced oversized body before reading it (cpp-httplib
          // would first read and discard it all, holding a worker for as long
          // as the client cares to send), and close.
          const std::string length = req.get_header_value("Content-Length");
          if (!length.empty()) {
            char* end = nullptr;
            const unsigned long long bytes =
                std::strtoull(length.c_str(), &end, 10);
            if (end == length.c_str() || *end != '\0') {
              res.set_header("Connection", "close");
              RespondError(
                  res, InvalidRequest("", "Content-Length is not a number"));
              return httplib::Server::HandlerResponse::Handled;
            }
            if (bytes > payload_max_bytes) {
              res.set_header("Connection", "close");
              RespondError(
                  res,
                  ApiError{
                      413,
                      "payload_too_large",
                      "the request body is larger than the server accepts (" +
                          std::to_string(payload_max_bytes) + " bytes)",
                      ""});
              return httplib::Server::HandlerResponse::Handled;
            }
          }
          return httplib::Server::HandlerResponse::Unhandled;
        };
    http_.set_pre_routing_handler(pre_routing);
  }

  void SetErrorHandlers() {
    // Errors cpp-httplib raises itself (404 without a route, 413, 400 for a
    // broken request line, ...) get the same JSON body as ours; our own error
    // bodies pass unchanged.
    httplib::Server::HandlerWithResponse error_handler =
        [](const httplib::Request&, httplib::Response& res) {
          if (!res.body.empty())
            return httplib::Server::HandlerResponse::Unhandled;
          ApiError error;
          error.status = res.status;
          error.code = CodeForStatus(res.status);
          switch (res.status) {
            case 404:
              error.message = "no such resource";
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

  // Wraps a handler: records the route pattern for the metrics, checks the
  // token, and catches every exception once, at the top (500 and one log line;
  // OSRM request_handler.cpp).
  Handler Route(const char* route, Access access, Handler handler) {
    return [this, route, access, handler](const httplib::Request& req,
                                          httplib::Response& res) {
      t_request.route = route;
      try {
        ApiError error;
        if (!Authorize(tokens_, req, access, &error))
          return RespondError(res, error);
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
    Handler wrapped = Route(route, access, std::move(handler));
    if (method == "GET") {
      http_.Get(pattern, wrapped);
    } else {
      http_.Post(pattern, wrapped);
    }
    allowed_methods_[pattern].insert(method);
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
    RegisterMethodNotAllowed();
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

  // A known path with a method it does not serve: 405 with Allow (cpp-httplib
  // alone says 404).
  void RegisterMethodNotAllowed() {
    for (const auto& [pattern, methods] : allowed_methods_) {
      std::string allow;
      for (const std::string& m : methods)
        allow += (allow.empty() ? "" : ", ") + m;
      allow_by_route_.emplace_back(std::regex(pattern), allow);
      Handler not_allowed = Route(
          "method_not_allowed",
          Access::kOpen,
          [allow](const httplib::Request& req, httplib::Response& res) {
            res.set_header("Allow", allow);
            RespondError(
                res,
                ApiError{405,
                         "method_not_allowed",
                         req.method + " is not allowed here; use " + allow,
                         ""});
          });
      if (!methods.count("GET")) http_.Get(pattern, not_allowed);
      if (!methods.count("POST")) http_.Post(pattern, not_allowed);
      http_.Put(pattern, not_allowed);
      http_.Patch(pattern, not_allowed);
      http_.Delete(pattern, not_allowed);
      http_.Options(pattern, not_allowed);
    }
  }

  ServerOptions options_;
  std::vector<TokenEntry> tokens_;
  std::unique_ptr<JobRepository> repository_;
  ServiceContext context_;
  Metrics metrics_;
  httplib::Server http_;
  std::unique_ptr<BatchRunner> batches_;
  std::map<std::string, std::set<std::string>> allowed_methods_;
  // Each route pattern with its Allow header, for the methods cpp-httplib has
  // no handler table for (TRACE, CONNECT): the pre-routing handler answers
  // those 405 itself. Filled once by RegisterRoutes before the server runs;
  // read-only afterwards.
  std::vector<std::pair<std::regex, std::string>> allow_by_route_;
  int port_ = -1;
};

GearloopServer::GearloopServer(const ServerOptions& options)
    : impl_(std::make_unique<Impl>(options)) {}
GearloopServer::~GearloopServer() = default;
int GearloopServer::Bind() { return impl_->Bind(); }
void GearloopServer::Serve() { impl_->Serve(); }
void GearloopServer::Stop() { impl_->Stop(); }
int GearloopServer::port() const { return impl_->port(); }
bool GearloopServer::IsRunning() const { return impl_->IsRunning(); }
long long GearloopServer::QueuedBatchItems() const {
  return impl_->QueuedBatchItems();
}

}  // namespace gearloop
