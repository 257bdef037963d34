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
#include <openssl/sha.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <string>
#include <thread>
#include <tuple>
#include <utility>
#include <vector>

#include "storage/job_repository.h"
#include "tests/server/raw_connection.h"
#include "tests/server/server_test_util.h"

#ifndef GEARLOOP_SOURCE_DIR
#error "GEARLOOP_SOURCE_DIR must name the repository root"
#endif

namespace gearloop {
namespace {

using testing_util::ParseBody;
using testing_util::RawConnection;
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

// The server's read timeout in these tests. A request answered "at once" is
// answered before it: a server that waited for a body would answer no sooner
// than the timeout. The bound leaves the answer the rest of that second, as a
// sanitizer build on a loaded 2-core machine took 0.58 s to answer at once.
constexpr int kReadTimeoutSeconds = 1;
constexpr double kAtOnceSeconds = 0.9 * kReadTimeoutSeconds;

class HostileRequestsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ServerOptions options;
    options.database_path = db_.path();
    options.read_timeout_seconds = kReadTimeoutSeconds;
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

// Resident memory of this process (the server runs in it) [bytes].
size_t ResidentBytes() {
  std::ifstream statm("/proc/self/statm");
  size_t pages = 0, resident = 0;
  statm >> pages >> resident;
  return resident * static_cast<size_t>(sysconf(_SC_PAGESIZE));
}

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
      .count();
}

// Sends a chunked body of `total` bytes of JSON-ish text in 64 KiB chunks
// until the server stops taking it; returns the bytes it took.
size_t SendChunked(RawConnection* connection, size_t total) {
  const std::string piece(64 * 1024, ' ');
  char size_line[32];
  std::snprintf(size_line, sizeof(size_line), "%zx\r\n", piece.size());
  const std::string chunk = size_line + piece + "\r\n";
  size_t sent = 0;
  while (sent < total && connection->Send(chunk)) sent += piece.size();
  return sent;
}

TEST_F(HostileRequestsTest, Refuses200MegabyteChunkedBodyAsItArrives) {
  const size_t before = ResidentBytes();
  RawConnection connection(running_->port());
  ASSERT_TRUE(connection.connected());
  connection.Send(
      "POST /api/v1/corrections HTTP/1.1\r\nHost: x\r\nContent-Type: "
      "application/json\r\nTransfer-Encoding: chunked\r\n\r\n");
  size_t sent = 0;
  std::thread sender(
      [&] { sent = SendChunked(&connection, size_t{200} << 20); });
  const std::string head = connection.ReceiveHead();
  sender.join();
  EXPECT_EQ(head.rfind("HTTP/1.1 413", 0), 0u) << head;
  EXPECT_NE(head.find("Connection: close"), std::string::npos) << head;
  EXPECT_LT(sent, size_t{200} << 20) << "the server read the whole body";
  const double grown_mb =
      (static_cast<double>(ResidentBytes()) - static_cast<double>(before)) /
      (1 << 20);
#ifndef GEARLOOP_SANITIZED_BUILD
  // Not under AddressSanitizer: its allocator keeps freed memory in
  // quarantine, so resident memory says nothing about what the server holds
  // (the soak's memory limit is left out of the sanitizer run for the same
  // reason). The 413 before the end of the body is checked there too.
  EXPECT_LT(grown_mb, 32.0);
#endif
  std::printf(
      "[ info     ] 200 MiB chunked body: 413 after %.1f MiB sent, "
      "memory grew %.1f MB\n",
      static_cast<double>(sent) / (1 << 20),
      grown_mb);
  auto health = client_->Get("/healthz");
  ASSERT_TRUE(health);
  EXPECT_EQ(health->status, 200);
}

TEST_F(HostileRequestsTest, RefusesANegativeOrMalformedContentLength) {
  for (const char* length : {"-1", "12abc", "+5", " ", "1e3"}) {
    RawConnection connection(running_->port());
    connection.Send(std::string("POST /api/v1/nominal HTTP/1.1\r\nHost: "
                                "x\r\nContent-Length: ") +
                    length + "\r\n\r\n{}");
    const std::string head = connection.ReceiveHead();
    EXPECT_EQ(head.rfind("HTTP/1.1 400", 0), 0u) << length << ": " << head;
  }
  // Both framings at once (request smuggling) and an unknown coding.
  RawConnection both(running_->port());
  both.Send(
      "POST /api/v1/nominal HTTP/1.1\r\nHost: x\r\nContent-Length: "
      "2\r\nTransfer-Encoding: chunked\r\n\r\n{}");
  EXPECT_EQ(both.ReceiveHead().rfind("HTTP/1.1 400", 0), 0u);
  RawConnection gzip(running_->port());
  gzip.Send(
      "POST /api/v1/nominal HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: "
      "gzip\r\n\r\n");
  EXPECT_EQ(gzip.ReceiveHead().rfind("HTTP/1.1 400", 0), 0u);
}

TEST_F(HostileRequestsTest, AnswersPutAndPatchWithoutBody405AtOnce) {
  for (const char* method : {"PUT", "PATCH", "DELETE"}) {
    RawConnection connection(running_->port());
    const auto start = std::chrono::steady_clock::now();
    connection.Send(std::string(method) +
                    " /api/v1/corrections HTTP/1.1\r\nHost: x\r\n\r\n");
    const std::string head = connection.ReceiveHead();
    EXPECT_EQ(head.rfind("HTTP/1.1 405", 0), 0u) << method << ": " << head;
    EXPECT_NE(head.find("Allow: GET, POST"), std::string::npos) << head;
    EXPECT_LT(SecondsSince(start), kAtOnceSeconds) << method;
  }
  // An unknown path is 404 before its body is read.
  RawConnection unknown(running_->port());
  const auto start = std::chrono::steady_clock::now();
  unknown.Send(
      "POST /api/v1/nowhere HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: "
      "chunked\r\n\r\n");
  EXPECT_EQ(unknown.ReceiveHead().rfind("HTTP/1.1 404", 0), 0u);
  EXPECT_LT(SecondsSince(start), kAtOnceSeconds);
}

std::string Sha256Hex(const std::string& text) {
  unsigned char digest[SHA256_DIGEST_LENGTH];
  SHA256(
      reinterpret_cast<const unsigned char*>(text.data()), text.size(), digest);
  char hex[2 * SHA256_DIGEST_LENGTH + 1];
  for (int i = 0; i < SHA256_DIGEST_LENGTH; ++i)
    std::snprintf(hex + 2 * i, 3, "%02x", digest[i]);
  return hex;
}

TEST(HostileRequests, RefusesAnUnauthenticatedBodyBeforeReadingIt) {
  TempPath db;
  TempPath token_file("gearloop_tokens");
  {
    std::ofstream out(token_file.path());
    out << "write " << Sha256Hex("writer-secret") << " cell\n";
  }
  ServerOptions options;
  options.database_path = db.path();
  options.token_file = token_file.path();
  RunningServer running(options);
  ASSERT_GT(running.port(), 0);
  // Announced within the limit, never sent: the answer cannot wait for it.
  RawConnection announced(running.port());
  auto start = std::chrono::steady_clock::now();
  announced.Send(
      "POST /api/v1/corrections HTTP/1.1\r\nHost: x\r\nContent-Length: "
      "8000000\r\n\r\n{\"gear\":");
  EXPECT_EQ(announced.ReceiveHead().rfind("HTTP/1.1 401", 0), 0u);
  EXPECT_LT(SecondsSince(start), 1.0);
  // 300 MiB chunked without a token: refused after a small part of it.
  RawConnection chunked(running.port());
  start = std::chrono::steady_clock::now();
  chunked.Send(
      "POST /api/v1/corrections HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: "
      "chunked\r\n\r\n");
  size_t sent = 0;
  std::thread sender([&] { sent = SendChunked(&chunked, size_t{300} << 20); });
  const std::string head = chunked.ReceiveHead();
  sender.join();
  EXPECT_EQ(head.rfind("HTTP/1.1 401", 0), 0u) << head;
  EXPECT_LT(sent, size_t{64} << 20) << "the server read the body";
}

// A valid correction request of the default gear: a 5 x 9 measurement of a
// few microns.
nlohmann::json StrictCorrectionRequest() {
  nlohmann::json request = testing_util::DefaultSetup();
  nlohmann::json grid = nlohmann::json::array();
  for (int i = 0; i < 5; ++i) {
    nlohmann::json row = nlohmann::json::array();
    for (int j = 0; j < 9; ++j) row.push_back(0.5 * (i - 2) + 0.1 * (j - 4));
    grid.push_back(row);
  }
  request["measurement"] = {{"deviations_um", grid}};
  request["options"] = {{"default_max_order", 2}};
  return request;
}

// Status and error field of a POST.
std::pair<int, nlohmann::json> PostJson(httplib::Client* client,
                                        const char* path,
                                        const nlohmann::json& body) {
  auto result = client->Post(path, body.dump(), "application/json");
  if (!result) return {-1, nlohmann::json()};
  return {result->status, ParseBody(result)};
}

TEST_F(HostileRequestsTest, RefusesUnknownKeysNamingTheNearestKnownOne) {
  const nlohmann::json valid = StrictCorrectionRequest();
  ASSERT_EQ(PostJson(client_.get(), "/api/v1/corrections", valid).first, 201);

  nlohmann::json typo = valid;
  typo["options"] = {{"default_max_ordr", 2}};
  auto [status, body] = PostJson(client_.get(), "/api/v1/corrections", typo);
  EXPECT_EQ(status, 422);
  EXPECT_EQ(body["error"]["field"], "options.default_max_ordr");
  EXPECT_NE(body["error"]["message"].get<std::string>().find(
                "did you mean default_max_order"),
            std::string::npos)
      << body.dump();

  // The grinder's own endpoints take the setup alone (strict top level).
  typo = testing_util::DefaultSetup();
  typo["gear"]["modul"] = 6;
  std::tie(status, body) = PostJson(client_.get(), "/api/v1/nominal", typo);
  EXPECT_EQ(status, 422);
  EXPECT_EQ(body["error"]["field"], "gear.modul");

  typo = testing_util::DefaultSetup();
  typo["machine"]["traverse_mm_per_deg"] = 0;
  std::tie(status, body) = PostJson(client_.get(), "/api/v1/evaluate", typo);
  EXPECT_EQ(status, 422);
  EXPECT_EQ(body["error"]["field"], "machine.traverse_mm_per_deg");
  EXPECT_NE(body["error"]["message"].get<std::string>().find(
                "did you mean traverse_mm_per_rad"),
            std::string::npos);

  typo = valid;
  typo["grid"]["lead_pints"] = 9;
  std::tie(status, body) = PostJson(client_.get(), "/api/v1/corrections", typo);
  EXPECT_EQ(status, 422);
  EXPECT_EQ(body["error"]["field"], "grid.lead_pints");

  typo = valid;
  typo["measurement"]["deviation_um"] = typo["measurement"]["deviations_um"];
  std::tie(status, body) = PostJson(client_.get(), "/api/v1/corrections", typo);
  EXPECT_EQ(status, 422);
  EXPECT_EQ(body["error"]["field"], "measurement.deviation_um");

  typo = valid;
  typo["options"] = {{"max_order", {{"Q", 2}}}};
  std::tie(status, body) = PostJson(client_.get(), "/api/v1/corrections", typo);
  EXPECT_EQ(status, 422);
  EXPECT_EQ(body["error"]["field"], "options.max_order.Q") << body.dump();

  typo = valid;
  typo["target"] = {{"modifications",
                     {{{"kind", "profile_crowning"},
                       {"amount_um", 2},
                       {"lenght_fraction", 1}}}}};
  std::tie(status, body) = PostJson(client_.get(), "/api/v1/corrections", typo);
  EXPECT_EQ(status, 422);
  EXPECT_EQ(body["error"]["field"], "target.modifications[0].lenght_fraction");

  typo = valid;
  typo["target"] = {{"deviation_um", nlohmann::json::array()}};
  std::tie(status, body) = PostJson(client_.get(), "/api/v1/corrections", typo);
  EXPECT_EQ(status, 422);
  EXPECT_EQ(body["error"]["field"], "target.deviation_um");

  typo = valid;
  typo["wheel"]["radius"] = 350;
  std::tie(status, body) = PostJson(client_.get(), "/api/v1/corrections", typo);
  EXPECT_EQ(status, 422);
  EXPECT_EQ(body["error"]["field"], "wheel.radius");
  EXPECT_EQ(ParseBody(client_->Get("/api/v1/corrections"))["total"], 1)
      << "a refused request stored a job";
}

TEST_F(HostileRequestsTest, RefusesImplausibleDeviationsUnlessAllowed) {
  nlohmann::json nanometres = StrictCorrectionRequest();
  for (auto& row : nanometres["measurement"]["deviations_um"])
    for (auto& value : row) value = value.get<double>() * 1000.0;
  auto [status, body] =
      PostJson(client_.get(), "/api/v1/corrections", nanometres);
  EXPECT_EQ(status, 422);
  EXPECT_EQ(body["error"]["field"], "measurement.deviations_um[0][0]");
  nanometres["allow_large_deviations"] = "yes";
  EXPECT_EQ(PostJson(client_.get(), "/api/v1/corrections", nanometres).first,
            400);
  nanometres["allow_large_deviations"] = true;
  EXPECT_EQ(PostJson(client_.get(), "/api/v1/corrections", nanometres).first,
            201);

  nlohmann::json huge_target = StrictCorrectionRequest();
  huge_target["target"] = {
      {"modifications",
       {{{"kind", "profile_crowning"}, {"amount_um", 1e308}}}}};
  std::tie(status, body) =
      PostJson(client_.get(), "/api/v1/corrections", huge_target);
  EXPECT_EQ(status, 422);
  EXPECT_EQ(body["error"]["field"], "target.modifications[0].amount_um");
}

TEST_F(HostileRequestsTest, RefusesBadJobListQueriesNamingTheParameter) {
  for (const auto& [query, field] :
       std::vector<std::pair<std::string, std::string>>{
           {"kind=x", "query.kind"},
           {"status=x", "query.status"},
           {"created_from=2026-13-45", "query.created_from"},
           {"created_to=2026-02-30", "query.created_to"},
           {"created_from=2026-11-22T25:00:00Z", "query.created_from"},
           {"knd=correction", "query.knd"}}) {
    auto result = client_->Get(("/api/v1/corrections?" + query).c_str());
    ASSERT_TRUE(result);
    EXPECT_EQ(result->status, 400) << query;
    EXPECT_EQ(ParseBody(result)["error"]["field"], field) << query;
  }
  for (const char* query : {"kind=correction",
                            "status=converged",
                            "created_from=2024-02-29",
                            "created_to=2026-11-22T08:00:00Z",
                            "kind=split_trajectory",
                            "status=target_partly_reachable",
                            "part_number=P-17",
                            "tooth=3"}) {
    auto result =
        client_->Get((std::string("/api/v1/corrections?") + query).c_str());
    ASSERT_TRUE(result);
    EXPECT_EQ(result->status, 200) << query;
  }
}

// A valid body of each endpoint that takes one (issue 17: strict input at the
// top level of every body).
nlohmann::json PublishedBevelJob() {
  return {{"side", "convex"},
          {"published", true},
          {"grid", {{"profile_points", 3}, {"lengthwise_points", 3}}}};
}

nlohmann::json BevelCorrectionRequest() {
  nlohmann::json grid = nlohmann::json::array();
  for (int i = 0; i < 3; ++i) grid.push_back({0.5, -0.25 * i, 0.1});
  return {{"machine", {{"kind", "free-form-bevel-generator"}}},
          {"job", PublishedBevelJob()},
          {"measurement", {{"deviations_um", grid}}}};
}

nlohmann::json SplitBevelRequest() {
  return nlohmann::json::parse(R"({
    "gear": {"teeth": 75, "pitch_angle_deg": 70, "outer_transverse_module_mm": 40,
             "face_width_mm": 240, "mean_spiral_angle_deg": 35, "hand": "right",
             "pressure_angle_deg": 20},
    "tool": {"radius_mm": 8, "stock_mm": 0.2},
    "cut": {"slot_index": 3, "flanks": ["convex"], "steps": 5},
    "machine": {"pivot_length_mm": 300}, "setup": {"apex_mm": [0, 0, 0]},
    "output": {"nc": false}})");
}

