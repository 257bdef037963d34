// POST /api/v1/bevel/split-trajectory against a real server (issue 14,
// SPLIT_BEVEL.md §8): the worked example of docs/split-bevel.md in degrees,
// every 422 of §8 with its field, the stored job in the history, the NC
// program fetched back, and the NC listing parsed back against the JSON answer
// to its 4 decimals.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "engine/core/units.h"
#include "engine/split_bevel/trajectory.h"
#include "server/codec/split_bevel_codec.h"
#include "server/http/gearloop_server.h"
#include "storage/job_repository.h"
#include "tests/server/server_test_util.h"

namespace gearloop {
namespace {

using testing_util::ParseBody;
using testing_util::ServerFixture;

constexpr const char* kPath = "/api/v1/bevel/split-trajectory";

// docs/split-bevel.md §6: z = 75, delta = 70 deg, m_et = 40 mm, b = 240 mm,
// beta_m = 35 deg right hand, alpha = 20 deg; r0 = 8 mm, 0.2 mm stock; slot 3,
// both flanks, 4 levels, 5 stations from the toe; pivot 300 mm.
nlohmann::json WorkedExample() {
  return nlohmann::json::parse(R"({
    "gear": {"teeth": 75, "pitch_angle_deg": 70, "outer_transverse_module_mm": 40,
             "face_width_mm": 240, "mean_spiral_angle_deg": 35, "hand": "right",
             "pressure_angle_deg": 20},
    "tool": {"radius_mm": 8, "stock_mm": 0.2},
    "cut": {"slot_index": 3, "flanks": ["convex", "concave"], "depth_levels": 4,
            "steps": 5},
    "machine": {"pivot_length_mm": 300},
    "output": {"nc": true}})");
}

struct Answer {
  int status = 0;
  std::string content_type;
  std::string text;
  nlohmann::json body;
};

// The value with 4 decimals as the NC listing writes it: x 10^4 rounded half
// away from zero, never "-0.0000".
std::string Fixed4(double x) {
  const long long q = std::llround(x * 1e4);
  char buffer[64];
  std::snprintf(buffer,
                sizeof(buffer),
                "%s%lld.%04lld",
                q < 0 ? "-" : "",
                std::llabs(q) / 10000,
                std::llabs(q) % 10000);
  return buffer;
}

// The G01 lines of the listing, pass by pass: the words X Y Z A B as written.
std::vector<std::vector<std::vector<std::string>>> ParseNcMoves(
    const std::string& nc) {
  std::vector<std::vector<std::vector<std::string>>> passes;
  std::istringstream lines(nc);
  std::string line;
  while (std::getline(lines, line)) {
    if (line.rfind("(PASS ", 0) == 0) passes.emplace_back();
    if (line.rfind("G01 ", 0) != 0 || passes.empty()) continue;
    std::istringstream words(line.substr(4));
    std::vector<std::string> axes;
    std::string word;
    for (const char letter : {'X', 'Y', 'Z', 'A', 'B'}) {
      words >> word;
      EXPECT_EQ(word[0], letter) << line;
      axes.push_back(word.substr(1));
    }
    passes.back().push_back(axes);
  }
  return passes;
}

class SplitBevelEndpointTest : public ServerFixture {
 protected:
  Answer Keep(const httplib::Result& result) {
    Answer answer;
    if (!result) return answer;
    answer.status = result->status;
    answer.content_type = result->get_header_value("Content-Type");
    answer.text = result->body;
    answer.body = ParseBody(result);
    return answer;
  }
  Answer Post(const nlohmann::json& body) {
    return Keep(client_->Post(kPath, body.dump(), "application/json"));
  }
  Answer Get(const std::string& path) {
    return Keep(client_->Get(path.c_str()));
  }

