// Checks that api/openapi.yaml tells the truth: every documented operation is
// called on the real server and answers with its documented success status, and
// with each documented error status (400, 401, 403, 404, 405, 413, 422) when
// provoked; every error code seen is in the closed list; every success answer
// and every error body matches the schema documented for it (the file read with
// libyaml, tests/server/openapi_schema.h), the grinder's and the bevel variants
// alike.
//
// The operation list is also scanned from the file's regular layout, as a
// second reading:
//   "  /path:" at indent 2 under "paths:", "    get:"/"    post:" at indent 4,
//   and response statuses as '        "201":' at indent 8.
#include <gtest/gtest.h>
#include <openssl/sha.h>

#include <fstream>
#include <functional>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "tests/formats/metrology_samples.h"
#include "tests/server/openapi_schema.h"
#include "tests/server/server_test_util.h"

#ifndef GEARLOOP_SOURCE_DIR
#error "GEARLOOP_SOURCE_DIR must name the repository root"
#endif

namespace gearloop {
namespace {

using testing_util::DefaultSetup;
using testing_util::LoadYamlAsJson;
using testing_util::ParseBody;
using testing_util::RunningServer;
using testing_util::SchemaValidator;
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
      } else if (std::regex_match(line, m, status_line) &&
                 !api.operations.empty()) {
        api.operations.back().statuses.insert(std::stoi(m[1]));
      }
    }
    // The closed list: "              enum:" under
    // Error.properties.error.properties.code.
    if (line.find("description: The closed list of error codes.") !=
        std::string::npos) {
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
  SHA256(
      reinterpret_cast<const unsigned char*>(text.data()), text.size(), digest);
  char hex[2 * SHA256_DIGEST_LENGTH + 1];
  for (int i = 0; i < SHA256_DIGEST_LENGTH; ++i)
    std::snprintf(hex + 2 * i, 3, "%02x", digest[i]);
  return hex;
}

class OpenApiTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const std::string file =
        std::string(GEARLOOP_SOURCE_DIR) + "/api/openapi.yaml";
    api_ = ScanOpenApi(file);
    spec_error_.clear();
    spec_ = LoadYamlAsJson(file, &spec_error_);
  }

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

  httplib::Result Call(const std::string& method,
                       const std::string& path,
                       const std::string& body,
                       const std::string& token) {
    httplib::Headers headers;
    if (!token.empty()) headers.emplace("Authorization", "Bearer " + token);
    if (method == "GET") return client_->Get(path.c_str(), headers);
    if (method == "POST")
      return client_->Post(path.c_str(), headers, body, "application/json");
    if (method == "PUT")
      return client_->Put(path.c_str(), headers, body, "application/json");
    return client_->Delete(path.c_str(), headers);
  }

  // Calls and checks the status; the error body (for >= 400) must carry a
  // listed code. With `documented` (the operation as the file names it, "POST
  // /api/v1/corrections/{id}/replay"), the JSON body must also match the schema
  // the file documents for that status. Returns the body.
  nlohmann::json Expect(const std::string& what,
                        const std::string& method,
                        const std::string& path,
                        const std::string& body,
                        const std::string& token,
                        int status,
                        const std::string& documented = "") {
    httplib::Result result = Call(method, path, body, token);
    EXPECT_TRUE(result) << what;
    if (!result) return nullptr;
    EXPECT_EQ(result->status, status) << what << ": " << method << " " << path
                                      << " -> " << result->body.substr(0, 300);
    const bool is_json =
        result->get_header_value("Content-Type").find("application/json") !=
        std::string::npos;
    const nlohmann::json answer =
        is_json ? ParseBody(result) : nlohmann::json(nullptr);
    if (result->status >= 400) {
      EXPECT_TRUE(answer.contains("error")) << what;
      if (!answer.contains("error")) return answer;
      EXPECT_TRUE(
          api_.error_codes.count(answer["error"]["code"].get<std::string>()))
          << what << ": code " << answer["error"]["code"]
          << " is not in the closed list";
    }
    if (!documented.empty() && is_json && result->status == status) {
      ExpectMatchesSchema(what, documented, status, answer);
    }
    return answer;
  }

  // The answer matches the schema documented for "METHOD /path" and this
  // status.
  void ExpectMatchesSchema(const std::string& what,
                           const std::string& documented,
                           int status,
                           const nlohmann::json& answer) {
    ASSERT_TRUE(spec_error_.empty()) << spec_error_;
    const size_t space = documented.find(' ');
    const SchemaValidator validator(spec_);
    const nlohmann::json schema = validator.ResponseSchema(
        documented.substr(0, space), documented.substr(space + 1), status);
    ASSERT_FALSE(schema.is_null())
        << documented << " documents no JSON schema for " << status;
    std::vector<std::string> problems;
    validator.Validate(schema, answer, &problems);
    std::string text;
    for (size_t i = 0; i < problems.size() && i < 10; ++i)
      text += "\n  " + problems[i];
    EXPECT_TRUE(problems.empty())
        << what << ": the " << status << " answer of " << documented
        << " does not match its schema:" << text;
  }

  // A small split-bevel trajectory (docs/split-bevel.md's wheel, 5 stations).
  static nlohmann::json SplitTrajectoryRequest() {
    return nlohmann::json::parse(R"({
      "gear": {"teeth": 75, "pitch_angle_deg": 70, "outer_transverse_module_mm": 40,
               "face_width_mm": 240, "mean_spiral_angle_deg": 35, "hand": "right",
               "pressure_angle_deg": 20},
      "tool": {"radius_mm": 8, "stock_mm": 0.2},
      "cut": {"slot_index": 3, "depth_levels": 2, "steps": 5},
      "machine": {"pivot_length_mm": 300},
      "output": {"nc": true}})");
  }

  nlohmann::json Measurement() {
    nlohmann::json request = DefaultSetup();
    request["random_hidden_errors"] = {{"block_size", 2.0}, {"seed", 3}};
    request["noise_um"] = 0.2;
    auto result =
        Call("POST", "/api/v1/simulations/measurement", request.dump(), "r");
    return ParseBody(result)["measurement"];
  }

  static OpenApi api_;
  static nlohmann::json spec_;
  static std::string spec_error_;
  TempPath db_;
  TempPath token_file_{"gearloop_tokens"};
  std::unique_ptr<RunningServer> running_;
  std::unique_ptr<httplib::Client> client_;
};