nlohmann::json ShavingRequest() {
  return nlohmann::json::parse(R"({
    "work_gear": {"teeth": 19, "normal_module_mm": 6, "normal_pressure_angle_deg": 20,
                  "helix_angle_deg": 9.91, "hand": "right", "face_width_mm": 75},
    "cutter": {"teeth": 37, "normal_module_mm": 6, "normal_pressure_angle_deg": 20,
               "helix_angle_deg": 15, "hand": "left", "face_width_mm": 78,
               "tip_radius_mm": 120.9157, "root_radius_mm": 107.1569},
    "diagonal_modification": {"root_um": 20, "tip_um": 20},
    "wheel_check": {"h_s_mm": 2},
    "grid": {"profile_points": 3, "lead_points": 3}})");
}

nlohmann::json ImportRequest() {
  return {{"gear", testing_util::DefaultSetup()["gear"]},
          {"format", "mka"},
          {"content", "HEADER KS.MK.FILE\r\n"}};
}

// One strict-input case: `body` posted to `path` is refused with 422 naming
// `field`, and the message offers `nearest` ("" = none near).
struct KeyCase {
  std::string path;
  nlohmann::json body;
  std::string field;
  std::string nearest;
};

void ExpectUnknownKey(httplib::Client* client, const KeyCase& c) {
  auto [status, body] = PostJson(client, c.path.c_str(), c.body);
  EXPECT_EQ(status, 422) << c.path << " " << c.field << ": " << body.dump();
  EXPECT_EQ(body["error"]["code"], "invalid_value") << c.field;
  EXPECT_EQ(body["error"]["field"], c.field) << c.path << ": " << body.dump();
  const std::string message = body["error"].value("message", "");
  std::string expected = "unknown key " + c.field;
  if (!c.nearest.empty()) expected += "; did you mean " + c.nearest + "?";
  EXPECT_EQ(message, expected) << c.path;
}

