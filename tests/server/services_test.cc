// tests/server/services_test.cc: the services of server/services/ called
// directly with a built httplib::Request, the real engine (or a stub solver in
// ServiceContext::compute_correction) and a ":memory:" job history, without a
// socket or the HTTP layer (as OSRM unit_tests/server/request_handler.cpp
// tests its handler).
#include <gtest/gtest.h>

#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <regex>
#include <string>
#include <vector>

#include "server/respond.h"
#include "server/services/correction_service.h"
#include "server/services/history_service.h"
#include "server/services/simulation_service.h"
#include "storage/job_repository.h"
#include "tests/server/server_test_util.h"

// Last: see server/respond.h.
#include <httplib.h>

namespace gearloop {
namespace {

using testing_util::DefaultSetup;

struct Answer {
  int status = 0;
  nlohmann::json body;
  std::string location;
};

class ServicesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    repository_ = OpenJobRepository(":memory:");
    context_.repository = repository_.get();
    context_.server_version = "test";
    context_.log_solves = false;
    context_.enqueue_batch_items = [this](std::vector<PendingBatchItem> items) {
      for (PendingBatchItem& item : items) queued_.push_back(std::move(item));
    };
    context_.queued_batch_items = [this] { return queued_.size(); };
  }

  using Service = void (*)(const ServiceContext&,
                           const httplib::Request&,
                           httplib::Response&);

  Answer Call(Service service,
              const nlohmann::json& body,
              const std::string& path_id = "") {
    httplib::Request req;
    req.method = "POST";
    req.body = body.is_null() ? "" : body.dump();
    if (!path_id.empty()) {
      // The route's regex capture, as cpp-httplib fills it (the match refers
      // into path_).
      path_ = "/" + path_id;
      std::regex_match(path_, req.matches, std::regex(R"(/(\d+))"));
    }
    httplib::Response res;
    service(context_, req, res);
    Answer answer;
    answer.status = res.status;
    answer.body = nlohmann::json::parse(res.body, nullptr, false);
    answer.location = res.get_header_value("Location");
    return answer;
  }

  // A simulated CMM measurement (of `teeth` teeth) of a part ground with hidden
  // machine errors.
  nlohmann::json Measurement(int teeth) {
    nlohmann::json request = DefaultSetup();
    request["random_hidden_errors"] = {
        {"block_size", 3.0}, {"max_order", 2}, {"seed", 4}};
    request["noise_um"] = 0.6;
    request["seed"] = 5;
    request["teeth"] = teeth;
    const Answer answer = Call(SimulateMeasurement, request);
    EXPECT_EQ(answer.status, 200) << answer.body.dump();
    return answer.body["measurement"];
  }

  std::unique_ptr<JobRepository> repository_;
  ServiceContext context_;
  std::vector<PendingBatchItem> queued_;
  std::string path_;
};

TEST_F(ServicesTest, CreateCorrectionStoresTheJobAndAnswersItsLocation) {
  nlohmann::json request = DefaultSetup();
  request["measurement"] = {{"deviations_um", Measurement(1)["deviations_um"]}};
  request["options"] = {{"probe_noise_um", 0.6}};
  const Answer created = Call(CreateCorrection, request);
  ASSERT_EQ(created.status, 201) << created.body.dump();
  EXPECT_EQ(created.location,
            "/api/v1/corrections/" +
                std::to_string(created.body["id"].get<int64_t>()));
  EXPECT_EQ(repository_->CountJobs(), 1);
  const std::optional<JobRecord> job =
      repository_->ReadJob(created.body["id"].get<int64_t>());
  ASSERT_TRUE(job.has_value());
  EXPECT_EQ(job->kind, "correction");
  EXPECT_EQ(job->server_version, "test");
  EXPECT_EQ(job->gear_teeth, 37);
  EXPECT_EQ(job->flank, "right");
  EXPECT_EQ(nlohmann::json::parse(job->result_json), created.body["result"]);
}

// The engine averages several teeth itself and knows that a mean of three
// readings is less noisy than one, so its regularisation keeps more than for
// the same mean sent as one grid.
TEST_F(ServicesTest, ThreeMeasuredTeethKeepMoreThanTheirMeanAsOneGrid) {
  const nlohmann::json measured = Measurement(3);
  ASSERT_EQ(measured["teeth"].size(), 3u);
  nlohmann::json teeth = DefaultSetup();
  teeth["measurement"] = {{"teeth", measured["teeth"]}};
  teeth["options"] = {{"probe_noise_um", 0.6}};
  nlohmann::json one_grid = teeth;
  one_grid["measurement"] = {{"deviations_um", measured["deviations_um"]}};
  const Answer from_teeth = Call(CreateCorrection, teeth);
  const Answer from_mean = Call(CreateCorrection, one_grid);
  ASSERT_EQ(from_teeth.status, 201) << from_teeth.body.dump();
  ASSERT_EQ(from_mean.status, 201) << from_mean.body.dump();
  // Both answers show the grid the solver corrected: the mean of the teeth.
  EXPECT_EQ(from_teeth.body["result"]["measured_um"],
            from_mean.body["result"]["measured_um"]);
  // At the estimated state each direction is filtered by its own signal to
  // noise (docs/correction-safety.md): less noise keeps more of every
  // direction, so the teeth's filter factors sum to more degrees of freedom.
  const nlohmann::json& teeth_filter =
      from_teeth.body["result"]["regularisation"];
  const nlohmann::json& mean_filter =
      from_mean.body["result"]["regularisation"];
  EXPECT_EQ(teeth_filter["filter"], "per-direction");
  EXPECT_EQ(mean_filter["filter"], "per-direction");
  EXPECT_GT(teeth_filter["effective_dof"].get<double>(),
            mean_filter["effective_dof"].get<double>());
}

