// A correction that comes back zero says why (issue 16: "with
// default_max_order: 6 a job came back converged with a zero correction and no
// word why"), on a real server, from the summary's own fields
// (server/codec/zero_correction.h).
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "tests/server/server_test_util.h"

namespace gearloop {
namespace {

using testing_util::ParseBody;
using testing_util::ServerFixture;

// What zero_correction.h calls no correction (size in 1 um of axis motion).
constexpr double kNegligibleSize = 1e-3;

// Probe noise alone, sigma 0.3 um (drawn once, seed 7, and written down).
nlohmann::json NoiseOnlyGrid() {
  return nlohmann::json::parse(R"([
    [-0.077, 0.153, -0.068, -0.095, -0.279, -0.064, 0.334, 0.127, 0.311],
    [0.075, 0.118, 0.056, -0.5, 0.257, 0.152, 0.15, -0.507, -0.523],
    [-0.267, -0.14, 0.092, -0.014, 0.156, -0.193, 0.093, 0.118, -0.198],
    [0.515, 0.167, 0.359, -0.186, -0.222, -0.103, -0.032, 0.19, 0.075],
    [-0.134, -0.287, -0.156, 0.366, -0.242, 0.073, 0.128, -0.447, 0.015]])");
}

// The README gear with a measurement and order 6 on every axis.
nlohmann::json Request(const nlohmann::json& measured) {
  nlohmann::json request = nlohmann::json::parse(R"({
    "gear": {"teeth": 37, "normal_module_mm": 6, "normal_pressure_angle_deg": 20,
             "helix_angle_deg": 15, "hand": "left", "face_width_mm": 78,
             "tip_radius_mm": 120.9157, "root_radius_mm": 107.1569},
    "wheel": {"radius_mm": 350},
    "flank": "right",
    "options": {"default_max_order": 6}})");
  request["measurement"] = {{"deviations_um", measured}};
  return request;
}

class ZeroCorrectionTest : public ServerFixture {
 protected:
  nlohmann::json Correct(const nlohmann::json& request) {
    const httplib::Result result = client_->Post(
        "/api/v1/corrections", request.dump(), "application/json");
    EXPECT_TRUE(result);
    if (!result) return nlohmann::json();
    EXPECT_EQ(result->status, 201) << result->body.substr(0, 300);
    return ParseBody(result)["result"];
  }
};

bool Says(const nlohmann::json& result, const std::string& words) {
  return result["message"].get<std::string>().find(words) != std::string::npos;
}

// The reproduction: a part measured as noise alone, order 6 on every axis.
// GCV keeps no effective direction; the job is still "converged", but its
// message and explain say: nothing above the noise.
TEST_F(ZeroCorrectionTest, NoiseAloneSaysNothingAboveTheNoise) {
  const nlohmann::json result = Correct(Request(NoiseOnlyGrid()));
  EXPECT_EQ(result["status"], "converged");
  ASSERT_LE(result["correction_size"].get<double>(), kNegligibleSize);
  ASSERT_TRUE(result.contains("explain")) << result["message"];
  EXPECT_EQ(result["explain"]["reason"], "nothing_above_noise");
  EXPECT_EQ(result["message"], result["explain"]["message"]);
  EXPECT_TRUE(Says(result, "nothing above the noise")) << result["message"];
  EXPECT_TRUE(Says(result, "gcv")) << result["message"];
  // Orders 4-6 were open: the answer says which orders it used (none moved).
  // The cubic answer asks no change (the filter keeps under 0.01 effective
  // directions, whether or not the safe step keeps their 1e-11 um: rounding
  // decides that), so the linear reach of orders 4-6 decides whether they are
  // solved: they reach too little above the noise.
  const std::string choice = result["orders"]["choice"];
  EXPECT_EQ(choice.rfind("orders 0-3 used: of their predicted", 0), 0u)
      << choice;
  EXPECT_NE(choice.find("not solved with them"), std::string::npos) << choice;
  EXPECT_EQ(result["orders"]["highest_moved"], -1);
  // Noise alone: the exact-model search is not run, and says so.
  EXPECT_EQ(
      result["exact_search"]["outcome"].get<std::string>().rfind("not run", 0),
      0u)
      << result["exact_search"];
  EXPECT_TRUE(result["exact_search"]["searched_predicted_rms_um"].is_null());

  nlohmann::json stated = Request(NoiseOnlyGrid());
  stated["options"]["probe_noise_um"] = 0.3;
  stated["options"]["regularisation_rule"] = "discrepancy-principle";
  const nlohmann::json with_noise = Correct(stated);
  ASSERT_LE(with_noise["correction_size"].get<double>(), kNegligibleSize);
  EXPECT_EQ(with_noise["explain"]["reason"], "nothing_above_noise");
  EXPECT_TRUE(Says(with_noise, "probe_noise_um = 0.3"))
      << with_noise["message"];
}

