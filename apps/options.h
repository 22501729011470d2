// Range checks for numeric command-line options, for CLI11's Option::check(). Every numeric
// option of every subcommand carries one, so that a value out of range (or NaN, or infinite)
// is refused at parse time with one line naming the option and the value, e.g.
//   photometria: --threads: -3 is not an integer in [0, 4096]
#pragma once

#include <CLI/CLI.hpp>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <sstream>
#include <string>

namespace options {

// A finite real number in the interval from `lo` to `hi`; `lo_open` / `hi_open` exclude the ends.
inline CLI::Validator real_in(double lo, double hi, bool lo_open = false, bool hi_open = false) {
  std::ostringstream range;
  range << (lo_open ? "(" : "[") << lo << ", ";
  if (std::isinf(hi)) range << "inf)";
  else range << hi << (hi_open ? ")" : "]");
  const std::string interval = range.str();
  return CLI::Validator(
      [=](std::string& text) -> std::string {
        char* end = nullptr;
        errno = 0;
        const double v = std::strtod(text.c_str(), &end);
        const bool parsed = !text.empty() && end == text.c_str() + text.size() && errno != ERANGE;
        const bool inside = parsed && std::isfinite(v) && (lo_open ? v > lo : v >= lo) && (hi_open ? v < hi : v <= hi);
        if (inside) return {};
        return text + " is not a finite number in " + interval;
      },
      "REAL in " + interval);
}

// An integer from `lo` to `hi`, both included.
inline CLI::Validator integer_in(long long lo, long long hi) {
  const std::string interval = "[" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  return CLI::Validator(
      [=](std::string& text) -> std::string {
        char* end = nullptr;
        errno = 0;
        const long long v = std::strtoll(text.c_str(), &end, 10);
        const bool parsed = !text.empty() && end == text.c_str() + text.size() && errno != ERANGE;
        if (parsed && v >= lo && v <= hi) return {};
        return text + " is not an integer in " + interval;
      },
      "INT in " + interval);
}

// `auto` or an integer from 1 to 2²⁴ (--rays; photometria::parse_ray_count takes it apart).
inline CLI::Validator auto_or_integer_in(long long lo, long long hi) {
  const CLI::Validator integer = integer_in(lo, hi);
  const std::string interval = "[" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  return CLI::Validator(
      [=](std::string& text) -> std::string {
        std::string copy = text;
        if (text == "auto" || integer(copy).empty()) return {};
        return text + " is not auto or an integer in " + interval;
      },
      "auto or INT in " + interval);
}

constexpr double kInf = std::numeric_limits<double>::infinity();

// Thread counts: 0 means every core; more than this many is surely a typo.
constexpr long long kMaxThreads = 4096;

}  // namespace options
