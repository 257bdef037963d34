// gearloop-load: a small load generator for a running gearloop-server. Posts
// corrections of the API.md example gear from N concurrent clients (each on its
// own keep-alive connection) for a fixed time, then reports latency percentiles
// and throughput, and checks that every job the server acknowledged (201) is
// stored (GET each one).
//
//   gearloop-load [--host 127.0.0.1] [--port 8080] [--clients 1] [--seconds 10]
//   [--token T]
//                 [--rate R]
//
// --rate R paces each client to R requests per second (0 = as fast as answers
// come), for a soak at a steady load; the latency figures are then printed
// every 10 s as well.
//
// The measurement is simulated once by the server
// (/api/v1/simulations/measurement) so every request is a realistic solve, not
// a trivial one.
#include <httplib.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

namespace {

nlohmann::json DefaultSetup() {
  return nlohmann::json::parse(R"({
    "gear": {"teeth": 37, "normal_module_mm": 6, "normal_pressure_angle_deg": 20,
             "helix_angle_deg": 15, "hand": "left", "face_width_mm": 78,
             "tip_radius_mm": 120.9157, "root_radius_mm": 107.1569},
    "wheel": {"radius_mm": 350}, "flank": "right"})");
}

double Percentile(std::vector<double> values, double p) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const size_t index = std::min(
      values.size() - 1, static_cast<size_t>(p * (values.size() - 1) + 0.5));
  return values[index];
}

struct LoadOptions {
  std::string host = "127.0.0.1";
  int port = 8080;
  int clients = 1;
  double seconds = 10.0;
  std::string token;
  double rate = 0.0;
};

void PrintUsage(std::FILE* out) {
  std::fprintf(out,
               "usage: gearloop-load [--host 127.0.0.1] [--port 8080] "
               "[--clients 1] [--seconds 10]\n"
               "                     [--token T] [--rate R]\n"
               "Posts corrections of the API.md example gear to a running "
               "gearloop-server from\n"
               "N concurrent clients, then prints latency percentiles and "
               "throughput and checks\n"
               "that every acknowledged job is stored. --rate R paces each "
               "client to R requests\n"
               "per second (0 = as fast as answers come).\n");
}

// A whole number or decimal of the argument `name`; false (reported) when it
// is not one, or below `min`.
bool ParseNumber(const std::string& name,
                 const char* text,
                 double min,
                 double* out) {
  char* end = nullptr;
  const double value = std::strtod(text, &end);
  if (end == text || *end != '\0' || !(value >= min) || value > 1e9) {
    std::fprintf(stderr,
                 "%s must be a number >= %g, not \"%s\"\n",
                 name.c_str(),
                 min,
                 text);
    return false;
  }
  *out = value;
  return true;
}

// Reads the command line. Returns -1 to go on, or the exit code: 0 after
// --help, 2 on a bad argument (reported, with the usage).
int ParseArguments(int argc, char** argv, LoadOptions* options) {
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--help" || arg == "-h") {
      PrintUsage(stdout);
      return 0;
    }
    if (i + 1 >= argc) {
      std::fprintf(stderr, "unknown or incomplete argument %s\n", arg.c_str());
      PrintUsage(stderr);
      return 2;
    }
    const char* value = argv[++i];
    double number = 0;
    bool ok = true;
    if (arg == "--host") {
      options->host = value;
    } else if (arg == "--token") {
      options->token = value;
    } else if (arg == "--port") {
      ok = ParseNumber(arg, value, 1, &number) && number <= 65535;
      options->port = static_cast<int>(number);
    } else if (arg == "--clients") {
      ok = ParseNumber(arg, value, 1, &number);
      options->clients = static_cast<int>(number);
    } else if (arg == "--seconds") {
      ok = ParseNumber(arg, value, 0, &number);
      options->seconds = number;
    } else if (arg == "--rate") {
      ok = ParseNumber(arg, value, 0, &number);
      options->rate = number;
    } else {
      std::fprintf(stderr, "unknown argument %s\n", arg.c_str());
      ok = false;
    }
    if (!ok) {
      PrintUsage(stderr);
      return 2;
    }
  }
  return -1;
}

// Has the server simulate a measurement of the default gear and returns the
// body of a correction request for it; false when the server cannot
// (reported).
bool BuildCorrectionBody(httplib::Client& setup_client,
                         const httplib::Headers& headers,
                         const LoadOptions& options,
                         std::string* body) {
  nlohmann::json simulation = DefaultSetup();
  simulation["random_hidden_errors"] = {
      {"block_size", 3.0}, {"max_order", 2}, {"seed", 4}};
  simulation["noise_um"] = 0.3;
  auto simulated = setup_client.Post("/api/v1/simulations/measurement",
                                     headers,
                                     simulation.dump(),
                                     "application/json");
  if (!simulated || simulated->status != 200) {
    std::fprintf(stderr,
                 "cannot simulate a measurement on %s:%d\n",
                 options.host.c_str(),
                 options.port);
    return false;
  }
  nlohmann::json request = DefaultSetup();
  request["measurement"] =
      nlohmann::json::parse(simulated->body)["measurement"];
  request["options"] = {{"probe_noise_um", 0.3}};
  *body = request.dump();
  return true;
}

