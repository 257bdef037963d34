// clients/cli/csv_grid.h: deviation grids (rows x columns, 5 x 9 by default)
// read from and written to CSV, the file format measuring machines and
// spreadsheets exchange. No engine, no JSON: the command-line client turns a
// CsvGrid into the API's "deviations_um" array of rows.
//
//   CsvGrid grid;
//   CsvGridError error;
//   if (!ParseCsvGrid(text, CsvGridOptions{}, &grid, &error)) {
//     std::cerr << "measure.csv:" << error.ToString() << "\n";   // "line 4,
//     column 7: ..."
//   }
//   std::string csv = FormatCsvGrid(grid, /*header=*/true);
//
// The format (clients/FORMATS.md):
//   - one line per profile row, first data line = grid row 0 (root side), last
//   = tip side;
//     cells separated by commas, ordered along the lead from x < 0 to x > 0 (as
//     the API);
//   - optionally one header line first: a line none of whose cells is a number
//   (e.g.
//     "L1,L2,...,L9"); it is skipped;
//   - an empty cell or "null" (any case) is a point the measuring machine did
//   not deliver;
//   - values in micrometres, positive = material left on; "nan"/"inf" are
//   refused;
//   - blank lines and lines starting with '#' are ignored; CRLF line ends, a
//   UTF-8 byte order
//     mark, spaces around cells and double quotes around a cell are accepted.
// Line and column numbers in errors are 1-based and count the file's own lines
// and cells.
#ifndef GEARLOOP_CLIENTS_CLI_CSV_GRID_H_
#define GEARLOOP_CLIENTS_CLI_CSV_GRID_H_

#include <optional>
#include <string>
#include <vector>

namespace gearloop {

// A grid of optional values in row-major order (row 0 = root side, column 0 = x
// < 0).
struct CsvGrid {
  int rows = 0;
  int columns = 0;
  // rows * columns entries; std::nullopt = missing point.
  std::vector<std::optional<double>> values;

  const std::optional<double>& at(int row, int column) const {
    return values[row * columns + column];
  }
  int NumMissing() const;
};

struct CsvGridOptions {
  // Expected shape; MODEL.md §4's default grid is 5 profile rows x 9 lead
  // columns.
  int rows = 5;
  int columns = 9;
  // Accept a missing point (empty cell or "null"). When false a missing point
  // is an error, as for a target grid, which must be complete.
  bool allow_missing = true;
};

// Where and what went wrong in a CSV file. line/column are 1-based; 0 when not
// about one.
struct CsvGridError {
  int line = 0;
  int column = 0;
  std::string message;

  // "line 4, column 7: 'x1' is not a number" / "line 6: 8 cells, expected 9".
  std::string ToString() const;
};

// Parses `text` as a rows x columns grid. Returns false and fills `error` on
// the first problem.
bool ParseCsvGrid(const std::string& text,
                  const CsvGridOptions& options,
                  CsvGrid* grid,
                  CsvGridError* error);

// Writes `grid` as CSV, one line per row (row 0 first), missing points as empty
// cells, numbers in their shortest round-trip form. With `header`, a first line
// "L1,...,Ln" names the lead columns. Ends with a newline.
std::string FormatCsvGrid(const CsvGrid& grid, bool header);

}  // namespace gearloop

#endif  // GEARLOOP_CLIENTS_CLI_CSV_GRID_H_
