// Checks that api/openapi.yaml tells the truth: every documented operation is called on the real
// server and answers with its documented success status, and with each documented error status
// (400, 401, 403, 404, 405, 413, 422) when provoked; every error code seen is in the closed list.
//
// No YAML library is installed, so the file keeps a regular layout this test scans:
//   "  /path:" at indent 2 under "paths:", "    get:"/"    post:" at indent 4, and response
//   statuses as '        "201":' at indent 8.
#include <gtest/gtest.h>

#include <fstream>
#include <functional>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <openssl/sha.h>

#include "tests/server/server_test_util.h"

#ifndef GEARLOOP_SOURCE_DIR
#error "GEARLOOP_SOURCE_DIR must name the repository root"
#endif

namespace gearloop {
namespace {

using testing_util::DefaultSetup;
using testing_util::ParseBody;
using testing_util::RunningServer;
using testing_util::TempPath;

struct Operation {
  std::string method;  // "GET", "POST"
  std::string path;    // "/api/v1/corrections/{id}"
  std::set<int> statuses;
};

struct OpenApi {
  std::vector<Operation> operations;
  std::set<std::string> error_codes;
};

OpenApi ScanOpenApi(const std::string& file) {
  std::ifstream in(file);
  OpenApi api;
  std::string line;
  bool in_paths = false;
  bool in_code_enum = false;
  std::string path;
  const std::regex path_line(R"(^  (/\S*):\s*$)");
  const std::regex method_line(R"(^    (get|post|put|patch|delete):\s*$)");
  const std::regex status_line(R"re(^        "(\d{3})":\s*$)re");
  std::smatch m;
  while (std::getline(in, line)) {
    if (line == "paths:") {
      in_paths = true;
      continue;
    }
    if (!line.empty() && line[0] != ' ') in_paths = false;
    if (in_paths) {
      if (std::regex_match(line, m, path_line)) {
        path = m[1];
      } else if (std::regex_match(line, m, method_line)) {
        std::string method = m[1];
        for (char& c : method) c = static_cast<char>(std::toupper(c));
        api.operations.push_back({method, path, {}});
      } else if (std::regex_match(line, m, status_line) && !api.operations.empty()) {
        api.operations.back().statuses.insert(std::stoi(m[1]));
      }
    }
    // The closed list: "              enum:" under Error.properties.error.properties.code.
    if (line.find("description: The closed list of error codes.") != std::string::npos) {
      in_code_enum = true;
      continue;
    }
    if (in_code_enum) {
      const std::regex item(R"(^\s+- (\w+)\s*$)");
      if (std::regex_match(line, m, item)) {
        api.error_codes.insert(m[1]);
      } else if (line.find("enum:") == std::string::npos) {
        in_code_enum = false;
      }
    }
  }
  return api;
}

std::string Sha256Hex(const std::string& text) {
  unsigned char digest[SHA256_DIGEST_LENGTH];
  SHA256(reinterpret_cast<const unsigned char*>(text.data()), text.size(), digest);
  char hex[2 * SHA256_DIGEST_LENGTH + 1];
  for (int i = 0; i < SHA256_DIGEST_LENGTH; ++i) std::snprintf(hex + 2 * i, 3, "%02x", digest[i]);
  return hex;
}

class OpenApiTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { api_ = ScanOpenApi(std::string(GEARLOOP_SOURCE_DIR) + "/api/openapi.yaml"); }

  void SetUp() override {
    {
      std::ofstream out(token_file_.path());
      out << "read " << Sha256Hex("r") << "\nwrite " << Sha256Hex("w") << "\n";
    }
    ServerOptions options;
    options.database_path = db_.path();
    options.token_file = token_file_.path();
    options.payload_max_bytes = 256 * 1024;
    running_ = std::make_unique<RunningServer>(options);
    ASSERT_GT(running_->port(), 0);
    client_ = running_->Client();
  }

  httplib::Result Call(const std::string& method, const std::string& path, const std::string& body,
                       const std::string& token) {
    httplib::Headers headers;
    if (!token.empty()) headers.emplace("Authorization", "Bearer " + token);
    if (method == "GET") return client_->Get(path.c_str(), headers);
    if (method == "POST") return client_->Post(path.c_str(), headers, body, "application/json");
    if (method == "PUT") return client_->Put(path.c_str(), headers, body, "application/json");
    return client_->Delete(path.c_str(), headers);
  }

  // Calls and checks the status; the error body (for >= 400) must carry a listed code.
  void Expect(const std::string& what, const std::string& method, const std::string& path, const std::string& body,
              const std::string& token, int status) {
    httplib::Result result = Call(method, path, body, token);
    ASSERT_TRUE(result) << what;
    EXPECT_EQ(result->status, status) << what << ": " << method << " " << path << " -> " << result->body.substr(0, 300);
    if (result->status >= 400) {
      const nlohmann::json error = ParseBody(result);
      ASSERT_TRUE(error.contains("error")) << what;
      EXPECT_TRUE(api_.error_codes.count(error["error"]["code"].get<std::string>()))
          << what << ": code " << error["error"]["code"] << " is not in the closed list";
    }
  }

