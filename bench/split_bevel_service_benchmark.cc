// split_bevel_service_benchmark: issue 14's request (2 000 stations x 10 depth
// levels x 2 flanks = 40 000 points) through the server's service, as the
// handler of POST /api/v1/bevel/split-trajectory runs it (parse, IsValid,
// engine with the NC listing, the JSON answer, the job stored in a ":memory:"
// history), and its parts. No socket: server-side time only. Run:
// build/bench/split_bevel_service_benchmark (BENCHMARKS.md, "Split bevel
// trajectory").
#include <benchmark/benchmark.h>

#include <condition_variable>
#include <cstdio>
#include <functional>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>

#include "engine/split_bevel/trajectory.h"
#include "server/codec/split_bevel_codec.h"
#include "server/respond.h"
#include "server/services/service_context.h"
#include "server/services/split_bevel_service.h"
#include "storage/job_repository.h"

// Last: see server/respond.h.
#include <httplib.h>

namespace {

// The engine benchmark's case (bench/split_bevel_benchmark.cc) in the API's
// degrees: z = 75, delta = 70 deg, m_et = 40 mm, b = 240 mm, beta_m = 35 deg
// right hand, alpha = 20 deg, r0 = 8 mm, 0.2 mm stock, pivot 300 mm, slot 3.
std::string RequestBody(bool nc) {
  nlohmann::json body = nlohmann::json::parse(R"({
    "gear": {"teeth": 75, "pitch_angle_deg": 70, "outer_transverse_module_mm": 40,
             "face_width_mm": 240, "mean_spiral_angle_deg": 35, "hand": "right",
             "pressure_angle_deg": 20},
    "tool": {"radius_mm": 8, "stock_mm": 0.2},
    "cut": {"slot_index": 3, "flanks": ["convex", "concave"], "depth_levels": 10,
            "steps": 2000},
    "machine": {"pivot_length_mm": 300}})");
  body["output"] = {{"nc", nc}};
  return body.dump();
}

// The service context of the benchmarks: `repository` as the history, no
// solve log.
gearloop::ServiceContext BenchContext(gearloop::JobRepository* repository) {
  gearloop::ServiceContext context;
  context.repository = repository;
  context.server_version = "bench";
  context.log_solves = false;
  return context;
}

// POST /api/v1/bevel/split-trajectory with the benchmark's request.
httplib::Request SplitRequest(bool nc) {
  httplib::Request req;
  req.method = "POST";
  req.path = "/api/v1/bevel/split-trajectory";
  req.body = RequestBody(nc);
  return req;
}

// The whole handler: parse, validate, engine (always with the listing: the job
// keeps it), answer dumped once, job written to a ":memory:" history.
void ServiceBenchmark(benchmark::State& state,
                      bool nc,
                      const std::string& database = ":memory:") {
  std::unique_ptr<gearloop::JobRepository> repository =
      gearloop::OpenJobRepository(database);
  const gearloop::ServiceContext context = BenchContext(repository.get());
  const httplib::Request req = SplitRequest(nc);
  size_t bytes = 0;
  for (auto _ : state) {
    httplib::Response res;
    gearloop::CreateSplitTrajectory(context, req, res);
    if (res.status != 200) state.SkipWithError(res.body.substr(0, 200).c_str());
    bytes = res.body.size();
    benchmark::DoNotOptimize(res.body.data());
  }
  state.counters["answer_MB"] = static_cast<double>(bytes) / 1e6;
}

void BM_SplitTrajectoryService2000x10x2(benchmark::State& state) {
  ServiceBenchmark(state, /*nc=*/false);
}
BENCHMARK(BM_SplitTrajectoryService2000x10x2)->Unit(benchmark::kMillisecond);

void BM_SplitTrajectoryService2000x10x2WithNc(benchmark::State& state) {
  ServiceBenchmark(state, /*nc=*/true);
}
BENCHMARK(BM_SplitTrajectoryService2000x10x2WithNc)
    ->Unit(benchmark::kMillisecond);

