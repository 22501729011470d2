// The shortest decimal that reads back as the same double, written fast.
//
// write_shortest(p, v) writes exactly the characters std::to_chars(p, p + 32, v) writes (the
// shortest round-trip form, C++17 [charconv.to.chars]: fixed or scientific, whichever is
// shorter, fixed on a tie; at most 17 significant digits), about a quarter faster. Why: the
// view-factor matrix of a 6,144-face room is 37.7 M such numbers, and formatting them was the
// largest cost of writing it as CSV (docs/performance.md "Writing the matrix").
//
// How: the shortest significand and exponent come from Dragonbox (Jeon, "Dragonbox: A New
// Floating-Point Binary-to-Decimal Conversion Algorithm", 2020; the implementation in the fmt
// library, libfmt-dev, `fmt::detail::dragonbox::to_decimal`), which is as exact as the Ryu
// algorithm libstdc++'s to_chars uses (Adams, "Ryū: fast float-to-string conversion", PLDI
// 2018): both give the shortest digits that round-trip, the closest to the value when several
// do. The digits are then placed two at a time. +0 is written as "0" at once (a closed room's
// faces that share a plane see each other with factor 0). Other values outside (0, 1e15) (-0,
// negatives, infinities, NaN, and large integers, which to_chars prints exactly rather than
// shortest) go to std::to_chars itself. tests/test_io_shortest_decimal.cpp compares the two on
// millions of values across the whole range.
#pragma once

namespace photometria {

// At most this many characters are written.
inline constexpr int kShortestDecimalMaxChars = 24;

// Writes v at p (no terminating NUL) and returns the end of what was written.
char* write_shortest(char* p, double v);

}  // namespace photometria