// A flank error the free axes cannot make: the predicted flank of a first
// correction towards a lead crowning, measured as the next part (nominal
// settings, same target). GCV keeps nothing and the advice is to free more of
// the machine, not to measure again.
TEST_F(ZeroCorrectionTest, AnErrorOutOfReachSaysSo) {
  nlohmann::json zero = nlohmann::json::array();
  for (int r = 0; r < 5; ++r) zero.push_back(std::vector<double>(9, 0.0));
  nlohmann::json request = Request(zero);
  request["options"].erase("default_max_order");
  request["target"] = {
      {"modifications", {{{"kind", "lead_crowning"}, {"amount_um", 4}}}}};
  const nlohmann::json first = Correct(request);
  nlohmann::json predicted = first["target_um"];
  for (size_t r = 0; r < predicted.size(); ++r)
    for (size_t c = 0; c < predicted[r].size(); ++c)
      predicted[r][c] = predicted[r][c].get<double>() +
                        first["predicted_residual_um"][r][c].get<double>();
  request["measurement"] = {{"deviations_um", predicted}};
  const nlohmann::json next = Correct(request);
  ASSERT_LE(next["correction_size"].get<double>(), kNegligibleSize);
  EXPECT_EQ(next["explain"]["reason"], "nothing_above_noise");
  EXPECT_TRUE(Says(next, "out of reach of the free axes")) << next["message"];
  // Every axis order 0-6 is open here (the default): not "higher orders".
  EXPECT_FALSE(Says(next, "higher orders")) << next["message"];
  EXPECT_TRUE(Says(next, "free more axes or the wheel's profile"))
      << next["message"];
  // The error is a smooth shape, noise alone scatters (the advice reads the
  // ratio: 0.5 in server/codec/zero_correction.cc).
  EXPECT_LT(next["error_neighbour_ratio"].get<double>(), 0.5);
  EXPECT_TRUE(Says(next, "smooth shape, not probe scatter")) << next["message"];
  // Noise alone keeps the advice to measure again.
  const nlohmann::json noise = Correct(Request(NoiseOnlyGrid()));
  EXPECT_GE(noise["error_neighbour_ratio"].get<double>(), 0.5);
  EXPECT_TRUE(Says(noise, "Measure again")) << noise["message"];
}

// No direction above min_flank_effect_um: rank 0, the safe step keeps the
// current settings; the reason is the rank, the engine's words follow.
TEST_F(ZeroCorrectionTest, RankZeroNamesMinFlankEffect) {
  nlohmann::json request = Request(NoiseOnlyGrid());
  request["target"] = {
      {"modifications", {{{"kind", "lead_crowning"}, {"amount_um", 1}}}}};
  // The per-direction filter looks down to 1 % of min_flank_effect_um: 500
  // leaves no direction above 5 um per unit.
  request["options"]["min_flank_effect_um"] = 500;
  const nlohmann::json result = Correct(request);
  EXPECT_EQ(result["rank"], 0);
  EXPECT_EQ(result["status"], "no_safe_improvement");
  EXPECT_EQ(result["explain"]["reason"], "below_min_flank_effect");
  EXPECT_TRUE(Says(result, "min_flank_effect_um")) << result["message"];
  EXPECT_TRUE(Says(result, "no fraction of the correction"))
      << result["message"];
}

// A measured flank that already is the target; and an ordinary correction,
// which has no explain and an empty message.
TEST_F(ZeroCorrectionTest, OnTargetAndOrdinaryCorrections) {
  nlohmann::json zero = nlohmann::json::array();
  for (int r = 0; r < 5; ++r) zero.push_back(std::vector<double>(9, 0.0));
  const nlohmann::json on_target = Correct(Request(zero));
  EXPECT_EQ(on_target["explain"]["reason"], "already_on_target");

  nlohmann::json request = Request(zero);
  request["target"] = {
      {"modifications", {{{"kind", "profile_crowning"}, {"amount_um", 3}}}}};
  const nlohmann::json ordinary = Correct(request);
  EXPECT_EQ(ordinary["status"], "converged");
  EXPECT_GT(ordinary["correction_size"].get<double>(), kNegligibleSize);
  EXPECT_FALSE(ordinary.contains("explain"));
  EXPECT_EQ(ordinary["message"], "");
}

}  // namespace
}  // namespace gearloop