  // A 422 naming `field`, and nothing stored.
  void ExpectRefused(const nlohmann::json& body, const std::string& field) {
    const Answer a = Post(body);
    EXPECT_EQ(a.status, 422) << field << ": " << a.text.substr(0, 300);
    EXPECT_EQ(a.body["error"]["code"], "invalid_value") << a.text;
    EXPECT_EQ(a.body["error"]["field"], field) << a.text;
    EXPECT_FALSE(a.body["error"]["message"].get<std::string>().empty());
    const Answer list = Get("/api/v1/corrections?kind=split_trajectory");
    EXPECT_EQ(list.body["total"], 0) << field << ": a refusal stored a job";
  }
};

TEST_F(SplitBevelEndpointTest, AnswersTheWorkedExampleInDegrees) {
  const Answer a = Post(WorkedExample());
  ASSERT_EQ(a.status, 200) << a.text.substr(0, 300);
  const nlohmann::json& d = a.body["derived"];
  EXPECT_NEAR(d["base_radius_mm"].get<double>(), 1209.286851, 1e-6);
  EXPECT_NEAR(d["normal_module_mm"].get<double>(), 30.302878, 1e-6);
  EXPECT_NEAR(d["crown_teeth"].get<double>(), 79.813333, 1e-6);
  EXPECT_NEAR(d["inner_cone_distance_mm"].get<double>(), 1356.266659, 1e-6);
  EXPECT_NEAR(d["inner_spiral_angle_deg"].get<double>(), 26.921319, 1e-6);
  EXPECT_NEAR(d["outer_spiral_angle_deg"].get<double>(), 40.749388, 1e-6);
  EXPECT_NEAR(d["slot_width_mm"].get<double>(), 47.599650, 1e-6);
  EXPECT_NEAR(a.body["setup"]["segment_mid_deg"].get<double>(), 14.4, 1e-12);
  ASSERT_EQ(a.body["setup"]["blank_to_machine"].size(), 16u);
  ASSERT_EQ(a.body["passes"].size(), 8u);
  const nlohmann::json& pass = a.body["passes"][0];
  EXPECT_EQ(pass["flank"], "convex");
  EXPECT_EQ(pass["level"], 0);
  EXPECT_EQ(pass["slot"], 3);
  EXPECT_NEAR(pass["tip_height_mm"].get<double>(), 13.257509, 1e-6);
  EXPECT_NEAR(pass["side_deviation_mm"]["max"].get<double>(), 0.2, 1e-6);
  ASSERT_EQ(pass["points"].size(), 5u);
  const nlohmann::json& p = pass["points"][0];
  EXPECT_NEAR(p["tool_centre_mm"][0].get<double>(), 1251.5543, 1e-4);
  EXPECT_NEAR(p["tool_axis"][2].get<double>(), -0.935986, 1e-6);
  EXPECT_NEAR(p["X_mm"].get<double>(), 1336.2082, 1e-4);
  EXPECT_NEAR(p["Y_mm"].get<double>(), -43.8387, 1e-4);
  EXPECT_NEAR(p["Z_mm"].get<double>(), -168.4312, 1e-4);
  EXPECT_NEAR(p["A_deg"].get<double>(), 17.3882, 1e-4);
  EXPECT_NEAR(p["B_deg"].get<double>(), 11.2437, 1e-4);
  EXPECT_EQ(a.body["passes"][4]["flank"], "concave");
  EXPECT_NEAR(
      a.body["passes"][4]["points"][0]["A_deg"].get<double>(), -19.84, 0.01);
  // The last point lies at the heel, one face length of arc from the toe.
  EXPECT_NEAR(pass["points"][4]["arc_mm"].get<double>(), 292.985901, 1e-6);
  const std::string nc = a.body["nc_program"].get<std::string>();
  EXPECT_EQ(nc.rfind("%\n(GEARLOOP SPLIT-BEVEL 1)\n", 0), 0u);
  EXPECT_NE(
      nc.find("G01 X1336.2082 Y-43.8387 Z-168.4312 A17.3882 B11.2437 F200.0\n"),
      std::string::npos);
}

TEST_F(SplitBevelEndpointTest, WithoutOutputNcTheAnswerHasNoProgram) {
  nlohmann::json body = WorkedExample();
  body.erase("output");
  const Answer a = Post(body);
  ASSERT_EQ(a.status, 200) << a.text.substr(0, 300);
  EXPECT_FALSE(a.body.contains("nc_program"));
  // The stored job keeps it all the same.
  const Answer nc = Get(a.body["nc_location"].get<std::string>());
  ASSERT_EQ(nc.status, 200);
  EXPECT_EQ(nc.text.rfind("%\n", 0), 0u);
}

TEST_F(SplitBevelEndpointTest, StoresTheJobInTheHistory) {
  const nlohmann::json request = WorkedExample();
  const Answer a = Post(request);
  ASSERT_EQ(a.status, 200) << a.text.substr(0, 300);
  const int64_t id = a.body["job_id"].get<int64_t>();
  EXPECT_EQ(a.body["location"], "/api/v1/corrections/" + std::to_string(id));
  const Answer list = Get("/api/v1/corrections?kind=split_trajectory");
  ASSERT_EQ(list.status, 200);
  ASSERT_EQ(list.body["total"], 1);
  const nlohmann::json& summary = list.body["jobs"][0];
  EXPECT_EQ(summary["id"], id);
  EXPECT_EQ(summary["kind"], "split_trajectory");
  EXPECT_EQ(summary["status"], "computed");
  EXPECT_EQ(summary["machine_kind"], "head-head-5-axis-mill");
  EXPECT_EQ(summary["flank"], "both");
  EXPECT_EQ(summary["gear"]["teeth"], 75);
  EXPECT_EQ(summary["gear"]["hand"], "right");
  EXPECT_NEAR(
      summary["gear"]["normal_module_mm"].get<double>(), 30.302878, 1e-6);
  EXPECT_NEAR(summary["gear"]["helix_angle_deg"].get<double>(), 35.0, 1e-9);
  const Answer job = Get(a.body["location"].get<std::string>());
  ASSERT_EQ(job.status, 200);
  EXPECT_EQ(job.body["request"], request);
  EXPECT_EQ(job.body["result"]["passes"], a.body["passes"]);
  EXPECT_EQ(job.body["result"]["derived"], a.body["derived"]);
  EXPECT_EQ(job.body["result"]["nc_program"], a.body["nc_program"]);
  // A trajectory is not a correction: a replay is refused and stores nothing.
  const Answer replay = Keep(
      client_->Post((a.body["location"].get<std::string>() + "/replay").c_str(),
                    "{}",
                    "application/json"));
  EXPECT_EQ(replay.status, 422) << replay.text;
  EXPECT_NE(replay.text.find("split-bevel trajectory"), std::string::npos);
  EXPECT_EQ(Get("/api/v1/corrections").body["total"], 1);
  // One flank: the job names it.
  nlohmann::json concave = request;
  concave["cut"]["flanks"] = {"concave"};
  const Answer b = Post(concave);
  ASSERT_EQ(b.status, 200);
  const Answer only = Get("/api/v1/corrections?flank=concave");
  ASSERT_EQ(only.body["total"], 1);
  EXPECT_EQ(only.body["jobs"][0]["id"], b.body["job_id"]);
}

// The job keeps the request, the per-pass summaries and the listing, not the
// points; GET /api/v1/corrections/{id} computes them again, and its result is
// the POST's answer byte for byte (then the stored listing).
TEST_F(SplitBevelEndpointTest, ShowComputesThePointsAgainByteForByte) {
  const Answer a = Post(WorkedExample());
  ASSERT_EQ(a.status, 200) << a.text.substr(0, 300);
  EXPECT_EQ(a.content_type, "application/json");
  const int64_t id = a.body["job_id"].get<int64_t>();
  {
    std::unique_ptr<JobRepository> repository = OpenJobRepository(db_.path());
    const std::optional<JobRecord> job = repository->ReadJob(id);
    ASSERT_TRUE(job.has_value());
    EXPECT_EQ(job->result_json.find("\"points\":"), std::string::npos);
    const nlohmann::json stored = nlohmann::json::parse(job->result_json);
    EXPECT_EQ(stored["points_stored"], false);
    EXPECT_EQ(stored["nc_program"], a.body["nc_program"]);
    EXPECT_EQ(stored["derived"], a.body["derived"]);
    EXPECT_EQ(stored["setup"], a.body["setup"]);
    ASSERT_EQ(stored["passes"].size(), a.body["passes"].size());
    for (size_t i = 0; i < stored["passes"].size(); ++i) {
      nlohmann::json pass = a.body["passes"][i];
      pass["point_count"] = pass["points"].size();
      pass.erase("points");
      EXPECT_EQ(stored["passes"][i], pass) << i;
    }
  }
  const Answer show = Get(a.body["location"].get<std::string>());
  ASSERT_EQ(show.status, 200) << show.text.substr(0, 300);
  EXPECT_EQ(show.body["points_recomputed"]["nc_program_matches"], true)
      << show.body["points_recomputed"].dump();
  EXPECT_FALSE(show.body["points_recomputed"].contains("error"));
  EXPECT_EQ(show.body["request"], WorkedExample());
  const std::string answered = a.text.substr(0, a.text.find(",\"job_id\":"));
  const std::string expected =
      answered + ",\"nc_program\":" + a.body["nc_program"].dump() + "}";
  const size_t at = show.text.find(",\"result\":{\"derived\"");
  ASSERT_NE(at, std::string::npos);
  const std::string shown =
      show.text.substr(at + 10, show.text.size() - at - 11);
  EXPECT_EQ(shown, expected);
}

// A stored request that no longer computes, or a listing that differs from
// the stored one (another engine), is shown without points and says why.
TEST_F(SplitBevelEndpointTest, ShowSaysWhenThePointsCannotBeComputedAgain) {
  const Answer a = Post(WorkedExample());
  ASSERT_EQ(a.status, 200);
  JobRecord job;
  {
    std::unique_ptr<JobRepository> repository = OpenJobRepository(db_.path());
    job = *repository->ReadJob(a.body["job_id"].get<int64_t>());
    JobRecord altered = job;
    nlohmann::json stored = nlohmann::json::parse(job.result_json);
    stored["nc_program"] = "%\nM30\n%\n";
    altered.result_json = stored.dump();
    altered.id = repository->WriteJob(altered);
    JobRecord refused = job;
    nlohmann::json request = WorkedExample();
    request["tool"]["radius_mm"] = 400;
    refused.request_json = request.dump();
    refused.id = repository->WriteJob(refused);
    for (const JobRecord& shown : {altered, refused}) {
      const Answer show =
          Get("/api/v1/corrections/" + std::to_string(shown.id));
      ASSERT_EQ(show.status, 200) << show.text.substr(0, 300);
      const nlohmann::json& note = show.body["points_recomputed"];
      EXPECT_FALSE(note.contains("nc_program_matches")) << note.dump();
      EXPECT_FALSE(note.value("error", "").empty()) << note.dump();
      EXPECT_EQ(show.body["result"], nlohmann::json::parse(shown.result_json));
      EXPECT_FALSE(show.body["result"]["passes"][0].contains("points"));
    }
  }
}

// A job stored with its points (before the points were computed again on
// show) is shown as stored.
TEST_F(SplitBevelEndpointTest, ShowsAJobStoredWithItsPointsAsStored) {
  SplitBevelRequest request;
  ApiError error;
  ASSERT_TRUE(ParseSplitBevelRequest(WorkedExample(), &request, &error));
  const SplitBevelResult result = ComputeSplitTrajectory(request);
  ASSERT_TRUE(result.ok) << result.message;
  JobRecord job;
  job.kind = "split_trajectory";
  job.status = "computed";
  job.machine_kind = "head-head-5-axis-mill";
  job.created_utc = "2026-11-23T10:00:00Z";
  job.request_json = WorkedExample().dump();
  SplitBevelTextOptions options;
  options.nc_program = &result.nc_program;
  job.result_json = SplitBevelResultJsonText(result, options);
  {
    std::unique_ptr<JobRepository> repository = OpenJobRepository(db_.path());
    job.id = repository->WriteJob(job);
  }
  const Answer show = Get("/api/v1/corrections/" + std::to_string(job.id));
  ASSERT_EQ(show.status, 200) << show.text.substr(0, 300);
  EXPECT_FALSE(show.body.contains("points_recomputed"));
  EXPECT_EQ(show.body["result"], nlohmann::json::parse(job.result_json));
  const Answer nc =
      Get("/api/v1/bevel/split-trajectory/" + std::to_string(job.id) + "/nc");
  EXPECT_EQ(nc.text, result.nc_program);
}

TEST_F(SplitBevelEndpointTest, ServesTheStoredNcProgramAsText) {
  const Answer a = Post(WorkedExample());
  ASSERT_EQ(a.status, 200);
  const std::string location = a.body["nc_location"].get<std::string>();
  EXPECT_EQ(location,
            "/api/v1/bevel/split-trajectory/" +
                std::to_string(a.body["job_id"].get<int64_t>()) + "/nc");
  const Answer nc = Get(location);
  ASSERT_EQ(nc.status, 200);
  EXPECT_EQ(nc.content_type.rfind("text/plain", 0), 0u) << nc.content_type;
  EXPECT_EQ(nc.text, a.body["nc_program"].get<std::string>());
  EXPECT_EQ(nc.text.substr(nc.text.size() - 7), "\nM30\n%\n");
  EXPECT_EQ(Get("/api/v1/bevel/split-trajectory/987654/nc").status, 404);
}

TEST_F(SplitBevelEndpointTest, NcOfAJobOfAnotherKindIsNotFound) {
  // A stored closed-loop round is a job, but not a trajectory.
  nlohmann::json loop = testing_util::DefaultSetup();
  loop["random_hidden_errors"] = {{"block_size", 2.0}, {"seed", 3}};
  loop["corrections"] = 1;
  loop["store"] = true;
  const Answer l = Keep(client_->Post(
      "/api/v1/simulations/closed-loop", loop.dump(), "application/json"));
  ASSERT_EQ(l.status, 200) << l.text.substr(0, 300);
  ASSERT_TRUE(l.body["iterations"][0].contains("job_id"));
  const std::string id =
      std::to_string(l.body["iterations"][0]["job_id"].get<int64_t>());
  const Answer nc = Get("/api/v1/bevel/split-trajectory/" + id + "/nc");
  EXPECT_EQ(nc.status, 404);
  EXPECT_EQ(nc.body["error"]["code"], "not_found");
}

// SPLIT_BEVEL.md §8's round trip: the G01 words of the listing are the JSON
// answer's X Y Z A B to 4 decimals, point by point, pass by pass; here on the
// left-hand pinion cut to a chord tolerance from the heel with an apex offset.
TEST_F(SplitBevelEndpointTest, NcListingParsedBackGivesTheAnswersAxes) {
  for (const bool pinion : {false, true}) {
    SCOPED_TRACE(pinion ? "pinion" : "wheel");
    nlohmann::json body = WorkedExample();
    if (pinion) {
      body = nlohmann::json::parse(R"({
        "gear": {"teeth": 19, "pitch_angle_deg": 20, "outer_transverse_module_mm": 30,
                 "face_width_mm": 120, "mean_spiral_angle_deg": 35, "hand": "left",
                 "pressure_angle_deg": 20},
        "tool": {"radius_mm": 6},
        "cut": {"slot_index": -2, "depth_levels": 2, "chord_tolerance_mm": 0.01,
                "from": "heel", "feed_mm_per_min": 150},
        "machine": {"pivot_length_mm": 200, "a_limits_deg": [-110, 110]},
        "setup": {"apex_mm": [100, -50, 400]},
        "output": {"nc": true}})");
    }
    const Answer a = Post(body);
    ASSERT_EQ(a.status, 200) << a.text.substr(0, 300);
    const auto moves = ParseNcMoves(a.body["nc_program"].get<std::string>());
    const nlohmann::json& passes = a.body["passes"];
    ASSERT_EQ(moves.size(), passes.size());
    size_t compared = 0;
    for (size_t i = 0; i < passes.size(); ++i) {
      const nlohmann::json& points = passes[i]["points"];
      ASSERT_EQ(moves[i].size(), points.size()) << "pass " << i;
      for (size_t j = 0; j < points.size(); ++j) {
        const nlohmann::json& p = points[j];
        const double json_axes[5] = {p["X_mm"].get<double>(),
                                     p["Y_mm"].get<double>(),
                                     p["Z_mm"].get<double>(),
                                     p["A_deg"].get<double>(),
                                     p["B_deg"].get<double>()};
        for (int k = 0; k < 5; ++k) {
          EXPECT_EQ(moves[i][j][k], Fixed4(json_axes[k]))
              << "pass " << i << " point " << j << " axis " << k;
          EXPECT_LE(std::abs(std::stod(moves[i][j][k]) - json_axes[k]),
                    0.5e-4 + 1e-9);
          ++compared;
        }
      }
    }
    EXPECT_GE(compared, 5u * 5u * 8u);
  }
}

