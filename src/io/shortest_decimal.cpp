// Shortest round-trip decimals (shortest_decimal.h).
#include "io/shortest_decimal.h"

#include <fmt/format.h>

#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>

namespace photometria {

namespace {

constexpr char kDigitPairs[] =
    "00010203040506070809101112131415161718192021222324252627282930313233343536373839404142434445464748495051525354"
    "555657585960616263646566676869707172737475767778798081828384858687888990919293949596979899";

int decimal_digits(uint64_t s) {
  int n = 1;
  while (s >= 10000) s /= 10000, n += 4;
  while (s >= 10) s /= 10, ++n;
  return n;
}

// The 8 digits of v < 10^8, leading zeros included.
void put_eight(char* p, uint32_t v) {
  const uint32_t high = v / 10000, low = v % 10000;
  std::memcpy(p, kDigitPairs + 2 * (high / 100), 2);
  std::memcpy(p + 2, kDigitPairs + 2 * (high % 100), 2);
  std::memcpy(p + 4, kDigitPairs + 2 * (low / 100), 2);
  std::memcpy(p + 6, kDigitPairs + 2 * (low % 100), 2);
}

// The n decimal digits of s (s < 10^n, n <= 18), at p.
void put_digits(char* p, uint64_t s, int n) {
  char all[18];  // s as 18 digits with leading zeros
  const uint64_t above = s / 100000000;
  std::memcpy(all, kDigitPairs + 2 * (above / 100000000), 2);
  put_eight(all + 2, uint32_t(above % 100000000));
  put_eight(all + 10, uint32_t(s % 100000000));
  std::memcpy(p, all + 18 - n, size_t(n));
}

}  // namespace

char* write_shortest(char* p, double v) {
  if (v == 0.0 && !std::signbit(v)) {  // a sixth of the meshed cube's view factors (faces sharing a plane)
    *p = '0';
    return p + 1;
  }
  if (!(v > 0.0 && v < 1e15)) return std::to_chars(p, p + kShortestDecimalMaxChars, v).ptr;
  // v = s · 10^e with s the shortest round-trip significand, n digits (at most 17).
  const auto decimal = fmt::detail::dragonbox::to_decimal(v);
  const uint64_t s = decimal.significand;
  const int e = decimal.exponent, n = decimal_digits(s);
  // The two forms' lengths, as to_chars chooses between them ("d.ddde±XX" against fixed).
  const int scientific_exponent = e + n - 1;
  const int magnitude = scientific_exponent < 0 ? -scientific_exponent : scientific_exponent;
  const int scientific_length = n + (n > 1 ? 1 : 0) + 2 + (magnitude >= 100 ? 3 : 2);
  const int fixed_length = e >= 0 ? n + e : (n + e > 0 ? n + 1 : 2 - e);
  char digits[18];
  put_digits(digits, s, n);
  if (fixed_length <= scientific_length) {
    if (e >= 0) {  // ddd000
      std::memcpy(p, digits, size_t(n));
      std::memset(p + n, '0', size_t(e));
      return p + n + e;
    }
    if (n + e > 0) {  // dd.ddd
      const int whole = n + e;
      std::memcpy(p, digits, size_t(whole));
      p[whole] = '.';
      std::memcpy(p + whole + 1, digits + whole, size_t(n - whole));
      return p + n + 1;
    }
    p[0] = '0';  // 0.000ddd
    p[1] = '.';
    const int zeros = -e - n;
    std::memset(p + 2, '0', size_t(zeros));
    std::memcpy(p + 2 + zeros, digits, size_t(n));
    return p + 2 - e;
  }
  *p++ = digits[0];  // d.ddde±XX
  if (n > 1) {
    *p++ = '.';
    std::memcpy(p, digits + 1, size_t(n - 1));
    p += n - 1;
  }
  *p++ = 'e';
  *p++ = scientific_exponent < 0 ? '-' : '+';
  int rest = magnitude;
  if (rest >= 100) {
    *p++ = char('0' + rest / 100);
    rest %= 100;
  }
  std::memcpy(p, kDigitPairs + 2 * rest, 2);
  return p + 2;
}

}  // namespace photometria
