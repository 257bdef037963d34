// The gearloop-server binary under SIGTERM: requests in flight are answered,
// the process exits 0, and every job it acknowledged (201) is in the database
// when it starts again.
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "storage/job_repository.h"
#include "tests/server/server_test_util.h"

#ifndef GEARLOOP_SERVER_BINARY
#error "GEARLOOP_SERVER_BINARY must name the gearloop-server executable"
#endif

namespace gearloop {
namespace {

using testing_util::DefaultSetup;
using testing_util::ParseBody;
using testing_util::TempPath;

// A port that was free a moment ago.
int FreePort() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  address.sin_port = 0;
  bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address));
  socklen_t length = sizeof(address);
  getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length);
  close(fd);
  return ntohs(address.sin_port);
}

class ServerProcess {
 public:
  ServerProcess(const std::string& db, int port) : port_(port) {
    pid_ = fork();
    if (pid_ == 0) {
      const std::string port_text = std::to_string(port);
      execl(GEARLOOP_SERVER_BINARY,
            GEARLOOP_SERVER_BINARY,
            "--port",
            port_text.c_str(),
            "--db",
            db.c_str(),
            "--quiet",
            static_cast<char*>(nullptr));
      _exit(127);
    }
  }
  ~ServerProcess() {
    if (pid_ > 0 && !exited_) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
  }
  bool WaitReady() {
    httplib::Client client("127.0.0.1", port_);
    for (int i = 0; i < 500; ++i) {
      auto result = client.Get("/healthz");
      if (result && result->status == 200) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return false;
  }
  void Terminate() { kill(pid_, SIGTERM); }
  void Kill() { kill(pid_, SIGKILL); }
  // The exit status, or -1 when the process is still running after `timeout_s`.
  int WaitExit(double timeout_s) {
    const auto deadline = std::chrono::steady_clock::now() +
                          std::chrono::duration<double>(timeout_s);
    while (std::chrono::steady_clock::now() < deadline) {
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        exited_ = true;
        return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return -1;
  }
  int port() const { return port_; }

 private:
  pid_t pid_ = -1;
  int port_ = 0;
  bool exited_ = false;
};

nlohmann::json CorrectionRequest(int port) {
  httplib::Client client("127.0.0.1", port);
  nlohmann::json request = DefaultSetup();
  request["random_hidden_errors"] = {{"block_size", 3.0}, {"seed", 4}};
  request["noise_um"] = 0.3;
  nlohmann::json correction = DefaultSetup();
  correction["measurement"] =
      ParseBody(client.Post("/api/v1/simulations/measurement",
                            request.dump(),
                            "application/json"))["measurement"];
  return correction;
}

// A sustained write load: `num_clients` clients post the same correction in a
// loop until Stop() or until the server stops answering, and collect the ids of
// the jobs acknowledged with 201.
class CorrectionLoad {
 public:
  CorrectionLoad(int port, const std::string& body, int num_clients) {
    for (int t = 0; t < num_clients; ++t) {
      clients_.emplace_back([this, port, body] {
        httplib::Client client("127.0.0.1", port);
        client.set_read_timeout(30, 0);
        while (!stop_) {
          auto result =
              client.Post("/api/v1/corrections", body, "application/json");
          if (!result) break;  // the server is gone
          if (result->status == 201) {
            std::lock_guard<std::mutex> lock(mutex_);
            acknowledged_.push_back(ParseBody(result)["id"].get<int64_t>());
          }
        }
      });
    }
  }
  ~CorrectionLoad() { Stop(); }
  CorrectionLoad(const CorrectionLoad&) = delete;
  CorrectionLoad& operator=(const CorrectionLoad&) = delete;

  size_t NumAcknowledged() {
    std::lock_guard<std::mutex> lock(mutex_);
    return acknowledged_.size();
  }
  // Stops and joins the clients; the ids of every job acknowledged so far.
  std::vector<int64_t> Stop() {
    stop_ = true;
    for (std::thread& thread : clients_) thread.join();
    clients_.clear();
    std::lock_guard<std::mutex> lock(mutex_);
    return acknowledged_;
  }

 private:
  std::atomic<bool> stop_{false};
  std::mutex mutex_;
  std::vector<int64_t> acknowledged_;
  std::vector<std::thread> clients_;
};

TEST(GracefulShutdown, AnswersInFlightRequestsAndExitsCleanly) {
  TempPath db;
  ServerProcess server(db.path(), FreePort());
  ASSERT_TRUE(server.WaitReady());
  // A closed loop of 20 corrections on a fine grid takes a while: ~0.8 s in
  // the Release build (2026-11-23; 8 corrections on 20 x 30 took 0.15 s once
  // the corrections at the noise stopped moving the axes: no longer in flight
  // after the 150 ms below), tens of seconds under ASan on a busy machine
  // (hence the long read timeout).
  nlohmann::json scenario = DefaultSetup();
  scenario["grid"] = {{"profile_points", 30}, {"lead_points", 40}};
  scenario["random_hidden_errors"] = {{"block_size", 3.0}, {"seed", 4}};
  scenario["noise_um"] = 0.3;
  scenario["corrections"] = 20;
  std::atomic<int> status{0};
  std::thread slow([&] {
    httplib::Client client("127.0.0.1", server.port());
    client.set_read_timeout(300, 0);
    auto result = client.Post(
        "/api/v1/simulations/closed-loop", scenario.dump(), "application/json");
    status = result ? result->status : -1;
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(150));
  const auto stop_time = std::chrono::steady_clock::now();
  server.Terminate();
  slow.join();
  const double answered_after_ms =
      std::chrono::duration<double, std::milli>(
          std::chrono::steady_clock::now() - stop_time)
          .count();
  EXPECT_EQ(status.load(), 200);
  // The answer came after the signal: the request really was in flight.
  EXPECT_GT(answered_after_ms, 1.0);
  EXPECT_EQ(server.WaitExit(30.0), 0);
  std::printf("[ info     ] in-flight request answered %.0f ms after SIGTERM\n",
              answered_after_ms);
  // Nothing listens any more.
  httplib::Client client("127.0.0.1", server.port());
  EXPECT_FALSE(client.Get("/healthz"));
}

TEST(GracefulShutdown, LosesNoAcknowledgedJobUnderLoad) {
  TempPath db;
  const int port = FreePort();
  std::vector<int64_t> acknowledged;
  {
    ServerProcess server(db.path(), port);
    ASSERT_TRUE(server.WaitReady());
    CorrectionLoad load(
        port, CorrectionRequest(port).dump(), /*num_clients=*/4);
    std::this_thread::sleep_for(std::chrono::milliseconds(400));
    server.Terminate();
    EXPECT_EQ(server.WaitExit(30.0), 0);
    acknowledged = load.Stop();
  }
  ASSERT_FALSE(acknowledged.empty());
  std::unique_ptr<JobRepository> repository = OpenJobRepository(db.path());
  for (int64_t id : acknowledged)
    EXPECT_TRUE(repository->JobExists(id)) << "job " << id;
  EXPECT_EQ(repository->IntegrityCheck(), "ok");
  std::printf("[ info     ] %zu acknowledged jobs, all stored\n",
              acknowledged.size());
}

// Issue 7's crash test: SIGKILL in the middle of a sustained write load,
// restart, and every acknowledged job is there and the database is intact.
TEST(CrashSafety, KeepsEveryAcknowledgedJobAfterSigkill) {
  TempPath db;
  const int port = FreePort();
  std::vector<int64_t> acknowledged;
  {
    ServerProcess server(db.path(), port);
    ASSERT_TRUE(server.WaitReady());
    CorrectionLoad load(
        port, CorrectionRequest(port).dump(), /*num_clients=*/4);
    // Kill once the load is sustained: at least 500 ms and 20 acknowledged jobs
    // (an ASan build of the server needs longer than 500 ms for its first
    // answers; scripts/test runs both).
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    const auto deadline =
        std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (std::chrono::steady_clock::now() < deadline &&
           load.NumAcknowledged() < 20) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    server.Kill();
    EXPECT_EQ(server.WaitExit(10.0), 128 + SIGKILL);
    acknowledged = load.Stop();
  }
  ASSERT_FALSE(acknowledged.empty());
  // Restart the server on the same file: it opens, and every acknowledged job
  // is served.
  ServerProcess restarted(db.path(), port);
  ASSERT_TRUE(restarted.WaitReady());
  httplib::Client client("127.0.0.1", port);
  for (int64_t id : acknowledged) {
    auto result =
        client.Get(("/api/v1/corrections/" + std::to_string(id)).c_str());
    ASSERT_TRUE(result);
    EXPECT_EQ(result->status, 200) << "job " << id;
  }
  restarted.Terminate();
  EXPECT_EQ(restarted.WaitExit(30.0), 0);
  std::unique_ptr<JobRepository> repository = OpenJobRepository(db.path());
  EXPECT_EQ(repository->IntegrityCheck(), "ok");
  std::printf(
      "[ info     ] killed under load: %zu acknowledged jobs, all stored after "
      "restart\n",
      acknowledged.size());
}

}  // namespace
}  // namespace gearloop