// What the clients gathered: latencies and ids of acknowledged jobs, and the
// count of failed requests.
struct LoadResults {
  std::mutex mutex;
  std::vector<double> latencies_ms;
  std::vector<long long> ids;
  std::atomic<long long> errors{0};
};

// steady_clock::now() plus a duration in seconds of double.
using Deadline = decltype(std::chrono::steady_clock::now() +
                          std::chrono::duration<double>(1.0));

// One client: posts the body on its own keep-alive connection until end,
// paced to options.rate, printing the latency of the last 10 s when paced.
void RunClient(const LoadOptions& options,
               const httplib::Headers& headers,
               const std::string& body,
               std::chrono::steady_clock::time_point start,
               Deadline end,
               LoadResults* results) {
  const double rate = options.rate;
  httplib::Client client(options.host, options.port);
  client.set_keep_alive(true);
  client.set_tcp_nodelay(true);
  client.set_read_timeout(60, 0);
  std::vector<double> local;
  std::vector<long long> local_ids;
  auto next = std::chrono::steady_clock::now();
  while (std::chrono::steady_clock::now() < end) {
    if (rate > 0.0) {
      next += std::chrono::duration_cast<std::chrono::steady_clock::duration>(
          std::chrono::duration<double>(1.0 / rate));
      std::this_thread::sleep_until(next);
    }
    const auto t0 = std::chrono::steady_clock::now();
    auto result =
        client.Post("/api/v1/corrections", headers, body, "application/json");
    const double ms = std::chrono::duration<double, std::milli>(
                          std::chrono::steady_clock::now() - t0)
                          .count();
    if (!result || result->status != 201) {
      ++results->errors;
      continue;
    }
    local.push_back(ms);
    local_ids.push_back(
        nlohmann::json::parse(result->body)["id"].get<long long>());
    if (rate > 0.0 &&
        local.size() % static_cast<size_t>(std::max(1.0, 10.0 * rate)) == 0) {
      const std::vector<double> window(
          local.end() - static_cast<long>(std::max(1.0, 10.0 * rate)),
          local.end());
      std::lock_guard<std::mutex> lock(results->mutex);
      std::printf("  t = %5.0f s: last 10 s p50 %.2f ms, p99 %.2f ms\n",
                  std::chrono::duration<double>(
                      std::chrono::steady_clock::now() - start)
                      .count(),
                  Percentile(window, 0.5),
                  Percentile(window, 0.99));
      std::fflush(stdout);
    }
  }
  std::lock_guard<std::mutex> lock(results->mutex);
  results->latencies_ms.insert(
      results->latencies_ms.end(), local.begin(), local.end());
  results->ids.insert(results->ids.end(), local_ids.begin(), local_ids.end());
}

}  // namespace

int main(int argc, char** argv) {
  LoadOptions options;
  const int exit_code = ParseArguments(argc, argv, &options);
  if (exit_code >= 0) return exit_code;
  httplib::Headers headers;
  if (!options.token.empty())
    headers.emplace("Authorization", "Bearer " + options.token);

  httplib::Client setup_client(options.host, options.port);
  setup_client.set_read_timeout(60, 0);
  std::string body;
  if (!BuildCorrectionBody(setup_client, headers, options, &body)) return 1;

  LoadResults results;
  const auto start = std::chrono::steady_clock::now();
  const auto end = start + std::chrono::duration<double>(options.seconds);
  std::vector<std::thread> threads;
  for (int c = 0; c < options.clients; ++c) {
    threads.emplace_back(
        [&] { RunClient(options, headers, body, start, end, &results); });
  }
  for (std::thread& thread : threads) thread.join();
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
          .count();

  const std::vector<double>& latencies_ms = results.latencies_ms;
  const std::vector<long long>& ids = results.ids;
  long long missing = 0;
  for (long long id : ids) {
    auto result = setup_client.Get(
        ("/api/v1/corrections/" + std::to_string(id)).c_str(), headers);
    if (!result || result->status != 200) ++missing;
  }
  std::printf("clients %d, %.1f s: %zu corrections (%.1f/s), errors %lld\n",
              options.clients,
              elapsed,
              latencies_ms.size(),
              latencies_ms.size() / elapsed,
              results.errors.load());
  std::printf("latency ms: p50 %.2f  p90 %.2f  p99 %.2f  max %.2f\n",
              Percentile(latencies_ms, 0.5),
              Percentile(latencies_ms, 0.9),
              Percentile(latencies_ms, 0.99),
              Percentile(latencies_ms, 1.0));
  std::printf("acknowledged jobs stored: %lld of %zu\n",
              static_cast<long long>(ids.size()) - missing,
              ids.size());
  return missing == 0 && results.errors == 0 ? 0 : 1;
}