TEST_F(SplitBevelEndpointTest, RefusesEveryInvalidValueNamingItsField) {
  using Edit = std::function<void(nlohmann::json*)>;
  const std::vector<std::pair<std::string, Edit>> cases = {
      {"gear.teeth", [](nlohmann::json* b) { (*b)["gear"]["teeth"] = 0; }},
      {"gear.pitch_angle_deg",
       [](nlohmann::json* b) { (*b)["gear"]["pitch_angle_deg"] = 95; }},
      {"gear.outer_cone_distance_mm",  // both of the pair
       [](nlohmann::json* b) {
         (*b)["gear"]["outer_cone_distance_mm"] = 1600;
       }},
      {"gear.outer_cone_distance_mm",  // neither
       [](nlohmann::json* b) {
         (*b)["gear"].erase("outer_transverse_module_mm");
       }},
      {"gear.outer_transverse_module_mm",
       [](nlohmann::json* b) {
         (*b)["gear"]["outer_transverse_module_mm"] = -40;
       }},
      {"gear.face_width_mm",
       [](nlohmann::json* b) { (*b)["gear"]["face_width_mm"] = 1700; }},
      {"gear.mean_spiral_angle_deg",  // both of the pair
       [](nlohmann::json* b) { (*b)["gear"]["outer_spiral_angle_deg"] = 40; }},
      {"gear.mean_spiral_angle_deg",  // neither
       [](nlohmann::json* b) { (*b)["gear"].erase("mean_spiral_angle_deg"); }},
      {"gear.mean_spiral_angle_deg",
       [](nlohmann::json* b) { (*b)["gear"]["mean_spiral_angle_deg"] = 60; }},
      {"gear.hand", [](nlohmann::json* b) { (*b)["gear"]["hand"] = "up"; }},
      {"gear.pressure_angle_deg",
       [](nlohmann::json* b) { (*b)["gear"]["pressure_angle_deg"] = 45; }},
      {"gear.addendum_mm",
       [](nlohmann::json* b) { (*b)["gear"]["addendum_mm"] = 0; }},
      {"tool.radius_mm",
       [](nlohmann::json* b) { (*b)["tool"]["radius_mm"] = 0; }},
      {"tool.stock_mm",
       [](nlohmann::json* b) { (*b)["tool"]["stock_mm"] = -8; }},
      {"cut.slot_index",
       [](nlohmann::json* b) { (*b)["cut"]["slot_index"] = -75; }},
      {"cut.flanks",
       [](nlohmann::json* b) {
         (*b)["cut"]["flanks"] = nlohmann::json::array();
       }},
      {"cut.flanks",
       [](nlohmann::json* b) {
         (*b)["cut"]["flanks"] = {"convex", "convex"};
       }},
      {"cut.flanks[1]",
       [](nlohmann::json* b) {
         (*b)["cut"]["flanks"] = {"convex", "left"};
       }},
      {"cut.depth_levels",
       [](nlohmann::json* b) { (*b)["cut"]["depth_levels"] = 101; }},
      {"cut.steps", [](nlohmann::json* b) { (*b)["cut"]["steps"] = 20002; }},
      {"cut.steps",  // both of the pair
       [](nlohmann::json* b) { (*b)["cut"]["chord_tolerance_mm"] = 0.01; }},
      {"cut.chord_tolerance_mm",
       [](nlohmann::json* b) {
         (*b)["cut"].erase("steps");
         (*b)["cut"]["chord_tolerance_mm"] = 9e-5;
       }},
      {"cut.from", [](nlohmann::json* b) { (*b)["cut"]["from"] = "middle"; }},
      {"cut.feed_mm_per_min",
       [](nlohmann::json* b) { (*b)["cut"]["feed_mm_per_min"] = 0; }},
      {"machine.pivot_length_mm",
       [](nlohmann::json* b) { (*b)["machine"]["pivot_length_mm"] = -1; }},
      {"machine.a_limits_deg",
       [](nlohmann::json* b) {
         (*b)["machine"]["a_limits_deg"] = {10, -10};
       }},
      {"machine.b_limits_deg",
       [](nlohmann::json* b) {
         (*b)["machine"]["b_limits_deg"] = {0, 0};
       }},
      {"setup.segment_angle_deg",
       [](nlohmann::json* b) { (*b)["setup"]["segment_angle_deg"] = 361; }},
      // r_b >= Ri: the field of the spiral angle given.
      {"gear.mean_spiral_angle_deg",
       [](nlohmann::json* b) { (*b)["gear"]["face_width_mm"] = 1000; }},
      {"gear.outer_spiral_angle_deg",
       [](nlohmann::json* b) {
         (*b)["gear"].erase("mean_spiral_angle_deg");
         (*b)["gear"]["outer_spiral_angle_deg"] = 20;
         (*b)["gear"]["face_width_mm"] = 500;
       }},
      // The slot closes above the root: w - 2 h_f tan(alpha) <= 0.
      {"gear.dedendum_mm",
       [](nlohmann::json* b) { (*b)["gear"]["dedendum_mm"] = 70; }},
      // The tool too wide for the slot.
      {"tool.radius_mm",
       [](nlohmann::json* b) { (*b)["tool"]["radius_mm"] = 20; }},
      // The slot outside a 1 deg segment around segment_mid_deg.
      {"cut.slot_index",
       [](nlohmann::json* b) { (*b)["setup"]["segment_angle_deg"] = 1; }},
      {"cut.slot_index",
       [](nlohmann::json* b) {
         (*b)["setup"]["segment_angle_deg"] = 30;
         (*b)["setup"]["segment_mid_deg"] = 40;
       }},
      // A point out of the axis limits (A is 17.4 deg at the first point).
      {"machine.a_limits_deg",
       [](nlohmann::json* b) {
         (*b)["machine"]["a_limits_deg"] = {-5, 5};
       }},
      {"machine.a_limits_deg",
       [](nlohmann::json* b) {
         (*b)["machine"]["b_limits_deg"] = {-5, 5};
       }},
  };
  for (const auto& [field, edit] : cases) {
    SCOPED_TRACE(field);
    nlohmann::json body = WorkedExample();
    body["setup"] = nlohmann::json::object();
    edit(&body);
    ExpectRefused(body, field);
  }
}

