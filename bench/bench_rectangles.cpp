// Exact rectangle form factors (formfactors/aligned_rectangles.h) on the unit cube, 32 × 32
// patches per wall (N = 6,144): the constructor (classification + tables), and area_factor over
// all N(N−1)/2 = 18,871,296 unordered pairs (one call serves F_ij and F_ji), OpenMP over rows
// with 1 and 2 threads. Pairs on one wall (coplanar) return 0 from the plane test; 15.7 M pairs
// have a nonzero factor. "rotated": the same cube under an arbitrary rotation (coordinate
// differences no longer deduplicate, larger corner tables); "direct": max_table_bytes = 0.
// Run: build/bench/bench_rectangles --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>
#include <omp.h>

#include <memory>
#include <vector>

#include "../tests/scene_builders.h"
#include "formfactors/aligned_rectangles.h"
#include "patching/patching.h"

namespace pm = photometria;

namespace {

pm::PatchMesh cube(int n, bool rotated) {
  pm::Scene s = builders::unit_cube();
  if (rotated) {
    const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, pm::Vec3(1, 2, 3).normalized()).toRotationMatrix();
    for (pm::Vec3& v : s.vertices) v = R * v;
  }
  return pm::subdivide(s, {(1.0 + 1e-9) / n, 0.0});
}

const pm::PatchMesh& mesh(bool rotated) {
  static const pm::PatchMesh aligned = cube(32, false), turned = cube(32, true);
  return rotated ? turned : aligned;
}

void construct(benchmark::State& state, bool rotated) {
  const pm::PatchMesh& m = mesh(rotated);
  omp_set_num_threads(static_cast<int>(state.range(0)));
  std::size_t bytes = 0;
  for (auto _ : state) {
    pm::AlignedRectangles ar(m);
    bytes = ar.table_bytes();
    benchmark::DoNotOptimize(bytes);
  }
  state.counters["table_MB"] = bytes / 1e6;
  omp_set_num_threads(omp_get_num_procs());
}

// All unordered pairs i < j, rows over threads; rows_step > 1 samples every rows_step-th row.
void pairs(benchmark::State& state, bool rotated, std::size_t budget, int rows_step) {
  const pm::PatchMesh& m = mesh(rotated);
  const pm::AlignedRectangles ar(m, budget);
  const int n = m.size(), threads = static_cast<int>(state.range(0));
  std::vector<double> row_sum(n);
  std::vector<long long> row_count(n);
  for (auto _ : state) {
#pragma omp parallel for schedule(dynamic, 8) num_threads(threads)
    for (int i = 0; i < n; i += rows_step) {
      double s = 0.0;
      for (int j = i + 1; j < n; ++j) s += ar.area_factor(i, j);
      row_sum[i] = s;
      row_count[i] = n - 1 - i;
    }
    benchmark::DoNotOptimize(row_sum.data());
    benchmark::ClobberMemory();
  }
  long long count = 0;
  double total = 0.0;
  for (int i = 0; i < n; i += rows_step) {
    count += row_count[i];
    total += row_sum[i];
  }
  state.SetItemsProcessed(state.iterations() * count);
  state.counters["pairs"] = static_cast<double>(count);
  state.counters["sum_AF"] = total;  // Σ_{i<j} A_i F_ij = 3 for the whole cube (rows sum to A_i)
  state.counters["table_MB"] = ar.table_bytes() / 1e6;
}

}  // namespace

BENCHMARK_CAPTURE(construct, aligned, false)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(construct, rotated, true)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);
BENCHMARK_CAPTURE(pairs, aligned, false, std::size_t(256) << 20, 1)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(pairs, rotated, true, std::size_t(256) << 20, 1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(1);
BENCHMARK_CAPTURE(pairs, direct_every_64th_row, false, std::size_t(0), 64)
    ->Arg(1)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

BENCHMARK_MAIN();
