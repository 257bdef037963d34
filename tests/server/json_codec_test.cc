// Tests of the JSON codec: API names and units in, engine names and units out,
// and errors that name the field with the API's own path.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "engine/core/units.h"
#include "engine/grinder/grinder_settings.h"
#include "server/codec/grinder_codec.h"
#include "server/codec/request_keys.h"

namespace gearloop {
namespace {

nlohmann::json DefaultRequest() {
  return nlohmann::json::parse(R"({
    "gear": {"teeth": 37, "normal_module_mm": 6, "normal_pressure_angle_deg": 20,
             "helix_angle_deg": 15, "hand": "left", "face_width_mm": 78,
             "tip_radius_mm": 120.9157, "root_radius_mm": 107.1569},
    "wheel": {"radius_mm": 350},
    "machine": {"kind": "flat-wheel-grinder", "k1_mm": 0, "k2_mm": 0, "traverse_mm_per_rad": 0},
    "grid": {"profile_points": 5, "lead_points": 9, "profile_range": [0.2, 0.9], "lead_range": [-0.4, 0.4]},
    "flank": "right"})");
}

TEST(ParseGrindingSetup, ConvertsDegreesAndHandToSignedRadians) {
  GrindingSetup setup;
  ApiError error;
  ASSERT_TRUE(ParseGrindingSetup(DefaultRequest(), &setup, &error))
      << error.message;
  EXPECT_EQ(setup.gear.teeth, 37);
  EXPECT_NEAR(setup.gear.normal_pressure_angle_rad, 20.0 * kPi / 180.0, 1e-15);
  // Left hand is beta > 0 (MODEL.md §1).
  EXPECT_NEAR(setup.gear.helix_angle_rad, 15.0 * kPi / 180.0, 1e-15);
  EXPECT_EQ(setup.flank, Flank::kRight);
  EXPECT_DOUBLE_EQ(setup.grid.profile_begin, 0.2);
  EXPECT_DOUBLE_EQ(setup.grid.lead_end, 0.4);

  nlohmann::json right = DefaultRequest();
  right["gear"]["hand"] = "right";
  right["flank"] = "left";
  ASSERT_TRUE(ParseGrindingSetup(right, &setup, &error)) << error.message;
  EXPECT_NEAR(setup.gear.helix_angle_rad, -15.0 * kPi / 180.0, 1e-15);
  EXPECT_EQ(setup.flank, Flank::kLeft);
}

TEST(ParseGrindingSetup, DefaultsOptionalParts) {
  nlohmann::json request = DefaultRequest();
  request.erase("machine");
  request.erase("grid");
  request.erase("flank");
  GrindingSetup setup;
  ApiError error;
  ASSERT_TRUE(ParseGrindingSetup(request, &setup, &error)) << error.message;
  EXPECT_EQ(setup.grid.profile_points, 5);
  EXPECT_EQ(setup.grid.lead_points, 9);
  EXPECT_EQ(setup.flank, Flank::kRight);
  EXPECT_DOUBLE_EQ(setup.machine.k1_mm, 0.0);
}

struct BadCase {
  const char* name;
  std::function<void(nlohmann::json*)> edit;
  int status;
  const char* field;
};

TEST(ParseGrindingSetup, NamesTheFieldOfEachError) {
  const std::vector<BadCase> cases = {
      {"missing gear",
       [](nlohmann::json* j) { j->erase("gear"); },
       400,
       "gear"},
      {"gear not object",
       [](nlohmann::json* j) { (*j)["gear"] = 3; },
       400,
       "gear"},
      {"teeth string",
       [](nlohmann::json* j) { (*j)["gear"]["teeth"] = "37"; },
       400,
       "gear.teeth"},
      {"teeth fraction",
       [](nlohmann::json* j) { (*j)["gear"]["teeth"] = 37.5; },
       400,
       "gear.teeth"},
      {"teeth negative",
       [](nlohmann::json* j) { (*j)["gear"]["teeth"] = -3; },
       422,
       "gear.teeth"},
      {"missing module",
       [](nlohmann::json* j) { (*j)["gear"].erase("normal_module_mm"); },
       400,
       "gear.normal_module_mm"},
      {"pressure angle 60",
       [](nlohmann::json* j) {
         (*j)["gear"]["normal_pressure_angle_deg"] = 60;
       },
       422,
       "gear.normal_pressure_angle_deg"},
      {"negative helix",
       [](nlohmann::json* j) { (*j)["gear"]["helix_angle_deg"] = -15; },
       422,
       "gear.helix_angle_deg"},
      {"helix without hand",
       [](nlohmann::json* j) { (*j)["gear"].erase("hand"); },
       400,
       "gear.hand"},
      {"bad hand",
       [](nlohmann::json* j) { (*j)["gear"]["hand"] = "up"; },
       422,
       "gear.hand"},
      {"tip below root",
       [](nlohmann::json* j) { (*j)["gear"]["tip_radius_mm"] = 100; },
       422,
       "gear.tip_radius_mm"},
      {"wheel missing",
       [](nlohmann::json* j) { j->erase("wheel"); },
       400,
       "wheel"},
      {"wheel negative",
       [](nlohmann::json* j) { (*j)["wheel"]["radius_mm"] = -1; },
       422,
       "wheel.radius_mm"},
      {"machine kind",
       [](nlohmann::json* j) { (*j)["machine"]["kind"] = "hob"; },
       422,
       "machine.kind"},
      {"range wrong way",
       [](nlohmann::json* j) {
         (*j)["grid"]["profile_range"] = {0.9, 0.2};
       },
       422,
       "grid.profile_range[1]"},
      {"range one number",
       [](nlohmann::json* j) { (*j)["grid"]["lead_range"] = {0.1}; },
       400,
       "grid.lead_range"},
      {"range entry string",
       [](nlohmann::json* j) {
         (*j)["grid"]["lead_range"] = {"a", 0.1};
       },
       400,
       "grid.lead_range[0]"},
      {"one profile point",
       [](nlohmann::json* j) { (*j)["grid"]["profile_points"] = 1; },
       422,
       "grid.profile_points"},
      {"bad flank",
       [](nlohmann::json* j) { (*j)["flank"] = "middle"; },
       422,
       "flank"},
  };
  for (const BadCase& c : cases) {
    nlohmann::json request = DefaultRequest();
    c.edit(&request);
    GrindingSetup setup;
    ApiError error;
    EXPECT_FALSE(ParseGrindingSetup(request, &setup, &error)) << c.name;
    EXPECT_EQ(error.status, c.status) << c.name << ": " << error.message;
    EXPECT_EQ(error.field, c.field) << c.name << ": " << error.message;
    EXPECT_EQ(error.code, c.status == 400 ? "invalid_request" : "invalid_value")
        << c.name;
    EXPECT_FALSE(error.message.empty()) << c.name;
  }
}

TEST(ApiFieldPath, MapsEngineNamesToApiNames) {
  EXPECT_EQ(ApiFieldPath("gear.normal_pressure_angle_rad"),
            "gear.normal_pressure_angle_deg");
  EXPECT_EQ(ApiFieldPath("gear.helix_angle_rad"), "gear.helix_angle_deg");
  EXPECT_EQ(ApiFieldPath("grid.profile_begin"), "grid.profile_range[0]");
  EXPECT_EQ(ApiFieldPath("grid.lead_end"), "grid.lead_range[1]");
  EXPECT_EQ(ApiFieldPath("settings.wheel.cone_angle_rad"),
            "settings.wheel.cone_angle_deg");
  EXPECT_EQ(ApiFieldPath("gear.teeth"), "gear.teeth");
}

TEST(ParseJsonBody, RefusesNonJsonNonObjectsAndDeepNesting) {
  nlohmann::json body;
  ApiError error;
  EXPECT_FALSE(ParseJsonBody("{\"a\": ", &body, &error));
  EXPECT_EQ(error.code, "invalid_json");
  EXPECT_FALSE(ParseJsonBody("{\"a\": NaN}", &body, &error));
  EXPECT_EQ(error.status, 400);
  EXPECT_FALSE(ParseJsonBody("[1, 2]", &body, &error));
  EXPECT_EQ(error.code, "invalid_request");
  EXPECT_FALSE(ParseJsonBody(
      std::string(10000, '[') + std::string(10000, ']'), &body, &error));
  EXPECT_EQ(error.code, "invalid_json");
  // Brackets inside strings do not count as nesting.
  EXPECT_TRUE(ParseJsonBody(
      "{\"a\": \"" + std::string(100, '[') + "\"}", &body, &error))
      << error.message;
  // 1e400 overflows a double: refused as not JSON, never turned into infinity.
  EXPECT_FALSE(ParseJsonBody("{\"a\": 1e400}", &body, &error));
  EXPECT_EQ(error.code, "invalid_json");
  // Invalid UTF-8 in a string.
  EXPECT_FALSE(ParseJsonBody("{\"a\": \"\xff\"}", &body, &error));
  EXPECT_EQ(error.code, "invalid_json");
}

TEST(ParseGridValues, NamesRowAndEntryAndMarksNulls) {
  Eigen::VectorXd values;
  std::vector<bool> present;
  ApiError error;
  nlohmann::json grid = nlohmann::json::array();
  for (int r = 0; r < 2; ++r) grid.push_back({1.0, 2.0, 3.0});
  grid[1][2] = nullptr;
  ASSERT_TRUE(ParseGridValues(grid, "m", 2, 3, true, &values, &present, &error))
      << error.message;
  EXPECT_FALSE(present[5]);
  EXPECT_TRUE(present[4]);
  EXPECT_DOUBLE_EQ(values(3), 1.0);
  EXPECT_FALSE(
      ParseGridValues(grid, "m", 2, 3, false, &values, &present, &error));
  EXPECT_EQ(error.field, "m[1][2]");
  grid[1] = {1.0, 2.0};
  EXPECT_FALSE(
      ParseGridValues(grid, "m", 2, 3, true, &values, &present, &error));
  EXPECT_EQ(error.field, "m[1]");
  EXPECT_FALSE(
      ParseGridValues(grid, "m", 3, 3, true, &values, &present, &error));
  EXPECT_EQ(error.field, "m");
  grid[1] = {1.0, "x", 2.0};
  EXPECT_FALSE(
      ParseGridValues(grid, "m", 2, 3, true, &values, &present, &error));
  EXPECT_EQ(error.field, "m[1][1]");
  EXPECT_EQ(error.status, 400);
}

TEST(MachineSettingsJson, RoundTripsWithConeAngleInDegrees) {
  MachineSettings settings;
  for (int i = 0; i < kNumAxes; ++i) {
    for (int k = 0; k < kCoefficientsPerAxis; ++k)
      settings.axes[i][k] = 0.1 * i + 0.01 * k;
  }
  settings.wheel.cone_angle_rad = 0.5 * kPi / 180.0;
  settings.wheel.parabola_coefficient_per_mm = 1e-4;
  settings.wheel.parabola_vertex_mm = 2.0;
  const nlohmann::json j = MachineSettingsToJson(settings);
  EXPECT_NEAR(j["wheel"]["cone_angle_deg"].get<double>(), 0.5, 1e-12);
  MachineSettings back;
  ApiError error;
  ASSERT_TRUE(ParseMachineSettings(j, "settings", &back, &error))
      << error.message;
  EXPECT_EQ(back.ToVector(), settings.ToVector());

  nlohmann::json bad = j;
  bad["axes"]["X"] = nlohmann::json::array();
  EXPECT_FALSE(ParseMachineSettings(bad, "settings", &back, &error));
  EXPECT_EQ(error.field, "settings.axes.X");
  bad = j;
  bad["axes"].erase("C");
  EXPECT_FALSE(ParseMachineSettings(bad, "settings", &back, &error));
  EXPECT_EQ(error.field, "settings.axes.C");
  bad = j;
  bad["axes"]["Q"] = {1.0};
  EXPECT_FALSE(ParseMachineSettings(bad, "settings", &back, &error));
  EXPECT_EQ(error.field, "settings.axes.Q");
  // A coefficient of power k may reach 1e6 x 10^k (an order-6 correction over
  // a short roll range has large ones), not beyond (a unit mistake).
  nlohmann::json large = j;
  large["axes"]["C"][2] = 9e7;
  large["axes"]["C"][6] = -9e11;
  EXPECT_TRUE(ParseMachineSettings(large, "settings", &back, &error))
      << error.message;
  large["axes"]["C"][2] = 1.1e8;
  EXPECT_FALSE(ParseMachineSettings(large, "settings", &back, &error));
  EXPECT_EQ(error.field, "settings.axes.C[2]");
  large = j;
  large["axes"]["X"][0] = 1.1e6;
  EXPECT_FALSE(ParseMachineSettings(large, "settings", &back, &error));
  EXPECT_EQ(error.field, "settings.axes.X[0]");
  // Fewer than seven coefficients: the higher orders are zero.
  nlohmann::json short_axes = j;
  short_axes["axes"]["Y"] = {5.0};
  ASSERT_TRUE(ParseMachineSettings(short_axes, "settings", &back, &error));
  EXPECT_DOUBLE_EQ(back.axes[1][0], 5.0);
  EXPECT_DOUBLE_EQ(back.axes[1][6], 0.0);
}

// Engine angles (_rad) are degrees in the API; a rate per radian keeps its
// name as the client wrote it (issue 17).
TEST(ApiFieldPath, RenamesAnglesButNotRatesPerRadian) {
  EXPECT_EQ(ApiFieldPath("gear.helix_angle_rad"), "gear.helix_angle_deg");
  EXPECT_EQ(ApiFieldPath("machine.swivel_rad"), "machine.swivel_deg");
  EXPECT_EQ(ApiFieldPath("machine.traverse_mm_per_rad"),
            "machine.traverse_mm_per_rad");
}

TEST(CheckKeys, NamesTheUnknownKeyAndTheNearestKnownOne) {
  ApiError error;
  EXPECT_TRUE(CheckKeys(
      nlohmann::json{{"radius_mm", 1}}, "wheel", {"radius_mm"}, &error));
  EXPECT_FALSE(CheckKeys(nlohmann::json{{"default_max_ordr", 1}},
                         "options",
                         {"max_order", "default_max_order"},
                         &error));
  EXPECT_EQ(error.status, 422);
  EXPECT_EQ(error.field, "options.default_max_ordr");
  EXPECT_NE(error.message.find("did you mean default_max_order?"),
            std::string::npos);
  EXPECT_FALSE(CheckKeys(nlohmann::json{{"zzzzzz", 1}}, "", {"teeth"}, &error));
  EXPECT_EQ(error.field, "zzzzzz");
  EXPECT_EQ(error.message.find("did you mean"), std::string::npos);
  EXPECT_EQ(NearestName("modul", {"normal_module_mm", "teeth"}), "");
  EXPECT_EQ(NearestName("teth", {"normal_module_mm", "teeth"}), "teeth");
}

// The top-level keys of a correction are its machine family's: a bevel job
// is unknown to the grinder and a gear to the bevel generator; a machine kind
// that cannot be read is left to the parser, which names it.
TEST(CheckRequestKeys, KnowsTheKeysOfTheMachineFamily) {
  ApiError error;
  const nlohmann::json grinder = {{"gear", nlohmann::json::object()},
                                  {"measurement", nlohmann::json::object()},
                                  {"allow_large_deviations", true}};
  EXPECT_TRUE(
      CheckRequestKeys(RequestSchema::kCorrection, grinder, "", &error));
  nlohmann::json with_job = grinder;
  with_job["job"] = nlohmann::json::object();
  EXPECT_FALSE(
      CheckRequestKeys(RequestSchema::kCorrection, with_job, "", &error));
  EXPECT_EQ(error.field, "job");

  const nlohmann::json bevel = {
      {"machine", {{"kind", "free-form-bevel-generator"}}},
      {"job", nlohmann::json::object()},
      {"motion", nlohmann::json::object()}};
  EXPECT_TRUE(CheckRequestKeys(RequestSchema::kCorrection, bevel, "", &error));
  nlohmann::json with_gear = bevel;
  with_gear["gear"] = nlohmann::json::object();
  EXPECT_FALSE(CheckRequestKeys(
      RequestSchema::kCorrection, with_gear, "items[2]", &error));
  EXPECT_EQ(error.field, "items[2].gear");
  EXPECT_EQ(error.message, "unknown key items[2].gear");
  // Bevel simulations take no point lists; closed loops take a target.
  nlohmann::json lists = bevel;
  lists["outlier_points"] = nlohmann::json::array();
  EXPECT_FALSE(CheckRequestKeys(
      RequestSchema::kMeasurementSimulation, lists, "", &error));
  nlohmann::json loop = bevel;
  loop["corrections"] = 2;
  EXPECT_TRUE(CheckRequestKeys(RequestSchema::kClosedLoop, loop, "", &error));
  EXPECT_FALSE(CheckRequestKeys(
      RequestSchema::kMeasurementSimulation, loop, "", &error));
  EXPECT_EQ(error.field, "corrections");

  nlohmann::json unknown_kind = with_job;
  unknown_kind["machine"] = {{"kind", "hob"}};
  EXPECT_TRUE(
      CheckRequestKeys(RequestSchema::kCorrection, unknown_kind, "", &error));
}

}  // namespace
}  // namespace gearloop
