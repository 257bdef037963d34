// POST /api/v1/measurements/import, corrections that take a measuring-machine
// file, the ISO 1328-1 figures of correction results and GET
// /api/v1/corrections/{id}/export?format=gde, on a real server (issue 15,
// METROLOGY.md). The sample files of shared/formats (copies in
// tests/formats/data) and malformed variants of them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "tests/formats/metrology_samples.h"
#include "tests/server/server_test_util.h"

#ifndef GEARLOOP_SOURCE_DIR
#error "GEARLOOP_SOURCE_DIR must name the repository root"
#endif

namespace gearloop {
namespace {

using testing::ReadSample;
using testing_util::ParseBody;
using testing_util::RunningServer;
using testing_util::TempPath;

// The sample gear of shared/formats/README.md in the API's shape.
nlohmann::json SampleGearJson() {
  return nlohmann::json::parse(R"({
    "teeth": 31, "normal_module_mm": 4.5, "normal_pressure_angle_deg": 20,
    "helix_angle_deg": 20, "hand": "right", "face_width_mm": 40,
    "tip_radius_mm": 78.726, "root_radius_mm": 68.601})");
}

nlohmann::json ImportBody(const std::string& format,
                          const std::string& content,
                          const std::string& flank = "right") {
  return {{"gear", SampleGearJson()},
          {"flank", flank},
          {"format", format},
          {"content", content}};
}

// The line (1-based) of `text` at byte `offset`.
int LineAt(const std::string& text, size_t offset) {
  int line = 1;
  for (size_t i = 0; i < offset && i < text.size(); ++i)
    line += text[i] == '\n';
  return line;
}

struct Answer {
  int status = 0;
  nlohmann::json body;
  std::string text;
  std::string content_type;
};

class MeasurementEndpointsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    mka_ = ReadSample("sample_topography.mka");
    gde_ = ReadSample("sample_topography.gde.xml");
    ASSERT_FALSE(mka_.empty());
    ASSERT_FALSE(gde_.empty());
    ServerOptions options;
    options.database_path = db_.path();
    server_ = std::make_unique<RunningServer>(options);
    ASSERT_GT(server_->port(), 0);
    client_ = server_->Client();
  }

  Answer Post(const std::string& path, const nlohmann::json& body) {
    return Take(client_->Post(path.c_str(), body.dump(), "application/json"));
  }
  Answer Get(const std::string& path) {
    return Take(client_->Get(path.c_str()));
  }

  static Answer Take(const httplib::Result& result) {
    Answer a;
    if (!result) return a;
    a.status = result->status;
    a.text = result->body;
    a.content_type = result->get_header_value("Content-Type");
    a.body = ParseBody(result);
    return a;
  }

  // A refusal of `content` (format `format`): 422 invalid_file on "content"
  // whose message names `place`.
  void ExpectRefused(const std::string& what,
                     const std::string& format,
                     const std::string& content,
                     const std::string& place) {
    const Answer a =
        Post("/api/v1/measurements/import", ImportBody(format, content));
    EXPECT_EQ(a.status, 422) << what << ": " << a.text.substr(0, 300);
    EXPECT_EQ(a.body["error"]["code"], "invalid_file") << what;
    EXPECT_EQ(a.body["error"]["field"], "content") << what;
    const std::string message =
        a.body["error"]["message"].is_string()
            ? a.body["error"]["message"].get<std::string>()
            : "";
    EXPECT_NE(message.find(place), std::string::npos)
        << what << ": the message does not name " << place << ": " << message;
  }

  std::string mka_;
  std::string gde_;
  TempPath db_;
  std::unique_ptr<RunningServer> server_;
  std::unique_ptr<httplib::Client> client_;
};

