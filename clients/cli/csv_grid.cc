// clients/cli/csv_grid.cc: the CSV grid reader and writer. Lenient where files
// from measuring machines and spreadsheets differ harmlessly (line ends, a byte
// order mark, quotes, spaces, a header line), strict about anything that would
// change a number: every refusal names the line and the cell, because the
// person fixing the file opens it in an editor, not in a debugger.
#include "clients/cli/csv_grid.h"

#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <sstream>
#include <system_error>

namespace gearloop {
namespace {

struct Cell {
  std::string text;  // trimmed, unquoted
  bool quoted = false;
};

std::string Trim(const std::string& s) {
  size_t begin = 0;
  size_t end = s.size();
  while (begin < end && std::isspace(static_cast<unsigned char>(s[begin])))
    ++begin;
  while (end > begin && std::isspace(static_cast<unsigned char>(s[end - 1])))
    --end;
  return s.substr(begin, end - begin);
}

std::string Lower(std::string s) {
  for (char& c : s)
    c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// Splits one line into cells. A cell may be wrapped in double quotes ("" inside
// is a quote); returns false with the 1-based cell number of an unterminated
// quote.
bool SplitCells(const std::string& line,
                std::vector<Cell>* cells,
                int* bad_cell) {
  cells->clear();
  size_t i = 0;
  while (true) {
    Cell cell;
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    if (i < line.size() && line[i] == '"') {
      cell.quoted = true;
      ++i;
      bool closed = false;
      while (i < line.size()) {
        if (line[i] == '"') {
          if (i + 1 < line.size() && line[i + 1] == '"') {
            cell.text += '"';
            i += 2;
            continue;
          }
          ++i;
          closed = true;
          break;
        }
        cell.text += line[i++];
      }
      if (!closed) {
        *bad_cell = static_cast<int>(cells->size()) + 1;
        return false;
      }
      // Anything between the closing quote and the comma must be blank.
      std::string rest;
      while (i < line.size() && line[i] != ',') rest += line[i++];
      if (!Trim(rest).empty()) {
        *bad_cell = static_cast<int>(cells->size()) + 1;
        return false;
      }
      cell.text = Trim(cell.text);
    } else {
      std::string raw;
      while (i < line.size() && line[i] != ',') raw += line[i++];
      cell.text = Trim(raw);
    }
    cells->push_back(cell);
    if (i >= line.size()) break;
    ++i;  // the comma
  }
  return true;
}

bool IsMissing(const Cell& cell) {
  return cell.text.empty() || Lower(cell.text) == "null";
}

// Parses the whole cell as a decimal number (strtod: accepts "1.5", "-2e-3",
// "+4"). *finite is false for "nan"/"inf" spellings, which strtod also takes.
bool ParseNumber(const std::string& text, double* value, bool* finite) {
  if (text.empty()) return false;
  const char* begin = text.c_str();
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(begin, &end);
  if (end != begin + text.size()) return false;
  *finite = std::isfinite(v) && errno != ERANGE;
  *value = v;
  return true;
}

bool LooksLikeHeader(const std::vector<Cell>& cells) {
  bool any_text = false;
  for (const Cell& cell : cells) {
    if (IsMissing(cell)) continue;
    double v = 0.0;
    bool finite = false;
    if (ParseNumber(cell.text, &v, &finite)) return false;
    any_text = true;
  }
  return any_text;
}

bool Fail(int line,
          int column,
          const std::string& message,
          CsvGridError* error) {
  error->line = line;
  error->column = column;
  error->message = message;
  return false;
}

// Checks the shape of one data row: the rows seen so far and its cell count.
bool CheckDataRow(const std::vector<Cell>& cells,
                  int line_number,
                  int data_rows,
                  const CsvGridOptions& options,
                  CsvGridError* error) {
  if (data_rows >= options.rows) {
    return Fail(line_number,
                0,
                "more than " + std::to_string(options.rows) +
                    " data rows (a grid has " + std::to_string(options.rows) +
                    " profile rows)",
                error);
  }
  if (static_cast<int>(cells.size()) != options.columns) {
    return Fail(line_number,
                0,
                std::to_string(cells.size()) + " cells, expected " +
                    std::to_string(options.columns) + " (one per lead column)",
                error);
  }
  return true;
}

// Reads cell `column` (1-based) of a data row into *values.
bool ReadCell(const Cell& cell,
              int line_number,
              int column,
              const CsvGridOptions& options,
              std::vector<std::optional<double>>* values,
              CsvGridError* error) {
  if (IsMissing(cell)) {
    if (!options.allow_missing) {
      return Fail(line_number,
                  column,
                  "missing value (this grid must be complete)",
                  error);
    }
    values->emplace_back(std::nullopt);
    return true;
  }
  double v = 0.0;
  bool finite = false;
  if (!ParseNumber(cell.text, &v, &finite)) {
    return Fail(line_number,
                column,
                "'" + cell.text +
                    "' is not a number (write a value in um, or leave the "
                    "cell empty " +
                    "or \"null\" for a missing point)",
                error);
  }
  if (!finite) {
    return Fail(line_number,
                column,
                "'" + cell.text + "' is not a finite number",
                error);
  }
  values->emplace_back(v);
  return true;
}

}  // namespace

int CsvGrid::NumMissing() const {
  int missing = 0;
  for (const auto& v : values) {
    if (!v) ++missing;
  }
  return missing;
}

std::string CsvGridError::ToString() const {
  std::ostringstream out;
  if (line > 0) {
    out << "line " << line;
    if (column > 0) out << ", column " << column;
    out << ": ";
  }
  out << message;
  return out.str();
}

bool ParseCsvGrid(const std::string& text,
                  const CsvGridOptions& options,
                  CsvGrid* grid,
                  CsvGridError* error) {
  *error = CsvGridError{};
  if (options.rows <= 0 || options.columns <= 0) {
    return Fail(
        0,
        0,
        "the expected grid shape must have at least one row and one column",
        error);
  }
  CsvGrid result;
  result.rows = options.rows;
  result.columns = options.columns;
  result.values.reserve(static_cast<size_t>(options.rows) * options.columns);

  std::string body = text;
  if (body.compare(0, 3, "\xEF\xBB\xBF") == 0)
    body.erase(0, 3);  // UTF-8 byte order mark

  std::istringstream in(body);
  std::string line;
  int line_number = 0;
  int data_rows = 0;
  bool seen_content = false;
  std::vector<Cell> cells;
  while (std::getline(in, line)) {
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const std::string trimmed = Trim(line);
    if (trimmed.empty() || trimmed[0] == '#') continue;

    int bad_cell = 0;
    if (!SplitCells(line, &cells, &bad_cell)) {
      return Fail(line_number,
                  bad_cell,
                  "unterminated or misplaced double quote",
                  error);
    }
    // Some spreadsheets end every line with a separator: one trailing empty
    // cell too many is harmless; any other count mismatch is not.
    if (static_cast<int>(cells.size()) == options.columns + 1 &&
        cells.back().text.empty() && !cells.back().quoted) {
      cells.pop_back();
    }
    const bool first = !seen_content;
    seen_content = true;
    if (first && LooksLikeHeader(cells)) continue;

    if (!CheckDataRow(cells, line_number, data_rows, options, error))
      return false;
    for (int c = 0; c < options.columns; ++c) {
      if (!ReadCell(
              cells[c], line_number, c + 1, options, &result.values, error))
        return false;
    }
    ++data_rows;
  }
  if (data_rows != options.rows) {
    return Fail(line_number + 1,
                0,
                "end of file after " + std::to_string(data_rows) +
                    " data rows, expected " + std::to_string(options.rows),
                error);
  }
  *grid = std::move(result);
  return true;
}

std::string FormatCsvGrid(const CsvGrid& grid, bool header) {
  std::string out;
  if (header) {
    for (int c = 0; c < grid.columns; ++c) {
      if (c > 0) out += ',';
      out += "L" + std::to_string(c + 1);
    }
    out += '\n';
  }
  char buffer[64];
  for (int r = 0; r < grid.rows; ++r) {
    // A row of empty cells alone would be a blank line, which the parsers skip
    // (a one-column grid found by tests/fuzz/csv_grid_fuzzer; a whole row the
    // shaving work gear does not generate): such a row spells its missing
    // points "null".
    bool row_missing = true;
    for (int c = 0; c < grid.columns; ++c) {
      const size_t index = static_cast<size_t>(r) * grid.columns + c;
      if (index < grid.values.size() && grid.values[index]) row_missing = false;
    }
    for (int c = 0; c < grid.columns; ++c) {
      if (c > 0) out += ',';
      const size_t index = static_cast<size_t>(r) * grid.columns + c;
      if (index < grid.values.size() && grid.values[index]) {
        const std::to_chars_result written =
            std::to_chars(buffer, buffer + sizeof(buffer), *grid.values[index]);
        if (written.ec == std::errc()) out.append(buffer, written.ptr);
      } else if (row_missing) {
        out += "null";
      }
    }
    out += '\n';
  }
  return out;
}

}  // namespace gearloop
