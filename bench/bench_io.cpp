// Output throughput: shortest round-trip decimals per second (one thread), ours against the
// standard library's (io/shortest_decimal.h).
#include <benchmark/benchmark.h>

#include <charconv>
#include <random>
#include <vector>

#include "io/shortest_decimal.h"

namespace {

// View factors of a finely meshed room: most need 16 or 17 significant digits.
std::vector<double> view_factors() {
  std::mt19937_64 random(7);
  std::uniform_real_distribution<double> factor(0.0, 0.003);
  std::vector<double> v(1 << 16);
  for (double& x : v) x = factor(random);
  return v;
}

template <class Write>
void format_all(benchmark::State& state, Write write) {
  const std::vector<double> values = view_factors();
  std::vector<char> text(values.size() * (photometria::kShortestDecimalMaxChars + 1));
  for (auto _ : state) {
    char* p = text.data();
    for (double v : values) {
      p = write(p, v);
      *p++ = ',';
    }
    benchmark::DoNotOptimize(p);
  }
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(values.size()));
}

void BM_ShortestDecimalOurs(benchmark::State& state) { format_all(state, photometria::write_shortest); }
void BM_ShortestDecimalStdToChars(benchmark::State& state) {
  format_all(state,
             [](char* p, double v) { return std::to_chars(p, p + photometria::kShortestDecimalMaxChars, v).ptr; });
}

}  // namespace

BENCHMARK(BM_ShortestDecimalOurs);
BENCHMARK(BM_ShortestDecimalStdToChars);
BENCHMARK_MAIN();
