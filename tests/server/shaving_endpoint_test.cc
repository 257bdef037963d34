// POST /api/v1/shaving/cutter-target against a real server (issue 18,
// SHAVING.md §6-7): the published pinion and cutter, the certified grids and
// wheel radii through the API, the points not generated reported per point,
// and every 422 of §7 with its field.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

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

// SHAVING.md §1: the published pinion (standard radii) and its cutter, with
// the diagonal modification C1 = C2 = 20 um, bands 0.3, parabolic, type I.
nlohmann::json PublishedShavingRequest() {
  return nlohmann::json::parse(R"({
    "work_gear": {"teeth": 19, "normal_module_mm": 6, "normal_pressure_angle_deg": 20,
                  "helix_angle_deg": 9.91, "hand": "right", "face_width_mm": 75},
    "cutter": {"teeth": 37, "normal_module_mm": 6, "normal_pressure_angle_deg": 20,
               "helix_angle_deg": 15, "hand": "left", "face_width_mm": 78,
               "tip_radius_mm": 120.9157, "root_radius_mm": 107.1569},
    "diagonal_modification": {"root_um": 20, "tip_um": 20, "root_band": 0.3,
                              "tip_band": 0.3, "exponent": 2, "root_slope": 0,
                              "tip_slope": 0},
    "wheel_check": {"h_s_mm": 2, "traverse_mm_per_rad": 0}})");
}

class ShavingEndpointTest : public ServerFixture {
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

  void ExpectRow(const nlohmann::json& grid,
                 int row,
                 const std::vector<double>& expected,
                 double tolerance) {
    ASSERT_TRUE(grid.is_array() && grid.size() > static_cast<size_t>(row));
    ASSERT_EQ(grid[row].size(), expected.size());
    for (size_t c = 0; c < expected.size(); ++c) {
      ASSERT_TRUE(grid[row][c].is_number()) << "row " << row << " col " << c;
      EXPECT_NEAR(grid[row][c].get<double>(), expected[c], tolerance)
          << "row " << row << " col " << c;
    }
  }
};

const char* kPath = "/api/v1/shaving/cutter-target";