// `body` with `key` set to `value` at the path of object keys `at`.
nlohmann::json With(nlohmann::json body,
                    const std::vector<std::string>& at,
                    const std::string& key,
                    const nlohmann::json& value) {
  nlohmann::json* node = &body;
  for (const std::string& k : at) node = &(*node)[k];
  (*node)[key] = value;
  return body;
}

TEST_F(HostileRequestsTest, RefusesUnknownTopLevelKeysOfEveryBody) {
  const nlohmann::json correction = StrictCorrectionRequest();
  const nlohmann::json setup = testing_util::DefaultSetup();
  const nlohmann::json bevel_job = {{"job", PublishedBevelJob()}};
  nlohmann::json bevel_simulation = BevelCorrectionRequest();
  bevel_simulation.erase("measurement");
  nlohmann::json reach = setup;
  reach["target"] = {
      {"modifications", {{{"kind", "profile_crowning"}, {"amount_um", 5}}}}};
  // Each body is valid without its typo.
  for (const auto& [path, body] :
       std::vector<std::pair<std::string, nlohmann::json>>{
           {"/api/v1/corrections", correction},
           {"/api/v1/corrections", BevelCorrectionRequest()},
           {"/api/v1/nominal", setup},
           {"/api/v1/bevel/evaluate", bevel_job},
           {"/api/v1/bevel/split-trajectory", SplitBevelRequest()},
           {"/api/v1/shaving/cutter-target", ShavingRequest()},
           {"/api/v1/targets/reach", reach}}) {
    const int status = PostJson(client_.get(), path.c_str(), body).first;
    EXPECT_TRUE(status == 200 || status == 201) << path << ": " << status;
  }
  const int64_t stored_before =
      ParseBody(client_->Get("/api/v1/corrections"))["total"];
  const std::vector<KeyCase> cases = {
      {"/api/v1/nominal", With(setup, {}, "flanc", "left"), "flanc", "flank"},
      {"/api/v1/evaluate",
       With(setup, {}, "setings", nullptr),
       "setings",
       "settings"},
      {"/api/v1/sensitivity", With(setup, {}, "grids", {}), "grids", "grid"},
      {"/api/v1/corrections",
       With(correction, {}, "measurment", correction["measurement"]),
       "measurment",
       "measurement"},
      {"/api/v1/corrections",
       With(correction, {}, "allow_large_deviation", true),
       "allow_large_deviation",
       "allow_large_deviations"},
      {"/api/v1/corrections",
       With(correction, {}, "job", PublishedBevelJob()),
       "job",
       ""},
      {"/api/v1/corrections",
       With(BevelCorrectionRequest(), {}, "motions", {}),
       "motions",
       "motion"},
      {"/api/v1/corrections",
       With(BevelCorrectionRequest(), {}, "gear", setup["gear"]),
       "gear",
       ""},
      {"/api/v1/batches",
       {{"items", {With(correction, {}, "tolerence", {{"rms_um", 2}})}}},
       "items[0].tolerence",
       "tolerance"},
      {"/api/v1/batches", {{"item", {correction}}}, "item", "items"},
      {"/api/v1/corrections/1/replay",
       {{"option", {{"default_max_order", 1}}}},
       "option",
       "options"},
      {"/api/v1/simulations/measurement",
       With(setup, {}, "noise_mm", 0.1),
       "noise_mm",
       "noise_um"},
      {"/api/v1/simulations/measurement",
       With(bevel_simulation, {}, "hidden_error", {{"X_mm", {0.001}}}),
       "hidden_error",
       "hidden_errors"},
      {"/api/v1/simulations/measurement",
       With(bevel_simulation, {}, "missing_points", {{0, 0}}),
       "missing_points",
       ""},
      {"/api/v1/simulations/closed-loop",
       With(setup, {}, "correction", 2),
       "correction",
       "corrections"},
      {"/api/v1/targets/reach",
       With(reach, {}, "option", {{"default_max_order", 2}}),
       "option",
       "options"},
      {"/api/v1/bevel/conversions",
       With(bevel_job, {}, "option", {{"polynomial_degree", 3}}),
       "option",
       "options"},
      {"/api/v1/bevel/evaluate",
       With(bevel_job, {}, "motions", {}),
       "motions",
       "motion"},
      {"/api/v1/bevel/axis-sensitivity",
       With(bevel_job, {}, "error", {{"exact", false}}),
       "error",
       "errors"},
      {"/api/v1/bevel/split-trajectory",
       With(SplitBevelRequest(), {}, "tools", {}),
       "tools",
       "tool"},
      {"/api/v1/shaving/cutter-target",
       With(ShavingRequest(), {}, "centre_distance", 150),
       "centre_distance",
       "centre_distance_mm"},
      {"/api/v1/measurements/import",
       With(ImportRequest(), {}, "toth", 1),
       "toth",
       "tooth"},
  };
  for (const KeyCase& c : cases) ExpectUnknownKey(client_.get(), c);
  EXPECT_EQ(ParseBody(client_->Get("/api/v1/corrections"))["total"],
            stored_before)
      << "a refused request stored a job";
}

