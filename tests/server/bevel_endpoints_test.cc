// Spiral-bevel pinion endpoints against a real server (issue 6): conversion of
// the published cradle summary, evaluation of free-form motions, the axis-error
// table, and a bevel correction job stored, listed, fetched and replayed that
// recovers hidden axis errors.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "engine/core/units.h"
#include "server/http/gearloop_server.h"
#include "tests/server/server_test_util.h"

namespace gearloop {
namespace {

using testing_util::ParseBody;
using testing_util::ServerFixture;

struct Answer {
  int status = 0;
  nlohmann::json body;
};

nlohmann::json PublishedJob(const std::string& side) {
  return {{"side", side}, {"published", true}};
}

double GridRms(const nlohmann::json& grid) {
  double sum = 0.0;
  int n = 0;
  for (const auto& row : grid) {
    for (const auto& v : row) {
      if (v.is_null()) continue;
      sum += v.get<double>() * v.get<double>();
      ++n;
    }
  }
  return n ? std::sqrt(sum / n) : NAN;
}

class BevelEndpointsTest : public ServerFixture {
 protected:
  Answer Post(const std::string& path, const nlohmann::json& body) {
    auto result = client_->Post(path.c_str(), body.dump(), "application/json");
    Answer answer;
    if (!result) return answer;
    answer.status = result->status;
    answer.body = ParseBody(result);
    return answer;
  }
  Answer Get(const std::string& path) {
    auto result = client_->Get(path.c_str());
    Answer answer;
    if (!result) return answer;
    answer.status = result->status;
    answer.body = ParseBody(result);
    return answer;
  }

