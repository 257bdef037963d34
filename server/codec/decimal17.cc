#include "server/codec/decimal17.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>

namespace gearloop {
namespace {

// 5^k for k = 0..20: x·10^k = m·5^k·2^(k+e) for x = m·2^e.
constexpr uint64_t kPow5[21] = {1ull,
                                5ull,
                                25ull,
                                125ull,
                                625ull,
                                3125ull,
                                15625ull,
                                78125ull,
                                390625ull,
                                1953125ull,
                                9765625ull,
                                48828125ull,
                                244140625ull,
                                1220703125ull,
                                6103515625ull,
                                30517578125ull,
                                152587890625ull,
                                762939453125ull,
                                3814697265625ull,
                                19073486328125ull,
                                95367431640625ull};
// 10^j for j = -4..15 (the decimal exponents of the fast path and one above).
constexpr double kPow10[20] = {1e-4, 1e-3, 1e-2, 1e-1, 1e0,  1e1, 1e2,
                               1e3,  1e4,  1e5,  1e6,  1e7,  1e8, 1e9,
                               1e10, 1e11, 1e12, 1e13, 1e14, 1e15};
constexpr char kDigitPairs[] =
    "00010203040506070809101112131415161718192021222324252627282930313233343536"
    "37383940414243444546474849505152535455565758596061626364656667686970717273"
    "7475767778798081828384858687888990919293949596979899";
constexpr uint64_t k1e8 = 100000000ull;
constexpr uint64_t k1e16 = 10000000000000000ull;
constexpr uint64_t k1e17 = 100000000000000000ull;
// The fast path's decimal exponents: 1e-4 <= |x| < 1e15, where "%.17g" writes
// the fixed form and x·10^(16 - exponent) fits 128 bits exactly.
constexpr int kMinExponent = -4;
constexpr int kMaxExponent = 14;

// The 8 digits of c < 10^8 at d.
void WriteEightDigits(uint32_t c, char* d) {
  const uint32_t high = c / 10000, low = c % 10000;
  std::memcpy(d, kDigitPairs + 2 * (high / 100), 2);
  std::memcpy(d + 2, kDigitPairs + 2 * (high % 100), 2);
  std::memcpy(d + 4, kDigitPairs + 2 * (low / 100), 2);
  std::memcpy(d + 6, kDigitPairs + 2 * (low % 100), 2);
}

// round(m·2^e·10^k), half to even, exactly: m·5^k < 2^100 for k <= 20, and
// 2^(k+e) shifts it.
uint64_t RoundScaled(uint64_t m, int e, int k) {
  using u128 = unsigned __int128;
  const u128 v = static_cast<u128>(m) * kPow5[k];
  const int shift = -(k + e);
  if (shift <= 0) return static_cast<uint64_t>(v << -shift);
  if (shift >= 128) return 0;
  uint64_t n = static_cast<uint64_t>(v >> shift);
  const u128 rest = v & ((static_cast<u128>(1) << shift) - 1);
  const u128 half = static_cast<u128>(1) << (shift - 1);
  if (rest > half || (rest == half && (n & 1) != 0)) ++n;
  return n;
}

// The 17 digits n (10^16 <= n < 10^17) of a value of decimal exponent
// `exponent` (-4..14) in fixed notation, trailing zeros dropped, ".0" kept.
// Copies of fixed length only (a variable one is a call to memmove): `out`
// has kDecimal17MaxChars of room.
char* WriteFixed(uint64_t n, int exponent, bool negative, char* out) {
  char d[17 + 16];  // the digits, then room for the fixed-length copies
  const uint64_t high = n / k1e8;
  const uint32_t top = static_cast<uint32_t>(high / k1e8);
  d[0] = static_cast<char>('0' + top);
  WriteEightDigits(static_cast<uint32_t>(high - top * k1e8), d + 1);
  WriteEightDigits(static_cast<uint32_t>(n - high * k1e8), d + 9);
  int last = 16;
  while (last > 0 && d[last] == '0') --last;
  if (negative) *out++ = '-';
  if (exponent >= 0) {
    std::memcpy(out, d, 16);
    out[exponent + 1] = '.';
    if (last <= exponent) {
      out[exponent + 2] = '0';
      return out + exponent + 3;
    }
    std::memcpy(out + exponent + 2, d + exponent + 1, 16);
    return out + last + 2;
  }
  std::memcpy(out, "0.000", 5);
  std::memcpy(out + 1 - exponent, d, 17);
  return out + 2 - exponent + last;
}

// The fast path: a normal double with 1e-4 <= |x| (rounded) < 1e15; false,
// nothing written, otherwise.
bool WriteFast(double x, char** out) {
  uint64_t bits = 0;
  std::memcpy(&bits, &x, sizeof(bits));
  const int biased = static_cast<int>((bits >> 52) & 0x7ff);
  if (biased == 0 || biased == 0x7ff) return false;
  const uint64_t m = (bits & ((uint64_t{1} << 52) - 1)) | (uint64_t{1} << 52);
  const int e = biased - 1075;  // x = ±m·2^e, 2^52 <= m < 2^53
  // floor(log10 |x|) is floor((e + 52)·log10 2) or one more.
  int exponent = ((e + 52) * 315653) >> 20;
  if (exponent >= kMinExponent - 1 && exponent <= kMaxExponent &&
      std::fabs(x) >= kPow10[exponent + 1 - kMinExponent])
    ++exponent;
  // |x| within an ulp of a power of ten: the rounded digits decide.
  for (int attempt = 0; attempt < 3; ++attempt) {
    if (exponent < kMinExponent || exponent > kMaxExponent) return false;
    const uint64_t n = RoundScaled(m, e, 16 - exponent);
    if (n >= k1e17) {
      ++exponent;
    } else if (n < k1e16) {
      --exponent;
    } else {
      *out = WriteFixed(n, exponent, (bits >> 63) != 0, *out);
      return true;
    }
  }
  return false;
}

}  // namespace

char* WriteDecimal17(double x, char* out) {
  if (!std::isfinite(x)) {
    std::memcpy(out, "null", 4);
    return out + 4;
  }
  if (WriteFast(x, &out)) return out;
  const std::to_chars_result r = std::to_chars(
      out, out + kDecimal17MaxChars - 2, x, std::chars_format::general, 17);
  const bool integral = std::find_if(out, r.ptr, [](char c) {
                          return c == '.' || c == 'e';
                        }) == r.ptr;
  out = r.ptr;
  if (integral) {
    *out++ = '.';
    *out++ = '0';
  }
  return out;
}

}  // namespace gearloop
