// tests/clients/grid_files_test.cc: measurement files (CSV and JSON) and target
// files read into the API's JSON, good and bad files (tests/clients/data/,
// clients/examples/), and the grids of a stored job.
#include "clients/cli/grid_files.h"

#include <gtest/gtest.h>

#include <string>

namespace gearloop {
namespace {

using nlohmann::json;

std::string DataFile(const std::string& name) {
  return std::string(GEARLOOP_CLIENTS_TEST_DATA_DIR) + "/" + name;
}
std::string ExampleFile(const std::string& name) {
  return std::string(GEARLOOP_CLIENTS_TEST_DATA_DIR) +
         "/../../../clients/examples/" + name;
}

std::string ReadMeasurementError(const std::string& path) {
  json measurement;
  std::string error;
  EXPECT_FALSE(ReadMeasurementFile(path, 5, 9, &measurement, &error)) << path;
  return error;
}

TEST(ReadMeasurementFile, CsvAndJsonExamplesGiveTheSameMeasurement) {
  json from_csv;
  json from_json;
  std::string error;
  ASSERT_TRUE(ReadMeasurementFile(
      ExampleFile("measurement.csv"), 5, 9, &from_csv, &error))
      << error;
  ASSERT_TRUE(ReadMeasurementFile(
      ExampleFile("measurement.json"), 5, 9, &from_json, &error))
      << error;
  EXPECT_EQ(from_csv, from_json);
  // Only the grid travels; the file's metadata (part, tooth, ...) stays local.
  EXPECT_EQ(from_json.size(), 1u);
  EXPECT_TRUE(from_json["deviations_um"][4][8].is_null());
  EXPECT_DOUBLE_EQ(from_json["deviations_um"][0][0].get<double>(), 2.1);
}

TEST(ReadMeasurementFile, ReadsTeethInsideMeasurement) {
  json measurement;
  std::string error;
  ASSERT_TRUE(ReadMeasurementFile(
      DataFile("measurement_teeth.json"), 5, 9, &measurement, &error))
      << error;
  ASSERT_TRUE(measurement.contains("teeth"));
  EXPECT_EQ(measurement["teeth"].size(), 2u);
  EXPECT_FALSE(measurement.contains("deviations_um"));
}

TEST(ReadMeasurementFile, NamesRowOfShortRow) {
  const std::string error =
      ReadMeasurementError(DataFile("bad_short_row.json"));
  EXPECT_NE(
      error.find(
          "bad_short_row.json: deviations_um[2] has 8 entries, expected 9"),
      std::string::npos)
      << error;
}

TEST(ReadMeasurementFile, NamesEntryOfStringValue) {
  const std::string error =
      ReadMeasurementError(DataFile("bad_string_value.json"));
  EXPECT_NE(
      error.find(
          "deviations_um[1][4] is \"5.5\", expected a number in um or null"),
      std::string::npos)
      << error;
}

TEST(ReadMeasurementFile, NamesLineAndColumnOfJsonSyntaxError) {
  const std::string error = ReadMeasurementError(DataFile("bad_syntax.json"));
  EXPECT_NE(error.find("bad_syntax.json: not valid JSON"), std::string::npos)
      << error;
  EXPECT_NE(error.find("line 2, column"), std::string::npos) << error;
}

TEST(ReadMeasurementFile, RefusesFileWithoutGridAndMissingFile) {
  EXPECT_NE(ReadMeasurementError(DataFile("bad_no_grid.json"))
                .find("holds \"deviations_um\""),
            std::string::npos);
  EXPECT_NE(ReadMeasurementError(DataFile("no_such_file.csv"))
                .find("cannot open file"),
            std::string::npos);
  // A bad CSV keeps the CSV reader's line and column, prefixed with the file.
  EXPECT_NE(ReadMeasurementError(DataFile("bad_not_a_number.csv"))
                .find("bad_not_a_number.csv: line 4, column 7"),
            std::string::npos);
}

TEST(ReadTargetFile, RefusesMissingPointAndReadsModifications) {
  json target;
  std::string error;
  EXPECT_FALSE(
      ReadTargetFile(ExampleFile("measurement.json"), 5, 9, &target, &error));
  EXPECT_NE(error.find("deviations_um[4][8] is null"), std::string::npos)
      << error;
  EXPECT_FALSE(ReadTargetFile(
      DataFile("measurement_header.csv"), 5, 9, &target, &error));
  EXPECT_NE(error.find("line 6, column 9: missing value"), std::string::npos)
      << error;
  ASSERT_TRUE(
      ReadTargetFile(ExampleFile("request.json"), 5, 9, &target, &error))
      << error;
  EXPECT_EQ(target["modifications"][0]["kind"], "lead_crowning");
}

// The server's own grids win; the request's grids serve jobs stored before it
// sent them.
TEST(StoredJobGrids, TakeTheResultsMeasuredAndTargetGrids) {
  const json job = {{"request",
                     {{"measurement", {{"deviations_um", {{9.0, 9.0}}}}},
                      {"target", {{"modifications", json::array()}}}}},
                    {"result",
                     {{"measured_um", {{1.5, nullptr}}},
                      {"target_um", {{-0.5, -1.0}}},
                      {"predicted_change_um", {{-1.0, 0.5}}},
                      {"predicted_residual_um", {{0.25, 0.0}}}}}};
  EXPECT_EQ(MeasuredGrid(job), json({{1.5, nullptr}}));
  EXPECT_EQ(TargetGrid(job), json({{-0.5, -1.0}}));
}

TEST(StoredJobGrids, OlderJobsFallBackToTheRequestWithoutRebuildingTheTarget) {
  const json job = {
      {"request",
       {{"measurement", {{"teeth", {{{1.0, 2.0}}, {{3.0, nullptr}}}}}},
        {"target", {{"modifications", json::array()}}}}},
      {"result",
       {{"predicted_change_um", {{-1.0, 0.5}}},
        {"predicted_residual_um", {{0.25, 0.0}}}}}};
  const json measured = MeasuredGrid(job);
  EXPECT_DOUBLE_EQ(measured[0][0].get<double>(), 2.0);  // mean of 1 and 3
  EXPECT_DOUBLE_EQ(measured[0][1].get<double>(),
                   2.0);  // the only tooth that delivered it
  // Modifications are the server's to evaluate: no grid rather than one pieced
  // together.
  EXPECT_TRUE(TargetGrid(job).is_null());
  // A target grid in the request is the target.
  json grid_target = job;
  grid_target["request"]["target"] = {{"deviations_um", {{-2.0, -3.0}}}};
  EXPECT_EQ(TargetGrid(grid_target), json({{-2.0, -3.0}}));
  // Without a target the designed flank is the involute itself.
  json plain = job;
  plain["request"].erase("target");
  EXPECT_EQ(TargetGrid(plain), json({{0.0, 0.0}}));
}

}  // namespace
}  // namespace gearloop