// METROLOGY.md §4, the sample right flank: both files give the same grid
// (0.001 um), row 0 of README.md, and the worked figures and classes.
TEST_F(MeasurementEndpointsTest, BothSamplesImportToTheSameGridAndFigures) {
  const Answer mka =
      Post("/api/v1/measurements/import", ImportBody("mka", mka_));
  ASSERT_EQ(mka.status, 200) << mka.text.substr(0, 300);
  const Answer gde =
      Post("/api/v1/measurements/import", ImportBody("gde", gde_));
  ASSERT_EQ(gde.status, 200) << gde.text.substr(0, 300);
  const nlohmann::json& a = mka.body["deviations_um"];
  const nlohmann::json& b = gde.body["deviations_um"];
  ASSERT_EQ(a.size(), 5u);
  ASSERT_EQ(b.size(), 5u);
  for (int i = 0; i < 5; ++i) {
    ASSERT_EQ(a[i].size(), 9u);
    for (int j = 0; j < 9; ++j)
      EXPECT_NEAR(a[i][j].get<double>(), b[i][j].get<double>(), 0.001)
          << i << "," << j;
  }
  const double row0[] = {
      -11.500, -8.501, -6.250, -4.750, -4.000, -4.000, -4.750, -6.250, -8.499};
  for (int j = 0; j < 9; ++j)
    EXPECT_NEAR(a[0][j].get<double>(), row0[j], 0.0015) << j;
  for (const Answer* answer : {&mka, &gde}) {
    const nlohmann::json& f = answer->body["figures"];
    EXPECT_NEAR(f["fHa_mean_grid"].get<double>(), 4.00, 0.01);
    EXPECT_NEAR(f["fHa_mean"].get<double>(), 5.43, 0.01);
    EXPECT_NEAR(f["ffa_max_abs"].get<double>(), 3.00, 0.01);
    EXPECT_NEAR(f["Fa_max_abs"].get<double>(), 6.75, 0.01);
    EXPECT_NEAR(f["fHb_mean_grid"].get<double>(), 5.00, 0.01);
    EXPECT_NEAR(f["fHb_mean"].get<double>(), 5.625, 0.01);
    EXPECT_NEAR(f["ffb_max_abs"].get<double>(), 6.00, 0.01);
    EXPECT_NEAR(f["Fb_max_abs"].get<double>(), 10.00, 0.01);
    EXPECT_NEAR(f["twist_alpha_grid"].get<double>(), 4.00, 0.01);
    EXPECT_NEAR(f["twist_beta_grid"].get<double>(), 4.00, 0.01);
    const nlohmann::json& c = answer->body["classes"];
    EXPECT_EQ(c["fHa"], 6);
    EXPECT_EQ(c["ffa"], 3);
    EXPECT_EQ(c["Fa"], 4);
    EXPECT_EQ(c["fHb"], 6);
    EXPECT_EQ(c["ffb"], 5);
    EXPECT_EQ(c["Fb"], 5);
    EXPECT_EQ(c["overall"], 6);
    EXPECT_TRUE(answer->body["warnings"].empty()) << answer->body["warnings"];
    EXPECT_TRUE(answer->body["not_measured"].empty());
  }
  EXPECT_LT(mka.body["max_crossing_mismatch_um"].get<double>(), 0.01);
  // Nothing is stored by an import.
  const Answer list = Get("/api/v1/corrections");
  EXPECT_EQ(list.body["total"], 0) << list.text.substr(0, 200);
}

// The left flank of the .mka sample: shared/formats/README.md's left forms
// (f_Halpha -3, f_Hbeta -4 over the grid).
TEST_F(MeasurementEndpointsTest, TheLeftFlankOfTheMkaSample) {
  const Answer left =
      Post("/api/v1/measurements/import", ImportBody("mka", mka_, "left"));
  ASSERT_EQ(left.status, 200) << left.text.substr(0, 300);
  EXPECT_NEAR(left.body["figures"]["fHa_mean_grid"].get<double>(), -3.0, 0.01);
  EXPECT_NEAR(left.body["figures"]["fHb_mean_grid"].get<double>(), -4.0, 0.01);
}

// A header value that contradicts the request names the header code and both
// values; a decimal comma names its line; a broken GDE number its element
// path.
TEST_F(MeasurementEndpointsTest, RefusalsNameTheFileLineOrElementPath) {
  std::string comma = mka_;
  const size_t value = comma.find("-16.458");
  ASSERT_NE(value, std::string::npos);
  comma.replace(value, 7, "-16,458");
  ExpectRefused("decimal comma",
                "mka",
                comma,
                "file:line " + std::to_string(LineAt(comma, value)));

  std::string short_trace = mka_;
  const size_t head = short_trace.find("/ 48 Werte");
  ASSERT_NE(head, std::string::npos);
  short_trace.replace(head, 10, "/ 49 Werte");
  ExpectRefused("value count", "mka", short_trace, "file:line ");

  ExpectRefused("value file", "mka", "HEADER KS.MW.FILE\r\n", "file");

  std::string dev = gde_;
  const size_t attribute = dev.find("dev=\"");
  ASSERT_NE(attribute, std::string::npos);
  dev.insert(attribute + 5, "x");
  ExpectRefused("GDE number", "gde", dev, "/GDE/");
  ExpectRefused("not XML", "gde", "<GDE><unclosed>", "");
  ExpectRefused("root", "gde", "<?xml version=\"1.0\"?><VDI/>", "");

  // The request's gear is authoritative: m_n 4.4 against the file's 4.5.
  nlohmann::json body = ImportBody("mka", mka_);
  body["gear"]["normal_module_mm"] = 4.4;
  const Answer module = Post("/api/v1/measurements/import", body);
  EXPECT_EQ(module.status, 422);
  EXPECT_EQ(module.body["error"]["code"], "invalid_file");
  const std::string message = module.body["error"]["message"];
  EXPECT_NE(message.find("code 21"), std::string::npos) << message;

  // The GDE sample has the right flank only.
  const Answer no_flank =
      Post("/api/v1/measurements/import", ImportBody("gde", gde_, "left"));
  EXPECT_EQ(no_flank.status, 422) << no_flank.text;
  EXPECT_EQ(no_flank.body["error"]["code"], "invalid_file");
  EXPECT_EQ(Get("/api/v1/corrections").body["total"], 0);
}

