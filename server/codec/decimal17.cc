#include "server/codec/decimal17.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>

// The digits are put together in words whose lowest byte is first in memory.
#if !defined(__BYTE_ORDER__) || __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "server/codec/decimal17.cc writes digits as little-endian words"
#endif

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
constexpr uint64_t k1e8 = 100000000ull;
constexpr uint64_t k1e16 = 10000000000000000ull;
constexpr uint64_t k1e17 = 100000000000000000ull;
// The fast path's decimal exponents: 1e-4 <= |x| < 1e15, where "%.17g" writes
// the fixed form and x·10^(16 - exponent) fits 128 bits exactly.
constexpr int kMinExponent = -4;
constexpr int kMaxExponent = 14;

// floor(log10 |x|) by the binary exponent b = floor(log2 |x|) for
// -14 <= b <= 49: the guess floor(b·log10 2) and the power of ten above it.
constexpr int kMinBinaryExponent = -14;
constexpr int kBinaryExponents = 64;
struct ExponentTable {
  int guess[kBinaryExponents] = {};
  double next_power[kBinaryExponents] = {};
};
constexpr ExponentTable MakeExponentTable() {
  ExponentTable table;
  for (int i = 0; i < kBinaryExponents; ++i) {
    // 315653 / 2^20 is log10 2 within 3e-7: floor exact for |b| <= 64 here
    // (and the loop below mends a guess one off).
    const int guess = ((i + kMinBinaryExponent) * 315653) >> 20;
    table.guess[i] = guess;
    table.next_power[i] = kPow10[guess + 1 - kMinExponent];
  }
  return table;
}
constexpr ExponentTable kExponentTable = MakeExponentTable();

// The 8 decimal digits of c < 10^8 as the bytes of a word, first digit in
// the lowest byte (the first in memory on a little-endian machine), each 0-9
// (not yet a character): split into two 4-digit lanes, then 2-digit, then
// 1-digit ones, by multiplications that divide exactly in these ranges
// (x·10486 >> 20 = x / 100 for x < 10^4, y·103 >> 10 = y / 10 for y < 100).
uint64_t EightDigitValues(uint32_t c) {
  uint64_t v = (c / 10000) | (static_cast<uint64_t>(c % 10000) << 32);
  uint64_t t = ((v * 10486) >> 20) & 0x0000007F0000007Full;
  v = t | ((v - 100 * t) << 16);
  t = ((v * 103) >> 10) & 0x000F000F000F000Full;
  return t | ((v - 10 * t) << 8);
}

constexpr uint64_t kZeros = 0x3030303030303030ull;  // "00000000"

// The bytes 0..k-1 of a word (k = 0..7).
uint64_t LowBytes(int k) { return (uint64_t{1} << (8 * k)) - 1; }

// The digits of `w` (8 characters) with '.' put before its byte `k` (0..7)
// and the bytes from k on moved one up (the last falls out): 9 characters
// become "w[0..k-1].w[k..6]".
uint64_t WithPoint(uint64_t w, int k) {
  return (w & LowBytes(k)) | (uint64_t{'.'} << (8 * k)) |
         ((w << 8) & (~LowBytes(k) << 8));
}

void Store(char* p, uint64_t w) { std::memcpy(p, &w, sizeof(w)); }

// round(m·2^e·10^k), half to even, exactly, for 1 <= -(k + e) <= 63 (the
// fast path's range: 1e-4 <= x < 1e15 gives 1..47): m·5^k < 2^100 for k <= 20,
// the bits shifted out all in its low word.
uint64_t RoundScaled(uint64_t m, int e, int k) {
  using u128 = unsigned __int128;
  const u128 v = static_cast<u128>(m) * kPow5[k];
  const int shift = -(k + e);
  const uint64_t n = static_cast<uint64_t>(v >> shift);
  const uint64_t rest = static_cast<uint64_t>(v) & ((uint64_t{1} << shift) - 1);
  const uint64_t half = uint64_t{1} << (shift - 1);
  return n + ((rest > half) | ((rest == half) & (n & 1)));
}

// The 17 digits n (10^16 <= n < 10^17) of a value of decimal exponent
// `exponent` (-4..14) in fixed notation, trailing zeros dropped, ".0" kept.
// The digits stay in registers and go out as whole words (a load of bytes
// just stored one by one would wait for them): `out` has kDecimal17MaxChars
// of room, of which up to 26 are written and fewer kept.
char* WriteFixed(uint64_t n, int exponent, bool negative, char* out) {
  const uint64_t high = n / k1e8;
  const uint32_t top = static_cast<uint32_t>(high / k1e8);
  const uint64_t mid =
      EightDigitValues(static_cast<uint32_t>(high - top * k1e8));
  const uint64_t low = EightDigitValues(static_cast<uint32_t>(n - high * k1e8));
  // The index (0..16) of the last digit that is not 0.
  int last = 0;
  if (low != 0)
    last = 16 - __builtin_clzll(low) / 8;
  else if (mid != 0)
    last = 8 - __builtin_clzll(mid) / 8;
  const char first = static_cast<char>('0' + top);
  const uint64_t a = mid + kZeros;  // digits 1..8
  const uint64_t b = low + kZeros;  // digits 9..16
  // Branch-free: the signs of vector components follow no pattern.
  *out = '-';
  out += negative ? 1 : 0;
  if (exponent < 0) {                   // "0.", -exponent - 1 zeros, the digits
    Store(out, 0x3030303030302e30ull);  // "0.000000"
    char* digits = out + 1 - exponent;
    *digits = first;
    Store(digits + 1, a);
    Store(digits + 9, b);
    return digits + last + 1;
  }
  // exponent + 1 digits, '.', the others; at least one digit after the point.
  const int point = exponent + 1;
  out[0] = first;
  if (point <= 8) {
    Store(out + 1, WithPoint(a, point - 1));
    out[9] = static_cast<char>(a >> 56);
    Store(out + 10, b);
  } else {
    Store(out + 1, a);
    Store(out + 9, WithPoint(b, point - 9));
    out[17] = static_cast<char>(b >> 56);
  }
  return out + (last > point ? last : point) + 2;
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
  // floor(log10 |x|) is floor((e + 52)·log10 2) or one more: both from a
  // table by the binary exponent, for 2^-14 <= |x| < 2^50 (the rest is
  // outside the fast path's 1e-4..1e15 anyway).
  const int binary = e + 52 - kMinBinaryExponent;
  if (binary < 0 || binary >= kBinaryExponents) return false;
  int exponent = kExponentTable.guess[binary] +
                 (std::fabs(x) >= kExponentTable.next_power[binary] ? 1 : 0);
  // |x| within an ulp of a power of ten: the rounded digits decide.
  for (int attempt = 0; attempt < 3; ++attempt) {
    const int k = 16 - exponent;
    if (exponent < kMinExponent || exponent > kMaxExponent || k + e > -1 ||
        k + e < -63)
      return false;
    const uint64_t n = RoundScaled(m, e, k);
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
