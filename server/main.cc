// gearloop-server: the HTTP server of gearloop (API.md).
//
//   gearloop-server [--port 8080] [--db ./gearloop.sqlite] [--host 127.0.0.1]
//   [--threads N]
//                   [--token-file F] [--batch-workers N] [--quiet]
//                   [--max-connections-per-client N] [--request-deadline S]
//                   [--seed-demo]
//
// --seed-demo: once listening, an empty job history is seeded with a short
// closed-loop demo (server/demo_seed.h) spoken over HTTP, and its summary
// printed; scripts/run uses it.
//
// SIGTERM or SIGINT stops it gracefully: no new connections, requests in flight
// are answered, batch workers finish the item in hand (waiting items stay
// pending in the database and resume on the next start).
#include <glog/logging.h>
#include <pthread.h>
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <string>
#include <thread>

#include "server/demo_seed.h"
#include "server/http/gearloop_server.h"

namespace {

void PrintUsage() {
  std::cerr << "usage: gearloop-server [--port 8080] [--db ./gearloop.sqlite] "
               "[--host 127.0.0.1]\n"
               "                       [--threads N] [--token-file F] "
               "[--batch-workers N] [--quiet]\n"
               "                       [--max-connections-per-client N] "
               "[--request-deadline S]\n"
               "                       [--seed-demo]\n"
               "--threads: connections served at once (default 256); "
               "docs/connections.md\n";
}

bool ParseInt(const char* text, int min, int max, int* out) {
  char* end = nullptr;
  const long value = std::strtol(text, &end, 10);
  if (end == text || *end != '\0' || value < min || value > max) return false;
  *out = static_cast<int>(value);
  return true;
}

// Reads the command line into *options and *seed_demo. Returns -1 to go on,
// or the exit code (0 after --help, 2 on a bad argument).
int ParseArguments(int argc,
                   char** argv,
                   gearloop::ServerOptions* options,
                   bool* seed_demo) {
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const bool has_value = i + 1 < argc;
    if (arg == "--help" || arg == "-h") {
      PrintUsage();
      return 0;
    } else if (arg == "--quiet") {
      options->access_log = false;
    } else if (arg == "--seed-demo") {
      *seed_demo = true;
    } else if (arg == "--port" && has_value) {
      if (!ParseInt(argv[++i], 0, 65535, &options->port)) {
        std::cerr << "--port must be 0..65535\n";
        return 2;
      }
    } else if (arg == "--threads" && has_value) {
      if (!ParseInt(argv[++i], 1, 1024, &options->threads)) {
        std::cerr << "--threads must be 1..1024\n";
        return 2;
      }
    } else if (arg == "--batch-workers" && has_value) {
      if (!ParseInt(argv[++i], 1, 64, &options->batch_workers)) {
        std::cerr << "--batch-workers must be 1..64\n";
        return 2;
      }
    } else if (arg == "--max-connections-per-client" && has_value) {
      if (!ParseInt(
              argv[++i], 1, 100000, &options->max_connections_per_client)) {
        std::cerr << "--max-connections-per-client must be 1..100000\n";
        return 2;
      }
    } else if (arg == "--request-deadline" && has_value) {
      int seconds = 0;
      if (!ParseInt(argv[++i], 1, 3600, &seconds)) {
        std::cerr << "--request-deadline must be 1..3600 seconds\n";
        return 2;
      }
      options->request_deadline_seconds = seconds;
    } else if (arg == "--db" && has_value) {
      options->database_path = argv[++i];
    } else if (arg == "--host" && has_value) {
      options->host = argv[++i];
    } else if (arg == "--token-file" && has_value) {
      options->token_file = argv[++i];
    } else {
      std::cerr << "unknown or incomplete argument: " << arg << "\n";
      PrintUsage();
      return 2;
    }
  }
  return -1;
}

// Once the server runs, seeds the demo (without tokens) and prints where the
// server listens.
void SeedDemoWhenRunning(const gearloop::GearloopServer& server,
                         const gearloop::ServerOptions& options,
                         int port) {
  while (!server.IsRunning())
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  if (!options.token_file.empty()) {
    std::cout << "Tokens are on: the demo is not seeded (it would need a "
                 "write token).\n";
  } else if (!gearloop::SeedDemo(options.host, port, "", std::cout)) {
    std::cout << "The demo could not be seeded (see above); the server keeps "
                 "running.\n";
  }
  std::cout << "\ngearloop-server is running on http://" << options.host << ":"
            << port
            << "  (dashboard: /, API: /api/v1, metrics: /metrics; Ctrl-C "
               "stops it)\n"
            << std::flush;
}

}  // namespace

int main(int argc, char** argv) {
  FLAGS_logtostderr = true;
  google::InitGoogleLogging(argv[0]);

  gearloop::ServerOptions options;
  bool seed_demo = false;
  const int exit_code = ParseArguments(argc, argv, &options, &seed_demo);
  if (exit_code >= 0) return exit_code;

  // Block the stop signals in every thread (the HTTP pool inherits the mask);
  // one thread waits for them with sigwait and stops the server from ordinary
  // code, not from a signal handler.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGTERM);
  sigaddset(&stop_signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);
  signal(SIGPIPE, SIG_IGN);

  std::unique_ptr<gearloop::GearloopServer> server;
  try {
    server = std::make_unique<gearloop::GearloopServer>(options);
  } catch (const std::exception& e) {
    LOG(ERROR) << "cannot start: " << e.what();
    return 1;
  }
  const int port = server->Bind();
  if (port < 0) {
    LOG(ERROR) << "cannot listen on " << options.host << ":" << options.port
               << ": " << server->bind_error();
    return 1;
  }
  if (options.token_file.empty()) {
    LOG(INFO)
        << "no token file: listening on loopback only, without access control";
  }
  LOG(INFO) << "gearloop-server " << gearloop::ServerVersion()
            << " listening on http://" << options.host << ":" << port
            << " (database " << options.database_path << ")";

  std::atomic<bool> signalled{false};
  std::thread signal_waiter([&server, &signalled, stop_signals] {
    int signal_number = 0;
    sigwait(&stop_signals, &signal_number);
    signalled = true;
    LOG(INFO) << "received " << strsignal(signal_number)
              << ": finishing requests in flight";
    server->Stop();
  });

  std::thread serving([&server] { server->Serve(); });
  if (seed_demo) SeedDemoWhenRunning(*server, options, port);
  serving.join();
  // Serve() returned: normally because the waiter called Stop(). Wake the
  // waiter otherwise, and let it leave Stop() before the server goes away.
  if (!signalled) kill(getpid(), SIGTERM);
  signal_waiter.join();
  server.reset();  // closes the database after the batch workers have stopped
  LOG(INFO) << "stopped";
  return 0;
}