TEST_F(ShavingEndpointTest, PublishedCaseAnswersTheCertifiedGrids) {
  const Answer answer = Post(kPath, PublishedShavingRequest());
  ASSERT_EQ(answer.status, 200) << answer.body.dump();
  const nlohmann::json& b = answer.body;
  EXPECT_NEAR(b["crossed_axes_angle_deg"].get<double>(), 5.09, 1e-9);
  EXPECT_NEAR(b["centre_distance_mm"].get<double>(), 172.7790, 5e-4);
  // SHAVING.md §4, certified (+-0.05 um).
  ExpectRow(b["base_um"],
            1,
            {6.47, 3.50, 1.42, 0.26, 0.03, 0.77, 2.48, 5.20, 8.94},
            0.05);
  ExpectRow(b["base_um"],
            4,
            {8.76, 5.24, 2.60, 0.87, 0.06, 0.20, 1.30, 3.40, 6.50},
            0.05);
  ExpectRow(b["delta_s_um"],
            1,
            {12.29, 7.46, 3.88, 1.59, 0.58, 0.87, 2.48, 5.20, 8.94},
            0.05);
  ExpectRow(b["delta_s_um"],
            4,
            {8.76, 5.24, 2.60, 0.87, 0.06, 0.20, 1.47, 4.05, 7.96},
            0.05);
  // Row 0 meets the pinion beyond its tip: null per point, listed, with the
  // contact it found (L1 ~ 35.0 > L_a1 = 33.65), not a failure of the request.
  ASSERT_EQ(b["outside_work_flank"].size(), 9u);
  for (int c = 0; c < 9; ++c) {
    EXPECT_EQ(b["outside_work_flank"][c], nlohmann::json({0, c}));
    EXPECT_TRUE(b["delta_s_um"][0][c].is_null());
    EXPECT_TRUE(b["stock_target_um"][0][c].is_null());
    EXPECT_EQ(b["contacts"][0][c]["status"], "outside_work_flank");
    EXPECT_GT(b["contacts"][0][c]["roll_length_mm"].get<double>(), 33.65);
  }
  EXPECT_TRUE(b["not_converged"].empty());
  // stock_target_um = delta_s_um - max(delta_s_um) <= 0, the maximum 12.289 at
  // row 1, column 0.
  double max_delta = -1e9;
  for (const auto& row : b["delta_s_um"])
    for (const auto& v : row)
      if (v.is_number()) max_delta = std::max(max_delta, v.get<double>());
  EXPECT_NEAR(max_delta, 12.289, 0.005);
  for (int r = 1; r < 5; ++r) {
    for (int c = 0; c < 9; ++c) {
      EXPECT_NEAR(b["stock_target_um"][r][c].get<double>(),
                  b["delta_s_um"][r][c].get<double>() - max_delta,
                  1e-9);
    }
  }
  EXPECT_DOUBLE_EQ(b["stock_target_um"][1][0].get<double>(), 0.0);
  // The contact of row 1, column 0 on the pinion (docs/shaving.md).
  EXPECT_NEAR(b["contacts"][1][0]["roll_length_mm"].get<double>(), 28.42, 0.01);
  EXPECT_NEAR(b["contacts"][1][0]["x_mm"].get<double>(), -30.55, 0.01);
  // SHAVING.md §5, certified.
  EXPECT_NEAR(b["contact_line_length_mm"].get<double>(), 75.342, 5e-4);
  EXPECT_NEAR(b["wheel_radius_min_mm"]["fixed"].get<double>(), 355.78, 5e-3);
  EXPECT_NEAR(
      b["wheel_radius_min_mm"]["traversing"].get<double>(), 336.97, 5e-3);
  EXPECT_NEAR(b["contact_angle_deg"].get<double>(), 5.236, 5e-4);
  EXPECT_GE(b["elapsed_ms"].get<double>(), 0.0);
  // The pinion's modification on its own grid: relief (<= 0) in the two
  // corners bounded by contact lines, none in the middle; with beta1 < 0 the
  // tip corner is at the -x face end, the root corner at +x.
  const nlohmann::json& relief = b["work_modification_um"];
  ASSERT_EQ(relief.size(), 5u);
  double most = 0.0;
  for (const auto& row : relief) {
    for (const auto& v : row) {
      ASSERT_TRUE(v.is_number());
      EXPECT_LE(v.get<double>(), 0.0);
      most = std::min(most, v.get<double>());
    }
  }
  EXPECT_LT(most, -1.0);
  EXPECT_GE(most, -20.0);
  EXPECT_LT(relief[4][0].get<double>(), -1.0);  // tip, -x
  EXPECT_LT(relief[0][8].get<double>(), -1.0);  // root, +x
  EXPECT_DOUBLE_EQ(relief[2][4].get<double>(), 0.0);
}

TEST_F(ShavingEndpointTest, DefaultsAreTheStandardInstallationAndNoRelief) {
  nlohmann::json body = PublishedShavingRequest();
  body.erase("diagonal_modification");
  body.erase("wheel_check");
  const Answer plain = Post(kPath, body);
  ASSERT_EQ(plain.status, 200) << plain.body.dump();
  // Without a modification delta_s is the unmodified envelope (two Newton
  // solves of the same point).
  for (int r = 1; r < 5; ++r) {
    for (int c = 0; c < 9; ++c) {
      EXPECT_NEAR(plain.body["delta_s_um"][r][c].get<double>(),
                  plain.body["base_um"][r][c].get<double>(),
                  1e-6);
    }
  }
  body["centre_distance_mm"] = 172.7790;
  const Answer given = Post(kPath, body);
  ASSERT_EQ(given.status, 200);
  EXPECT_NEAR(given.body["delta_s_um"][2][4].get<double>(),
              plain.body["delta_s_um"][2][4].get<double>(),
              0.01);
  // The traversing wheel reports the traversing contact line.
  body["wheel_check"] = {{"traverse_mm_per_rad", -8.0}};
  const Answer traversing = Post(kPath, body);
  ASSERT_EQ(traversing.status, 200);
  EXPECT_EQ(traversing.body["contact_line_length_mm"],
            traversing.body["contact_line_traversing_mm"]);
}