// The concave flank more curved than the tool allows (a narrow-spiral pinion
// whose base circle lies just inside Ri, tests/engine's case in degrees); the
// convex flank alone is cut.
TEST_F(SplitBevelEndpointTest, RefusesATooCurvedConcaveFlank) {
  const double ri = 70.0, rm = 85.0, rb = ri - 0.05;
  nlohmann::json body = {
      {"gear",
       {{"teeth", 19},
        {"pitch_angle_deg", 20},
        {"outer_cone_distance_mm", 100},
        {"face_width_mm", 30},
        {"mean_spiral_angle_deg", RadToDeg(std::acos(rb / rm))},
        {"hand", "left"},
        {"pressure_angle_deg", 20},
        {"addendum_mm", 3},
        {"dedendum_mm", 3},
        {"slot_width_mm", 40}}},
      {"tool", {{"radius_mm", 4}}},
      {"cut", {{"flanks", {"convex", "concave"}}, {"steps", 5}}}};
  ExpectRefused(body, "tool.radius_mm");
  body["cut"]["flanks"] = {"convex"};
  const Answer a = Post(body);
  EXPECT_EQ(a.status, 200) << a.text.substr(0, 300);
}

// More than 20001 stations needed for the chord tolerance (tests/engine's
// case): a line starting just outside its base circle over a long face.
TEST_F(SplitBevelEndpointTest, RefusesAChordToleranceNeedingTooManyStations) {
  nlohmann::json body = {{"gear",
                          {{"teeth", 19},
                           {"pitch_angle_deg", 20},
                           {"outer_cone_distance_mm", 5766},
                           {"face_width_mm", 3766},
                           {"mean_spiral_angle_deg",
                            RadToDeg(std::acos((2000.0 - 1e-4) / 3883.0))},
                           {"hand", "left"},
                           {"pressure_angle_deg", 20},
                           {"addendum_mm", 0.01},
                           {"dedendum_mm", 0.01}}},
                         {"tool", {{"radius_mm", 1}, {"stock_mm", -0.999}}},
                         {"cut",
                          {{"flanks", {"convex"}},
                           {"depth_levels", 1},
                           {"chord_tolerance_mm", 1e-4}}},
                         {"machine", {{"pivot_length_mm", 200}}}};
  ExpectRefused(body, "cut.chord_tolerance_mm");
}