OpenApi OpenApiTest::api_;
nlohmann::json OpenApiTest::spec_;
std::string OpenApiTest::spec_error_;

// The file read as YAML names the same operations the layout scan finds, so the
// schemas the tests below check against are the ones of the operations listed.
TEST_F(OpenApiTest, ParsesAsYamlWithTheScannedOperations) {
  ASSERT_TRUE(spec_error_.empty()) << spec_error_;
  ASSERT_TRUE(spec_.contains("paths"));
  std::set<std::string> parsed, scanned;
  for (auto path = spec_["paths"].begin(); path != spec_["paths"].end();
       ++path) {
    for (auto method = path.value().begin(); method != path.value().end();
         ++method) {
      std::string name = method.key();
      if (name != "get" && name != "post" && name != "put" && name != "patch" &&
          name != "delete")
        continue;
      for (char& c : name) c = static_cast<char>(std::toupper(c));
      parsed.insert(name + " " + path.key());
      for (auto status = method.value()["responses"].begin();
           status != method.value()["responses"].end();
           ++status) {
        parsed.insert(name + " " + path.key() + " " + status.key());
      }
    }
  }
  for (const Operation& op : api_.operations) {
    scanned.insert(op.method + " " + op.path);
    for (int status : op.statuses)
      scanned.insert(op.method + " " + op.path + " " + std::to_string(status));
  }
  EXPECT_EQ(parsed, scanned);
}

TEST_F(OpenApiTest, ListsEveryOperationWithErrorCodes) {
  std::set<std::string> operations;
  for (const Operation& op : api_.operations)
    operations.insert(op.method + " " + op.path);
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
      "POST /api/v1/measurements/import",
      "GET /api/v1/corrections/{id}/export",
      "POST /api/v1/shaving/cutter-target",
      "POST /api/v1/bevel/split-trajectory",
      "GET /api/v1/bevel/split-trajectory/{id}/nc",
      "GET /api/v1/corrections/{id}/settings",
      "GET /api/v1/openapi.yaml",
      "POST /api/v1/targets/reach",
  };
  EXPECT_EQ(operations, expected);
  for (const char* code : {"invalid_json",
                           "invalid_request",
                           "invalid_value",
                           "not_found",
                           "method_not_allowed",
                           "payload_too_large",
                           "unauthorized",
                           "forbidden",
                           "internal_error"}) {
    EXPECT_TRUE(api_.error_codes.count(code)) << code;
  }
  for (const Operation& op : api_.operations) {
    int successes = 0;
    for (int s : op.statuses) successes += (s >= 200 && s < 300);
    EXPECT_EQ(successes, 1)
        << op.method << " " << op.path << " documents one success status";
  }
}

