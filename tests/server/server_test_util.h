// tests/server/server_test_util.h: a real gearloop server on an ephemeral
// loopback port with a real SQLite temp file, and the default gear of API.md,
// for the server tests.
#ifndef GEARLOOP_TESTS_SERVER_SERVER_TEST_UTIL_H_
#define GEARLOOP_TESTS_SERVER_SERVER_TEST_UTIL_H_

#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

#include "server/http/gearloop_server.h"

// Last: <httplib.h> brings <resolv.h> whose `_res` macro breaks Eigen headers
// included after it.
#include <httplib.h>

namespace gearloop {
namespace testing_util {

// API.md's example gear: z = 37, m_n = 6, 20 deg, helix 15 deg left hand, b =
// 78, r_a = 120.9157, r_f = 107.1569, R_w = 350, K1 = K2 = 0, traverse 0, right
// flank, 5 x 9 grid.
inline nlohmann::json DefaultSetup() {
  return nlohmann::json::parse(R"({
    "gear": {"teeth": 37, "normal_module_mm": 6, "normal_pressure_angle_deg": 20,
             "helix_angle_deg": 15, "hand": "left", "face_width_mm": 78,
             "tip_radius_mm": 120.9157, "root_radius_mm": 107.1569},
    "wheel": {"radius_mm": 350},
    "machine": {"kind": "flat-wheel-grinder", "k1_mm": 0, "k2_mm": 0, "traverse_mm_per_rad": 0},
    "grid": {"profile_points": 5, "lead_points": 9, "profile_range": [0.2, 0.9], "lead_range": [-0.4, 0.4]},
    "flank": "right"})");
}

// A unique temp path for a SQLite file; removes it and its WAL files on
// destruction.
class TempPath {
 public:
  explicit TempPath(const std::string& stem = "gearloop_server_test") {
    std::string pattern = "/tmp/" + stem + "_XXXXXX";
    std::vector<char> buffer(pattern.begin(), pattern.end());
    buffer.push_back('\0');
    const int fd = mkstemp(buffer.data());
    close(fd);
    path_ = buffer.data();
    std::remove(path_.c_str());
  }
  ~TempPath() {
    for (const char* suffix : {"", "-wal", "-shm"})
      std::remove((path_ + suffix).c_str());
  }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

// The server in this process, serving on its own thread.
class RunningServer {
 public:
  explicit RunningServer(ServerOptions options) {
    options.port = 0;
    options.access_log = false;
    server_ = std::make_unique<GearloopServer>(options);
    port_ = server_->Bind();
    if (port_ > 0) {
      thread_ = std::thread([this] { server_->Serve(); });
      for (int i = 0; i < 500 && !server_->IsRunning(); ++i) {
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
      }
    }
  }
  ~RunningServer() { Stop(); }
  void Stop() {
    if (!server_) return;
    server_->Stop();
    if (thread_.joinable()) thread_.join();
    server_.reset();
  }
  int port() const { return port_; }
  GearloopServer* server() { return server_.get(); }

  std::unique_ptr<httplib::Client> Client() const {
    auto client = std::make_unique<httplib::Client>("127.0.0.1", port_);
    client->set_read_timeout(120, 0);
    client->set_write_timeout(30, 0);
    return client;
  }

 private:
  std::unique_ptr<GearloopServer> server_;
  std::thread thread_;
  int port_ = -1;
};

// A test with its own running server on a fresh SQLite file and a client of
// it (the endpoint tests' common set-up).
class ServerFixture : public ::testing::Test {
 protected:
  void SetUp() override {
    ServerOptions options;
    options.database_path = db_.path();
    server_ = std::make_unique<RunningServer>(options);
    ASSERT_GT(server_->port(), 0);
    client_ = server_->Client();
  }

  TempPath db_;
  std::unique_ptr<RunningServer> server_;
  std::unique_ptr<httplib::Client> client_;
};

inline nlohmann::json ParseBody(const httplib::Result& result) {
  if (!result) return nlohmann::json();
  return nlohmann::json::parse(result->body, nullptr, false);
}

}  // namespace testing_util
}  // namespace gearloop

#endif  // GEARLOOP_TESTS_SERVER_SERVER_TEST_UTIL_H_