// Request shapes and values: 400 for shapes, 422 naming the field, 413 for a
// file over the 4 MiB upload limit (the body itself under the server's 8 MiB).
TEST_F(MeasurementEndpointsTest, RefusesBadRequestsAndLargeFiles) {
  nlohmann::json body = ImportBody("csv", mka_);
  Answer a = Post("/api/v1/measurements/import", body);
  EXPECT_EQ(a.status, 422);
  EXPECT_EQ(a.body["error"]["field"], "format");

  body = ImportBody("mka", mka_);
  body.erase("content");
  a = Post("/api/v1/measurements/import", body);
  EXPECT_EQ(a.status, 400);
  EXPECT_EQ(a.body["error"]["field"], "content");

  body = ImportBody("mka", mka_);
  body["tooth"] = -2;
  a = Post("/api/v1/measurements/import", body);
  EXPECT_EQ(a.status, 422);
  EXPECT_EQ(a.body["error"]["field"], "tooth");

  body = ImportBody("mka", mka_);
  body["sign_factors"] = {{"helix_left", 2}};
  a = Post("/api/v1/measurements/import", body);
  EXPECT_EQ(a.status, 422);
  EXPECT_EQ(a.body["error"]["field"], "sign_factors.helix_left");

  body = ImportBody("mka", mka_);
  body["gear"]["teeth"] = 3;
  a = Post("/api/v1/measurements/import", body);
  EXPECT_EQ(a.status, 422);
  EXPECT_EQ(a.body["error"]["field"], "gear.teeth");

  // 4 MiB of trace values and more: refused by size, before reading.
  std::string huge = mka_;
  while (huge.size() <= (4u << 20)) huge += mka_;
  a = Post("/api/v1/measurements/import", ImportBody("mka", huge));
  EXPECT_EQ(a.status, 413) << a.text.substr(0, 300);
  EXPECT_EQ(a.body["error"]["code"], "payload_too_large");
  EXPECT_EQ(a.body["error"]["field"], "content");
}

// The sign factors are an import option: flipping the helix traces of the
// right flank breaks the crossing of profile and helix traces, which the
// answer warns of.
TEST_F(MeasurementEndpointsTest, AWrongSignFactorIsWarnedOf) {
  nlohmann::json body = ImportBody("mka", mka_);
  body["sign_factors"] = {{"helix_right", -1}};
  const Answer a = Post("/api/v1/measurements/import", body);
  ASSERT_EQ(a.status, 200) << a.text.substr(0, 300);
  EXPECT_GT(a.body["max_crossing_mismatch_um"].get<double>(), 2.0);
  EXPECT_FALSE(a.body["warnings"].empty());
}

// A correction of the sample gear on a flat-wheel grinder.
nlohmann::json CorrectionWithFile(const std::string& format,
                                  const std::string& content) {
  nlohmann::json body = {{"gear", SampleGearJson()},
                         {"wheel", {{"radius_mm", 350}}},
                         {"flank", "right"}};
  body["measurement"] = {{"file", {{"format", format}, {"content", content}}}};
  return body;
}

double MaxAbsDifference(const nlohmann::json& a, const nlohmann::json& b) {
  double worst = 0.0;
  for (size_t i = 0; i < a.size(); ++i) {
    for (size_t j = 0; j < a[i].size(); ++j) {
      if (a[i][j].is_null() || b[i][j].is_null()) return INFINITY;
      worst = std::max(worst,
                       std::abs(a[i][j].get<double>() - b[i][j].get<double>()));
    }
  }
  return worst;
}

