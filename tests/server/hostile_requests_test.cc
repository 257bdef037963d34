// Issue 7's bad input: the corpus tests/server/data/hostile_requests.jsonl
// (broken JSON, wrong types, wrong grid shapes, NaN and Infinity written in
// many ways, huge numbers, negative teeth, impossible gears, a wheel too small,
// deeply nested JSON, bad UTF-8, SQL-looking strings, unknown routes and
// methods) sent to the real server: each gets its 4xx with the error body,
// never a 5xx; the server stays up; nothing is stored. Plus a 100 MB body and a
// slow client.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <string>
#include <thread>

#include "tests/server/server_test_util.h"

#ifndef GEARLOOP_SOURCE_DIR
#error "GEARLOOP_SOURCE_DIR must name the repository root"
#endif

namespace gearloop {
namespace {

using testing_util::ParseBody;
using testing_util::RunningServer;
using testing_util::TempPath;

std::string DecodeBase64(const std::string& text) {
  static const std::string kAlphabet =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  int bits = 0;
  unsigned value = 0;
  for (char c : text) {
    const size_t index = kAlphabet.find(c);
    if (index == std::string::npos) continue;  // '=' padding
    value = ((value << 6) | static_cast<unsigned>(index)) & 0xffffffu;
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out.push_back(static_cast<char>((value >> bits) & 0xff));
    }
  }
  return out;
}

// A raw TCP connection to the server, for what httplib::Client will not send.
class RawConnection {
 public:
  explicit RawConnection(int port) {
    fd_ = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(static_cast<uint16_t>(port));
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    connected_ =
        connect(fd_, reinterpret_cast<sockaddr*>(&address), sizeof(address)) ==
        0;
    timeval timeout{10, 0};
    setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof(timeout));
  }
  ~RawConnection() { close(fd_); }
  bool connected() const { return connected_; }
  void Send(const std::string& data) {
    (void)send(fd_, data.data(), data.size(), MSG_NOSIGNAL);
  }
  // Until the end of a response head, the peer closing, or the 10 s socket
  // timeout.
  std::string ReceiveHead() {
    std::string out;
    char buffer[4096];
    while (out.find("\r\n\r\n") == std::string::npos) {
      const ssize_t n = recv(fd_, buffer, sizeof(buffer), 0);
      if (n <= 0) break;
      out.append(buffer, static_cast<size_t>(n));
    }
    return out;
  }

 private:
  int fd_ = -1;
  bool connected_ = false;
};

class HostileRequestsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ServerOptions options;
    options.database_path = db_.path();
    options.read_timeout_seconds = 1;
    running_ = std::make_unique<RunningServer>(options);
    ASSERT_GT(running_->port(), 0);
    client_ = running_->Client();
  }
  TempPath db_;
  std::unique_ptr<RunningServer> running_;
  std::unique_ptr<httplib::Client> client_;
};

TEST_F(HostileRequestsTest, AnswersEveryCorpusRequestWithItsClientError) {
  std::ifstream in(std::string(GEARLOOP_SOURCE_DIR) +
                   "/tests/server/data/hostile_requests.jsonl");
  ASSERT_TRUE(in.good());
  std::string line;
  int count = 0;
  while (std::getline(in, line)) {
    const nlohmann::json c = nlohmann::json::parse(line);
    const std::string name = c["name"];
    const std::string method = c["method"];
    const std::string path = c["path"];
    const std::string body = c.contains("body_b64")
                                 ? DecodeBase64(c["body_b64"])
                                 : c["body"].get<std::string>();
    httplib::Result result = [&]() -> httplib::Result {
      if (method == "GET") return client_->Get(path.c_str());
      if (method == "POST")
        return client_->Post(path.c_str(), body, "application/json");
      if (method == "PUT")
        return client_->Put(path.c_str(), body, "application/json");
      if (method == "PATCH")
        return client_->Patch(path.c_str(), body, "application/json");
      if (method == "OPTIONS") return client_->Options(path.c_str());
      return client_->Delete(path.c_str());
    }();
    ++count;
    ASSERT_TRUE(result) << name << ": no answer (the server is down?)";
    if (c["expect"].is_number()) {
      EXPECT_EQ(result->status, c["expect"].get<int>())
          << name << ": " << result->body.substr(0, 300);
    } else {
      EXPECT_TRUE(result->status >= 400 && result->status < 500)
          << name << ": " << result->status;
    }
    EXPECT_LT(result->status, 500) << name;
    if (method != "OPTIONS") {
      const nlohmann::json error = ParseBody(result);
      EXPECT_TRUE(error.is_object() && error.contains("error") &&
                  error["error"].contains("code") &&
                  !error["error"]["message"].get<std::string>().empty())
          << name << ": " << result->body.substr(0, 300);
    }
  }
  EXPECT_GE(count, 200);
  auto health = client_->Get("/healthz");
  ASSERT_TRUE(health);
  EXPECT_EQ(health->status, 200);
  auto history = client_->Get("/api/v1/corrections");
  EXPECT_EQ(ParseBody(history)["total"], 0) << "a refused request stored a job";
  std::printf("[ info     ] %d hostile requests answered 4xx\n", count);
}

TEST_F(HostileRequestsTest, Refuses100MegabyteBodyWithoutReadingIt) {
  RawConnection connection(running_->port());
  ASSERT_TRUE(connection.connected());
  const auto start = std::chrono::steady_clock::now();
  connection.Send(
      "POST /api/v1/corrections HTTP/1.1\r\nHost: x\r\nContent-Type: "
      "application/json\r\n"
      "Content-Length: 104857600\r\n\r\n");
  connection.Send(std::string(64 * 1024, '['));
  const std::string head = connection.ReceiveHead();
  EXPECT_EQ(head.rfind("HTTP/1.1 413", 0), 0u) << head;
  EXPECT_LT(
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
          .count(),
      2.0);
}

TEST_F(HostileRequestsTest, CutsOffASlowClientWithoutHoldingTheServer) {
  RawConnection slow(running_->port());
  ASSERT_TRUE(slow.connected());
  slow.Send(
      "POST /api/v1/corrections HTTP/1.1\r\nHost: x\r\nContent-Length: "
      "1000\r\n\r\n{\"gear\":");
  // While it dawdles, others are served.
  auto health = client_->Get("/healthz");
  ASSERT_TRUE(health);
  EXPECT_EQ(health->status, 200);
  // After the read timeout (1 s here) the server gives up on it and closes the
  // connection.
  const auto start = std::chrono::steady_clock::now();
  // (ReceiveHead returns when the server answers or closes, or after our own 10
  // s timeout.)
  slow.ReceiveHead();
  const double waited =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
          .count();
  EXPECT_LT(waited, 9.0);
  auto history = client_->Get("/api/v1/corrections");
  EXPECT_EQ(ParseBody(history)["total"], 0);
}

}  // namespace
}  // namespace gearloop