// The document served is this file, byte for byte, and needs no token.
TEST_F(OpenApiTest, ServesTheDocumentItWasBuiltWith) {
  std::ifstream in(std::string(GEARLOOP_SOURCE_DIR) + "/api/openapi.yaml");
  ASSERT_TRUE(in.good());
  std::stringstream file;
  file << in.rdbuf();
  auto served = Call("GET", "/api/v1/openapi.yaml", "", "");
  ASSERT_TRUE(served);
  EXPECT_EQ(served->status, 200);
  EXPECT_EQ(served->get_header_value("Content-Type"),
            "application/yaml; charset=utf-8");
  EXPECT_EQ(served->body, file.str());
}

TEST_F(OpenApiTest, EveryOperationAnswersAsDocumented) {
  // Jobs and a batch to point {id} at.
  nlohmann::json correction = DefaultSetup();
  correction["measurement"] = Measurement();
  correction["options"] = {{"probe_noise_um", 0.2}};
  correction["trace"] = {{"part_number", "4711-A"},
                         {"serial", "S1"},
                         {"teeth", {3}},
                         {"measured_at", "2026-11-22T07:45:00Z"},
                         {"file_name", "S1.mka"},
                         {"machine_id", "RZ260-2"}};
  correction["tolerance"] = {{"rms_um", 0.5}, {"iso_class", 6}};
  auto created = Call("POST", "/api/v1/corrections", correction.dump(), "w");
  ASSERT_TRUE(created && created->status == 201);
  const std::string job_id =
      std::to_string(ParseBody(created)["id"].get<int64_t>());
  auto batch = Call("POST",
                    "/api/v1/batches",
                    nlohmann::json{{"items", {correction}}}.dump(),
                    "w");
  ASSERT_TRUE(batch && batch->status == 202);
  const std::string batch_id =
      std::to_string(ParseBody(batch)["id"].get<int64_t>());
  const std::string split = SplitTrajectoryRequest().dump();
  nlohmann::json split_impossible = SplitTrajectoryRequest();
  split_impossible["tool"]["radius_mm"] = 40;
  auto split_job = Call("POST", "/api/v1/bevel/split-trajectory", split, "w");
  ASSERT_TRUE(split_job && split_job->status == 200);
  const std::string split_id =
      std::to_string(ParseBody(split_job)["job_id"].get<int64_t>());

  nlohmann::json simulation = DefaultSetup();
  simulation["random_hidden_errors"] = {{"block_size", 2.0}, {"seed", 3}};
  simulation["noise_um"] = 0.2;
  // A closed loop's own keys are unknown to a measurement (strict input).
  nlohmann::json closed_loop = simulation;
  closed_loop["corrections"] = 1;
  nlohmann::json impossible = DefaultSetup();
  impossible["gear"]["teeth"] = 3;
  nlohmann::json impossible_correction = correction;
  impossible_correction["gear"]["teeth"] = 3;
  nlohmann::json impossible_loop = closed_loop;
  impossible_loop["corrections"] = 0;

  // How to call each operation: a valid body, an invalid-values body (422), a
  // wrongly shaped body or query (400), the concrete path.
  struct Call {
    std::string path;
    std::string valid;
    std::string invalid_value;
    std::string bad_shape;
  };
  const std::string setup = DefaultSetup().dump();
  const std::string bevel = R"({"job": {"side": "convex", "published": true}})";
  const std::string bevel_impossible =
      R"({"job": {"side": "convex", "published": true, "machine": {"ratio_of_roll": 0}}})";
  // SHAVING.md §1: the published pinion (standard radii) and its cutter.
  const nlohmann::json shaving = nlohmann::json::parse(R"({
    "work_gear": {"teeth": 19, "normal_module_mm": 6, "normal_pressure_angle_deg": 20,
                  "helix_angle_deg": 9.91, "hand": "right", "face_width_mm": 75},
    "cutter": {"teeth": 37, "normal_module_mm": 6, "normal_pressure_angle_deg": 20,
               "helix_angle_deg": 15, "hand": "left", "face_width_mm": 78,
               "tip_radius_mm": 120.9157, "root_radius_mm": 107.1569},
    "diagonal_modification": {"root_um": 20, "tip_um": 20}})");
  nlohmann::json shaving_impossible = shaving;
  shaving_impossible["centre_distance_mm"] = 400;
  std::map<std::string, Call> calls = {
      {"GET /healthz", {"/healthz", "", "", ""}},
      {"GET /metrics", {"/metrics", "", "", ""}},
      {"GET /api/v1/openapi.yaml", {"/api/v1/openapi.yaml", "", "", ""}},
      {"POST /api/v1/nominal",
       {"/api/v1/nominal", setup, impossible.dump(), "{\"gear\": 1}"}},
      {"POST /api/v1/evaluate",
       {"/api/v1/evaluate", setup, impossible.dump(), "{\"gear\": 1}"}},
      {"POST /api/v1/sensitivity",
       {"/api/v1/sensitivity", setup, impossible.dump(), "{\"gear\": 1}"}},
      {"POST /api/v1/corrections",
       {"/api/v1/corrections",
        correction.dump(),
        impossible_correction.dump(),
        "{\"gear\": 1}"}},
      {"GET /api/v1/corrections",
       {"/api/v1/corrections",
        "?part_number=4711-A&tooth=3",
        "?limit=0",
        "?tooth=x"}},
      {"GET /api/v1/corrections/{id}",
       {"/api/v1/corrections/" + job_id, "", "", ""}},
      {"GET /api/v1/corrections/{id}/lineage",
       {"/api/v1/corrections/" + job_id + "/lineage", "", "", ""}},
      {"POST /api/v1/corrections/{id}/replay",
       {"/api/v1/corrections/" + job_id + "/replay",
        "{\"options\": {\"solver\": \"lsq-plain\"}}",
        "{\"options\": {\"solver\": \"none-such\"}}",
        "{\"options\": 3}"}},
      {"POST /api/v1/batches",
       {"/api/v1/batches",
        nlohmann::json{{"items", {correction}}}.dump(),
        "{\"items\": []}",
        "{\"items\": 5}"}},
      {"GET /api/v1/batches/{id}", {"/api/v1/batches/" + batch_id, "", "", ""}},
      {"POST /api/v1/simulations/measurement",
       {"/api/v1/simulations/measurement",
        simulation.dump(),
        impossible.dump(),
        "{\"gear\": 1}"}},
      {"POST /api/v1/simulations/closed-loop",
       {"/api/v1/simulations/closed-loop",
        closed_loop.dump(),
        impossible_loop.dump(),
        "{\"gear\": 1}"}},
      {"POST /api/v1/bevel/conversions",
       {"/api/v1/bevel/conversions", bevel, bevel_impossible, "{\"job\": 1}"}},
      {"POST /api/v1/bevel/evaluate",
       {"/api/v1/bevel/evaluate", bevel, bevel_impossible, "{\"job\": 1}"}},
      {"POST /api/v1/bevel/axis-sensitivity",
       {"/api/v1/bevel/axis-sensitivity",
        bevel,
        bevel_impossible,
        "{\"job\": 1}"}},
      {"POST /api/v1/shaving/cutter-target",
       {"/api/v1/shaving/cutter-target",
        shaving.dump(),
        shaving_impossible.dump(),
        "{\"work_gear\": 1}"}},
      {"POST /api/v1/bevel/split-trajectory",
       {"/api/v1/bevel/split-trajectory",
        split,
        split_impossible.dump(),
        "{\"gear\": 1}"}},
      {"GET /api/v1/bevel/split-trajectory/{id}/nc",
       {"/api/v1/bevel/split-trajectory/" + split_id + "/nc", "", "", ""}},
  };

  // A measuring-machine file (issue 15): the sample gear and its .mka file.
  nlohmann::json import = {
      {"gear",
       {{"teeth", 31},
        {"normal_module_mm", 4.5},
        {"normal_pressure_angle_deg", 20},
        {"helix_angle_deg", 20},
        {"hand", "right"},
        {"face_width_mm", 40},
        {"tip_radius_mm", 78.726},
        {"root_radius_mm", 68.601}}},
      {"flank", "right"},
      {"format", "mka"},
      {"content", testing::ReadSample("sample_topography.mka")}};
  nlohmann::json import_broken = import;
  import_broken["content"] = "HEADER KS.MK.FILE\n   21 :mn: 4,5\n";
  calls.insert({"POST /api/v1/measurements/import",
                {"/api/v1/measurements/import",
                 import.dump(),
                 import_broken.dump(),
                 "{\"gear\": 1}"}});
  calls.insert({"GET /api/v1/corrections/{id}/export",
                {"/api/v1/corrections/" + job_id + "/export?format=gde",
                 "",
                 "x",
                 "&format=xml"}});

  nlohmann::json reach = DefaultSetup();
  reach["target"] = {
      {"modifications", {{{"kind", "lead_crowning"}, {"amount_um", 10}}}}};
  nlohmann::json reach_impossible = reach;
  reach_impossible["gear"]["teeth"] = 2;
  calls.insert({"POST /api/v1/targets/reach",
                {"/api/v1/targets/reach",
                 reach.dump(),
                 reach_impossible.dump(),
                 "{\"gear\": 1}"}});
  calls.insert({"GET /api/v1/corrections/{id}/settings",
                {"/api/v1/corrections/" + job_id + "/settings?format=csv",
                 "",
                 "&samples=1",
                 "&samples=x"}});

  for (const Operation& op : api_.operations) {
    const std::string key = op.method + " " + op.path;
    SCOPED_TRACE(key);
    const auto it = calls.find(key);
    ASSERT_NE(it, calls.end()) << "no test call for " << key;
    const Call& call = it->second;
    const bool is_get = op.method == "GET";
    const bool open = op.path == "/healthz" || op.path == "/metrics" ||
                      op.path == "/api/v1/openapi.yaml";
    const bool needs_write = op.statuses.count(403) > 0;
    const std::string token = needs_write ? "w" : "r";
    for (int status : op.statuses) {
      if (status >= 200 && status < 300) {
        Expect("success",
               op.method,
               call.path,
               call.valid,
               open ? "" : token,
               status,
               key);
      } else if (status == 400) {
        if (is_get) {
          Expect("bad query",
                 op.method,
                 call.path + call.bad_shape,
                 "",
                 token,
                 400,
                 key);
        } else {
          Expect(
              "not JSON", op.method, call.path, "{\"gear\": ", token, 400, key);
          Expect("wrong shape",
                 op.method,
                 call.path,
                 call.bad_shape,
                 token,
                 400,
                 key);
        }
      } else if (status == 401) {
        Expect("no token", op.method, call.path, call.valid, "", 401, key);
        Expect("unknown token",
               op.method,
               call.path,
               call.valid,
               "guess",
               401,
               key);
      } else if (status == 403) {
        Expect("read token", op.method, call.path, call.valid, "r", 403, key);
      } else if (status == 404) {
        const std::string missing =
            std::regex_replace(call.path, std::regex(R"(/\d+)"), "/987654");
        Expect("unknown id", op.method, missing, call.valid, token, 404, key);
      } else if (status == 405) {
        Expect("wrong method", "PUT", call.path, "{}", token, 405, key);
        Expect("wrong method", "DELETE", call.path, "", token, 405, key);
      } else if (status == 413) {
        Expect("huge body",
               op.method,
               call.path,
               std::string(400 * 1024, ' ') + "{}",
               token,
               413,
               key);
      } else if (status == 422) {
        if (is_get) {
          Expect("invalid query",
                 op.method,
                 call.path + call.invalid_value,
                 "",
                 token,
                 422,
                 key);
        } else {
          Expect("invalid value",
                 op.method,
                 call.path,
                 call.invalid_value,
                 token,
                 422,
                 key);
        }
      } else if (status == 503) {
        // Needs 20000 queued batch items; RefusesMalformedBatches and the batch
        // tests cover the queue, the status is documented for clients.
      } else {
        ADD_FAILURE() << "no way to provoke documented status " << status;
      }
    }
    // Operations that do not document 403 accept a read token.
    if (!needs_write && !open)
      Expect("read token suffices",
             op.method,
             call.path,
             call.valid,
             "r",
             *op.statuses.begin() < 300 ? *op.statuses.begin() : 200);
  }
}