// POST /api/v1/corrections with "measurement": {"file": ...}: the solver gets
// the grid the import gives, the result carries the ISO figures and classes of
// the measured, target-relative and predicted flank, the stored request keeps
// the file and a replay reads it again.
TEST_F(MeasurementEndpointsTest, ACorrectionTakesAMeasurementFile) {
  const Answer imported =
      Post("/api/v1/measurements/import", ImportBody("mka", mka_));
  ASSERT_EQ(imported.status, 200);
  const Answer created =
      Post("/api/v1/corrections", CorrectionWithFile("mka", mka_));
  ASSERT_EQ(created.status, 201) << created.text.substr(0, 300);
  const nlohmann::json& result = created.body["result"];
  EXPECT_LE(
      MaxAbsDifference(result["measured_um"], imported.body["deviations_um"]),
      1e-9);
  EXPECT_EQ(result["measurement_file"]["format"], "mka");
  EXPECT_TRUE(result["measurement_file"]["warnings"].empty());
  const nlohmann::json& iso = result["iso1328"];
  // The result's figures use the file's own L_alpha (code 45, 24.961 mm), as
  // its import does.
  EXPECT_EQ(result["measurement_file"]["profile_evaluation_length_mm"], 24.961);
  EXPECT_EQ(iso["measured"]["figures"], imported.body["figures"]);
  EXPECT_EQ(iso["measured"]["classes"], imported.body["classes"]);
  EXPECT_EQ(iso["measured"]["classes"]["overall"], 6);
  // No target: relative to the target is the measured flank itself.
  EXPECT_EQ(iso["target_relative"], iso["measured"]);
  // The predicted part: its slopes, which the grinder's settings reach, are
  // corrected.
  const nlohmann::json& predicted = iso["predicted"]["figures"];
  ASSERT_TRUE(predicted.is_object()) << iso["predicted"];
  EXPECT_LT(std::abs(predicted["fHa_mean_grid"].get<double>()), 1.0);
  EXPECT_LT(std::abs(predicted["fHb_mean_grid"].get<double>()), 1.0);
  ASSERT_TRUE(iso["predicted"]["classes"]["overall"].is_number());
  EXPECT_LE(iso["predicted"]["classes"]["overall"].get<int>(), 6);

  const std::string id = std::to_string(created.body["id"].get<int64_t>());
  const Answer job = Get("/api/v1/corrections/" + id);
  ASSERT_EQ(job.status, 200);
  EXPECT_EQ(job.body["request"]["measurement"]["file"]["content"], mka_);
  EXPECT_EQ(job.body["result"]["iso1328"], iso);
  const Answer replay = Post("/api/v1/corrections/" + id + "/replay",
                             {{"options", {{"solver", "lsq-plain"}}}});
  ASSERT_EQ(replay.status, 201) << replay.text.substr(0, 300);
  EXPECT_EQ(replay.body["result"]["measured_um"], result["measured_um"]);
  EXPECT_EQ(replay.body["result"]["measurement_file"]["format"], "mka");
}

// With a target the figures relative to it differ from the measured ones by
// the target's own form: a profile crowning target of 3 um.
TEST_F(MeasurementEndpointsTest, FiguresRelativeToTheTarget) {
  nlohmann::json body = CorrectionWithFile("gde", gde_);
  body["target"] = {
      {"modifications", {{{"kind", "profile_slope"}, {"amount_um", 4.0}}}}};
  const Answer created = Post("/api/v1/corrections", body);
  ASSERT_EQ(created.status, 201) << created.text.substr(0, 300);
  const nlohmann::json& iso = created.body["result"]["iso1328"];
  const double measured =
      iso["measured"]["figures"]["fHa_mean_grid"].get<double>();
  const double relative =
      iso["target_relative"]["figures"]["fHa_mean_grid"].get<double>();
  EXPECT_NEAR(measured, 4.0, 0.01);
  EXPECT_GT(std::abs(measured - relative), 1.0)
      << "a profile slope target changes the slope relative to it";
}

