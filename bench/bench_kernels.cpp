// Kernel throughput: Lambert point-to-quad evaluations per second (one thread).
#include <benchmark/benchmark.h>

#include <random>

#include "kernels/lambert.h"

namespace pm = photometria;

static void BM_LambertPointToQuad(benchmark::State& state) {
  // Receivers scattered on the floor of a unit room, the source a unit quad on the ceiling.
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<pm::Receiver> receivers;
  for (int i = 0; i < 1024; ++i) receivers.push_back({pm::Vec3(u(rng), u(rng), 0.0), pm::Vec3::UnitZ()});
  const pm::Vec3 quad[4] = {{0.2, 0.2, 1.0}, {0.2, 0.8, 1.0}, {0.8, 0.8, 1.0}, {0.8, 0.2, 1.0}};
  double sum = 0.0;
  for (auto _ : state) {
    for (const auto& r : receivers) sum += pm::lambert_form_factor(r, quad, 4);
  }
  benchmark::DoNotOptimize(sum);
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(receivers.size()));
}
BENCHMARK(BM_LambertPointToQuad);

// Half of the receivers see the quad cut by their horizon (clipping path).
static void BM_LambertPointToQuadClipped(benchmark::State& state) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<pm::Receiver> receivers;
  for (int i = 0; i < 1024; ++i) receivers.push_back({pm::Vec3(u(rng), u(rng), 0.5), pm::Vec3::UnitX()});
  const pm::Vec3 quad[4] = {{0.2, 0.2, 1.0}, {0.2, 0.8, 1.0}, {0.8, 0.8, 1.0}, {0.8, 0.2, 1.0}};
  double sum = 0.0;
  for (auto _ : state) {
    for (const auto& r : receivers) sum += pm::lambert_form_factor(r, quad, 4);
  }
  benchmark::DoNotOptimize(sum);
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(receivers.size()));
}
BENCHMARK(BM_LambertPointToQuadClipped);

BENCHMARK_MAIN();
