// Visibility throughput: rays per second per core and the share of pairs culled by shafts, in the
// form-factor fill of meshes/room_with_table.obj at three patch sizes (ray and exact modes) and
// of the empty convex meshes/furnace_cube.obj (every shaft empty: 100% culled). One thread.
#include <benchmark/benchmark.h>
#include <omp.h>

#include <filesystem>
#include <map>

#include "formfactors/formfactors.h"
#include "visibility/visibility.h"

namespace pm = photometria;

namespace {

// The shipped meshes, found from this source file's location (bench/ is next to meshes/).
std::string meshes_dir() { return std::filesystem::path(__FILE__).parent_path().parent_path().string() + "/meshes/"; }

const pm::Scene& scene(const std::string& name) {
  static std::map<std::string, pm::Scene> cache;
  auto it = cache.find(name);
  if (it == cache.end()) it = cache.emplace(name, pm::load_scene(meshes_dir() + name)).first;
  return it->second;
}

void fill(benchmark::State& state, const std::string& name, pm::VisibilityMethod method) {
  omp_set_num_threads(1);
  const pm::Scene& s = scene(name);
  const double max_edge = state.range(0) / 100.0;
  const pm::PatchMesh mesh = pm::subdivide(s, {max_edge, 0.0});
  const pm::Visibility vis(s, method);
  pm::FillOptions opt;
  opt.visibility = &vis;
  pm::FillStats stats;
  for (auto _ : state) {
    stats = {};
    benchmark::DoNotOptimize(pm::fill_form_factors(mesh, opt, stats));
  }
  state.counters["patches"] = mesh.size();
  state.counters["pairs_tested"] = double(stats.pairs_tested);
  state.counters["culled_share"] = stats.pairs_tested ? double(stats.pairs_culled) / stats.pairs_tested : 1.0;
  state.counters["rays_per_s"] =
      benchmark::Counter(double(stats.rays_cast) * state.iterations(), benchmark::Counter::kIsRate);
  state.counters["pairs_per_s"] =
      benchmark::Counter(double(stats.pairs_tested) * state.iterations(), benchmark::Counter::kIsRate);
}

void BM_RoomWithTableRays(benchmark::State& state) { fill(state, "room_with_table.obj", pm::VisibilityMethod::Rays); }
void BM_RoomWithTableExact(benchmark::State& state) { fill(state, "room_with_table.obj", pm::VisibilityMethod::Exact); }
void BM_FurnaceCubeRays(benchmark::State& state) { fill(state, "furnace_cube.obj", pm::VisibilityMethod::Rays); }

}  // namespace

// Patch sizes (max edge, cm): 100, 70, 50 on the 4 × 3 × 2.5 m room.
BENCHMARK(BM_RoomWithTableRays)->Arg(100)->Arg(70)->Arg(50)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_RoomWithTableExact)->Arg(100)->Arg(70)->Arg(50)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_FurnaceCubeRays)->Arg(10)->Unit(benchmark::kMillisecond)->Iterations(1);

BENCHMARK_MAIN();