TEST_F(HostileRequestsTest, RefusesUnknownKeysInBevelJobsAndSimulations) {
  const nlohmann::json job = {{"job", PublishedBevelJob()}};
  const nlohmann::json setup = testing_util::DefaultSetup();
  nlohmann::json bevel_simulation = BevelCorrectionRequest();
  bevel_simulation.erase("measurement");
  const nlohmann::json motion = {{"A_rad", {0.0}},
                                 {"B_rad", {0.0}},
                                 {"X_mm", {0.0}},
                                 {"Y_mm", {0.0}},
                                 {"Z_mm", {0.0}}};
  const std::vector<KeyCase> cases = {
      {"/api/v1/bevel/evaluate",
       With(job, {"job"}, "publishd", true),
       "job.publishd",
       "published"},
      {"/api/v1/bevel/evaluate",
       With(job, {"job", "cutter"}, "point_radius", 75),
       "job.cutter.point_radius",
       "point_radius_mm"},
      {"/api/v1/bevel/conversions",
       With(job, {"job", "machine"}, "ratio_of_rol", 3),
       "job.machine.ratio_of_rol",
       "ratio_of_roll"},
      {"/api/v1/bevel/axis-sensitivity",
       With(job, {"job", "blank"}, "face_angle_dg", 30),
       "job.blank.face_angle_dg",
       "face_angle_deg"},
      {"/api/v1/corrections",
       With(BevelCorrectionRequest(), {"job", "grid"}, "profile_point", 3),
       "job.grid.profile_point",
       "profile_points"},
      {"/api/v1/corrections",
       With(BevelCorrectionRequest(), {"machine"}, "knd", "x"),
       "machine.knd",
       "kind"},
      {"/api/v1/bevel/evaluate",
       With(With(job, {}, "motion", motion), {"motion"}, "Z_mn", {0.0}),
       "motion.Z_mn",
       "Z_mm"},
      {"/api/v1/bevel/conversions",
       With(job, {"options"}, "polynomial_degre", 3),
       "options.polynomial_degre",
       "polynomial_degree"},
      {"/api/v1/bevel/axis-sensitivity",
       With(job, {"errors"}, "exakt", false),
       "errors.exakt",
       "exact"},
      {"/api/v1/simulations/measurement",
       With(bevel_simulation, {"hidden_errors"}, "X_m", {0.001}),
       "hidden_errors.X_m",
       "X_mm"},
      {"/api/v1/simulations/closed-loop",
       With(bevel_simulation, {"hidden_errors"}, "Y_m", {0.001}),
       "hidden_errors.Y_m",
       "Y_mm"},
      {"/api/v1/simulations/measurement",
       With(setup, {"hidden_errors"}, "axis", {{"X", {0.001}}}),
       "hidden_errors.axis",
       "axes"},
      {"/api/v1/simulations/closed-loop",
       With(setup, {"hidden_errors", "wheel"}, "cone_angle_dg", 0.01),
       "hidden_errors.wheel.cone_angle_dg",
       "cone_angle_deg"},
      {"/api/v1/simulations/measurement",
       With(setup, {"random_hidden_errors"}, "block_sise", 1),
       "random_hidden_errors.block_sise",
       "block_size"},
      {"/api/v1/bevel/split-trajectory",
       With(SplitBevelRequest(), {"gear"}, "hnd", "left"),
       "gear.hnd",
       "hand"},
      {"/api/v1/bevel/split-trajectory",
       With(SplitBevelRequest(), {"tool"}, "stock_m", 0.1),
       "tool.stock_m",
       "stock_mm"},
      {"/api/v1/bevel/split-trajectory",
       With(SplitBevelRequest(), {"cut"}, "step", 5),
       "cut.step",
       "steps"},
      {"/api/v1/bevel/split-trajectory",
       With(SplitBevelRequest(), {"machine"}, "pivot_length", 300),
       "machine.pivot_length",
       "pivot_length_mm"},
      {"/api/v1/bevel/split-trajectory",
       With(SplitBevelRequest(), {"setup"}, "apex_m", {0, 0, 0}),
       "setup.apex_m",
       "apex_mm"},
      {"/api/v1/bevel/split-trajectory",
       With(SplitBevelRequest(), {"output"}, "nc_program", true),
       "output.nc_program",
       ""},
      {"/api/v1/shaving/cutter-target",
       With(ShavingRequest(), {"diagonal_modification"}, "tip_bands", 0.3),
       "diagonal_modification.tip_bands",
       "tip_band"},
      {"/api/v1/shaving/cutter-target",
       With(ShavingRequest(), {"wheel_check"}, "hs_mm", 2),
       "wheel_check.hs_mm",
       "h_s_mm"},
      {"/api/v1/corrections",
       With(StrictCorrectionRequest(),
            {},
            "target",
            {{"shaving", With(ShavingRequest(), {"wheel_check"}, "hs_mm", 2)}}),
       "target.shaving.wheel_check.hs_mm",
       "h_s_mm"},
      {"/api/v1/corrections",
       With(StrictCorrectionRequest(),
            {},
            "target",
            {{"shaving", With(ShavingRequest(), {}, "centre_distanse_mm", 1)}}),
       "target.shaving.centre_distanse_mm",
       "centre_distance_mm"},
      {"/api/v1/measurements/import",
       With(ImportRequest(), {"sign_factors"}, "helix_rigt", -1),
       "sign_factors.helix_rigt",
       "helix_right"},
      {"/api/v1/corrections",
       With(StrictCorrectionRequest(),
            {},
            "measurement",
            {{"file", {{"format", "mka"}, {"content", "x"}, {"toth", 1}}}}),
       "measurement.file.toth",
       "tooth"},
  };
  for (const KeyCase& c : cases) ExpectUnknownKey(client_.get(), c);
  EXPECT_EQ(ParseBody(client_->Get("/api/v1/corrections"))["total"], 0)
      << "a refused request stored a job";
}