TEST_F(SplitBevelEndpointTest, RefusesMissingFieldsAndWrongTypesWith400) {
  const std::vector<
      std::pair<std::string, std::function<void(nlohmann::json*)>>>
      cases = {
          {"gear", [](nlohmann::json* b) { b->erase("gear"); }},
          {"tool", [](nlohmann::json* b) { b->erase("tool"); }},
          {"gear.teeth",
           [](nlohmann::json* b) { (*b)["gear"].erase("teeth"); }},
          {"gear.teeth",
           [](nlohmann::json* b) { (*b)["gear"]["teeth"] = 7.5; }},
          {"gear.hand", [](nlohmann::json* b) { (*b)["gear"]["hand"] = 1; }},
          {"tool.radius_mm",
           [](nlohmann::json* b) { (*b)["tool"]["radius_mm"] = "8"; }},
          {"cut.flanks",
           [](nlohmann::json* b) { (*b)["cut"]["flanks"] = "convex"; }},
          {"cut.steps", [](nlohmann::json* b) { (*b)["cut"]["steps"] = "5"; }},
          {"machine.a_limits_deg",
           [](nlohmann::json* b) { (*b)["machine"]["a_limits_deg"] = {1}; }},
          {"setup.apex_mm",
           [](nlohmann::json* b) {
             (*b)["setup"] = {{"apex_mm", {1, 2}}};
           }},
          {"output.nc",
           [](nlohmann::json* b) { (*b)["output"]["nc"] = "yes"; }},
      };
  for (const auto& [field, edit] : cases) {
    SCOPED_TRACE(field);
    nlohmann::json body = WorkedExample();
    edit(&body);
    const Answer a = Post(body);
    EXPECT_EQ(a.status, 400) << a.text.substr(0, 300);
    EXPECT_EQ(a.body["error"]["field"], field) << a.text;
  }
}

