// server/http/bounded_http.h: the connection layer under GearloopServer
// (docs/connections.md). cpp-httplib parses requests and routes them; this
// layer owns the sockets: an exclusive bind, a fixed number of connection
// threads with a cap per client address, a deadline for each whole request
// (head and body), an idle timeout between keep-alive requests, and the close
// of a connection whose body was refused before it was read.
//
//   ConnectionLimits limits;
//   limits.max_connections = 256;
//   BoundedHttpServer http(limits);
//   http.Post("/x", handler);            // as httplib::Server
//   ... in a handler: BoundedHttpServer::CloseAfterResponse();
#ifndef GEARLOOP_SERVER_HTTP_BOUNDED_HTTP_H_
#define GEARLOOP_SERVER_HTTP_BOUNDED_HTTP_H_

#include <map>
#include <mutex>
#include <string>

// Last in every .cc: see server/respond.h.
#include <httplib.h>

namespace gearloop {

struct ConnectionLimits {
  // Connections served at once; each holds one thread. Beyond it a new
  // connection is answered 503 at once and closed.
  int max_connections = 256;
  // Connections one client address may hold open at once (503 beyond).
  int max_connections_per_client = 128;
  // A request's head and body must have arrived this long after its first
  // byte, or it is answered 408 and the connection closed.
  double request_deadline_seconds = 10.0;
  // Longest silence while a request arrives.
  double read_timeout_seconds = 5.0;
  // Longest wait for the next request on a keep-alive connection.
  double idle_timeout_seconds = 5.0;
  // Longest wait for the client to take response bytes.
  double write_timeout_seconds = 10.0;
  // Requests on one connection before it is closed.
  int max_requests_per_connection = 1000;
};

class BoundedHttpServer : public httplib::Server {
 public:
  explicit BoundedHttpServer(const ConnectionLimits& limits);

  // Binds without port sharing (SO_REUSEADDR only: a port another process
  // listens on is refused). Returns the port, or -1 with the reason in
  // bind_error().
  int BindExclusive(const std::string& host, int port);
  const std::string& bind_error() const { return bind_error_; }

  // For the request being handled on this thread: close the connection after
  // its response (its body was not read, or not all of it).
  static void CloseAfterResponse();
  // True when the request being handled on this thread ran past its deadline
  // while its head or body arrived.
  static bool DeadlinePassed();

  // Connections open now.
  int OpenConnections() const;

 private:
  // cpp-httplib's per-connection entry point (run on a pool thread).
  bool process_and_close_socket(socket_t sock) override;
  // Serves the requests of one admitted connection.
  bool ServeConnection(socket_t sock);
  bool AdmitClient(const std::string& address);
  void ReleaseClient(const std::string& address);

  ConnectionLimits limits_;
  std::string bind_error_;
  mutable std::mutex clients_mutex_;
  std::map<std::string, int> connections_by_client_;
  int open_connections_ = 0;
};

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_HTTP_BOUNDED_HTTP_H_