// A correction from a measuring-machine file (issue 15) answers
// CorrectionCreated with iso1328 and measurement_file, its stored job (whose
// request keeps the file) matches Job, and a refused file is an Error with the
// listed code invalid_file.
TEST_F(OpenApiTest, MeasurementFileAnswersMatchTheirSchemas) {
  nlohmann::json correction = {{"gear",
                                {{"teeth", 31},
                                 {"normal_module_mm", 4.5},
                                 {"normal_pressure_angle_deg", 20},
                                 {"helix_angle_deg", 20},
                                 {"hand", "right"},
                                 {"face_width_mm", 40},
                                 {"tip_radius_mm", 78.726},
                                 {"root_radius_mm", 68.601}}},
                               {"wheel", {{"radius_mm", 350}}},
                               {"flank", "right"}};
  correction["measurement"] = {
      {"file",
       {{"format", "gde"},
        {"content", testing::ReadSample("sample_topography.gde.xml")}}}};
  const nlohmann::json created = Expect("correction from a file",
                                        "POST",
                                        "/api/v1/corrections",
                                        correction.dump(),
                                        "w",
                                        201,
                                        "POST /api/v1/corrections");
  ASSERT_TRUE(created.contains("result"));
  EXPECT_TRUE(created["result"].contains("iso1328"));
  EXPECT_EQ(created["result"]["measurement_file"]["format"], "gde");
  const std::string id = std::to_string(created["id"].get<int64_t>());
  const nlohmann::json job = Expect("its job",
                                    "GET",
                                    "/api/v1/corrections/" + id,
                                    "",
                                    "r",
                                    200,
                                    "GET /api/v1/corrections/{id}");
  EXPECT_EQ(job["request"]["measurement"]["file"]["format"], "gde");
  correction["measurement"]["file"]["content"] = "<GDE><unclosed></GDE>";
  const nlohmann::json refused = Expect("a broken file",
                                        "POST",
                                        "/api/v1/corrections",
                                        correction.dump(),
                                        "w",
                                        422,
                                        "POST /api/v1/corrections");
  EXPECT_EQ(refused["error"]["code"], "invalid_file");
}