// Every refusal of SHAVING.md §7, with the field it names.
TEST_F(ShavingEndpointTest, EveryRefusalOfSection7NamesItsField) {
  struct Case {
    const char* what;
    nlohmann::json patch;  // RFC 7396 merge patch on the published request
    const char* field;
    const char* words;
  };
  const std::vector<Case> cases = {
      {"teeth", {{"work_gear", {{"teeth", 0}}}}, "work_gear.teeth", "teeth"},
      {"module",
       {{"cutter", {{"normal_module_mm", 0}}}},
       "cutter.normal_module_mm",
       "module"},
      {"face width",
       {{"work_gear", {{"face_width_mm", -1}}}},
       "work_gear.face_width_mm",
       "face width"},
      {"radius",
       {{"cutter", {{"root_radius_mm", -3}}}},
       "cutter.root_radius_mm",
       "positive"},
      {"h_s", {{"wheel_check", {{"h_s_mm", 0}}}}, "wheel_check.h_s_mm", "h_s"},
      {"helix",
       {{"work_gear", {{"helix_angle_deg", 45}}}},
       "work_gear.helix_angle_deg",
       "45"},
      {"tip below root",
       {{"cutter", {{"tip_radius_mm", 100}}}},
       "cutter.tip_radius_mm",
       "exceed"},
      {"base pitch",
       {{"cutter", {{"normal_pressure_angle_deg", 20.5}}}},
       "cutter.normal_module_mm",
       "not conjugate"},
      {"parallel axes",
       {{"cutter", {{"helix_angle_deg", 9.91}}}},
       "cutter.helix_angle_deg",
       "crossed-axes angle is zero"},
      {"too far",
       {{"centre_distance_mm", 200}},
       "centre_distance_mm",
       "no contact"},
      {"too near",
       {{"centre_distance_mm", 150}},
       "centre_distance_mm",
       "no contact"},
      {"amount",
       {{"diagonal_modification", {{"root_um", 250}}}},
       "diagonal_modification.root_um",
       ""},
      {"negative amount",
       {{"diagonal_modification", {{"tip_um", -1}}}},
       "diagonal_modification.tip_um",
       ""},
      {"band",
       {{"diagonal_modification", {{"root_band", 0}}}},
       "diagonal_modification.root_band",
       ""},
      {"band above 1",
       {{"diagonal_modification", {{"tip_band", 1.5}}}},
       "diagonal_modification.tip_band",
       ""},
      {"exponent",
       {{"diagonal_modification", {{"exponent", 3}}}},
       "diagonal_modification.exponent",
       ""},
      {"slope",
       {{"diagonal_modification", {{"root_slope", 1.5}}}},
       "diagonal_modification.root_slope",
       ""},
      {"grid", {{"grid", {{"profile_points", 1}}}}, "grid.profile_points", ""},
      // Rows on the cutter's root side all meet the pinion beyond its tip.
      {"no point generated",
       {{"grid", {{"profile_range", {0.0, 0.1}}}}},
       "grid",
       ""},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    nlohmann::json body = PublishedShavingRequest();
    body.merge_patch(c.patch);
    const Answer answer = Post(kPath, body);
    ASSERT_EQ(answer.status, 422) << answer.body.dump();
    EXPECT_EQ(answer.body["error"]["code"], "invalid_value");
    EXPECT_EQ(answer.body["error"]["field"], c.field)
        << answer.body["error"]["message"];
    EXPECT_NE(answer.body["error"]["message"].get<std::string>().find(c.words),
              std::string::npos)
        << answer.body["error"]["message"];
  }
}

TEST_F(ShavingEndpointTest, WrongShapesAre400WithTheirField) {
  nlohmann::json body = PublishedShavingRequest();
  body.erase("cutter");
  Answer answer = Post(kPath, body);
  EXPECT_EQ(answer.status, 400);
  EXPECT_EQ(answer.body["error"]["field"], "cutter");
  body = PublishedShavingRequest();
  body["work_gear"].erase("hand");
  answer = Post(kPath, body);
  EXPECT_EQ(answer.status, 400);
  EXPECT_EQ(answer.body["error"]["field"], "work_gear.hand");
  body = PublishedShavingRequest();
  body["diagonal_modification"]["exponent"] = 1.5;
  answer = Post(kPath, body);
  EXPECT_EQ(answer.status, 400);
  EXPECT_EQ(answer.body["error"]["field"], "diagonal_modification.exponent");
}

