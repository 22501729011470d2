// Kernel throughput: point-to-quad evaluations per second (one thread), per formulation.
#include <benchmark/benchmark.h>

#include <random>

#include "kernels/kernels.h"

namespace pm = photometria;

namespace {
// Receivers scattered in a unit room; `tilted` receivers face +x so the ceiling quad is cut by
// their horizon (the clipping path).
std::vector<pm::Receiver> receivers(bool tilted) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<pm::Receiver> r;
  for (int i = 0; i < 1024; ++i)
    r.push_back(tilted ? pm::Receiver{pm::Vec3(u(rng), u(rng), 0.5), pm::Vec3::UnitX()}
                       : pm::Receiver{pm::Vec3(u(rng), u(rng), 0.0), pm::Vec3::UnitZ()});
  return r;
}
const pm::Vec3 kQuad[4] = {{0.2, 0.2, 1.0}, {0.2, 0.8, 1.0}, {0.8, 0.8, 1.0}, {0.8, 0.2, 1.0}};  // faces down

void run(benchmark::State& state, pm::Kernel kernel, bool tilted) {
  const auto recv = receivers(tilted);
  double sum = 0.0;
  for (auto _ : state)
    for (const auto& r : recv) sum += pm::point_form_factor(kernel, r, kQuad, 4);
  benchmark::DoNotOptimize(sum);
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(recv.size()));
}
}  // namespace

BENCHMARK_CAPTURE(run, lambert_quad, pm::Kernel::Lambert, false);
BENCHMARK_CAPTURE(run, lambert_quad_clipped, pm::Kernel::Lambert, true);
BENCHMARK_CAPTURE(run, iwanicki_quad, pm::Kernel::Iwanicki, false);
BENCHMARK_CAPTURE(run, stark_vertex_quad, pm::Kernel::StarkVertex, false);
BENCHMARK_CAPTURE(run, stark_image_quad, pm::Kernel::StarkImage, false);

BENCHMARK_MAIN();
