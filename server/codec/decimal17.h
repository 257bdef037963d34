// server/codec/decimal17.h: a double as JSON text with 17 significant digits
// (SPLIT_BEVEL.md §8), fast enough for answers of a million numbers (the
// split-bevel trajectory's 40 000 points, BENCHMARKS.md "Split bevel
// trajectory"). Pure text, no JSON library.
//
//   char buffer[kDecimal17MaxChars];
//   const char* end = WriteDecimal17(value_mm, buffer);
//
// The text is the one std::to_chars(first, last, x, std::chars_format::general,
// 17) writes (printf's "%.17g": the exact binary value rounded half to even to
// 17 significant digits, trailing zeros dropped, an exponent below 1e-4 and
// from 1e17 on), with ".0" appended when it has neither a point nor an
// exponent (35 -> "35.0", so a float stays a float for JSON readers), and
// "null" for a value that is not finite (as nlohmann-json writes NaN). Any 17
// significant digits read back to the same double, so the text is exact.
#ifndef GEARLOOP_SERVER_CODEC_DECIMAL17_H_
#define GEARLOOP_SERVER_CODEC_DECIMAL17_H_

#include <cstddef>

namespace gearloop {

// Room WriteDecimal17 needs at `out` (its texts are at most 26 characters,
// "-1.2345678901234567e-308.0" would be the longest; the fixed-length copies
// that make it fast use more room than they keep).
constexpr size_t kDecimal17MaxChars = 48;

// Writes `x` at `out` (kDecimal17MaxChars free) and returns the end.
char* WriteDecimal17(double x, char* out);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_CODEC_DECIMAL17_H_