// POST /api/v1/corrections with target {"shaving": ...}: the gear being ground
// is the published cutter (API.md's example gear); the server resolves the
// cutter target, stores it in the job's request, and a replay uses the stored
// grid.
nlohmann::json ShavingCorrection() {
  nlohmann::json body = testing_util::DefaultSetup();
  nlohmann::json zeros = nlohmann::json::array();
  for (int r = 0; r < 5; ++r) zeros.push_back(std::vector<double>(9, 0.0));
  body["measurement"] = {{"deviations_um", zeros}};
  body["options"] = {{"probe_noise_um", 0.2}};
  body["target"] = {{"shaving", PublishedShavingRequest()}};
  return body;
}

TEST_F(ShavingEndpointTest, CorrectionResolvesAndStoresTheShavingTarget) {
  const Answer target = Post(kPath, PublishedShavingRequest());
  ASSERT_EQ(target.status, 200);
  const nlohmann::json& stock = target.body["stock_target_um"];

  const Answer created = Post("/api/v1/corrections", ShavingCorrection());
  ASSERT_EQ(created.status, 201) << created.body.dump();
  const nlohmann::json& result = created.body["result"];
  // The target the solver corrected towards is the cutter's stock target; the
  // points the pinion does not generate (row 0) are null and carry no weight.
  for (int r = 0; r < 5; ++r) {
    for (int c = 0; c < 9; ++c) {
      if (stock[r][c].is_null()) {
        EXPECT_TRUE(result["target_um"][r][c].is_null());
      } else {
        EXPECT_NEAR(result["target_um"][r][c].get<double>(),
                    stock[r][c].get<double>(),
                    1e-9);
      }
    }
  }
  EXPECT_TRUE(result["target_um"][0][4].is_null());
  EXPECT_DOUBLE_EQ(result["target_um"][1][0].get<double>(), 0.0);

  // The stored job's request carries the resolved grid beside the shaving
  // request.
  const int64_t id = created.body["id"].get<int64_t>();
  const Answer job = Get("/api/v1/corrections/" + std::to_string(id));
  ASSERT_EQ(job.status, 200);
  const nlohmann::json& stored = job.body["request"]["target"];
  EXPECT_EQ(stored["shaving"], PublishedShavingRequest());
  ASSERT_TRUE(stored.contains("stock_target_um"));
  EXPECT_EQ(stored["stock_target_um"].size(), 5u);
  for (int r = 0; r < 5; ++r) {
    for (int c = 0; c < 9; ++c) {
      EXPECT_EQ(stored["stock_target_um"][r][c].is_null(),
                stock[r][c].is_null());
      if (stock[r][c].is_number()) {
        EXPECT_NEAR(stored["stock_target_um"][r][c].get<double>(),
                    stock[r][c].get<double>(),
                    1e-9);
      }
    }
  }

  // A replay with other options solves again towards the same stored target.
  const Answer replay =
      Post("/api/v1/corrections/" + std::to_string(id) + "/replay",
           {{"options", {{"solver", "lsq-plain"}}}});
  ASSERT_EQ(replay.status, 201) << replay.body.dump();
  EXPECT_EQ(replay.body["result"]["target_um"], result["target_um"]);
}

