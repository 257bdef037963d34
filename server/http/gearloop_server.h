// server/http/gearloop_server.h: the gearloop HTTP server (API.md,
// api/openapi.yaml): cpp-httplib routes, one thin handler per endpoint (parse
// -> validate -> engine -> persist -> respond), the SQLite job history, a
// bounded background pool for batches, metrics and the access log.
//
//   ServerOptions options;
//   options.port = 0;                              // ephemeral; see port()
//   after Bind() options.database_path = "/tmp/gearloop.sqlite"; GearloopServer
//   server(options);                // opens and migrates the database if
//   (server.Bind() < 0) { ... } std::thread serving([&] { server.Serve(); });
//   // blocks until Stop()
//   ...
//   server.Stop();                                 // in-flight requests finish
//   first serving.join();
//
// Durability: a correction is answered 201 only after its job is committed; a
// batch is answered 202 only after all its items are committed as pending, and
// pending items are picked up again when the server starts, so no acknowledged
// work is lost by a stop or a crash.
#ifndef GEARLOOP_SERVER_HTTP_GEARLOOP_SERVER_H_
#define GEARLOOP_SERVER_HTTP_GEARLOOP_SERVER_H_

#include <cstddef>
#include <memory>
#include <string>

namespace gearloop {

struct ServerOptions {
  // Address to listen on. Without a token file only loopback addresses are
  // allowed.
  std::string host = "127.0.0.1";
  // TCP port; 0 picks a free one (read it from port() after Bind()).
  int port = 8080;
  // SQLite file of the job history (":memory:" for a throwaway one).
  std::string database_path = "./gearloop.sqlite";
  // Connections served at once (0 = 256); each holds one thread
  // (docs/connections.md). A connection beyond it is answered 503 at once.
  int threads = 0;
  // Connections one client address may hold at once (503 beyond).
  int max_connections_per_client = 128;
  // A request's head and body must arrive within this many seconds of its
  // first byte (408 beyond, and the connection is closed).
  double request_deadline_seconds = 10.0;
  // Seconds a keep-alive connection may wait idle for its next request.
  double idle_timeout_seconds = 5.0;
  // Background workers running batch items.
  int batch_workers = 1;
  // Largest request body accepted [bytes]; larger ones are answered 413.
  size_t payload_max_bytes = 8u << 20;
  // Most items in one batch, and most batch items waiting at once (503 beyond).
  int max_batch_items = 1000;
  int max_queued_batch_items = 20000;
  // Token file of issue 7 ("<role> <sha256-hex> [name]" per line); empty = no
  // tokens.
  std::string token_file;
  // One access-log line per request (method, path, status, ms) through glog.
  bool access_log = true;
  // Longest silence [s] while a request arrives before it is cut off.
  int read_timeout_seconds = 5;
};

// The server version reported in /healthz and stored with each job.
const char* ServerVersion();

class GearloopServer {
 public:
  // Opens (and migrates) the database and loads the token file. Throws
  // std::runtime_error (StorageError for the database) when either fails, or
  // when tokens are off and the host is not a loopback address.
  explicit GearloopServer(const ServerOptions& options);
  ~GearloopServer();
  GearloopServer(const GearloopServer&) = delete;
  GearloopServer& operator=(const GearloopServer&) = delete;

  // Binds the listening socket, without sharing the port with another
  // process; returns the bound port, or -1 when the address is unusable (the
  // reason in bind_error(), e.g. another server on the port).
  int Bind();
  const std::string& bind_error() const;
  // Serves requests until Stop(); returns after in-flight requests have been
  // answered. Bind() must have succeeded. Batch workers stop with it (their
  // current item is finished; waiting items stay pending in the database).
  void Serve();
  // Asks Serve() to return; callable from any thread, any number of times.
  void Stop();

  int port() const;
  // True once Serve() is accepting connections.
  bool IsRunning() const;
  // Number of batch items waiting for a worker.
  long long QueuedBatchItems() const;
  // Connections admitted and not yet closed (each counted against its
  // client's max_connections_per_client).
  int OpenConnections() const;

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_HTTP_GEARLOOP_SERVER_H_