  nlohmann::json Measurement() {
    nlohmann::json request = DefaultSetup();
    request["random_hidden_errors"] = {{"block_size", 2.0}, {"seed", 3}};
    request["noise_um"] = 0.2;
    auto result = Call("POST", "/api/v1/simulations/measurement", request.dump(), "r");
    return ParseBody(result)["measurement"];
  }

  static OpenApi api_;
  TempPath db_;
  TempPath token_file_{"gearloop_tokens"};
  std::unique_ptr<RunningServer> running_;
  std::unique_ptr<httplib::Client> client_;
};

OpenApi OpenApiTest::api_;

TEST_F(OpenApiTest, ListsEveryOperationWithErrorCodes) {
  std::set<std::string> operations;
  for (const Operation& op : api_.operations) operations.insert(op.method + " " + op.path);
  const std::set<std::string> expected = {
      "GET /healthz",
      "GET /metrics",
      "POST /api/v1/nominal",
      "POST /api/v1/evaluate",
      "POST /api/v1/sensitivity",
      "POST /api/v1/corrections",
      "GET /api/v1/corrections",
      "GET /api/v1/corrections/{id}",
      "GET /api/v1/corrections/{id}/lineage",
      "POST /api/v1/corrections/{id}/replay",
      "POST /api/v1/batches",
      "GET /api/v1/batches/{id}",
      "POST /api/v1/simulations/measurement",
      "POST /api/v1/simulations/closed-loop",
      "POST /api/v1/bevel/conversions",
      "POST /api/v1/bevel/evaluate",
      "POST /api/v1/bevel/axis-sensitivity",
  };
  EXPECT_EQ(operations, expected);
  for (const char* code : {"invalid_json", "invalid_request", "invalid_value", "not_found", "method_not_allowed",
                           "payload_too_large", "unauthorized", "forbidden", "internal_error"}) {
    EXPECT_TRUE(api_.error_codes.count(code)) << code;
  }
  for (const Operation& op : api_.operations) {
    int successes = 0;
    for (int s : op.statuses) successes += (s >= 200 && s < 300);
    EXPECT_EQ(successes, 1) << op.method << " " << op.path << " documents one success status";
  }
}

TEST_F(OpenApiTest, EveryOperationAnswersAsDocumented) {
  // Jobs and a batch to point {id} at.
  nlohmann::json correction = DefaultSetup();
  correction["measurement"] = Measurement();
  correction["options"] = {{"probe_noise_um", 0.2}};
  auto created = Call("POST", "/api/v1/corrections", correction.dump(), "w");
  ASSERT_TRUE(created && created->status == 201);
  const std::string job_id = std::to_string(ParseBody(created)["id"].get<int64_t>());
  auto batch = Call("POST", "/api/v1/batches", nlohmann::json{{"items", {correction}}}.dump(), "w");
  ASSERT_TRUE(batch && batch->status == 202);
  const std::string batch_id = std::to_string(ParseBody(batch)["id"].get<int64_t>());

  nlohmann::json closed_loop = DefaultSetup();
  closed_loop["random_hidden_errors"] = {{"block_size", 2.0}, {"seed", 3}};
  closed_loop["noise_um"] = 0.2;
  closed_loop["corrections"] = 1;
  nlohmann::json impossible = DefaultSetup();
  impossible["gear"]["teeth"] = 3;
  nlohmann::json impossible_correction = correction;
  impossible_correction["gear"]["teeth"] = 3;
  nlohmann::json impossible_loop = closed_loop;
  impossible_loop["corrections"] = 0;

  // How to call each operation: a valid body, an invalid-values body (422), a wrongly shaped
  // body or query (400), the concrete path.
  struct Call {
    std::string path;
    std::string valid;
    std::string invalid_value;
    std::string bad_shape;
  };
  const std::string setup = DefaultSetup().dump();
  const std::string bevel = R"({"job": {"side": "convex", "published": true}})";
  const std::string bevel_impossible = R"({"job": {"side": "convex", "published": true, "machine": {"ratio_of_roll": 0}}})";
  const std::map<std::string, Call> calls = {
      {"GET /healthz", {"/healthz", "", "", ""}},
      {"GET /metrics", {"/metrics", "", "", ""}},
      {"POST /api/v1/nominal", {"/api/v1/nominal", setup, impossible.dump(), "{\"gear\": 1}"}},
      {"POST /api/v1/evaluate", {"/api/v1/evaluate", setup, impossible.dump(), "{\"gear\": 1}"}},
      {"POST /api/v1/sensitivity", {"/api/v1/sensitivity", setup, impossible.dump(), "{\"gear\": 1}"}},
      {"POST /api/v1/corrections",
       {"/api/v1/corrections", correction.dump(), impossible_correction.dump(), "{\"gear\": 1}"}},
      {"GET /api/v1/corrections", {"/api/v1/corrections", "", "?limit=0", "?limit=x"}},
      {"GET /api/v1/corrections/{id}", {"/api/v1/corrections/" + job_id, "", "", ""}},
      {"GET /api/v1/corrections/{id}/lineage", {"/api/v1/corrections/" + job_id + "/lineage", "", "", ""}},
      {"POST /api/v1/corrections/{id}/replay",
       {"/api/v1/corrections/" + job_id + "/replay", "{\"options\": {\"solver\": \"lsq-plain\"}}",
        "{\"options\": {\"solver\": \"none-such\"}}", "{\"options\": 3}"}},
      {"POST /api/v1/batches",
       {"/api/v1/batches", nlohmann::json{{"items", {correction}}}.dump(), "{\"items\": []}", "{\"items\": 5}"}},
      {"GET /api/v1/batches/{id}", {"/api/v1/batches/" + batch_id, "", "", ""}},
      {"POST /api/v1/simulations/measurement",
       {"/api/v1/simulations/measurement", closed_loop.dump(), impossible.dump(), "{\"gear\": 1}"}},
      {"POST /api/v1/simulations/closed-loop",
       {"/api/v1/simulations/closed-loop", closed_loop.dump(), impossible_loop.dump(), "{\"gear\": 1}"}},
      {"POST /api/v1/bevel/conversions", {"/api/v1/bevel/conversions", bevel, bevel_impossible, "{\"job\": 1}"}},
      {"POST /api/v1/bevel/evaluate", {"/api/v1/bevel/evaluate", bevel, bevel_impossible, "{\"job\": 1}"}},
      {"POST /api/v1/bevel/axis-sensitivity",
       {"/api/v1/bevel/axis-sensitivity", bevel, bevel_impossible, "{\"job\": 1}"}},
  };

  for (const Operation& op : api_.operations) {
    const std::string key = op.method + " " + op.path;
    SCOPED_TRACE(key);
    const auto it = calls.find(key);
    ASSERT_NE(it, calls.end()) << "no test call for " << key;
    const Call& call = it->second;
    const bool is_get = op.method == "GET";
    const bool open = op.path == "/healthz" || op.path == "/metrics";
    const bool needs_write = op.statuses.count(403) > 0;
    const std::string token = needs_write ? "w" : "r";
    for (int status : op.statuses) {
      if (status >= 200 && status < 300) {
        Expect("success", op.method, call.path, call.valid, open ? "" : token, status);
      } else if (status == 400) {
        if (is_get) {
          Expect("bad query", op.method, call.path + call.bad_shape, "", token, 400);
        } else {
          Expect("not JSON", op.method, call.path, "{\"gear\": ", token, 400);
          Expect("wrong shape", op.method, call.path, call.bad_shape, token, 400);
        }
      } else if (status == 401) {
        Expect("no token", op.method, call.path, call.valid, "", 401);
        Expect("unknown token", op.method, call.path, call.valid, "guess", 401);
      } else if (status == 403) {
        Expect("read token", op.method, call.path, call.valid, "r", 403);
      } else if (status == 404) {
        const std::string missing = std::regex_replace(call.path, std::regex(R"(/\d+)"), "/987654");
        Expect("unknown id", op.method, missing, call.valid, token, 404);
      } else if (status == 405) {
        Expect("wrong method", "PUT", call.path, "{}", token, 405);
        Expect("wrong method", "DELETE", call.path, "", token, 405);
      } else if (status == 413) {
        Expect("huge body", op.method, call.path, std::string(400 * 1024, ' ') + "{}", token, 413);
      } else if (status == 422) {
        if (is_get) {
          Expect("invalid query", op.method, call.path + call.invalid_value, "", token, 422);
        } else {
          Expect("invalid value", op.method, call.path, call.invalid_value, token, 422);
        }
      } else if (status == 503) {
        // Needs 20000 queued batch items; RefusesMalformedBatches and the batch tests cover
        // the queue, the status is documented for clients.
      } else {
        ADD_FAILURE() << "no way to provoke documented status " << status;
      }
    }
    // Operations that do not document 403 accept a read token.
    if (!needs_write && !open) Expect("read token suffices", op.method, call.path, call.valid, "r",
                                      *op.statuses.begin() < 300 ? *op.statuses.begin() : 200);
  }
}

}  // namespace
}  // namespace gearloop