// The answer's text is written without a JSON tree (server/codec/
// split_bevel_codec.h): every number must read back to the engine's double
// exactly, in degrees where the API says so, and a non-finite one as null.
TEST(SplitBevelResultJsonText, EveryNumberReadsBackToTheEnginesDouble) {
  nlohmann::json body = WorkedExample();
  body["cut"]["from"] = "heel";
  body["setup"] = {{"apex_mm", {10.5, -3.25, 700}}};
  SplitBevelRequest request;
  ApiError error;
  ASSERT_TRUE(ParseSplitBevelRequest(body, &request, &error)) << error.message;
  const SplitBevelResult result = ComputeSplitTrajectory(request);
  ASSERT_TRUE(result.ok) << result.message;
  const nlohmann::json answer =
      nlohmann::json::parse(SplitBevelResultJsonText(result));
  ASSERT_EQ(answer["passes"].size(), result.passes.size());
  EXPECT_EQ(answer["derived"]["base_radius_mm"].get<double>(),
            result.derived.base_radius_mm);
  EXPECT_EQ(answer["setup"]["blank_to_machine"][3].get<double>(), 10.5);
  EXPECT_EQ(answer["setup"]["blank_to_machine"][11].get<double>(), 700.0);
  const auto vec = [](const nlohmann::json& v) {
    return Eigen::Vector3d(
        v[0].get<double>(), v[1].get<double>(), v[2].get<double>());
  };
  for (size_t i = 0; i < result.passes.size(); ++i) {
    const SplitBevelPass& pass = result.passes[i];
    const nlohmann::json& a = answer["passes"][i];
    EXPECT_EQ(a["flank"], SplitBevelFlankName(pass.flank));
    EXPECT_EQ(a["level"], pass.level);
    EXPECT_EQ(a["slot"], pass.slot);
    EXPECT_EQ(a["tip_height_mm"].get<double>(), pass.tip_height_mm);
    EXPECT_EQ(a["side_deviation_mm"]["min"].get<double>(),
              pass.side_deviation_mm.min_mm);
    EXPECT_EQ(a["side_deviation_mm"]["max"].get<double>(),
              pass.side_deviation_mm.max_mm);
    ASSERT_EQ(a["points"].size(), pass.points.size());
    for (size_t j = 0; j < pass.points.size(); ++j) {
      const SplitBevelPoint& p = pass.points[j];
      const nlohmann::json& q = a["points"][j];
      EXPECT_EQ(q.size(), 13u);
      EXPECT_EQ(q["arc_mm"].get<double>(), p.arc_mm);
      EXPECT_EQ(q["cone_distance_mm"].get<double>(), p.cone_distance_mm);
      EXPECT_EQ(q["spiral_angle_deg"].get<double>(),
                RadToDeg(p.spiral_angle_rad));
      EXPECT_EQ(vec(q["pitch_point_mm"]), p.pitch_point_mm);
      EXPECT_EQ(vec(q["flank_point_mm"]), p.flank_point_mm);
      EXPECT_EQ(vec(q["flank_normal"]), p.flank_normal);
      EXPECT_EQ(vec(q["tool_centre_mm"]), p.tool_centre_mm);
      EXPECT_EQ(vec(q["tool_axis"]), p.tool_axis);
      EXPECT_EQ(q["X_mm"].get<double>(), p.axes.x_mm);
      EXPECT_EQ(q["Y_mm"].get<double>(), p.axes.y_mm);
      EXPECT_EQ(q["Z_mm"].get<double>(), p.axes.z_mm);
      EXPECT_EQ(q["A_deg"].get<double>(), RadToDeg(p.axes.a_rad));
      EXPECT_EQ(q["B_deg"].get<double>(), RadToDeg(p.axes.b_rad));
      EXPECT_TRUE(q["A_deg"].is_number_float());
    }
  }
  SplitBevelResult odd = result;
  odd.passes.resize(1);
  odd.passes[0].points.resize(1);
  odd.passes[0].points[0].axes.x_mm = std::nan("");
  odd.passes[0].points[0].axes.y_mm = 35.0;
  const nlohmann::json text =
      nlohmann::json::parse(SplitBevelResultJsonText(odd));
  EXPECT_TRUE(text["passes"][0]["points"][0]["X_mm"].is_null());
  EXPECT_TRUE(text["passes"][0]["points"][0]["Y_mm"].is_number_float());
}

