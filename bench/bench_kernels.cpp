// Kernel throughput: point-to-quad evaluations per second (one thread), per formulation.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "kernels/kernels.h"
#include "kernels/lambert_batch.h"

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
const pm::Vec3 kTriangle[3] = {{0.2, 0.2, 1.0}, {0.5, 0.8, 1.0}, {0.8, 0.2, 1.0}};               // faces down

// The plain textbook form for comparison only: Heitz 2017 eq. (1) (kernels/lambert.h) with acos of
// normalized vectors, no clipping, no one-sided test (valid for these unclipped configurations).
double plain_acos_lambert(const pm::Receiver& r, const pm::Vec3* v, int n) {
  double sum = 0.0;
  for (int i = 0; i < n; ++i) {
    const pm::Vec3 a = (v[i] - r.point).normalized(), b = (v[(i + 1) % n] - r.point).normalized();
    const pm::Vec3 c = a.cross(b);
    sum += std::acos(std::clamp(a.dot(b), -1.0, 1.0)) * r.normal.dot(c) / c.norm();
  }
  return -sum / (2 * M_PI);
}

void run(benchmark::State& state, pm::Kernel kernel, bool tilted, int corners) {
  const auto recv = receivers(tilted);
  const pm::Vec3* poly = corners == 4 ? kQuad : kTriangle;
  double sum = 0.0;
  for (auto _ : state)
    for (const auto& r : recv) sum += pm::point_form_factor(kernel, r, poly, corners);
  benchmark::DoNotOptimize(sum);
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(recv.size()));
}
}  // namespace

void run_plain(benchmark::State& state, int corners) {
  const auto recv = receivers(false);
  const pm::Vec3* poly = corners == 4 ? kQuad : kTriangle;
  double sum = 0.0;
  for (auto _ : state)
    for (const auto& r : recv) sum += plain_acos_lambert(r, poly, corners);
  benchmark::DoNotOptimize(sum);
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(recv.size()));
}

// The batched kernel (lambert_batch.h) on exactly the configurations of `run`: one receiver at the
// origin (same normal) against the polygon translated by −p for each of the 1,024 receivers, i.e.
// a row of 1,024 sources with the same relative geometry, evaluated in one call. Items are
// point-to-polygon evaluations, as above. The clipped variant mostly takes the scalar fallback.
void run_batch(benchmark::State& state, bool tilted, int corners) {
  const auto recv = receivers(tilted);
  const pm::Vec3* poly = corners == 4 ? kQuad : kTriangle;
  pm::PolygonBatch batch;
  for (const auto& r : recv) {
    pm::Vec3 v[4];
    for (int i = 0; i < corners; ++i) v[i] = poly[i] - r.point;
    batch.push_back(v, corners);
  }
  const pm::Receiver r0{pm::Vec3::Zero(), recv.front().normal};
  std::vector<double> out(recv.size());
  double sum = 0.0;
  int scalar_calls = 0;
  for (auto _ : state) {
    scalar_calls = pm::lambert_form_factors(r0, batch, out.data());
    sum += out[17];
    benchmark::ClobberMemory();
  }
  benchmark::DoNotOptimize(sum);
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(recv.size()));
  state.counters["scalar_share"] = static_cast<double>(scalar_calls) / static_cast<double>(recv.size());
  state.SetLabel(pm::lambert_batch_isa());
}

// A receiver on the floor of a room against a ceiling meshed 64 × 64 (4,096 quads, the shape of a
// fill row over one wall): every edge inside the grid belongs to two quads, so with shared edges
// (PolygonBatch::share_edges) the kernel evaluates 8,320 edge terms instead of 16,384.
void run_grid(benchmark::State& state, bool shared) {
  constexpr int n = 64;
  pm::PolygonBatch batch;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const double x0 = 4.0 * i / n, x1 = 4.0 * (i + 1) / n, y0 = 4.0 * j / n, y1 = 4.0 * (j + 1) / n;
      const pm::Vec3 v[4] = {{x0, y0, 2.5}, {x0, y1, 2.5}, {x1, y1, 2.5}, {x1, y0, 2.5}};  // faces down
      batch.push_back(v, 4);
    }
  if (shared) batch.share_edges();
  std::vector<pm::Receiver> recv;
  for (int k = 0; k < 16; ++k) recv.push_back({pm::Vec3(0.13 + 0.24 * k, 1.7 - 0.1 * k, 0.0), pm::Vec3::UnitZ()});
  std::vector<double> out(size_t(batch.size));
  double sum = 0.0;
  for (auto _ : state)
    for (const pm::Receiver& r : recv) {
      pm::lambert_form_factors(r, batch, out.data());
      sum += out[17];
      benchmark::ClobberMemory();
    }
  benchmark::DoNotOptimize(sum);
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(recv.size()) * batch.size);
  state.SetLabel(pm::lambert_batch_isa());
}

BENCHMARK_CAPTURE(run_plain, plain_acos_quad, 4);
BENCHMARK_CAPTURE(run_plain, plain_acos_triangle, 3);
BENCHMARK_CAPTURE(run, lambert_quad, pm::Kernel::Lambert, false, 4);
BENCHMARK_CAPTURE(run, lambert_triangle, pm::Kernel::Lambert, false, 3);
BENCHMARK_CAPTURE(run, lambert_quad_clipped, pm::Kernel::Lambert, true, 4);
BENCHMARK_CAPTURE(run_batch, lambert_batch_quad, false, 4);
BENCHMARK_CAPTURE(run_batch, lambert_batch_triangle, false, 3);
BENCHMARK_CAPTURE(run_batch, lambert_batch_quad_clipped, true, 4);
BENCHMARK_CAPTURE(run_grid, lambert_batch_grid, false);
BENCHMARK_CAPTURE(run_grid, lambert_batch_grid_shared_edges, true);
BENCHMARK_CAPTURE(run, iwanicki_quad, pm::Kernel::Iwanicki, false, 4);
BENCHMARK_CAPTURE(run, iwanicki_triangle, pm::Kernel::Iwanicki, false, 3);
BENCHMARK_CAPTURE(run, stark_vertex_quad, pm::Kernel::StarkVertex, false, 4);
BENCHMARK_CAPTURE(run, stark_vertex_triangle, pm::Kernel::StarkVertex, false, 3);
BENCHMARK_CAPTURE(run, stark_image_quad, pm::Kernel::StarkImage, false, 4);
BENCHMARK_CAPTURE(run, stark_image_triangle, pm::Kernel::StarkImage, false, 3);

// The approximations (Lawlor 2007, kernels/approximations.h), for their cost next to the exact
// kernels' (their error is in docs/kernels.md).
BENCHMARK_CAPTURE(run, point_source_quad, pm::Kernel::PointSource, false, 4);
BENCHMARK_CAPTURE(run, point_source_triangle, pm::Kernel::PointSource, false, 3);
BENCHMARK_CAPTURE(run, tampieri_quad, pm::Kernel::Tampieri, false, 4);
BENCHMARK_CAPTURE(run, tampieri_triangle, pm::Kernel::Tampieri, false, 3);
BENCHMARK_CAPTURE(run, cross_product_quad, pm::Kernel::CrossProduct, false, 4);
BENCHMARK_CAPTURE(run, cross_product_triangle, pm::Kernel::CrossProduct, false, 3);
BENCHMARK_MAIN();