  // The converted (nominal) motion of a side, with hidden errors added to some
  // coefficients.
  nlohmann::json WithHiddenErrors(nlohmann::json motion) {
    motion["A_rad"][0] = motion["A_rad"][0].get<double>() + 0.004 * kPi / 180.0;
    motion["B_rad"][0] = motion["B_rad"][0].get<double>() - 0.003 * kPi / 180.0;
    motion["X_mm"][0] = motion["X_mm"][0].get<double>() + 0.008;
    motion["Y_mm"][1] = motion["Y_mm"][1].get<double>() - 0.02;
    motion["Z_mm"][0] = motion["Z_mm"][0].get<double>() + 0.005;
    return motion;
  }
};

TEST_F(BevelEndpointsTest,
       ConvertsThePublishedConvexSummaryWithinATenthOfAMicrometre) {
  const Answer a =
      Post("/api/v1/bevel/conversions", {{"job", PublishedJob("convex")}});
  ASSERT_EQ(a.status, 200) << a.body.dump();
  EXPECT_EQ(a.body["degree"], 5);
  EXPECT_EQ(a.body["motion"]["A_rad"].size(), 6u);
  EXPECT_EQ(a.body["motion"]["C_rad"].size(), 6u);
  EXPECT_LT(a.body["flank_distance"]["max_um"].get<double>(), 0.1);
  EXPECT_EQ(a.body["flank_distance"]["points_found"], 45);
  EXPECT_LT(a.body["exact"]["max_rotation_difference"].get<double>(), 1e-12);
  EXPECT_LT(a.body["exact"]["max_translation_difference_mm"].get<double>(),
            1e-9);
  ASSERT_EQ(a.body["fit_residual"].size(), 6u);
  EXPECT_EQ(a.body["fit_residual"][0]["axis"], "A");
  EXPECT_TRUE(a.body["fit_residual"][0].contains("max_rad"));
  EXPECT_TRUE(a.body["fit_residual"][2].contains("max_mm"));
  EXPECT_EQ(a.body["points"].size(), 45u);
  // The summary comes back in degrees: Q = 104 deg 56'.
  EXPECT_NEAR(a.body["job"]["machine"]["cradle_angle_deg"].get<double>(),
              104.0 + 56.0 / 60.0,
              1e-9);
}

TEST_F(BevelEndpointsTest, ChoosesTheDegreeForAFlankTolerance) {
  const Answer a = Post("/api/v1/bevel/conversions",
                        {{"job", PublishedJob("concave")},
                         {"options", {{"max_flank_distance_um", 0.1}}}});
  ASSERT_EQ(a.status, 200) << a.body.dump();
  EXPECT_EQ(a.body["degree"], 4);
  EXPECT_LT(a.body["flank_distance"]["max_um"].get<double>(), 0.1);
}

TEST_F(BevelEndpointsTest, EvaluatesTheConvertedMotionAsTheCradleFlank) {
  const Answer conversion =
      Post("/api/v1/bevel/conversions", {{"job", PublishedJob("convex")}});
  ASSERT_EQ(conversion.status, 200);
  const Answer a = Post(
      "/api/v1/bevel/evaluate",
      {{"job", PublishedJob("convex")}, {"motion", conversion.body["motion"]}});
  ASSERT_EQ(a.status, 200) << a.body.dump();
  ASSERT_EQ(a.body["deviations_um"].size(), 5u);
  ASSERT_EQ(a.body["deviations_um"][0].size(), 9u);
  EXPECT_EQ(a.body["reached"], 45);
  EXPECT_LT(GridRms(a.body["deviations_um"]), 0.01);
  EXPECT_EQ(a.body["points"][0]["normal"].size(), 3u);
  // A 0.01 mm Z offset moves the flank by about 4.23 um (10 um sin 25 deg).
  nlohmann::json shifted = conversion.body["motion"];
  shifted["Z_mm"][0] = shifted["Z_mm"][0].get<double>() + 0.01;
  const Answer b = Post("/api/v1/bevel/evaluate",
                        {{"job", PublishedJob("convex")}, {"motion", shifted}});
  ASSERT_EQ(b.status, 200);
  EXPECT_NEAR(
      std::fabs(b.body["deviations_um"][2][4].get<double>()), 4.23, 0.05);
}

TEST_F(BevelEndpointsTest, RanksTheSwingAxisFirstInTheAxisErrorTable) {
  const Answer a = Post(
      "/api/v1/bevel/axis-sensitivity",
      {{"job", PublishedJob("convex")},
       {"errors", {{"linear_error_mm", 0.01}, {"angular_error_deg", 0.01}}}});
  ASSERT_EQ(a.status, 200) << a.body.dump();
  ASSERT_EQ(a.body["offsets"].size(), 5u);
  EXPECT_EQ(a.body["offset_ranking"][0], "B");
  EXPECT_EQ(a.body["coefficient_ranking"][0], "B0");
  for (const auto& entry : a.body["offsets"]) {
    if (entry["axis"] == "Z") {
      EXPECT_NEAR(entry["rms_um"].get<double>(), 4.23, 0.01);
    }
    EXPECT_EQ(entry["grid_um"].size(), 5u);
  }
}

TEST_F(BevelEndpointsTest, RefusesBadBevelRequestsNamingTheField) {
  Answer a = Post("/api/v1/bevel/conversions", {{"job", 3}});
  EXPECT_EQ(a.status, 400);
  EXPECT_EQ(a.body["error"]["field"], "job");
  a = Post("/api/v1/bevel/conversions", {{"job", {{"side", "flat"}}}});
  EXPECT_EQ(a.status, 422);
  EXPECT_EQ(a.body["error"]["field"], "job.side");
  nlohmann::json job = PublishedJob("convex");
  job["cutter"] = {{"blade_angle_deg", 50}};
  a = Post("/api/v1/bevel/conversions", {{"job", job}});
  EXPECT_EQ(a.status, 422);
  EXPECT_EQ(a.body["error"]["field"], "job.cutter.blade_angle_deg");
  job = PublishedJob("convex");
  job["machine"] = {{"ratio_of_roll", -1}};
  a = Post("/api/v1/bevel/evaluate", {{"job", job}});
  EXPECT_EQ(a.status, 422);
  EXPECT_EQ(a.body["error"]["field"], "job.machine.ratio_of_roll");
  a = Post("/api/v1/bevel/conversions", {{"job", {{"side", "convex"}}}});
  EXPECT_EQ(a.status, 400);
  EXPECT_EQ(a.body["error"]["field"], "job.cutter.point_radius_mm");
  a = Post("/api/v1/bevel/conversions",
           {{"job", PublishedJob("convex")},
            {"options", {{"polynomial_degree", 20}}}});
  EXPECT_EQ(a.status, 422);
  EXPECT_EQ(a.body["error"]["field"], "options.polynomial_degree");
  a = Post("/api/v1/bevel/evaluate",
           {{"job", PublishedJob("convex")},
            {"motion",
             {{"A_rad", {0, 1}},
              {"B_rad", {0}},
              {"X_mm", {0, 0}},
              {"Y_mm", {0, 0}},
              {"Z_mm", {0, 0}}}}});
  EXPECT_EQ(a.status, 400);
  EXPECT_EQ(a.body["error"]["field"], "motion.B_rad");
  a = Post(
      "/api/v1/bevel/axis-sensitivity",
      {{"job", PublishedJob("convex")}, {"errors", {{"linear_error_mm", 0}}}});
  EXPECT_EQ(a.status, 422);
  EXPECT_EQ(a.body["error"]["field"], "errors.linear_error_mm");
  nlohmann::json correction = {
      {"machine", {{"kind", "free-form-bevel-generator"}}},
      {"job", PublishedJob("convex")}};
  a = Post("/api/v1/corrections", correction);
  EXPECT_EQ(a.status, 400);
  EXPECT_EQ(a.body["error"]["field"], "measurement");
  correction["measurement"] = {{"deviations_um", {{1, 2, 3}}}};
  a = Post("/api/v1/corrections", correction);
  EXPECT_EQ(a.status, 400);
  EXPECT_EQ(Get("/api/v1/corrections").body["total"], 0);
}

TEST_F(BevelEndpointsTest,
       CorrectionRecoversHiddenAxisErrorsStoredAndReplayed) {
  const nlohmann::json job = PublishedJob("convex");
  const Answer conversion = Post("/api/v1/bevel/conversions", {{"job", job}});
  ASSERT_EQ(conversion.status, 200);
  const nlohmann::json nominal = conversion.body["motion"];
  // The machine runs the commanded motion with hidden axis errors; the CMM
  // measures the result.
  const Answer measured =
      Post("/api/v1/bevel/evaluate",
           {{"job", job}, {"motion", WithHiddenErrors(nominal)}});
  ASSERT_EQ(measured.status, 200);
  const double initial_rms = GridRms(measured.body["deviations_um"]);
  EXPECT_GT(initial_rms, 1.0);

  const nlohmann::json request = {
      {"machine", {{"kind", "free-form-bevel-generator"}}},
      {"job", job},
      {"motion", nominal},
      {"measurement", {{"deviations_um", measured.body["deviations_um"]}}},
      {"options", {{"default_max_order", 2}}}};
  const Answer created = Post("/api/v1/corrections", request);
  ASSERT_EQ(created.status, 201) << created.body.dump();
  EXPECT_EQ(created.body["result"]["machine_kind"],
            "free-form-bevel-generator");
  EXPECT_LT(created.body["result"]["residual_rms_um"].get<double>(), 0.05);
  const int64_t id = created.body["id"].get<int64_t>();
  // The result carries the grids it used and the axis motion over the cradle
  // roll range: dX(t) = sum_k delta_X_mm[k] t^k, in um.
  const nlohmann::json& result = created.body["result"];
  EXPECT_EQ(result["measured_um"], measured.body["deviations_um"]);
  EXPECT_EQ(result["target_um"].size(), measured.body["deviations_um"].size());
  const nlohmann::json& motion = result["axis_motion"];
  ASSERT_EQ(motion["roll_rad"].size(), 9u);
  for (int i = 0; i < 9; ++i) {
    const double t = motion["roll_rad"][i].get<double>();
    double expected_um = 0.0;
    for (size_t k = 0; k < result["delta"]["X_mm"].size(); ++k) {
      expected_um +=
          1e3 * result["delta"]["X_mm"][k].get<double>() * std::pow(t, k);
    }
    EXPECT_NEAR(motion["axes"]["X"]["change_um"][i].get<double>(),
                expected_um,
                1e-9 * (1.0 + std::fabs(expected_um)));
  }
  EXPECT_TRUE(motion["axes"]["B"].contains("rms_urad"));

  // Cut again with the corrected motion on the same erring machine: the flank
  // is back.
  nlohmann::json corrected = created.body["result"]["motion"];
  nlohmann::json delta = created.body["result"]["delta"];
  nlohmann::json actual = WithHiddenErrors(nominal);
  for (const char* axis : {"A_rad", "B_rad", "X_mm", "Y_mm", "Z_mm"}) {
    for (size_t k = 0; k < actual[axis].size(); ++k) {
      actual[axis][k] =
          actual[axis][k].get<double>() + delta[axis][k].get<double>();
      EXPECT_NEAR(corrected[axis][k].get<double>(),
                  nominal[axis][k].get<double>() + delta[axis][k].get<double>(),
                  1e-9);
    }
  }
  const Answer recut =
      Post("/api/v1/bevel/evaluate", {{"job", job}, {"motion", actual}});
  ASSERT_EQ(recut.status, 200);
  EXPECT_LT(GridRms(recut.body["deviations_um"]), 0.05 * initial_rms);

  // Stored, listed and fetched like a grinder job.
  const Answer fetched = Get("/api/v1/corrections/" + std::to_string(id));
  ASSERT_EQ(fetched.status, 200);
  EXPECT_EQ(fetched.body["flank"], "convex");
  EXPECT_EQ(fetched.body["machine_kind"], "free-form-bevel-generator");
  EXPECT_EQ(fetched.body["request"]["machine"]["kind"],
            "free-form-bevel-generator");
  const Answer list = Get("/api/v1/corrections");
  ASSERT_EQ(list.status, 200);
  EXPECT_EQ(list.body["total"], 1);
  EXPECT_EQ(list.body["jobs"][0]["machine_kind"], "free-form-bevel-generator");
  EXPECT_EQ(Get("/api/v1/corrections?flank=convex").body["total"], 1);
  EXPECT_EQ(Get("/api/v1/corrections?flank=concave").body["total"], 0);

  const Answer replay =
      Post("/api/v1/corrections/" + std::to_string(id) + "/replay",
           {{"options", {{"solver", "lsq-plain"}}}});
  ASSERT_EQ(replay.status, 201) << replay.body.dump();
  EXPECT_EQ(replay.body["parent_job_id"], id);
  EXPECT_EQ(replay.body["result"]["solver"], "lsq-plain");
  EXPECT_EQ(replay.body["result"]["motion"]["A_rad"].size(), 6u);
}

// A bevel job takes an rms/max tolerance (no ISO 1328-1 classes for a pinion
// flank) and lists its corrected motions for the machine.
TEST_F(BevelEndpointsTest, JudgesToleranceAndListsTheCorrectedMotion) {
  const nlohmann::json job = PublishedJob("convex");
  const nlohmann::json nominal =
      Post("/api/v1/bevel/conversions", {{"job", job}}).body["motion"];
  const Answer measured =
      Post("/api/v1/bevel/evaluate",
           {{"job", job}, {"motion", WithHiddenErrors(nominal)}});
  ASSERT_EQ(measured.status, 200);
  nlohmann::json request = {
      {"machine", {{"kind", "free-form-bevel-generator"}}},
      {"job", job},
      {"motion", nominal},
      {"measurement", {{"deviations_um", measured.body["deviations_um"]}}},
      {"options", {{"default_max_order", 2}}},
      {"tolerance", {{"iso_class", 5}}}};
  Answer refused = Post("/api/v1/corrections", request);
  EXPECT_EQ(refused.status, 422);
  EXPECT_EQ(refused.body["error"]["field"], "tolerance.iso_class");
  request["tolerance"] = {{"rms_um", 0.5}};
  const Answer created = Post("/api/v1/corrections", request);
  ASSERT_EQ(created.status, 201) << created.body.dump();
  const nlohmann::json& result = created.body["result"];
  EXPECT_EQ(result["verdict"]["measured"]["verdict"], "FAIL");
  EXPECT_EQ(result["verdict"]["predicted"]["verdict"], "PASS");

  const std::string path = "/api/v1/corrections/" +
                           std::to_string(created.body["id"].get<int>()) +
                           "/settings?format=nc";
  const auto listing = client_->Get(path.c_str());
  ASSERT_TRUE(listing);
  ASSERT_EQ(listing->status, 200);
  const std::string& text = listing->body;
  for (const char* axis : {"A_rad", "B_rad", "X_mm", "Y_mm", "Z_mm"}) {
    const std::string name = std::string(1, axis[0]) + "_A1 = ";
    const size_t at = text.find("\n" + name);
    ASSERT_NE(at, std::string::npos) << name;
    EXPECT_NEAR(
        std::stod(text.substr(at + 1 + name.size())),
        result["motion"][axis][1].get<double>(),
        1e-9 * (1.0 + std::fabs(result["motion"][axis][1].get<double>())))
        << axis;
  }
}

TEST_F(BevelEndpointsTest, SimulatedMeasurementWithProbeNoiseIsCorrected) {
  const nlohmann::json job = PublishedJob("concave");
  const nlohmann::json scenario = {
      {"machine", {{"kind", "free-form-bevel-generator"}}},
      {"job", job},
      {"hidden_errors",
       {{"B_rad", {-0.003 * kPi / 180.0}},
        {"X_mm", {0.008}},
        {"Y_mm", {0.0, -0.02}}}},
      {"noise_um", 0.2},
      {"seed", 5}};
  const Answer cmm = Post("/api/v1/simulations/measurement", scenario);
  ASSERT_EQ(cmm.status, 200) << cmm.body.dump();
  EXPECT_EQ(cmm.body["machine_kind"], "free-form-bevel-generator");
  const double true_rms = GridRms(cmm.body["true_deviations_um"]);
  EXPECT_GT(true_rms, 1.0);
  EXPECT_GT(
      std::fabs(GridRms(cmm.body["measurement"]["deviations_um"]) - true_rms),
      1e-6);  // noise added
  const Answer created =
      Post("/api/v1/corrections",
           {{"machine", {{"kind", "free-form-bevel-generator"}}},
            {"job", job},
            {"measurement", cmm.body["measurement"]},
            {"options", {{"default_max_order", 2}, {"probe_noise_um", 0.2}}}});
  ASSERT_EQ(created.status, 201) << created.body.dump();
  // The same erring machine cuts the next pinion with the corrected motion.
  nlohmann::json next = scenario;
  next["motion"] = created.body["result"]["motion"];
  next["noise_um"] = 0.0;
  const Answer recut = Post("/api/v1/simulations/measurement", next);
  ASSERT_EQ(recut.status, 200);
  EXPECT_LT(GridRms(recut.body["true_deviations_um"]), 0.1 * true_rms);

  nlohmann::json bad = scenario;
  bad["hidden_errors"] = {{"W_mm", {1}}};
  // An unknown axis is an unknown key (strict input, issue 17).
  const Answer unknown = Post("/api/v1/simulations/measurement", bad);
  EXPECT_EQ(unknown.status, 422);
  EXPECT_EQ(unknown.body["error"]["field"], "hidden_errors.W_mm");
  // Plausibility limits as for the grinder (issue 17): 1e308 is a 422 naming
  // the coefficient, not a 200 with empty grids.
  bad = scenario;
  bad["hidden_errors"] = {{"X_mm", {1e308}}};
  Answer huge = Post("/api/v1/simulations/measurement", bad);
  EXPECT_EQ(huge.status, 422) << huge.body.dump();
  EXPECT_EQ(huge.body["error"]["field"], "hidden_errors.X_mm[0]");
  bad = scenario;
  bad["motion"] = created.body["result"]["motion"];
  bad["motion"]["A_rad"][1] = 1e308;
  huge = Post("/api/v1/simulations/measurement", bad);
  EXPECT_EQ(huge.status, 422) << huge.body.dump();
  EXPECT_EQ(huge.body["error"]["field"], "motion.A_rad[1]");
  huge =
      Post("/api/v1/bevel/evaluate", {{"job", job}, {"motion", bad["motion"]}});
  EXPECT_EQ(huge.status, 422) << huge.body.dump();
  bad = scenario;
  bad["noise_um"] = -1;
  const Answer refused = Post("/api/v1/simulations/measurement", bad);
  EXPECT_EQ(refused.status, 422);
  EXPECT_EQ(refused.body["error"]["field"], "noise_um");
}

TEST_F(BevelEndpointsTest, ClosedLoopConvergesAndStoresReplayableJobs) {
  const nlohmann::json scenario = {
      {"machine", {{"kind", "free-form-bevel-generator"}}},
      {"job", PublishedJob("concave")},
      {"hidden_errors",
       {{"B_rad", {-0.003 * kPi / 180.0}},
        {"X_mm", {0.008}},
        {"Y_mm", {0.0, -0.02}}}},
      {"noise_um", 0.2},
      {"seed", 11},
      {"corrections", 2},
      {"options", {{"default_max_order", 2}}},
      {"store", true}};
  const Answer loop = Post("/api/v1/simulations/closed-loop", scenario);
  ASSERT_EQ(loop.status, 200) << loop.body.dump();
  ASSERT_EQ(loop.body["iterations"].size(), 3u);
  EXPECT_TRUE(loop.body["completed"].get<bool>());
  const double first = loop.body["iterations"][0]["true_rms_um"].get<double>();
  const double last = loop.body["iterations"][2]["true_rms_um"].get<double>();
  EXPECT_GT(first, 1.0);
  EXPECT_LT(last, 0.1 * first);
  const int64_t second_job =
      loop.body["iterations"][1]["job_id"].get<int64_t>();
  const Answer fetched =
      Get("/api/v1/corrections/" + std::to_string(second_job));
  ASSERT_EQ(fetched.status, 200);
  EXPECT_EQ(fetched.body["machine_kind"], "free-form-bevel-generator");
  EXPECT_EQ(fetched.body["settings_source_job_id"],
            loop.body["iterations"][0]["job_id"]);
  // The stored round has the grids and the axis motion of any bevel correction:
  // A, B in urad, X, Y, Z in um over the cradle roll range, no wheel
  // parameters.
  const nlohmann::json& stored = fetched.body["result"];
  for (const char* key : {"predicted_residual_um",
                          "predicted_change_um",
                          "measured_um",
                          "target_um"}) {
    EXPECT_TRUE(stored.contains(key) && stored[key].is_array() &&
                !stored[key].empty())
        << key;
  }
  ASSERT_TRUE(stored.contains("axis_motion"));
  EXPECT_EQ(stored["axis_motion"],
            loop.body["iterations"][1]["correction"]["axis_motion"]);
  EXPECT_EQ(stored["axis_motion"]["axes"]["A"]["change_urad"].size(), 9u);
  EXPECT_EQ(stored["axis_motion"]["axes"]["X"]["change_um"].size(), 9u);
  EXPECT_TRUE(stored["axis_motion"]["wheel"].empty());
  const Answer replay =
      Post("/api/v1/corrections/" + std::to_string(second_job) + "/replay",
           nlohmann::json::object());
  ASSERT_EQ(replay.status, 201) << replay.body.dump();
  EXPECT_NEAR(replay.body["result"]["residual_rms_um"].get<double>(),
              fetched.body["result"]["residual_rms_um"].get<double>(),
              1e-6);
}

}  // namespace
}  // namespace gearloop