// The operations that take a bevel body as well (machine.kind
// "free-form-bevel-generator") answer with their bevel schemas; a closed loop,
// grinder and bevel, stored or not, answers ClosedLoopResponse or
// BevelClosedLoopResponse part by part, and each stored round is a job whose
// result matches CorrectionResult or BevelCorrectionResult.
TEST_F(OpenApiTest, SplitTrajectoryJobMatchesTheJobSchemas) {
  const nlohmann::json answer = Expect("split trajectory",
                                       "POST",
                                       "/api/v1/bevel/split-trajectory",
                                       SplitTrajectoryRequest().dump(),
                                       "w",
                                       200,
                                       "POST /api/v1/bevel/split-trajectory");
  ASSERT_TRUE(answer.contains("location"));
  Expect("stored split trajectory",
         "GET",
         answer["location"].get<std::string>(),
         "",
         "r",
         200,
         "GET /api/v1/corrections/{id}");
  Expect("history with a split trajectory",
         "GET",
         "/api/v1/corrections?kind=split_trajectory&flank=both",
         "",
         "r",
         200,
         "GET /api/v1/corrections");
}

TEST_F(OpenApiTest, GrinderAndBevelAnswersMatchTheirSchemas) {
  const nlohmann::json bevel_machine = {{"kind", "free-form-bevel-generator"}};
  const nlohmann::json bevel_job = {{"side", "concave"}, {"published", true}};
  nlohmann::json bevel_scenario = {
      {"machine", bevel_machine},
      {"job", bevel_job},
      {"hidden_errors", {{"X_mm", {0.008}}, {"Y_mm", {0.0, -0.02}}}},
      {"noise_um", 0.2},
      {"seed", 11}};
  const nlohmann::json cmm = Expect("bevel measurement",
                                    "POST",
                                    "/api/v1/simulations/measurement",
                                    bevel_scenario.dump(),
                                    "r",
                                    200,
                                    "POST /api/v1/simulations/measurement");
  ASSERT_TRUE(cmm.contains("measurement"));
  const nlohmann::json bevel_correction = {
      {"machine", bevel_machine},
      {"job", bevel_job},
      {"measurement", cmm["measurement"]},
      {"options", {{"default_max_order", 2}, {"probe_noise_um", 0.2}}}};
  const nlohmann::json created = Expect("bevel correction",
                                        "POST",
                                        "/api/v1/corrections",
                                        bevel_correction.dump(),
                                        "w",
                                        201,
                                        "POST /api/v1/corrections");
  ASSERT_TRUE(created.contains("id"));
  const std::string bevel_job_path =
      "/api/v1/corrections/" + std::to_string(created["id"].get<int64_t>());
  Expect("bevel job",
         "GET",
         bevel_job_path,
         "",
         "r",
         200,
         "GET /api/v1/corrections/{id}");
  Expect("bevel replay",
         "POST",
         bevel_job_path + "/replay",
         "{}",
         "w",
         201,
         "POST /api/v1/corrections/{id}/replay");

  nlohmann::json grinder_loop = DefaultSetup();
  grinder_loop["random_hidden_errors"] = {{"block_size", 2.0}, {"seed", 3}};
  grinder_loop["noise_um"] = 0.2;
  grinder_loop["corrections"] = 2;
  nlohmann::json bevel_loop = bevel_scenario;
  bevel_loop["corrections"] = 2;
  bevel_loop["options"] = {{"default_max_order", 2}};
  for (const bool store : {false, true}) {
    for (const nlohmann::json* scenario : {&grinder_loop, &bevel_loop}) {
      const bool bevel = scenario == &bevel_loop;
      SCOPED_TRACE(std::string(bevel ? "bevel" : "grinder") +
                   (store ? ", stored" : ""));
      nlohmann::json body = *scenario;
      body["store"] = store;
      const nlohmann::json loop =
          Expect("closed loop",
                 "POST",
                 "/api/v1/simulations/closed-loop",
                 body.dump(),
                 "w",
                 200,
                 "POST /api/v1/simulations/closed-loop");
      ASSERT_TRUE(loop.contains("iterations"));
      ASSERT_EQ(loop["iterations"].size(), 3u);
      // A corrected part, so that the correction summary is there to be
      // checked.
      ASSERT_TRUE(loop["iterations"][0]["correction"].is_object());
      EXPECT_TRUE(loop["iterations"][2]["correction"].is_null());
      for (const nlohmann::json& iteration : loop["iterations"]) {
        EXPECT_EQ(iteration.contains("job_id"),
                  store && iteration["correction"].is_object());
        if (!iteration.contains("job_id")) continue;
        Expect("stored round",
               "GET",
               "/api/v1/corrections/" +
                   std::to_string(iteration["job_id"].get<int64_t>()),
               "",
               "r",
               200,
               "GET /api/v1/corrections/{id}");
      }
    }
  }
}

