// tests/clients/csv_grid_test.cc: CSV deviation grids of measuring machines,
// good and bad files (tests/clients/data/), and the round trip through
// FormatCsvGrid.
#include "clients/cli/csv_grid.h"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

namespace gearloop {
namespace {

std::string ReadDataFile(const std::string& name) {
  const std::string path =
      std::string(GEARLOOP_CLIENTS_TEST_DATA_DIR) + "/" + name;
  std::ifstream in(path, std::ios::binary);
  EXPECT_TRUE(in.good()) << "cannot open " << path;
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

CsvGridError ParseExpectingError(const std::string& text,
                                 const CsvGridOptions& options = {}) {
  CsvGrid grid;
  CsvGridError error;
  EXPECT_FALSE(ParseCsvGrid(text, options, &grid, &error))
      << "parsed but should not have:\n"
      << text;
  return error;
}

TEST(ParseCsvGrid, ReadsMeasurementWithHeaderAndMissingCorner) {
  CsvGrid grid;
  CsvGridError error;
  ASSERT_TRUE(ParseCsvGrid(
      ReadDataFile("measurement_header.csv"), CsvGridOptions{}, &grid, &error))
      << error.ToString();
  EXPECT_EQ(grid.rows, 5);
  EXPECT_EQ(grid.columns, 9);
  ASSERT_EQ(grid.values.size(), 45u);
  // First data line is grid row 0 (root side), first cell lead column 0 (x <
  // 0).
  EXPECT_DOUBLE_EQ(*grid.at(0, 0), -1.2);
  EXPECT_DOUBLE_EQ(*grid.at(0, 8), 1.6);
  EXPECT_DOUBLE_EQ(*grid.at(3, 4), 0.5);
  EXPECT_FALSE(
      grid.at(4, 8)
          .has_value());  // "null": the probe did not reach the tip corner
  EXPECT_EQ(grid.NumMissing(), 1);
}

TEST(ParseCsvGrid, ReadsCrlfCommentsQuotesTrailingSeparatorWithoutHeader) {
  CsvGrid grid;
  CsvGridError error;
  ASSERT_TRUE(ParseCsvGrid(ReadDataFile("measurement_crlf_no_header.csv"),
                           CsvGridOptions{},
                           &grid,
                           &error))
      << error.ToString();
  EXPECT_DOUBLE_EQ(*grid.at(0, 0),
                   1.0);  // the first line is data, not a header
  EXPECT_FALSE(grid.at(1, 2).has_value());  // empty cell
  EXPECT_DOUBLE_EQ(*grid.at(1, 8), 9.5);
  EXPECT_DOUBLE_EQ(*grid.at(2, 6), 7.0);    // quoted
  EXPECT_DOUBLE_EQ(*grid.at(3, 0), -0.1);   // exponent
  EXPECT_DOUBLE_EQ(*grid.at(3, 1), 2.0);    // explicit plus sign
  EXPECT_FALSE(grid.at(4, 8).has_value());  // NULL in capitals
  EXPECT_EQ(grid.NumMissing(), 2);
}

TEST(ParseCsvGrid, AcceptsByteOrderMarkAndOtherShapes) {
  CsvGridOptions options;
  options.rows = 2;
  options.columns = 3;
  CsvGrid grid;
  CsvGridError error;
  ASSERT_TRUE(ParseCsvGrid(
      "\xEF\xBB\xBFroot a,b,c\n1,2,3\n 4 , 5 ,6\n", options, &grid, &error))
      << error.ToString();
  EXPECT_DOUBLE_EQ(*grid.at(1, 1), 5.0);
}

TEST(ParseCsvGrid, NamesLineAndColumnOfNonNumber) {
  const CsvGridError error =
      ParseExpectingError(ReadDataFile("bad_not_a_number.csv"));
  EXPECT_EQ(error.line, 4);
  EXPECT_EQ(error.column, 7);
  EXPECT_NE(error.message.find("'1..5' is not a number"), std::string::npos)
      << error.message;
  EXPECT_EQ(error.ToString().rfind("line 4, column 7: ", 0), 0u)
      << error.ToString();
}

TEST(ParseCsvGrid, NamesLineOfShortRow) {
  const CsvGridError error =
      ParseExpectingError(ReadDataFile("bad_short_row.csv"));
  EXPECT_EQ(error.line, 3);
  EXPECT_EQ(error.column, 0);
  EXPECT_NE(error.message.find("8 cells, expected 9"), std::string::npos)
      << error.message;
}

TEST(ParseCsvGrid, RefusesTooFewRowsAtEndOfFile) {
  const CsvGridError error =
      ParseExpectingError(ReadDataFile("bad_too_few_rows.csv"));
  EXPECT_EQ(error.line, 6);  // one past the last line
  EXPECT_NE(error.message.find("4 data rows, expected 5"), std::string::npos)
      << error.message;
}

TEST(ParseCsvGrid, RefusesSixthRow) {
  const CsvGridError error =
      ParseExpectingError(ReadDataFile("bad_too_many_rows.csv"));
  EXPECT_EQ(error.line, 6);
  EXPECT_NE(error.message.find("more than 5 data rows"), std::string::npos)
      << error.message;
}

TEST(ParseCsvGrid, RefusesNotFiniteValue) {
  const CsvGridError error = ParseExpectingError(ReadDataFile("bad_nan.csv"));
  EXPECT_EQ(error.line, 3);
  EXPECT_EQ(error.column, 2);
  EXPECT_NE(error.message.find("not a finite number"), std::string::npos)
      << error.message;
}

TEST(ParseCsvGrid, RefusesMissingPointInCompleteGrid) {
  CsvGridOptions options;
  options.allow_missing = false;
  const CsvGridError error =
      ParseExpectingError(ReadDataFile("measurement_header.csv"), options);
  EXPECT_EQ(error.line, 6);
  EXPECT_EQ(error.column, 9);
}

TEST(ParseCsvGrid, RefusesEmptyFileAndUnterminatedQuote) {
  EXPECT_NE(ParseExpectingError("").message.find("0 data rows"),
            std::string::npos);
  EXPECT_NE(
      ParseExpectingError("# only a comment\n\n").message.find("0 data rows"),
      std::string::npos);
  const CsvGridError quote = ParseExpectingError("1,2,\"3,4,5,6,7,8,9\n");
  EXPECT_EQ(quote.line, 1);
  EXPECT_EQ(quote.column, 3);
}

TEST(ParseCsvGrid, TreatsFirstLineWithANumberAsData) {
  // A typo in the first data line ("1,2,x,...") is data with a bad cell, not a
  // header.
  const CsvGridError error = ParseExpectingError(
      "1,2,x,4,5,6,7,8,9\n1,2,3,4,5,6,7,8,9\n1,2,3,4,5,6,7,8,9\n1,2,3,4,5,6,7,"
      "8,9\n1,2,3,4,5,6,7,8,9\n");
  EXPECT_EQ(error.line, 1);
  EXPECT_EQ(error.column, 3);
}

TEST(FormatCsvGrid, RoundTripsExactlyWithAndWithoutHeader) {
  CsvGrid grid;
  grid.rows = 5;
  grid.columns = 9;
  for (int i = 0; i < 45; ++i) {
    if (i == 8 || i == 36) {
      grid.values.emplace_back(std::nullopt);
    } else {
      grid.values.emplace_back(0.1 * i - 2.0 / 3.0);
    }
  }
  for (const bool header : {true, false}) {
    const std::string text = FormatCsvGrid(grid, header);
    CsvGrid back;
    CsvGridError error;
    ASSERT_TRUE(ParseCsvGrid(text, CsvGridOptions{}, &back, &error))
        << error.ToString() << "\n"
        << text;
    ASSERT_EQ(back.values.size(), grid.values.size());
    for (size_t i = 0; i < grid.values.size(); ++i) {
      EXPECT_EQ(back.values[i], grid.values[i])
          << "entry " << i;  // bit-exact: shortest round trip
    }
  }
  EXPECT_EQ(FormatCsvGrid(grid, true).substr(0, 27),
            "L1,L2,L3,L4,L5,L6,L7,L8,L9\n");
}

// Found by tests/fuzz/csv_grid_fuzzer: a missing point of a one-column grid was
// written as an empty line, which the parser skips as blank.
TEST(FormatCsvGrid, RoundTripsMissingPointOfOneColumnGrid) {
  CsvGridOptions options;
  options.rows = 2;
  options.columns = 1;
  CsvGrid grid;
  CsvGridError error;
  ASSERT_TRUE(ParseCsvGrid("null\n1.5\n", options, &grid, &error))
      << error.ToString();
  for (bool header : {false, true}) {
    CsvGrid again;
    ASSERT_TRUE(
        ParseCsvGrid(FormatCsvGrid(grid, header), options, &again, &error))
        << error.ToString();
    EXPECT_EQ(again.values, grid.values);
  }
}

// A whole row missing (the shaving cutter's row 0, not generated by the work
// gear) was written as ",,": the Python reader skips such a line as blank. It
// is written as nulls and reads back as the same grid.
TEST(FormatCsvGrid, WritesAWholeMissingRowAsNulls) {
  CsvGridOptions options;
  options.rows = 2;
  options.columns = 3;
  CsvGrid grid;
  CsvGridError error;
  ASSERT_TRUE(ParseCsvGrid(",,\n1,2,3\n", options, &grid, &error))
      << error.ToString();
  const std::string text = FormatCsvGrid(grid, /*header=*/false);
  EXPECT_EQ(text, "null,null,null\n1,2,3\n");
  CsvGrid again;
  ASSERT_TRUE(ParseCsvGrid(text, options, &again, &error)) << error.ToString();
  EXPECT_EQ(again.values, grid.values);
}

}  // namespace
}  // namespace gearloop