TEST_F(ServicesTest,
       CreateCorrectionRefusesAnUnknownMachineKindAndStoresNothing) {
  nlohmann::json request = DefaultSetup();
  request["machine"]["kind"] = "hobbing-machine";
  request["measurement"] = {{"deviations_um", Measurement(1)["deviations_um"]}};
  const Answer refused = Call(CreateCorrection, request);
  EXPECT_EQ(refused.status, 422);
  EXPECT_EQ(refused.body["error"]["field"], "machine.kind");
  EXPECT_EQ(repository_->CountJobs(), 0);
}

TEST_F(ServicesTest, BevelCorrectionRefusesInvoluteTargetModifications) {
  const nlohmann::json bevel = {
      {"machine", {{"kind", "free-form-bevel-generator"}}},
      {"job", {{"side", "convex"}, {"published", true}}}};
  const Answer measured = Call(SimulateMeasurement, bevel);
  ASSERT_EQ(measured.status, 200) << measured.body.dump();
  EXPECT_EQ(measured.body["machine_kind"], "free-form-bevel-generator");
  nlohmann::json request = bevel;
  request["measurement"] = {
      {"deviations_um", measured.body["measurement"]["deviations_um"]}};
  request["target"] = {{"modifications", nlohmann::json::array()}};
  const Answer refused = Call(CreateCorrection, request);
  EXPECT_EQ(refused.status, 422) << refused.body.dump();
  EXPECT_EQ(refused.body["error"]["field"], "target.modifications");
  EXPECT_EQ(repository_->CountJobs(), 0);
}

// A stored closed-loop job carries the grid the simulated machine measured for
// its part: the same grid the measurement simulation gives for the same
// machine, commanded settings and seed.
TEST_F(ServicesTest, ClosedLoopStoresWhatTheMachineMeasuredForEachPart) {
  nlohmann::json loop = DefaultSetup();
  loop["random_hidden_errors"] = {
      {"block_size", 3.0}, {"max_order", 2}, {"seed", 4}};
  loop["noise_um"] = 0.3;
  loop["seed"] = 21;
  loop["corrections"] = 2;
  loop["store"] = true;
  const Answer answer = Call(SimulateClosedLoop, loop);
  ASSERT_EQ(answer.status, 200) << answer.body.dump();
  const nlohmann::json& iterations = answer.body["iterations"];
  ASSERT_EQ(iterations.size(), 3u);
  for (int k = 0; k < 2; ++k) {
    ASSERT_TRUE(iterations[k].contains("job_id")) << k;
    EXPECT_FALSE(iterations[k].contains("job_index"));
    const std::optional<JobRecord> job =
        repository_->ReadJob(iterations[k]["job_id"].get<int64_t>());
    ASSERT_TRUE(job.has_value());
    EXPECT_EQ(job->kind, "closed_loop");
    const nlohmann::json stored = nlohmann::json::parse(job->request_json);
    nlohmann::json part = loop;
    part.erase("corrections");
    part.erase("store");
    part["settings"] = iterations[k]["settings"];
    part["seed"] = 21 + k;
    const Answer measured = Call(SimulateMeasurement, part);
    ASSERT_EQ(measured.status, 200);
    EXPECT_EQ(stored["measurement"]["deviations_um"],
              measured.body["measurement"]["deviations_um"])
        << k;
    // Part k was ground with the settings job k-1 computed.
    if (k > 0) {
      EXPECT_EQ(job->settings_source_job_id,
                iterations[k - 1]["job_id"].get<int64_t>());
    }
  }
  EXPECT_FALSE(iterations[2].contains("job_id"));
}

TEST_F(ServicesTest, ReplayOfAMissingJobIsNotFound) {
  const Answer answer = Call(ReplayCorrection, nlohmann::json(), "42");
  EXPECT_EQ(answer.status, 404);
  EXPECT_EQ(answer.body["error"]["code"], "not_found");
}

TEST_F(ServicesTest, BatchItemsWaitForTheQueueAndRunOneByOne) {
  nlohmann::json item = DefaultSetup();
  item["measurement"] = {{"deviations_um", Measurement(1)["deviations_um"]}};
  nlohmann::json bad = item;
  bad["gear"]["teeth"] = 2;
  const Answer accepted = Call(CreateBatch, {{"items", {item, bad}}});
  ASSERT_EQ(accepted.status, 202) << accepted.body.dump();
  ASSERT_EQ(queued_.size(), 2u);
  for (const PendingBatchItem& pending : queued_)
    RunBatchItem(context_, pending);
  const Answer batch = Call(GetBatch,
                            nlohmann::json(),
                            std::to_string(accepted.body["id"].get<int64_t>()));
  ASSERT_EQ(batch.status, 200);
  EXPECT_EQ(batch.body["done"], 1);
  EXPECT_EQ(batch.body["failed"], 1);
  EXPECT_EQ(batch.body["items"][1]["error"]["field"], "gear.teeth");
  EXPECT_EQ(repository_->CountJobs(), 1);
}