// The answer as it was first built, through a nlohmann-json tree (b84310b):
// the text written without one must parse to the same values, every number
// exactly, with the same members.
nlohmann::json TreeAnswer(const SplitBevelResult& result) {
  const SplitBevelGearData& d = result.derived;
  nlohmann::json answer;
  answer["derived"] = {
      {"base_radius_mm", d.base_radius_mm},
      {"normal_module_mm", d.normal_module_mm},
      {"crown_teeth", d.crown_teeth},
      {"inner_cone_distance_mm", d.inner_cone_distance_mm},
      {"mean_cone_distance_mm", d.mean_cone_distance_mm},
      {"outer_cone_distance_mm", d.outer_cone_distance_mm},
      {"inner_spiral_angle_deg", RadToDeg(d.inner_spiral_angle_rad)},
      {"mean_spiral_angle_deg", RadToDeg(d.mean_spiral_angle_rad)},
      {"outer_spiral_angle_deg", RadToDeg(d.outer_spiral_angle_rad)},
      {"addendum_mm", d.addendum_mm},
      {"dedendum_mm", d.dedendum_mm},
      {"slot_width_mm", d.slot_width_mm}};
  nlohmann::json matrix = nlohmann::json::array();
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) matrix.push_back(result.blank_to_machine(i, j));
  answer["setup"] = {{"blank_to_machine", matrix},
                     {"segment_mid_deg", RadToDeg(result.segment_mid_rad)}};
  const auto vec = [](const Eigen::Vector3d& v) {
    return nlohmann::json::array({v.x(), v.y(), v.z()});
  };
  answer["passes"] = nlohmann::json::array();
  for (const SplitBevelPass& pass : result.passes) {
    nlohmann::json points = nlohmann::json::array();
    for (const SplitBevelPoint& p : pass.points) {
      points.push_back({{"arc_mm", p.arc_mm},
                        {"cone_distance_mm", p.cone_distance_mm},
                        {"spiral_angle_deg", RadToDeg(p.spiral_angle_rad)},
                        {"pitch_point_mm", vec(p.pitch_point_mm)},
                        {"flank_point_mm", vec(p.flank_point_mm)},
                        {"flank_normal", vec(p.flank_normal)},
                        {"tool_centre_mm", vec(p.tool_centre_mm)},
                        {"tool_axis", vec(p.tool_axis)},
                        {"X_mm", p.axes.x_mm},
                        {"Y_mm", p.axes.y_mm},
                        {"Z_mm", p.axes.z_mm},
                        {"A_deg", RadToDeg(p.axes.a_rad)},
                        {"B_deg", RadToDeg(p.axes.b_rad)}});
    }
    answer["passes"].push_back({{"slot", pass.slot},
                                {"flank", SplitBevelFlankName(pass.flank)},
                                {"level", pass.level},
                                {"tip_height_mm", pass.tip_height_mm},
                                {"side_deviation_mm",
                                 {{"min", pass.side_deviation_mm.min_mm},
                                  {"max", pass.side_deviation_mm.max_mm}}},
                                {"points", points}});
  }
  return answer;
}