// A file the reader refuses refuses the correction: 422 on
// measurement.file.content, nothing stored; a bevel request takes no file.
TEST_F(MeasurementEndpointsTest, ACorrectionWithABadFileIsRefused) {
  std::string broken = mka_;
  broken.replace(broken.find("-16.458"), 7, "nan");
  Answer a = Post("/api/v1/corrections", CorrectionWithFile("mka", broken));
  EXPECT_EQ(a.status, 422) << a.text.substr(0, 300);
  EXPECT_EQ(a.body["error"]["code"], "invalid_file");
  EXPECT_EQ(a.body["error"]["field"], "measurement.file.content");
  EXPECT_NE(a.body["error"]["message"].get<std::string>().find("file:line"),
            std::string::npos);

  nlohmann::json body = CorrectionWithFile("mka", mka_);
  body["measurement"]["file"]["format"] = "csv";
  a = Post("/api/v1/corrections", body);
  EXPECT_EQ(a.status, 422);
  EXPECT_EQ(a.body["error"]["field"], "measurement.file.format");

  body = CorrectionWithFile("mka", mka_);
  body["measurement"]["deviations_um"] = nullptr;
  a = Post("/api/v1/corrections", body);
  EXPECT_EQ(a.status, 400);
  EXPECT_EQ(a.body["error"]["field"], "measurement.deviations_um");

  body = {{"machine", {{"kind", "free-form-bevel-generator"}}},
          {"job", {{"side", "convex"}, {"published", true}}}};
  body["measurement"] = {{"file", {{"format", "mka"}, {"content", mka_}}}};
  a = Post("/api/v1/corrections", body);
  EXPECT_EQ(a.status, 422);
  EXPECT_EQ(a.body["error"]["field"], "measurement.file");
  EXPECT_EQ(Get("/api/v1/corrections").body["total"], 0);
}

// The file's flank against the request's (issue 16): the GDE sample holds the
// right flank only, the mka sample cut to one flank either; a correction of
// the other flank is refused with 422 on measurement.file naming both flanks,
// the import on "flank", and nothing is stored. The x_positive datum face
// swaps which flank of the file lands on the request's.
TEST_F(MeasurementEndpointsTest, AFileOfTheOtherFlankIsRefused) {
  const size_t left_start =
      mka_.find("TOPOGRAFIE: Zahn-Nr.: 1 /Profil:1 links");
  const size_t first_trace = mka_.find("TOPOGRAFIE:");
  ASSERT_NE(left_start, std::string::npos);
  const std::string right_only = mka_.substr(0, left_start);
  const std::string left_only =
      mka_.substr(0, first_trace) + mka_.substr(left_start);
  struct Case {
    std::string format, content, flank, file_flank;
  };
  const Case cases[] = {{"gde", gde_, "left", "right"},
                        {"mka", right_only, "left", "right"},
                        {"mka", left_only, "right", "left"}};
  for (const Case& c : cases) {
    SCOPED_TRACE(c.format + " of the " + c.file_flank + " flank");
    nlohmann::json body = CorrectionWithFile(c.format, c.content);
    body["flank"] = c.flank;
    const Answer a = Post("/api/v1/corrections", body);
    EXPECT_EQ(a.status, 422) << a.text.substr(0, 300);
    EXPECT_EQ(a.body["error"]["code"], "invalid_file");
    EXPECT_EQ(a.body["error"]["field"], "measurement.file");
    const std::string message = a.body["error"]["message"];
    EXPECT_NE(
        message.find("the file measures the " + c.file_flank +
                     " flank, the request corrects the " + c.flank + " flank"),
        std::string::npos)
        << message;
    const Answer i = Post("/api/v1/measurements/import",
                          ImportBody(c.format, c.content, c.flank));
    EXPECT_EQ(i.status, 422);
    EXPECT_EQ(i.body["error"]["field"], "flank");
  }
  // The same files on their own flank are taken.
  nlohmann::json body = CorrectionWithFile("mka", left_only);
  body["flank"] = "left";
  EXPECT_EQ(Post("/api/v1/corrections", body).status, 201);
  EXPECT_EQ(Post("/api/v1/measurements/import",
                 ImportBody("mka", right_only, "right"))
                .status,
            200);
  // Seen from the x_positive face the file's right flank is the request's left.
  body = CorrectionWithFile("mka", right_only);
  body["measurement"]["file"]["datum_face"] = "x_positive";
  const Answer swapped = Post("/api/v1/corrections", body);
  EXPECT_EQ(swapped.status, 422);
  EXPECT_NE(
      swapped.body["error"]["message"].get<std::string>().find("x_positive"),
      std::string::npos);
  EXPECT_EQ(Get("/api/v1/corrections").body["total"], 1);
}