TEST(ParseId, TakesPositiveIdsOfAtMost18Digits) {
  int64_t id = 0;
  EXPECT_TRUE(ParseId("17", &id));
  EXPECT_EQ(id, 17);
  EXPECT_FALSE(ParseId("0", &id));
  EXPECT_FALSE(ParseId("", &id));
  EXPECT_FALSE(ParseId("1234567890123456789", &id));
}

// A stub solver in place of the engine's: the service's mapping of each
// outcome, without the engine's numerics. It answers every request with the
// given status, no change and the measured error as the predicted residual.
std::function<CorrectionResult(const CorrectionOptions&,
                               const CorrectionInput&)>
StubSolver(CorrectionStatus status, const std::string& message) {
  return [status, message](const CorrectionOptions& options,
                           const CorrectionInput& input) {
    CorrectionResult result;
    result.summary.status = status;
    result.summary.message = message;
    result.summary.solver = options.solver;
    result.summary.residual_rms_um = 1.25;
    result.summary.best_reachable_rms_um = 0.5;
    result.summary.rank = 7;
    result.parameters = input.current_parameters;
    result.delta = Eigen::VectorXd::Zero(input.current_parameters.size());
    result.predicted_residual_um = input.measured_um - input.target_um;
    result.predicted_change_um =
        Eigen::VectorXd::Zero(input.measured_um.size());
    return result;
  };
}

nlohmann::json FlatMeasurementRequest() {
  nlohmann::json request = DefaultSetup();
  nlohmann::json rows = nlohmann::json::array();
  for (int r = 0; r < 5; ++r) rows.push_back(std::vector<double>(9, 1.5));
  request["measurement"] = {{"deviations_um", rows}};
  return request;
}

TEST_F(ServicesTest, StubSolverNoSafeImprovementIsStoredWithItsStatus) {
  context_.compute_correction = StubSolver(CorrectionStatus::kNoSafeImprovement,
                                           "the current settings are kept");
  const Answer created = Call(CreateCorrection, FlatMeasurementRequest());
  ASSERT_EQ(created.status, 201) << created.body.dump();
  EXPECT_EQ(created.body["status"], "no_safe_improvement");
  EXPECT_EQ(created.body["result"]["status"], "no_safe_improvement");
  // A zero correction says why first (server/codec/zero_correction.h), the
  // engine's own words kept after it.
  const std::string message = created.body["result"]["message"];
  EXPECT_EQ(message.rfind("zero correction: ", 0), 0u) << message;
  EXPECT_NE(message.find("(the current settings are kept)"), std::string::npos)
      << message;
  EXPECT_TRUE(created.body["result"]["explain"].is_object());
  const std::optional<JobRecord> job =
      repository_->ReadJob(created.body["id"].get<int64_t>());
  ASSERT_TRUE(job.has_value());
  EXPECT_EQ(job->status, "no_safe_improvement");
  EXPECT_EQ(job->machine_kind, "flat-wheel-grinder");
  EXPECT_EQ(job->residual_rms_um, 1.25);
  EXPECT_EQ(job->rank, 7);
  // No change: every axis coefficient of the delta is zero.
  ASSERT_TRUE(created.body["result"]["delta"]["axes"].is_object());
  for (const auto& axis : created.body["result"]["delta"]["axes"].items()) {
    for (const auto& coefficient : axis.value()) EXPECT_EQ(coefficient, 0.0);
  }
}

TEST_F(ServicesTest, StubSolverInvalidInputIsA422AndNothingIsStored) {
  context_.compute_correction =
      StubSolver(CorrectionStatus::kInvalidInput, "no usable grid point");
  const Answer refused = Call(CreateCorrection, FlatMeasurementRequest());
  EXPECT_EQ(refused.status, 422) << refused.body.dump();
  EXPECT_EQ(refused.body["error"]["field"], "measurement");
  EXPECT_NE(refused.body["error"]["message"].get<std::string>().find(
                "no usable grid point"),
            std::string::npos);
  EXPECT_EQ(repository_->CountJobs(), 0);
}

TEST_F(ServicesTest, StubSolverNotConvergedIsStoredWithItsReason) {
  context_.compute_correction = StubSolver(CorrectionStatus::kNotConverged,
                                           "the refinement reached its limit");
  const Answer created = Call(CreateCorrection, FlatMeasurementRequest());
  ASSERT_EQ(created.status, 201) << created.body.dump();
  EXPECT_EQ(created.body["result"]["status"], "not_converged");
  EXPECT_EQ(repository_->CountJobs(), 1);
}

}  // namespace
}  // namespace gearloop