// The check above would catch a schema that claims more than the server sends:
// a closed-loop iteration's correction is a summary, not a full result (no
// settings, delta or grids).
TEST_F(OpenApiTest, ValidatorRefusesAClosedLoopCorrectionAsAFullResult) {
  ASSERT_TRUE(spec_error_.empty()) << spec_error_;
  nlohmann::json body = DefaultSetup();
  body["random_hidden_errors"] = {{"block_size", 2.0}, {"seed", 3}};
  body["corrections"] = 1;
  const nlohmann::json loop = Expect("closed loop",
                                     "POST",
                                     "/api/v1/simulations/closed-loop",
                                     body.dump(),
                                     "w",
                                     200);
  ASSERT_TRUE(loop["iterations"][0]["correction"].is_object());
  const SchemaValidator validator(spec_);
  std::vector<std::string> problems;
  EXPECT_TRUE(validator.Validate(validator.Schema("CorrectionSummary"),
                                 loop["iterations"][0]["correction"],
                                 &problems))
      << problems.front();
  problems.clear();
  EXPECT_FALSE(validator.Validate(validator.Schema("CorrectionResult"),
                                  loop["iterations"][0]["correction"],
                                  &problems));
  ASSERT_FALSE(problems.empty());
  EXPECT_NE(problems.front().find("\"settings\""), std::string::npos)
      << problems.front();
  // And the bevel answer is not a grinder loop, nor the grinder's a bevel loop.
  problems.clear();
  EXPECT_FALSE(validator.Validate(
      validator.Schema("BevelClosedLoopResponse"), loop, &problems));
}

}  // namespace
}  // namespace gearloop
