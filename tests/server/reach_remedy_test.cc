// The remedies of the reach report (issue 16 item 1), on a real server: what
// would make the rest of a target modification the machine configuration
// cannot make whole, each share checked against solves of its own (a stored
// correction from a perfect flank with the remedy's options gives the same
// best reachable residual), and the reach block of a job that misses its
// tolerance.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "tests/server/server_test_util.h"

namespace gearloop {
namespace {

using testing_util::ParseBody;
using testing_util::ServerFixture;

// Shares computed twice through the same engine agree to rounding.
constexpr double kSameShareTolerance = 1e-9;
// What reach_remedy.h calls a remedy that helps.
constexpr double kUsefulShareGain = 0.05;

// The README gear (clients/examples/request.json), without a target.
nlohmann::json ReadmeSetup() {
  return nlohmann::json::parse(R"({
    "gear": {"teeth": 37, "normal_module_mm": 6, "normal_pressure_angle_deg": 20,
             "helix_angle_deg": 15, "hand": "left", "face_width_mm": 78,
             "tip_radius_mm": 120.9157, "root_radius_mm": 107.1569},
    "wheel": {"radius_mm": 350},
    "machine": {"kind": "flat-wheel-grinder", "k1_mm": 0, "k2_mm": 0,
                "traverse_mm_per_rad": 0},
    "flank": "right"})");
}

// The same gear straight (spur): its contact lines run along the face width.
nlohmann::json SpurSetup() {
  nlohmann::json setup = ReadmeSetup();
  setup["gear"]["helix_angle_deg"] = 0;
  setup["gear"].erase("hand");
  return setup;
}

nlohmann::json ZeroGrid() {
  nlohmann::json zero = nlohmann::json::array();
  for (int r = 0; r < 5; ++r) zero.push_back(std::vector<double>(9, 0.0));
  return zero;
}

class ReachRemedyTest : public ServerFixture {
 protected:
  nlohmann::json Post(const std::string& path,
                      const nlohmann::json& body,
                      int expected_status) {
    const httplib::Result result =
        client_->Post(path.c_str(), body.dump(), "application/json");
    EXPECT_TRUE(result);
    if (!result) return nlohmann::json();
    EXPECT_EQ(result->status, expected_status) << result->body.substr(0, 400);
    return ParseBody(result);
  }

  // The share of `modification` a stored correction from a perfect flank
  // with `options` reaches: 1 - (best reachable / target)^2.
  double ShareBySolve(const nlohmann::json& setup,
                      const nlohmann::json& modification,
                      const nlohmann::json& options) {
    nlohmann::json request = setup;
    request["measurement"] = {{"deviations_um", ZeroGrid()}};
    request["target"] = {{"modifications", {modification}}};
    if (!options.is_null()) request["options"] = options;
    const nlohmann::json job = Post("/api/v1/corrections", request, 201);
    const double target = job["result"]["initial_rms_um"];
    // What is left: the linear best reachable or, larger, the correction's
    // exact prediction within the motion bound (reach_remedy.cc, ShareOf).
    const double left =
        std::max(job["result"]["best_reachable_rms_um"].get<double>(),
                 job["result"]["residual_rms_um"].get<double>());
    return std::max(0.0, 1.0 - (left * left) / (target * target));
  }

