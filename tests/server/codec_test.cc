// tests/server/codec_test.cc: the codecs of server/codec/ are pure mappings:
// what one renders parses back to the same value, and parsing computes nothing
// (no model, no solve).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <vector>

#include "server/codec/bevel_codec.h"
#include "server/codec/correction_codec.h"
#include "server/codec/grinder_codec.h"
#include "server/codec/json_read.h"
#include "tests/server/server_test_util.h"

namespace gearloop {
namespace {

TEST(GrinderCodec, SettingsRoundTrip) {
  GrindingSetup setup;
  ApiError error;
  ASSERT_TRUE(ParseGrindingSetup(testing_util::DefaultSetup(), &setup, &error))
      << error.message;
  MachineSettings settings = NominalSettings(setup);
  settings.axes[0][2] = 1e-3;
  settings.wheel.cone_angle_rad = 0.25;
  const nlohmann::json rendered = MachineSettingsToJson(settings);
  MachineSettings parsed;
  ASSERT_TRUE(ParseMachineSettings(rendered, "settings", &parsed, &error))
      << error.message;
  EXPECT_EQ(MachineSettingsToJson(parsed), rendered);
  EXPECT_NEAR(parsed.wheel.cone_angle_rad, 0.25, 1e-15);
}

TEST(JsonRead, GridRoundTripKeepsMissingPoints) {
  Eigen::VectorXd values(6);
  values << 1.5, -2.0, std::numeric_limits<double>::quiet_NaN(), 0.0, 3.25,
      1e-7;
  const nlohmann::json rendered = GridToJson(values, {}, 2, 3);
  Eigen::VectorXd parsed;
  std::vector<bool> present;
  ApiError error;
  ASSERT_TRUE(ParseGridValues(
      rendered, "grid", 2, 3, /*allow_null=*/true, &parsed, &present, &error));
  EXPECT_FALSE(present[2]);
  EXPECT_EQ(GridToJson(parsed, present, 2, 3), rendered);
}

TEST(BevelCodec, JobAndMotionRoundTrip) {
  BevelPinionJob job;
  ApiError error;
  ASSERT_TRUE(ParseBevelJob(
      {{"job", {{"side", "concave"}, {"published", true}}}}, &job, &error))
      << error.message;
  const nlohmann::json rendered_job = BevelJobToJson(job);
  nlohmann::json summary = rendered_job;
  summary.erase("cutter");  // "blade" is derived from the side
  summary["cutter"] = {
      {"point_radius_mm", rendered_job["cutter"]["point_radius_mm"]},
      {"blade_angle_deg", rendered_job["cutter"]["blade_angle_deg"]},
      {"edge_radius_mm", rendered_job["cutter"]["edge_radius_mm"]}};
  BevelPinionJob parsed_job;
  ASSERT_TRUE(ParseBevelJob({{"job", summary}}, &parsed_job, &error))
      << error.message;
  EXPECT_EQ(BevelJobToJson(parsed_job), rendered_job);

  FreeFormMotion motion = FreeFormMotion::Zero(2);
  motion.coefficients[0](1) = 0.125;
  motion.coefficients[4](2) = -3.5;
  const nlohmann::json rendered_motion = FreeFormMotionToJson(motion);
  nlohmann::json given = rendered_motion;
  given.erase("degree");
  FreeFormMotion parsed_motion;
  ASSERT_TRUE(ParseFreeFormMotion(given, "motion", &parsed_motion, &error))
      << error.message;
  EXPECT_EQ(FreeFormMotionToJson(parsed_motion), rendered_motion);
}

// Several teeth reach the engine as they are, and target modifications stay a
// list: the codec neither averages nor evaluates.
TEST(CorrectionCodec, ParsesTeethAndModificationsWithoutComputing) {
  const nlohmann::json tooth =
      GridToJson(Eigen::VectorXd::Constant(6, 1.0), {}, 2, 3);
  nlohmann::json other = tooth;
  other[0][0] = nullptr;
  const nlohmann::json body = {
      {"measurement", {{"teeth", {tooth, other, tooth}}}},
      {"target",
       {{"modifications",
         {{{"kind", "profile_crowning"}, {"amount_um", 2.0}}}}}},
      {"settings_source_job_id", 7}};
  CorrectionRequest request;
  ApiError error;
  ASSERT_TRUE(ParseCorrectionRequest(
      body, 2, 3, /*target_modifications_allowed=*/true, &request, &error))
      << error.field << ": " << error.message;
  ASSERT_EQ(request.measured_teeth_um.size(), 3u);
  EXPECT_EQ(request.measured_um.size(), 0);
  EXPECT_TRUE(std::isnan(request.measured_teeth_um[1](0)));
  ASSERT_TRUE(request.target_modifications.has_value());
  EXPECT_EQ(request.target_modifications->size(), 1u);
  EXPECT_EQ(request.target_um, Eigen::VectorXd::Zero(6));
  EXPECT_EQ(request.settings_source_job_id, 7);

  EXPECT_FALSE(ParseCorrectionRequest(
      body, 2, 3, /*target_modifications_allowed=*/false, &request, &error));
  EXPECT_EQ(error.status, 422);
  EXPECT_EQ(error.field, "target.modifications");
}

}  // namespace
}  // namespace gearloop
