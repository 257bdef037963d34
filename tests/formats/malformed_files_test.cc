// Every refusal of METROLOGY.md §5 with the place it names, on a corpus of
// malformed files made from the two samples (one defect each), and hostile
// inputs: all refused, none crashes.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "formats/measurement_import.h"
#include "tests/formats/metrology_samples.h"

namespace gearloop {
namespace {

using testing::ReadSample;
using testing::SampleGear;

// The sample's lines (without their line ends) and back, with CRLF as in the
// sample.
std::vector<std::string> Lines(const std::string& content) {
  std::vector<std::string> lines;
  size_t begin = 0;
  while (begin <= content.size()) {
    size_t end = content.find('\n', begin);
    if (end == std::string::npos) end = content.size();
    std::string line = content.substr(begin, end - begin);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    lines.push_back(line);
    if (end == content.size()) break;
    begin = end + 1;
  }
  if (!lines.empty() && lines.back().empty()) lines.pop_back();
  return lines;
}

std::string Join(const std::vector<std::string>& lines) {
  std::string out;
  for (const std::string& line : lines) out += line + "\r\n";
  return out;
}

std::string Replace(std::string s,
                    const std::string& from,
                    const std::string& to,
                    bool all = false) {
  size_t at = s.find(from);
  if (at == std::string::npos)
    return s + "<<replace target not found: " + from + ">>";
  do {
    s.replace(at, from.size(), to);
    at = all ? s.find(from, at + to.size()) : std::string::npos;
  } while (at != std::string::npos);
  return s;
}

struct Case {
  std::string name;
  MeasurementFormat format;
  std::string content;
  std::string place;    // FilePlace::ToString() expected
  std::string message;  // a part of the message
  Flank flank = Flank::kRight;
  GearData gear = SampleGear();
};

std::vector<Case> MalformedCorpus() {
  const std::string mka = ReadSample("sample_topography.mka");
  const std::vector<std::string> lines = Lines(mka);
  auto with_line =
      [&](int number, const std::string& text) {  // 1-based, BOM kept on line 1
        std::vector<std::string> l = lines;
        l[number - 1] = text;
        return Join(l);
      };
  auto edit_line =
      [&](int number, const std::string& from, const std::string& to) {
        return with_line(number, Replace(lines[number - 1], from, to));
      };
  auto without_line = [&](int number) {
    std::vector<std::string> l = lines;
    l.erase(l.begin() + (number - 1));
    return Join(l);
  };
  auto inserted = [&](int number,
                      const std::string& text) {  // becomes line `number`
    std::vector<std::string> l = lines;
    l.insert(l.begin() + (number - 1), text);
    return Join(l);
  };
  const auto K = MeasurementFormat::kMka;
  const auto G = MeasurementFormat::kGde;
  std::vector<Case> cases = {
      {"mka_empty", K, "", "file:line 1", "HEADER KS.MK.FILE"},
      {"mka_value_file",
       K,
       with_line(1, "HEADER KS.MW.FILE"),
       "file:line 1",
       "value file"},
      {"mka_wrong_first_line",
       K,
       with_line(1, "HEADER KS.XX.FILE"),
       "file:line 1",
       "first line"},
      {"mka_utf16",
       K,
       std::string("\xFF\xFEH\0E\0", 6),
       "file:line 1",
       "UTF-16"},
      {"mka_nul_byte",
       K,
       edit_line(20, "20.0000", std::string("20.0\0", 5)),
       "file:line 20",
       "control character"},
      {"mka_c1_byte",
       K,
       edit_line(10, "FILTER", "FILT\x85R"),
       "file:line 10",
       "neither UTF-8 nor Latin-1"},
      {"mka_decimal_comma_value",
       K,
       edit_line(41, "-16.458", "-16,458"),
       "file:line 41",
       "decimal comma"},
      {"mka_nan_value",
       K,
       edit_line(42, "-11.056", "nan"),
       "file:line 42",
       "not a finite number"},
      {"mka_inf_value",
       K,
       edit_line(42, "-11.056", "-inf"),
       "file:line 42",
       "not a finite number"},
      {"mka_overflow_value",
       K,
       edit_line(42, "-11.056", "1e999"),
       "file:line 42",
       "out of range"},
      {"mka_word_value",
       K,
       edit_line(43, "-8.550", "x8.550"),
       "file:line 43",
       "is not a number"},
      {"mka_garbage_in_values",
       K,
       edit_line(43, "-8.550", "-8.5a0"),
       "file:line 43",
       "is not a number"},
      {"mka_huge_deviation",
       K,
       edit_line(43, "-8.550", "-85500.0"),
       "file:line 43",
       "no deviation"},
      {"mka_repeated_code",
       K,
       inserted(19, lines[17]),
       "file:line 19",
       "code 21 repeated"},
      {"mka_decimal_comma_header",
       K,
       edit_line(18, "4.5000", "4,5000"),
       "file:line 18",
       "decimal comma"},
      {"mka_inf_header",
       K,
       edit_line(23, "40.000", "inf"),
       "file:line 23",
       "not a finite number"},
      {"mka_head_without_position",
       K,
       edit_line(40, "/ z= 3.000", ""),
       "file:line 40",
       "trace head"},
      {"mka_head_unknown_flank",
       K,
       edit_line(40, "rechts", "mitte"),
       "file:line 40",
       "rechts' or '<k> links"},
      {"mka_head_unknown_kind",
       K,
       edit_line(40, "Profil:1", "Teilung:1"),
       "file:line 40",
       "'Profil:<k>'"},
      {"mka_head_tooth_zero",
       K,
       edit_line(40, "Zahn-Nr.: 1", "Zahn-Nr.: 0"),
       "file:line 40",
       "tooth number"},
      {"mka_head_comma_position",
       K,
       edit_line(40, "z= 3.000", "z= 3,000"),
       "file:line 40",
       "decimal comma"},
      {"mka_fewer_values",
       K,
       without_line(44),
       "file:line 44",
       "only 36 values"},
      {"mka_more_values",
       K,
       edit_line(40, "48 Werte", "47 Werte"),
       "file:line 44",
       "more values than the 47 Werte"},
      {"mka_one_value",
       K,
       edit_line(40, "48 Werte", "1 Werte"),
       "file:line 40",
       "at least 2"},
      {"mka_huge_count",
       K,
       edit_line(40, "48 Werte", "999999999 Werte"),
       "file:line 40",
       "more than 100000"},
      {"mka_fractional_count",
       K,
       edit_line(40, "48 Werte", "4.5 Werte"),
       "file:line 40",
       "not whole"},
      {"mka_missing_code_41", K, without_line(25), "file:line 39", "code 41"},
      {"mka_missing_code_64", K, without_line(34), "file:line 64", "code 64"},
      {"mka_range_wrong_way",
       K,
       edit_line(28, "157.000   157.000", "130.000   130.000"),
       "file:line 28",
       "wrong way"},
      {"mka_range_inside_base_circle",
       K,
       edit_line(25, "140.500   140.500", "130.000   130.000"),
       "file:line 25",
       "inside the base circle"},
      {"mka_helix_inside_base_circle",
       K,
       edit_line(65, "d= 143.000", "d= 120.000"),
       "file:line 65",
       "inside the base circle"},
      {"mka_module_differs",
       K,
       edit_line(18, "4.5000", "5.0000"),
       "file:line 18",
       "code 21 (m_n) is 5 mm in the file"},
      {"mka_teeth_differ",
       K,
       edit_line(19, "31", "33"),
       "file:line 19",
       "code 22 (z) is 33"},
      {"mka_face_width_differs",
       K,
       edit_line(23, "40.000", "45.000"),
       "file:line 23",
       "code 26 (b) is 45 mm"},
      {"mka_values_before_a_trace",
       K,
       with_line(39, "  1.000  2.000"),
       "file:line 39",
       "values before any trace head"},
      {"mka_unknown_line",
       K,
       with_line(39, "Zahnweite: 52.3"),
       "file:line 39",
       "line not understood"},
      {"mka_truncated",
       K,
       Join(std::vector<std::string>(lines.begin(), lines.begin() + 42)),
       "file:line 43",
       "end of file after 24 values"},
      {"mka_undefined_marker_bad",
       K,
       edit_line(9, "-2147483.648", "-2147483,648"),
       "file:line 9",
       "decimal comma"},
      {"mka_header_only",
       K,
       Join(std::vector<std::string>(lines.begin(), lines.begin() + 39)),
       "file",
       "no trace"},
      {"mka_no_left_flank_of_tooth",
       K,
       Replace(mka, " links ", " rechts ", true),
       "file:line 85",
       "same position"},
  };
  const std::string gde = ReadSample("sample_topography.gde.xml");
  const std::string net =
      "/GDE/GEAR_DATA/INSPECTION/MEASUREMENT_RESULTS/TOPOGRAPHY[1]";
  const std::string geometry = "/GDE/GEAR_DATA/GEOMETRY/BASIC_GEOMETRY/";
  std::string deep = "<GDE>";
  for (int i = 0; i < 100; ++i) deep += "<a>";
  std::vector<Case> gde_cases = {
      {"gde_empty", G, "", "file:line 1", "no root element"},
      {"gde_not_xml",
       G,
       "HEADER KS.MK.FILE\r\n",
       "file:line 1",
       "not well-formed"},
      {"gde_truncated",
       G,
       gde.substr(0, gde.size() / 2),
       "file:line 65",
       "not closed"},
      {"gde_wrong_root",
       G,
       Replace(Replace(gde, "<GDE ", "<GEAR "), "</GDE>", "</GEAR>"),
       "/GEAR",
       "expected <GDE>"},
      {"gde_doctype",
       G,
       Replace(gde, "<GDE ", "<!DOCTYPE GDE [<!ENTITY a \"aaaa\">]><GDE "),
       "file:line 7",
       "DOCTYPE"},
      {"gde_unknown_entity",
       G,
       Replace(gde, "GL-31-45-R", "&a;"),
       "file:line 10",
       "unknown entity"},
      {"gde_end_tag_mismatch",
       G,
       Replace(gde, "</IDENTIFICATION>", "</IDENTIFICATIONS>"),
       "file:line 12",
       "does not match"},
      {"gde_too_deep", G, deep, "file:line 1", "deeper than 64"},
      {"gde_decimal_comma_dev",
       G,
       Replace(gde, "dev=\"-3.999\"", "dev=\"-3,999\""),
       net + "/P[25]/@dev",
       "decimal comma"},
      {"gde_nan_dev",
       G,
       Replace(gde, "dev=\"-10.550\"", "dev=\"NaN\""),
       net + "/P[3]/@dev",
       "not a finite number"},
      {"gde_word_d",
       G,
       Replace(gde, "<P d=\"141.000\" z=\"5.600\"", "<P d=\"abc\" z=\"5.600\""),
       net + "/P[2]/@d",
       "not a number"},
      {"gde_missing_dev",
       G,
       Replace(gde, " dev=\"-10.550\"", ""),
       net + "/P[3]",
       "without dev"},
      {"gde_net_not_full",
       G,
       Replace(gde, "<P d=\"156.000\" z=\"38.000\" dev=\"-4.035\"/>", ""),
       net,
       "net not full"},
      {"gde_duplicate_point",
       G,
       Replace(
           gde, "<P d=\"141.000\" z=\"5.600\"", "<P d=\"141.000\" z=\"2.000\""),
       net + "/P[2]",
       "duplicate point"},
      {"gde_rows_disagree",
       G,
       Replace(gde, "rows=\"7\"", "rows=\"8\""),
       net + "/@rows",
       "8 rows declared"},
      {"gde_unknown_length_unit",
       G,
       Replace(gde, "length_unit=\"mm\"", "length_unit=\"furlong\""),
       net + "/@length_unit",
       "unknown unit"},
      {"gde_unknown_module_unit",
       G,
       Replace(gde,
               "<normal_module unit=\"mm\">",
               "<normal_module unit=\"cubit\">"),
       geometry + "normal_module/@unit",
       "unknown unit"},
      {"gde_decimal_comma_module",
       G,
       Replace(gde, ">4.5<", ">4,5<"),
       geometry + "normal_module",
       "decimal comma"},
      {"gde_teeth_differ",
       G,
       Replace(gde, ">31<", ">33<"),
       geometry + "number_of_teeth",
       "is 33 in the file"},
      {"gde_repeated_element",
       G,
       Replace(gde,
               "<number_of_teeth>31</number_of_teeth>",
               "<number_of_teeth>31</number_of_teeth><number_of_teeth>31</"
               "number_of_teeth>"),
       geometry + "number_of_teeth[2]",
       "repeated"},
      {"gde_unknown_flank",
       G,
       Replace(
           gde, "flank=\"right\" length_unit", "flank=\"middle\" length_unit"),
       net + "/@flank",
       "unknown flank"},
      {"gde_unknown_datum_face",
       G,
       Replace(gde, ">x_negative<", ">up<"),
       geometry + "datum_face",
       "unknown datum face"},
      {"gde_range_wrong_way",
       G,
       Replace(gde,
               "from=\"140.243\" to=\"156.217\"",
               "from=\"156.217\" to=\"140.243\""),
       "/GDE/GEAR_DATA/INSPECTION/MEASURING_CONDITIONS/"
       "profile_evaluation_range",
       "wrong way"},
      {"gde_inside_base_circle",
       G,
       Replace(gde, "d=\"141.000\"", "d=\"130.000\"", true),
       net,
       "inside the base circle"},
      {"gde_no_net",
       G,
       Replace(gde, "<TOPOGRAPHY tooth", "<TOPOGRAPHY kind=\"target\" tooth"),
       "/GDE/GEAR_DATA/INSPECTION/MEASUREMENT_RESULTS",
       "no TOPOGRAPHY net of kind 'measured'"},
      {"gde_stray_element_in_net",
       G,
       Replace(gde,
               "<P d=\"141.000\" z=\"5.600\"",
               "<Q/><P d=\"141.000\" z=\"5.600\""),
       net + "/Q",
       "unexpected element"},
  };
  cases.insert(cases.end(), gde_cases.begin(), gde_cases.end());
  Case left{"gde_no_left_flank", G, gde, "file", "no trace of the left flank"};
  left.flank = Flank::kLeft;
  cases.push_back(left);
  return cases;
}

TEST(MalformedFiles, EveryRefusalNamesItsPlace) {
  const std::vector<Case> cases = MalformedCorpus();
  ASSERT_GE(cases.size(), 30u);
  int located = 0;
  for (const Case& c : cases) {
    MeasurementImportOptions options;
    options.format = c.format;
    options.flank = c.flank;
    const MeasurementImportResult r =
        ImportMeasurementFile(options, c.gear, c.content);
    EXPECT_FALSE(r.ok) << c.name;
    EXPECT_FALSE(r.error.too_large) << c.name;
    EXPECT_EQ(r.error.place.ToString(), c.place)
        << c.name << ": " << r.error.ToString();
    EXPECT_NE(r.error.message.find(c.message), std::string::npos)
        << c.name << ": " << r.error.ToString();
    if (r.error.place.ToString() != "file") ++located;
  }
  EXPECT_GE(located, 60);
  std::printf(
      "%zu malformed files refused, %d with a file line or element path\n",
      cases.size(),
      located);
}

TEST(MalformedFiles, TheUploadLimit) {
  std::string big = ReadSample("sample_topography.mka");
  big.append(kMaxMeasurementFileBytes, ' ');
  MeasurementImportOptions options;
  const MeasurementImportResult r =
      ImportMeasurementFile(options, SampleGear(), big);
  EXPECT_FALSE(r.ok);
  EXPECT_TRUE(r.error.too_large);
}

// Truncation at every 97th byte and single byte flips: refused or accepted,
// never a crash.
TEST(MalformedFiles, TruncationsAndByteFlipsNeverCrash) {
  for (const auto& [format, name] :
       {std::make_pair(MeasurementFormat::kMka, "sample_topography.mka"),
        std::make_pair(MeasurementFormat::kGde, "sample_topography.gde.xml")}) {
    const std::string sample = ReadSample(name);
    MeasurementImportOptions options;
    options.format = format;
    int refused = 0;
    for (size_t n = 0; n < sample.size(); n += 97) {
      const MeasurementImportResult r =
          ImportMeasurementFile(options, SampleGear(), sample.substr(0, n));
      if (!r.ok) {
        ++refused;
        EXPECT_FALSE(r.error.message.empty());
      }
    }
    EXPECT_GT(refused, 0);
    for (size_t at = 0; at < sample.size(); at += 131) {
      std::string flipped = sample;
      flipped[at] = static_cast<char>(flipped[at] ^ 0x5A);
      const MeasurementImportResult r =
          ImportMeasurementFile(options, SampleGear(), flipped);
      if (!r.ok) {
        EXPECT_FALSE(r.error.message.empty()) << name << " flipped at " << at;
      }
    }
  }
}

}  // namespace
}  // namespace gearloop
