// io/shortest_decimal.h: the same characters as std::to_chars, everywhere.
#include <gtest/gtest.h>

#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <string>

#include "io/shortest_decimal.h"

namespace photometria {
namespace {

std::string ours(double v) {
  char buf[kShortestDecimalMaxChars + 8];
  return std::string(buf, write_shortest(buf, v));
}

std::string standard(double v) {
  char buf[64];
  return std::string(buf, std::to_chars(buf, buf + sizeof buf, v).ptr);
}

// Counts the values where the two differ, reporting the first few.
struct Comparison {
  long long checked = 0, differ = 0;
  void check(double v) {
    ++checked;
    const std::string a = ours(v), b = standard(v);
    if (a == b) return;
    if (++differ <= 5) ADD_FAILURE() << "write_shortest gave " << a << ", std::to_chars " << b;
  }
};

TEST(ShortestDecimal, EdgesOfEveryForm) {
  Comparison c;
  for (double v : {0.0,
                   -0.0,
                   1.0,
                   -1.0,
                   0.1,
                   0.5,
                   1e-7,
                   1e-5,
                   1e-4,
                   1e-3,
                   123456.0,
                   1e15,
                   9.99999999999999e14,
                   1e16,
                   1e21,
                   1e22,
                   1e23,
                   5e-324,
                   2.2250738585072014e-308,
                   1.7976931308623157e308,
                   0.2141948,
                   0.30000000000000004,
                   123456789012345.6,
                   1234567.0,
                   12345678.0,
                   100.0,
                   1e2,
                   1e-10,
                   std::numeric_limits<double>::infinity(),
                   -std::numeric_limits<double>::infinity(),
                   std::numeric_limits<double>::quiet_NaN()})
    c.check(v);
  // Every power of ten and its neighbours: where the fixed and scientific lengths cross.
  for (int k = -330; k <= 310; ++k) {
    const double p = std::pow(10.0, k);
    c.check(p);
    c.check(std::nextafter(p, 0.0));
    c.check(std::nextafter(p, 1e308));
    for (int m : {2, 5, 12, 123, 1234567}) c.check(m * p);
  }
  EXPECT_EQ(c.differ, 0) << "of " << c.checked;
}

TEST(ShortestDecimal, MillionsOfValuesAcrossTheRange) {
  Comparison c;
  std::mt19937_64 random(20261206);
  std::uniform_real_distribution<double> factor(0.0, 0.003);  // view factors of a fine mesh
  std::uniform_int_distribution<int> digits(1, 17), shift(-20, 20);
  for (int k = 0; k < 1000000; ++k) {
    uint64_t bits = random();  // any double: every exponent, both signs, NaNs and infinities
    double any;
    std::memcpy(&any, &bits, sizeof any);
    c.check(any);
    c.check(factor(random));
    // Short decimals (few significant digits) at every scale near 1.
    const double short_decimal =
        double(random() % uint64_t(std::pow(10.0, digits(random)))) * std::pow(10.0, shift(random));
    c.check(short_decimal);
  }
  EXPECT_EQ(c.differ, 0) << "of " << c.checked;
}

}  // namespace
}  // namespace photometria