// The same with the history in a SQLite file (WAL, synchronous=NORMAL), as the
// server keeps it.
void BM_SplitTrajectoryService2000x10x2FileDb(benchmark::State& state) {
  const std::string path = "/tmp/split_bevel_service_benchmark.sqlite";
  for (const char* suffix : {"", "-wal", "-shm"})
    std::remove((path + suffix).c_str());
  ServiceBenchmark(state, /*nc=*/false, path);
  for (const char* suffix : {"", "-wal", "-shm"})
    std::remove((path + suffix).c_str());
}
BENCHMARK(BM_SplitTrajectoryService2000x10x2FileDb)
    ->Unit(benchmark::kMillisecond);

// The whole handler on one long-lived thread, as cpp-httplib's thread pool
// runs it: its memory comes from that thread's malloc arena, not the main
// thread's (the 25 MB answer is allocated and freed on every request). Wall
// time only: the work is on the worker.
class Worker {
 public:
  Worker() : thread_([this] { Loop(); }) {}
  ~Worker() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    thread_.join();
  }
  // Runs `task` on the worker and waits for it.
  void Run(std::function<void()> task) {
    std::unique_lock<std::mutex> lock(mutex_);
    task_ = std::move(task);
    wake_.notify_all();
    wake_.wait(lock, [this] { return !task_; });
  }

 private:
  void Loop() {
    std::unique_lock<std::mutex> lock(mutex_);
    for (;;) {
      wake_.wait(lock, [this] { return stop_ || task_; });
      if (stop_) return;
      task_();
      task_ = nullptr;
      wake_.notify_all();
    }
  }
  std::mutex mutex_;
  std::condition_variable wake_;
  std::function<void()> task_;
  bool stop_ = false;
  std::thread thread_;
};

void BM_SplitTrajectoryService2000x10x2OnWorkerThread(benchmark::State& state) {
  std::unique_ptr<gearloop::JobRepository> repository =
      gearloop::OpenJobRepository(":memory:");
  const gearloop::ServiceContext context = BenchContext(repository.get());
  const httplib::Request req = SplitRequest(false);
  Worker worker;
  for (auto _ : state) {
    int status = 0;
    worker.Run([&] {
      httplib::Response res;
      gearloop::CreateSplitTrajectory(context, req, res);
      status = res.status;
      benchmark::DoNotOptimize(res.body.data());
    });
    if (status != 200) state.SkipWithError("not 200");
  }
}
BENCHMARK(BM_SplitTrajectoryService2000x10x2OnWorkerThread)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// Parts of the handler: the codec and the engine (with the listing), then the
// JSON answer alone (the 40 000 points written as text).
void BM_SplitTrajectoryCodecAndEngine(benchmark::State& state) {
  const nlohmann::json body = nlohmann::json::parse(RequestBody(true));
  for (auto _ : state) {
    gearloop::SplitBevelRequest request;
    gearloop::ApiError error;
    if (!gearloop::ParseSplitBevelRequest(body, &request, &error) ||
        !gearloop::CheckSplitBevelRequest(request, &error))
      state.SkipWithError(error.message.c_str());
    const gearloop::SplitBevelResult result =
        gearloop::ComputeSplitTrajectory(request);
    benchmark::DoNotOptimize(result.nc_program.data());
  }
}
BENCHMARK(BM_SplitTrajectoryCodecAndEngine)->Unit(benchmark::kMillisecond);

void BM_SplitTrajectoryAnswerJson(benchmark::State& state) {
  const nlohmann::json body = nlohmann::json::parse(RequestBody(true));
  gearloop::SplitBevelRequest request;
  gearloop::ApiError error;
  gearloop::ParseSplitBevelRequest(body, &request, &error);
  const gearloop::SplitBevelResult result =
      gearloop::ComputeSplitTrajectory(request);
  for (auto _ : state) {
    const std::string text = gearloop::SplitBevelResultJsonText(result);
    benchmark::DoNotOptimize(text.data());
  }
}
BENCHMARK(BM_SplitTrajectoryAnswerJson)->Unit(benchmark::kMillisecond);