TEST_F(HostileRequestsTest, RefusesImplausibleTargetGridsUnlessAllowed) {
  nlohmann::json request = StrictCorrectionRequest();
  nlohmann::json target = nlohmann::json::array();
  for (int i = 0; i < 5; ++i)
    target.push_back(std::vector<double>(9, 1.0 * (i - 2)));
  target[3][4] = -700.0;  // a target of -0.7 um written in nm
  request["target"] = {{"deviations_um", target}};
  auto [status, body] = PostJson(client_.get(), "/api/v1/corrections", request);
  EXPECT_EQ(status, 422);
  EXPECT_EQ(body["error"]["field"], "target.deviations_um[3][4]");
  request["allow_large_deviations"] = true;
  EXPECT_EQ(PostJson(client_.get(), "/api/v1/corrections", request).first, 201);

  // A closed loop's target, and a bevel correction's.
  nlohmann::json loop = testing_util::DefaultSetup();
  loop["corrections"] = 1;
  loop["target"] = {{"deviations_um", target}};
  std::tie(status, body) =
      PostJson(client_.get(), "/api/v1/simulations/closed-loop", loop);
  EXPECT_EQ(status, 422);
  EXPECT_EQ(body["error"]["field"], "target.deviations_um[3][4]");
  loop["allow_large_deviations"] = true;
  loop["store"] = true;
  std::tie(status, body) =
      PostJson(client_.get(), "/api/v1/simulations/closed-loop", loop);
  ASSERT_EQ(status, 200) << body.dump();
  // Its stored part carries the allowance, so it replays as it ran.
  ASSERT_TRUE(body["iterations"][0].contains("job_id")) << body.dump();
  const std::string part =
      "/api/v1/corrections/" + body["iterations"][0]["job_id"].dump();
  EXPECT_EQ(ParseBody(client_->Get(
                part.c_str()))["request"]["allow_large_deviations"],
            true);
  EXPECT_EQ(
      PostJson(
          client_.get(), (part + "/replay").c_str(), nlohmann::json::object())
          .first,
      201);

  nlohmann::json bevel = BevelCorrectionRequest();
  bevel["target"] = {
      {"deviations_um", {{0.0, 0.0, 0.0}, {0.0, 0.0, 501.0}, {0.0, 0.0, 0.0}}}};
  std::tie(status, body) =
      PostJson(client_.get(), "/api/v1/corrections", bevel);
  EXPECT_EQ(status, 422);
  EXPECT_EQ(body["error"]["field"], "target.deviations_um[1][2]");
}

