// tests/fuzz/csv_grid_fuzzer.cc: libFuzzer target for the CSV grid import of
// the command-line client (clients/cli/csv_grid.h, issue 7). The first two
// bytes choose the expected shape and whether missing points are allowed; the
// rest is the file's text.
//
// Besides the sanitizers' own findings it checks the parser's contract: a
// refusal names a line (or says why not) and renders; an accepted grid has the
// expected shape, only finite values, no missing point when they are not
// allowed, and survives FormatCsvGrid -> ParseCsvGrid unchanged (FORMATS.md
// promises the shortest round-trip form), with and without the header line.
//
//   build-fuzz/tests/fuzz/csv_grid_fuzzer -max_total_time=60
//   tests/fuzz/corpus/csv_grid
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "clients/cli/csv_grid.h"
#include "tests/fuzz/fuzz_check.h"

namespace {

using gearloop::fuzz::Check;

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  gearloop::CsvGridOptions options;
  if (size >= 2) {
    // Byte 0: rows 1..8 (low 3 bits) and allow_missing (bit 3); byte 1:
    // columns 1..16. The seeds (make_corpus.py) carry the two bytes of their
    // grid's shape: "\x0c\x08" is 5 x 9.
    options.rows = 1 + (data[0] & 0x07);
    options.allow_missing = (data[0] & 0x08) != 0;
    options.columns = 1 + (data[1] & 0x0f);
    data += 2;
    size -= 2;
  }
  const std::string text(reinterpret_cast<const char*>(data), size);
  gearloop::CsvGrid grid;
  gearloop::CsvGridError error;
  if (!gearloop::ParseCsvGrid(text, options, &grid, &error)) {
    Check(!error.message.empty(), "a refusal says why");
    Check(error.line >= 0 && error.column >= 0, "1-based positions or 0");
    Check(!error.ToString().empty(), "the error renders");
    return 0;
  }
  Check(grid.rows == options.rows && grid.columns == options.columns,
        "the expected shape");
  Check(grid.values.size() == static_cast<size_t>(grid.rows) * grid.columns,
        "rows x columns values");
  for (const auto& value : grid.values) {
    if (value) {
      Check(std::isfinite(*value), "only finite values");
    } else {
      Check(options.allow_missing, "no missing point when not allowed");
    }
  }
  for (bool header : {false, true}) {
    gearloop::CsvGrid again;
    Check(gearloop::ParseCsvGrid(
              gearloop::FormatCsvGrid(grid, header), options, &again, &error),
          "a formatted grid parses");
    Check(again.rows == grid.rows && again.columns == grid.columns &&
              again.values == grid.values,
          "the round trip keeps every value");
  }
  return 0;
}
