// Visibility throughput: rays per second per core and the share of pairs culled by shafts, in the
// form-factor fill of meshes/room_with_table.obj at three patch sizes (ray and exact modes) and
// of the empty convex meshes/furnace_cube.obj (every shaft empty: 100% culled). One thread.
// And the setup of exact visibility on a many-face scene: the occluders merged from the ground of
// 3 × 3 city blocks meshed into n × n quads (a plane with holes, split into convex pieces).
#include <benchmark/benchmark.h>
#include <omp.h>

#include <chrono>
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

// Ground of 3 × 3 blocks: an n × n grid of unit quads (n a multiple of 10) in the plane z = 0
// without the 3 × 3 building footprints, squares of n/5 cells apart by streets of n/10 cells.
pm::Scene city_ground(int n) {
  pm::Scene s;
  s.source = "city ground";
  s.materials = {pm::Material{}};
  s.groups = {"ground"};
  const int street = n / 10, block = 2 * street;
  auto in_building = [&](int i) { return i % (street + block) >= street && i < n - street; };
  std::vector<int> id(size_t(n + 1) * size_t(n + 1), -1);
  auto vertex = [&](int i, int j) {
    int& v = id[size_t(j) * size_t(n + 1) + size_t(i)];
    if (v < 0) {
      v = static_cast<int>(s.vertices.size());
      s.vertices.emplace_back(i, j, 0.0);
    }
    return v;
  };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i)
      if (!(in_building(i) && in_building(j)))
        s.faces.push_back({{vertex(i, j), vertex(i + 1, j), vertex(i + 1, j + 1), vertex(i, j + 1)},
                           0,
                           0,
                           static_cast<int>(s.faces.size())});
  return s;
}

void BM_CityGroundOccluders(benchmark::State& state) {
  const pm::Scene s = city_ground(static_cast<int>(state.range(0)));
  int occluders = 0;
  double seconds = 0.0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    occluders = pm::ShaftCuller(s).occluder_count();
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  state.counters["faces"] = double(s.faces.size());
  state.counters["occluders"] = occluders;
  state.counters["us_per_face"] = seconds * 1e6 / (double(s.faces.size()) * double(state.iterations()));
}

}  // namespace

// Patch sizes (max edge, cm): 100, 70, 50 on the 4 × 3 × 2.5 m room.
BENCHMARK(BM_RoomWithTableRays)->Arg(100)->Arg(70)->Arg(50)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_RoomWithTableExact)->Arg(100)->Arg(70)->Arg(50)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_FurnaceCubeRays)->Arg(10)->Unit(benchmark::kMillisecond)->Iterations(1);
// Ground grids of 100², 200² and 400² cells: 6,400, 25,600 and 102,400 quads.
BENCHMARK(BM_CityGroundOccluders)->Arg(100)->Arg(200)->Arg(400)->Unit(benchmark::kMillisecond)->Iterations(1);

BENCHMARK_MAIN();