// Writing the job as the handler stores it (the request, the per-pass
// summaries without points and the 2.2 MB listing) to a ":memory:" history;
// the text of that stored result is its own part.
gearloop::SplitBevelResult BenchResult() {
  const nlohmann::json body = nlohmann::json::parse(RequestBody(true));
  gearloop::SplitBevelRequest request;
  gearloop::ApiError error;
  gearloop::ParseSplitBevelRequest(body, &request, &error);
  return gearloop::ComputeSplitTrajectory(request);
}

gearloop::SplitBevelTextOptions StoredOptions(
    const gearloop::SplitBevelResult& result) {
  gearloop::SplitBevelTextOptions stored;
  stored.points = false;
  stored.members = {{"points_stored", false}};
  stored.nc_program = &result.nc_program;
  return stored;
}

void BM_SplitTrajectoryStoredText(benchmark::State& state) {
  const gearloop::SplitBevelResult result = BenchResult();
  for (auto _ : state) {
    const std::string text =
        gearloop::SplitBevelResultJsonText(result, StoredOptions(result));
    benchmark::DoNotOptimize(text.data());
  }
}
BENCHMARK(BM_SplitTrajectoryStoredText)->Unit(benchmark::kMillisecond);

void StoreJobBenchmark(benchmark::State& state, const std::string& database) {
  const gearloop::SplitBevelResult result = BenchResult();
  gearloop::JobRecord job;
  job.kind = "split_trajectory";
  job.status = "computed";
  job.machine_kind = "head-head-5-axis-mill";
  job.request_json = RequestBody(true);
  job.result_json =
      gearloop::SplitBevelResultJsonText(result, StoredOptions(result));
  std::unique_ptr<gearloop::JobRepository> repository =
      gearloop::OpenJobRepository(database);
  for (auto _ : state) benchmark::DoNotOptimize(repository->WriteJob(job));
  state.counters["stored_MB"] =
      static_cast<double>(job.result_json.size()) / 1e6;
}

void BM_SplitTrajectoryStoreJob(benchmark::State& state) {
  StoreJobBenchmark(state, ":memory:");
}
BENCHMARK(BM_SplitTrajectoryStoreJob)->Unit(benchmark::kMillisecond);

void BM_SplitTrajectoryStoreJobFileDb(benchmark::State& state) {
  const std::string path = "/tmp/split_bevel_store_benchmark.sqlite";
  for (const char* suffix : {"", "-wal", "-shm"})
    std::remove((path + suffix).c_str());
  StoreJobBenchmark(state, path);
  for (const char* suffix : {"", "-wal", "-shm"})
    std::remove((path + suffix).c_str());
}
BENCHMARK(BM_SplitTrajectoryStoreJobFileDb)->Unit(benchmark::kMillisecond);

// GET /api/v1/corrections/{id} of the stored job: the points computed again
// (not the issue's target; a shop reads a job far less often than it posts).
void BM_SplitTrajectoryShowStoredJob(benchmark::State& state) {
  std::unique_ptr<gearloop::JobRepository> repository =
      gearloop::OpenJobRepository(":memory:");
  const gearloop::ServiceContext context = BenchContext(repository.get());
  httplib::Request req;
  req.body = RequestBody(false);
  httplib::Response posted;
  gearloop::CreateSplitTrajectory(context, req, posted);
  const std::optional<gearloop::JobRecord> job = repository->ReadJob(1);
  if (!job) state.SkipWithError("no stored job");
  for (auto _ : state) {
    httplib::Response res;
    if (!job || !gearloop::RespondStoredSplitTrajectory(context, *job, res))
      state.SkipWithError("not shown");
    benchmark::DoNotOptimize(res.body.data());
  }
}
BENCHMARK(BM_SplitTrajectoryShowStoredJob)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
