// server/codec/decimal17.h: the split-bevel answer's numbers (SPLIT_BEVEL.md
// §8, 17 significant digits) written without std::to_chars on the fast path
// must be exactly std::to_chars(general, 17)'s text (with ".0" on an integral
// value), and read back to the same double.
#include "server/codec/decimal17.h"

#include <gtest/gtest.h>

#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <random>
#include <string>

namespace gearloop {
namespace {

std::string Written(double x) {
  char buffer[kDecimal17MaxChars];
  return std::string(buffer, WriteDecimal17(x, buffer));
}

// The reference: std::to_chars' 17 significant digits, ".0" when integral.
std::string Reference(double x) {
  char buffer[64];
  const std::to_chars_result r = std::to_chars(
      buffer, buffer + sizeof(buffer), x, std::chars_format::general, 17);
  std::string text(buffer, r.ptr);
  if (text.find_first_of(".e") == std::string::npos) text += ".0";
  return text;
}

void ExpectExact(double x) {
  const std::string text = Written(x);
  ASSERT_EQ(text, Reference(x)) << "bits of x: " << std::hexfloat << x;
  EXPECT_EQ(std::strtod(text.c_str(), nullptr), x) << text;
}

TEST(Decimal17, WritesWhatToCharsWritesForTheAnswersMagnitudes) {
  // Millimetres, degrees and unit-vector components of a trajectory, and
  // every decade from 1e-6 to 1e17 around the fast path's ends (1e-4, 1e15).
  std::mt19937_64 rng(14);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::uniform_int_distribution<int> decade(-6, 17);
  for (int i = 0; i < 400000; ++i) {
    ExpectExact(unit(rng) * std::pow(10.0, decade(rng)));
    ExpectExact(unit(rng));
    ExpectExact(600.0 + 400.0 * unit(rng));
  }
  // Random bit patterns of every exponent (subnormals, huge values).
  for (int i = 0; i < 200000; ++i) {
    const uint64_t bits = rng();
    double x = 0.0;
    std::memcpy(&x, &bits, sizeof(x));
    if (std::isfinite(x)) ExpectExact(x);
  }
}

TEST(Decimal17, RoundsHalfToEvenAndCarriesAcrossAPowerOfTen) {
  // 100000000000000.125 has 18 digits: its 17th (2, even) stays, and
  // ...0.375 rounds its 7 up to 8 (round half to even on the exact value).
  EXPECT_EQ(Written(100000000000000.125), "100000000000000.12");
  EXPECT_EQ(Written(100000000000000.375), "100000000000000.38");
  ExpectExact(100000000000000.125);
  ExpectExact(100000000000000.375);
  ExpectExact(100000000000000.625);
  // Values whose digits round up to the next power of ten, and the powers
  // themselves with their neighbours.
  for (int k = -5; k <= 16; ++k) {
    const double p = std::pow(10.0, k);
    ExpectExact(p);
    ExpectExact(-p);
    ExpectExact(std::nextafter(p, 0.0));
    ExpectExact(std::nextafter(p, 2.0 * p));
    ExpectExact(std::nextafter(std::nextafter(p, 0.0), 0.0));
  }
  ExpectExact(999999999999999.9);
  ExpectExact(0.099999999999999999);
}

TEST(Decimal17, KeepsFloatsFloatsAndWritesNullForNonFinite) {
  EXPECT_EQ(Written(35.0), "35.0");
  EXPECT_EQ(Written(-2.5), "-2.5");
  EXPECT_EQ(Written(0.1), "0.10000000000000001");
  EXPECT_EQ(Written(0.00012), "0.00012");
  EXPECT_EQ(Written(1e-5), "1.0000000000000001e-05");
  EXPECT_EQ(Written(0.0), "0.0");
  EXPECT_EQ(Written(-0.0), "-0.0");
  EXPECT_EQ(Written(1e300), "1.0000000000000001e+300");
  EXPECT_EQ(Written(std::nan("")), "null");
  EXPECT_EQ(Written(std::numeric_limits<double>::infinity()), "null");
  EXPECT_EQ(Written(-std::numeric_limits<double>::infinity()), "null");
  ExpectExact(std::numeric_limits<double>::denorm_min());
  ExpectExact(std::numeric_limits<double>::max());
}

}  // namespace
}  // namespace gearloop