TEST(SplitBevelResultJsonText, ParsesToTheValuesOfTheJsonTreeAnswer) {
  nlohmann::json body = WorkedExample();
  body["cut"]["steps"] = 7;
  body["cut"]["from"] = "heel";
  body["gear"]["hand"] = "left";
  SplitBevelRequest request;
  ApiError error;
  ASSERT_TRUE(ParseSplitBevelRequest(body, &request, &error)) << error.message;
  const SplitBevelResult result = ComputeSplitTrajectory(request);
  ASSERT_TRUE(result.ok) << result.message;
  const nlohmann::json tree = TreeAnswer(result);
  EXPECT_EQ(nlohmann::json::parse(SplitBevelResultJsonText(result)), tree);
  // With the job's members and the listing, as the POST answers.
  SplitBevelTextOptions options;
  options.members = {{"job_id", 12}, {"location", "/api/v1/corrections/12"}};
  options.nc_program = &result.nc_program;
  nlohmann::json expected = tree;
  expected["job_id"] = 12;
  expected["location"] = "/api/v1/corrections/12";
  expected["nc_program"] = result.nc_program;
  const std::string text = SplitBevelResultJsonText(result, options);
  EXPECT_EQ(nlohmann::json::parse(text), expected);
  // The listing's escapes are nlohmann-json's own.
  const std::string listing = result.nc_program + "\"\\\t\x01";
  options.nc_program = &listing;
  expected["nc_program"] = listing;
  EXPECT_EQ(nlohmann::json::parse(SplitBevelResultJsonText(result, options)),
            expected);
  EXPECT_NE(SplitBevelResultJsonText(result, options)
                .find(nlohmann::json(listing).dump()),
            std::string::npos);
  // Stored form: the passes' point counts instead of their points.
  options.points = false;
  const nlohmann::json stored =
      nlohmann::json::parse(SplitBevelResultJsonText(result, options));
  for (size_t i = 0; i < result.passes.size(); ++i) {
    nlohmann::json pass = tree["passes"][i];
    pass.erase("points");
    pass["point_count"] = result.passes[i].points.size();
    EXPECT_EQ(stored["passes"][i], pass);
  }
}

// The depth levels of a flank share each station's arc length, cone distance,
// spiral angle, pitch point, tool axis and A, B: the text writes them for the
// first level and copies them for the next when their numbers are the same
// bits. A later pass whose shared numbers differ is written with its own.
TEST(SplitBevelResultJsonText, SharedPartsOfAPointAreCopiedOnlyWhenTheSame) {
  SplitBevelRequest request;
  ApiError error;
  ASSERT_TRUE(ParseSplitBevelRequest(WorkedExample(), &request, &error))
      << error.message;
  const SplitBevelResult result = ComputeSplitTrajectory(request);
  ASSERT_TRUE(result.ok) << result.message;
  ASSERT_GE(result.passes.size(), 3u);
  ASSERT_EQ(result.passes[1].flank, result.passes[0].flank);
  ASSERT_GE(result.passes[1].points.size(), 4u);
  // The levels do share them (otherwise nothing below is tested).
  const SplitBevelPoint& first = result.passes[0].points[2];
  const SplitBevelPoint& second = result.passes[1].points[2];
  EXPECT_EQ(first.pitch_point_mm, second.pitch_point_mm);
  EXPECT_EQ(first.tool_axis, second.tool_axis);
  EXPECT_EQ(first.axes.b_rad, second.axes.b_rad);
  EXPECT_NE(first.tool_centre_mm, second.tool_centre_mm);
  EXPECT_EQ(nlohmann::json::parse(SplitBevelResultJsonText(result)),
            TreeAnswer(result));

  SplitBevelResult edited = result;
  std::vector<SplitBevelPoint>& points = edited.passes[1].points;
  points[0].axes.b_rad += 2.0 * kPi;  // a turn on: the same axis
  points[1].pitch_point_mm.y() =
      std::nextafter(points[1].pitch_point_mm.y(), 1e300);
  points[2].cone_distance_mm += 1e-9;
  points[3].tool_axis.z() = std::nextafter(points[3].tool_axis.z(), -1e300);
  // The pass after the edited one copies from the edited one.
  edited.passes[2].points[1].pitch_point_mm = points[1].pitch_point_mm;
  EXPECT_EQ(nlohmann::json::parse(SplitBevelResultJsonText(edited)),
            TreeAnswer(edited));
}

}  // namespace
}  // namespace gearloop