// Strictness is where a client's body enters, not where a stored request is
// read back: a job stored by an older version with a key the check now
// refuses replays, and shows, as it was stored.
TEST_F(HostileRequestsTest, ReplaysAStoredRequestWithAKeyTheCheckRefuses) {
  ASSERT_EQ(
      PostJson(client_.get(), "/api/v1/corrections", StrictCorrectionRequest())
          .first,
      201);
  client_.reset();
  running_.reset();
  int64_t old_id = 0;
  {
    std::unique_ptr<JobRepository> repository = OpenJobRepository(db_.path());
    std::optional<JobRecord> job = repository->ReadJob(1);
    ASSERT_TRUE(job.has_value());
    nlohmann::json stored = nlohmann::json::parse(job->request_json);
    stored["operator_note"] = "stored by gearloop 0.9, before strict input";
    job->request_json = stored.dump();
    job->id = 0;
    old_id = repository->WriteJob(*job);
  }
  ServerOptions options;
  options.database_path = db_.path();
  running_ = std::make_unique<RunningServer>(options);
  ASSERT_GT(running_->port(), 0);
  client_ = running_->Client();

  const std::string job_path = "/api/v1/corrections/" + std::to_string(old_id);
  auto shown = client_->Get(job_path.c_str());
  ASSERT_TRUE(shown);
  EXPECT_EQ(shown->status, 200);
  const nlohmann::json stored = ParseBody(shown)["request"];
  EXPECT_TRUE(stored.contains("operator_note")) << stored.dump();
  auto [status, body] = PostJson(
      client_.get(), (job_path + "/replay").c_str(), nlohmann::json::object());
  EXPECT_EQ(status, 201) << body.dump();
  EXPECT_EQ(body["parent_job_id"], old_id);
  auto lineage = client_->Get((job_path + "/lineage").c_str());
  ASSERT_TRUE(lineage);
  EXPECT_EQ(lineage->status, 200);
  // The same request sent by a client is refused.
  std::tie(status, body) =
      PostJson(client_.get(), "/api/v1/corrections", stored);
  EXPECT_EQ(status, 422);
  EXPECT_EQ(body["error"]["field"], "operator_note");
}

}  // namespace
}  // namespace gearloop