// METROLOGY.md §3: the export holds the measured, target and predicted nets;
// importing it back gives the stored measured grid within 0.001 um.
TEST_F(MeasurementEndpointsTest, ExportRoundTripsThroughTheImport) {
  nlohmann::json body = CorrectionWithFile("mka", mka_);
  body["target"] = {
      {"modifications", {{{"kind", "lead_crowning"}, {"amount_um", 5.0}}}}};
  const Answer created = Post("/api/v1/corrections", body);
  ASSERT_EQ(created.status, 201) << created.text.substr(0, 300);
  const std::string id = std::to_string(created.body["id"].get<int64_t>());
  const Answer exported =
      Get("/api/v1/corrections/" + id + "/export?format=gde");
  ASSERT_EQ(exported.status, 200) << exported.text.substr(0, 300);
  EXPECT_NE(exported.content_type.find("application/xml"), std::string::npos);
  for (const char* kind : {"measured", "target", "predicted"}) {
    EXPECT_NE(exported.text.find("kind=\"" + std::string(kind) + "\""),
              std::string::npos)
        << kind;
  }
  const Answer back =
      Post("/api/v1/measurements/import", ImportBody("gde", exported.text));
  ASSERT_EQ(back.status, 200) << back.text.substr(0, 300);
  EXPECT_LE(MaxAbsDifference(back.body["deviations_um"],
                             created.body["result"]["measured_um"]),
            0.001);
  EXPECT_EQ(back.body["classes"],
            created.body["result"]["iso1328"]["measured"]["classes"]);

  Answer a = Get("/api/v1/corrections/" + id + "/export?format=mka");
  EXPECT_EQ(a.status, 422);
  EXPECT_EQ(a.body["error"]["field"], "query.format");
  a = Get("/api/v1/corrections/" + id + "/export");
  EXPECT_EQ(a.status, 400);
  a = Get("/api/v1/corrections/987654/export?format=gde");
  EXPECT_EQ(a.status, 404);

  // A spiral-bevel job has no involute gear to write as GDE.
  const nlohmann::json bevel = {
      {"machine", {{"kind", "free-form-bevel-generator"}}},
      {"job", {{"side", "concave"}, {"published", true}}},
      {"hidden_errors", {{"X_mm", {0.008}}}},
      {"noise_um", 0.2},
      {"seed", 11},
      {"corrections", 1},
      {"store", true}};
  const Answer loop = Post("/api/v1/simulations/closed-loop", bevel);
  ASSERT_EQ(loop.status, 200) << loop.text.substr(0, 300);
  const nlohmann::json& round = loop.body["iterations"][0];
  ASSERT_TRUE(round.contains("job_id")) << round.dump().substr(0, 300);
  a = Get("/api/v1/corrections/" +
          std::to_string(round["job_id"].get<int64_t>()) +
          "/export?format=gde");
  EXPECT_EQ(a.status, 422) << a.text.substr(0, 300);
  EXPECT_NE(a.body["error"]["message"].get<std::string>().find(
                "not a flat-wheel grinder job"),
            std::string::npos);
}

// POST /api/v1/evaluate carries the ISO figures of the ground flank: the
// nominal settings grind the design flank (class 1), a changed wheel cone
// angle tilts the profile and the class follows.
TEST_F(MeasurementEndpointsTest, AnEvaluationCarriesTheIsoFigures) {
  nlohmann::json body = {{"gear", SampleGearJson()},
                         {"wheel", {{"radius_mm", 350}}},
                         {"flank", "right"}};
  const Answer nominal = Post("/api/v1/evaluate", body);
  ASSERT_EQ(nominal.status, 200) << nominal.text.substr(0, 300);
  const nlohmann::json& iso = nominal.body["iso1328"];
  ASSERT_TRUE(iso["figures"].is_object()) << iso;
  EXPECT_LT(std::abs(iso["figures"]["Fa_max_abs"].get<double>()), 0.1);
  EXPECT_EQ(iso["classes"]["overall"], 1);

  const Answer settings = Post("/api/v1/nominal", body);
  ASSERT_EQ(settings.status, 200);
  body["settings"] = settings.body["settings"];
  body["settings"]["wheel"]["cone_angle_deg"] = 0.01;
  const Answer tilted = Post("/api/v1/evaluate", body);
  ASSERT_EQ(tilted.status, 200) << tilted.text.substr(0, 300);
  const nlohmann::json& figures = tilted.body["iso1328"]["figures"];
  EXPECT_GT(std::abs(figures["fHa_mean"].get<double>()), 1.0) << figures;
  EXPECT_GT(tilted.body["iso1328"]["classes"]["overall"].get<int>(), 1);
}

}  // namespace
}  // namespace gearloop
