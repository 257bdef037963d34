#include "formats/mka_reader.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "tests/formats/metrology_samples.h"

namespace gearloop {
namespace {

using testing::ReadSample;

std::string Replace(std::string s,
                    const std::string& from,
                    const std::string& to) {
  for (size_t at = s.find(from); at != std::string::npos;
       at = s.find(from, at + to.size()))
    s.replace(at, from.size(), to);
  return s;
}

TEST(ReadMkaFile, TheSample) {
  const std::string content = ReadSample("sample_topography.mka");
  ASSERT_FALSE(content.empty());
  MeasurementFile file;
  FileError error;
  ASSERT_TRUE(ReadMkaFile(content, &file, &error)) << error.ToString();
  ASSERT_EQ(file.traces.size(), 18u);
  const MeasuredTrace& p2 = file.traces[1];
  EXPECT_EQ(p2.kind, TraceKind::kProfile);
  EXPECT_EQ(p2.flank, Flank::kRight);
  EXPECT_EQ(p2.tooth, 1);
  EXPECT_DOUBLE_EQ(p2.position_mm, 11.5);
  EXPECT_DOUBLE_EQ(p2.begin_mm, 140.5);
  EXPECT_DOUBLE_EQ(p2.end_mm, 157.0);
  ASSERT_EQ(p2.values_um.size(), 48u);
  EXPECT_DOUBLE_EQ(p2.values_um[0], -10.840);
  EXPECT_EQ(file.trace_places[1].line, 45);
  const MeasuredTrace& h2 = file.traces[6];
  EXPECT_EQ(h2.kind, TraceKind::kHelix);
  EXPECT_DOUBLE_EQ(h2.position_mm, 147.0);
  EXPECT_DOUBLE_EQ(h2.begin_mm, 1.0);
  EXPECT_DOUBLE_EQ(h2.end_mm, 39.0);
  EXPECT_TRUE(std::isnan(h2.values_um[0]));  // UNDEFINED -2147483.648
  EXPECT_EQ(file.traces[9].flank, Flank::kLeft);
  const MeasurementFileHeader& h = file.header;
  EXPECT_DOUBLE_EQ(h.normal_module_mm->value, 4.5);
  EXPECT_EQ(h.normal_module_mm->place.line, 18);
  EXPECT_DOUBLE_EQ(h.teeth->value, 31);
  EXPECT_DOUBLE_EQ(h.helix_angle_deg->value, 20);
  EXPECT_DOUBLE_EQ(h.face_width_mm->value, 40);
  EXPECT_DOUBLE_EQ(h.profile_evaluation_length_mm->value, 24.961);
  EXPECT_DOUBLE_EQ(h.root_diameter_mm->value, 137.202);
  EXPECT_EQ(h.helix_hand, "right");
}

// UTF-8 with BOM and CRLF (the sample), LF without BOM, and Latin-1: the same
// traces.
TEST(ReadMkaFile, ToleratesBomCrlfAndLatin1) {
  const std::string sample = ReadSample("sample_topography.mka");
  std::string lf = Replace(sample.substr(3), "\r\n", "\n");
  std::string latin1 =
      Replace(Replace(Replace(lf, "\xC3\xA4", "\xE4"), "\xC3\x9F", "\xDF"),
              "\xCE\xB2",
              "b");
  latin1 =
      Replace(Replace(Replace(latin1, "\xCE\xB1", "a"), "\xC2\xB0", "\xB0"),
              "\xC3\xBC",
              "\xFC");
  MeasurementFile a, b, c;
  FileError error;
  ASSERT_TRUE(ReadMkaFile(sample, &a, &error)) << error.ToString();
  ASSERT_TRUE(ReadMkaFile(lf, &b, &error)) << error.ToString();
  ASSERT_TRUE(ReadMkaFile(latin1, &c, &error)) << error.ToString();
  ASSERT_EQ(a.traces.size(), b.traces.size());
  ASSERT_EQ(a.traces.size(), c.traces.size());
  for (size_t i = 0; i < a.traces.size(); ++i) {
    for (size_t k = 0; k < a.traces[i].values_um.size(); ++k) {
      const double x = a.traces[i].values_um[k];
      if (std::isnan(x)) continue;
      EXPECT_EQ(x, b.traces[i].values_um[k]);
      EXPECT_EQ(x, c.traces[i].values_um[k]);
    }
  }
}

TEST(ReadMkaFile, PlainBlocksMapToMidFaceAndTheMeasuringDiameter) {
  std::string sample =
      Replace(ReadSample("sample_topography.mka").substr(3), "\r\n", "\n");
  const size_t first = sample.find("TOPOGRAFIE:");
  std::string head = sample.substr(0, first);
  std::string body =
      "Profil:\nZahn-Nr.: 3 rechts / 4 Werte\n 1.0 2.0 3.0 4.0\nZahn-Nr.: 3 "
      "links / 4 Werte\n 1 2 3 4\n"
      "Flankenlinie:\nZahn-Nr.: 3 rechts / 3 Werte\n 0.5 0.25\n 0.0\n"
      "Teilung:\n  1  2.0  3.0 ...whatever the pitch table holds\n";
  MeasurementFile file;
  FileError error;
  ASSERT_TRUE(ReadMkaFile(head + body, &file, &error)) << error.ToString();
  ASSERT_EQ(file.traces.size(), 3u);
  EXPECT_EQ(file.traces[0].tooth, 3);
  EXPECT_DOUBLE_EQ(file.traces[0].position_mm, 20.0);     // b / 2
  EXPECT_DOUBLE_EQ(file.traces[2].position_mm, 148.453);  // code 46
  EXPECT_EQ(file.traces[2].kind, TraceKind::kHelix);
}

}  // namespace
}  // namespace gearloop