// The replay takes the stored stock_target_um as it is and recomputes nothing:
// a job whose stored grid differs from what the engine would compute is
// replayed towards the stored grid.
TEST_F(ShavingEndpointTest, ReplayUsesTheStoredTargetWithoutRecomputing) {
  nlohmann::json body = ShavingCorrection();
  nlohmann::json stored_grid = nlohmann::json::array();
  for (int r = 0; r < 5; ++r) {
    nlohmann::json row = nlohmann::json::array();
    for (int c = 0; c < 9; ++c) {
      if (r == 2 && c == 3) {
        row.push_back(nullptr);  // a point stored as not generated
      } else {
        row.push_back(-1.0 - 0.5 * r - 0.1 * c);
      }
    }
    stored_grid.push_back(row);
  }
  body["target"]["stock_target_um"] = stored_grid;
  const Answer created = Post("/api/v1/corrections", body);
  ASSERT_EQ(created.status, 201) << created.body.dump();
  EXPECT_EQ(created.body["result"]["target_um"], stored_grid);
  const int64_t id = created.body["id"].get<int64_t>();
  const Answer replay =
      Post("/api/v1/corrections/" + std::to_string(id) + "/replay",
           {{"options", {{"probe_noise_um", 0.5}}}});
  ASSERT_EQ(replay.status, 201) << replay.body.dump();
  EXPECT_EQ(replay.body["result"]["target_um"], stored_grid);
  const Answer job = Get("/api/v1/corrections/" +
                         std::to_string(replay.body["id"].get<int64_t>()));
  ASSERT_EQ(job.status, 200);
  EXPECT_EQ(job.body["request"]["target"]["stock_target_um"], stored_grid);

  // A replay with a new shaving target resolves that one.
  nlohmann::json other = PublishedShavingRequest();
  other["diagonal_modification"]["root_um"] = 0;
  const Answer retarget =
      Post("/api/v1/corrections/" + std::to_string(id) + "/replay",
           {{"target", {{"shaving", other}}}});
  ASSERT_EQ(retarget.status, 201) << retarget.body.dump();
  const Answer computed = Post(kPath, other);
  ASSERT_EQ(computed.status, 200);
  EXPECT_NEAR(retarget.body["result"]["target_um"][4][8].get<double>(),
              computed.body["stock_target_um"][4][8].get<double>(),
              1e-9);
  EXPECT_TRUE(retarget.body["result"]["target_um"][0][0].is_null());
}

TEST_F(ShavingEndpointTest, ShavingTargetOfAnotherGearOrGridIs422) {
  struct Case {
    const char* what;
    nlohmann::json patch;
    const char* field;
  };
  const std::vector<Case> cases = {
      {"cutter teeth",
       {{"target", {{"shaving", {{"cutter", {{"teeth", 41}}}}}}}},
       "target.shaving.cutter.teeth"},
      {"cutter radius",
       {{"target", {{"shaving", {{"cutter", {{"tip_radius_mm", 121}}}}}}}},
       "target.shaving.cutter.tip_radius_mm"},
      {"grid",
       {{"target", {{"shaving", {{"grid", {{"lead_points", 7}}}}}}}},
       "target.shaving.grid"},
      {"left flank", {{"flank", "left"}}, "flank"},
      {"modification",
       {{"target",
         {{"shaving", {{"diagonal_modification", {{"root_um", 300}}}}}}}},
       "target.shaving.diagonal_modification.root_um"},
      {"parallel axes",
       {{"target", {{"shaving", {{"work_gear", {{"helix_angle_deg", 15}}}}}}}},
       "target.shaving.cutter.helix_angle_deg"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    nlohmann::json body = ShavingCorrection();
    body.merge_patch(c.patch);
    const Answer answer = Post("/api/v1/corrections", body);
    ASSERT_EQ(answer.status, 422) << answer.body.dump();
    EXPECT_EQ(answer.body["error"]["field"], c.field)
        << answer.body["error"]["message"];
  }
  // A stored grid without a generated point leaves nothing to correct.
  nlohmann::json all_null = ShavingCorrection();
  all_null["target"]["stock_target_um"] = nlohmann::json::array();
  for (int r = 0; r < 5; ++r)
    all_null["target"]["stock_target_um"].push_back(
        std::vector<std::nullptr_t>(9, nullptr));
  Answer refused = Post("/api/v1/corrections", all_null);
  EXPECT_EQ(refused.status, 422) << refused.body.dump();
  EXPECT_EQ(refused.body["error"]["field"], "target.stock_target_um");
  // A missing cutter is a shape error of the shaving body.
  nlohmann::json body = ShavingCorrection();
  body["target"]["shaving"].erase("cutter");
  Answer answer = Post("/api/v1/corrections", body);
  EXPECT_EQ(answer.status, 400);
  EXPECT_EQ(answer.body["error"]["field"], "target.shaving.cutter");
  // The closed-loop simulation does not resolve shaving targets.
  nlohmann::json loop = testing_util::DefaultSetup();
  loop["corrections"] = 1;
  loop["target"] = {{"shaving", PublishedShavingRequest()}};
  answer = Post("/api/v1/simulations/closed-loop", loop);
  EXPECT_EQ(answer.status, 422);
  EXPECT_EQ(answer.body["error"]["field"], "target.shaving");
}

}  // namespace
}  // namespace gearloop