  nlohmann::json Reach(nlohmann::json setup,
                       const nlohmann::json& modifications) {
    setup["target"] = {{"modifications", modifications}};
    return Post("/api/v1/targets/reach", setup, 200);
  }
};

// (a) With every axis at order 1, a 10 um profile crowning is far from made;
// the remedy names the axis and order that make the most of it, and no other
// single axis opened higher (orders 2..6, each solved here) beats it.
TEST_F(ReachRemedyTest, NamesTheAxisAndOrderThatMakeTheMostOfTheRest) {
  nlohmann::json setup = ReadmeSetup();
  setup["options"] = {{"default_max_order", 1}};
  const nlohmann::json crowning = {{"kind", "profile_crowning"},
                                   {"amount_um", 10}};
  const nlohmann::json reach = Reach(setup, nlohmann::json::array({crowning}));
  const nlohmann::json& c = reach["components"][0];
  const double share = c["reachable_share"];
  ASSERT_LT(share, 0.9);
  const nlohmann::json& remedy = c["remedy"];
  ASSERT_TRUE(remedy.is_object()) << c.dump();
  EXPECT_EQ(remedy["kind"], "higher_order") << remedy.dump();
  const nlohmann::json& named = remedy["higher_order"];
  const std::string axis = named["axis"];
  const int order = named["order"];
  const double named_share = named["reachable_share"];
  EXPECT_GT(named_share - share, kUsefulShareGain);
  EXPECT_NEAR(named["share_gain"].get<double>(), named_share - share, 1e-12);
  EXPECT_NE(remedy["message"].get<std::string>().find(
                "open axis " + axis + " to order " + std::to_string(order)),
            std::string::npos)
      << remedy["message"];
  double best = -1.0;
  for (const char* a : {"X", "Y", "Z", "A", "B", "C"}) {
    for (int k = 2; k <= 6; ++k) {
      nlohmann::json options = setup["options"];
      options["max_order"][a] = k;
      const double s = ShareBySolve(setup, crowning, options);
      if (a == axis && k == order) {
        EXPECT_NEAR(s, named_share, kSameShareTolerance);
      }
      best = std::max(best, s);
    }
  }
  EXPECT_NEAR(named_share, best, 1e-4) << "a better single axis order exists";
}

// (b) On the README setup the wheel's parabola (fixed by default) makes most
// of a tip relief: the remedy says so with the share a solve with it freed
// reaches; it tried the axes (less). (A lead crowning the fixed wheel now
// makes whole through its dish, issue 13.)
TEST_F(ReachRemedyTest, AFreedWheelProfileMakesMostOfTheTipRelief) {
  const nlohmann::json tip = {{"kind", "tip_relief"}, {"amount_um", 10}};
  const nlohmann::json c =
      Reach(ReadmeSetup(), nlohmann::json::array({tip}))["components"][0];
  const double share = c["reachable_share"];
  const nlohmann::json& remedy = c["remedy"];
  ASSERT_TRUE(remedy.is_object());
  EXPECT_EQ(remedy["kind"], "wheel_profile") << remedy.dump();
  const double profile = remedy["wheel_profile"]["reachable_share"];
  // It helps as reach_remedy.h counts help: 5 % more, or half of what is
  // missing closed.
  EXPECT_TRUE(profile - share > kUsefulShareGain ||
              1.0 - profile < 0.5 * (1.0 - share))
      << share << " -> " << profile;
  const nlohmann::json freed = {{"max_order",
                                 {{"cone_angle", 0},
                                  {"parabola_coefficient", 0},
                                  {"parabola_vertex", 0}}}};
  EXPECT_NEAR(
      profile, ShareBySolve(ReadmeSetup(), tip, freed), kSameShareTolerance);
  // Every axis is free to order 6 by default: no higher order to try.
  EXPECT_TRUE(remedy["higher_order"].is_null()) << remedy.dump();
}

// (c) A spur gear with the wheel's parabola already free: no axis order and no
// wheel form make the rest of an end relief; the remedy is the wheel
// traverse along the lead, outside the model. That C_s gives nothing is
// checked another way too: a machine with C_s = 20 mm/rad (its nominal
// settings move the wheel along the lead with the roll) reaches the same
// share, and has no traverse remedy (it is not the fixed-wheel setup).
TEST_F(ReachRemedyTest, AnEndReliefOnTheFixedWheelNeedsAWheelTraverse) {
  nlohmann::json setup = SpurSetup();
  // Every axis held to its cubic term, so that the higher orders are tried.
  setup["options"] = {
      {"default_max_order", 3},
      {"max_order", {{"parabola_coefficient", 0}, {"parabola_vertex", 0}}}};
  const nlohmann::json lead = {{"kind", "end_relief"}, {"amount_um", 10}};
  const nlohmann::json c =
      Reach(setup, nlohmann::json::array({lead}))["components"][0];
  const double share = c["reachable_share"];
  ASSERT_LT(share, 0.95);
  const nlohmann::json& remedy = c["remedy"];
  ASSERT_TRUE(remedy.is_object());
  EXPECT_EQ(remedy["kind"], "wheel_traverse") << remedy.dump();
  EXPECT_LT(remedy["higher_order"]["share_gain"].get<double>(),
            kUsefulShareGain);
  EXPECT_EQ(remedy["wheel_traverse"]["in_model"], false);
  const std::string message = remedy["message"];
  EXPECT_NE(message.find("traverse along the lead"), std::string::npos)
      << message;
  EXPECT_NE(message.find("fixed-wheel"), std::string::npos) << message;

  nlohmann::json traversing = setup;
  traversing["machine"]["traverse_mm_per_rad"] = 20;
  const nlohmann::json t =
      Reach(traversing, nlohmann::json::array({lead}))["components"][0];
  EXPECT_NEAR(t["reachable_share"].get<double>(), share, 1e-3);
  ASSERT_TRUE(t["remedy"].is_object());
  EXPECT_TRUE(t["remedy"]["wheel_traverse"].is_null());
  EXPECT_EQ(t["remedy"]["kind"], "outside_model");
}

// A component the machine makes whole has no remedy; the CLI's threshold.
TEST_F(ReachRemedyTest, AComponentMadeWholeHasNoRemedy) {
  const nlohmann::json reach =
      Reach(SpurSetup(), {{{"kind", "profile_crowning"}, {"amount_um", 3}}});
  const nlohmann::json& c = reach["components"][0];
  EXPECT_GE(c["reachable_share"].get<double>(), 0.99);
  EXPECT_TRUE(c["remedy"].is_null());
}

// A job that misses its tolerance carries the reach of its target with the
// remedies (stored with the job); a job that passes does not.
TEST_F(ReachRemedyTest, APartlyReachableJobCarriesTheReachAndRemedies) {
  nlohmann::json request = ReadmeSetup();
  request["measurement"] = {{"deviations_um", ZeroGrid()}};
  request["target"] = {
      {"modifications", {{{"kind", "tip_relief"}, {"amount_um", 10}}}}};
  request["tolerance"] = {{"rms_um", 0.5}};
  const nlohmann::json job = Post("/api/v1/corrections", request, 201);
  const nlohmann::json& result = job["result"];
  EXPECT_EQ(result["status"], "target_partly_reachable");
  ASSERT_TRUE(result.contains("reach")) << result.dump().substr(0, 300);
  const nlohmann::json standalone =
      Reach(ReadmeSetup(), request["target"]["modifications"]);
  EXPECT_EQ(result["reach"]["components"], standalone["components"]);
  EXPECT_EQ(result["reach"]["components"][0]["remedy"]["kind"],
            "wheel_profile");
  const httplib::Result stored = client_->Get(
      ("/api/v1/corrections/" + std::to_string(job["id"].get<int64_t>()))
          .c_str());
  ASSERT_TRUE(stored);
  EXPECT_EQ(ParseBody(stored)["result"]["reach"], result["reach"]);

  request["tolerance"] = {{"rms_um", 5}};
  const nlohmann::json passing = Post("/api/v1/corrections", request, 201);
  EXPECT_EQ(passing["result"]["verdict"]["predicted"]["verdict"], "PASS");
  EXPECT_FALSE(passing["result"].contains("reach"));
}

}  // namespace
}  // namespace gearloop
