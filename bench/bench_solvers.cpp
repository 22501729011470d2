// Solver cost on the white furnace: unit cube, 32 × 32 patches per wall (N = 6,144), uniform
// E = 1 and ρ ∈ {0.5, 0.9, 0.99, 0.999}, solved to a relative residual of 1e-10 (solver.h).
// scene:0 is that furnace. Its first residual (from B = E) is exactly the constant eigenvector,
// so Krylov methods finish it in one step; scene:1 (same room and ρ, only the floor emits) is the
// honest stiff case for them: its error has every mode.
// The form factors are filled once (centroid quadrature, no visibility: the room is convex) and
// reused by every run. Time = SolverReport::seconds (the solve alone); counters: iterations
// (sweeps or matrix-vector products), final residual, max |B(1 − ρ) − 1| against the closed form
// B = E/(1 − ρ), and for cg the measured reciprocity error of F.
// Run: build/bench/bench_solvers --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>

#include <memory>

#include "../tests/scene_builders.h"
#include "formfactors/formfactors.h"
#include "patching/patching.h"
#include "solver/solver.h"

namespace pm = photometria;

namespace {

struct Furnace {
  pm::PatchMesh mesh;
  pm::FormFactors F;
  Eigen::VectorXd areas;
};

const Furnace& furnace() {
  static const std::unique_ptr<Furnace> f = [] {
    auto out = std::make_unique<Furnace>();
    out->mesh = pm::subdivide(builders::unit_cube(), {1.0 / 32.0, 0.0});
    pm::FillStats stats;
    out->F = pm::fill_form_factors(out->mesh, pm::FillOptions{}, stats);
    out->areas.resize(out->mesh.size());
    for (int i = 0; i < out->mesh.size(); ++i) out->areas[i] = out->mesh.patches[i].area;
    return out;
  }();
  return *f;
}

const pm::SolverMethod kMethods[] = {pm::SolverMethod::GaussSeidel, pm::SolverMethod::Sor,    pm::SolverMethod::Cg,
                                     pm::SolverMethod::Gmres,       pm::SolverMethod::Direct, pm::SolverMethod::Auto};
const double kRho[] = {0.5, 0.9, 0.99, 0.999};

void BM_FurnaceSolve(benchmark::State& state) {
  const Furnace& f = furnace();
  const int n = f.mesh.size();
  const double rho = kRho[state.range(1)];
  pm::SolverOptions opt;
  opt.tolerance = 1e-10;
  opt.method = kMethods[state.range(0)];
  opt.areas = f.areas;
  pm::ChannelMatrix E = pm::ChannelMatrix::Constant(n, 3, 1.0);
  if (state.range(2) == 1)
    for (int i = 0; i < n; ++i)
      if (f.mesh.patches[i].face != 0) E.row(i).setZero();  // face 0 = floor (scene_builders.h)
  const pm::ChannelMatrix R = pm::ChannelMatrix::Constant(n, 3, rho), H = pm::ChannelMatrix::Zero(n, 3);
  pm::ChannelMatrix B;
  pm::SolverReport rep;
  for (auto _ : state) {
    rep = pm::solve_radiosity(f.F, E, R, H, true, opt, B);
    state.SetIterationTime(rep.seconds);
  }
  state.SetLabel(std::string(pm::method_name(opt.method)) + " -> " + pm::method_name(rep.method) +
                 " rho=" + std::to_string(rho).substr(0, 5) + (state.range(2) ? " floor-emitting" : " furnace") +
                 (rep.converged ? "" : " NOT CONVERGED"));
  state.counters["N"] = n;
  state.counters["iterations"] = rep.iterations;
  state.counters["residual"] = rep.residual;
  // Closed form only for the uniform furnace; for scene:1 the counter is 0.
  state.counters["max_err"] = state.range(2) == 0 ? ((B.col(0).array() * (1 - rho)) - 1.0).abs().maxCoeff() : 0.0;
  state.counters["recip_err"] = rep.reciprocity_error;
  state.counters["omega"] = rep.omega;
}

}  // namespace

BENCHMARK(BM_FurnaceSolve)
    ->ArgsProduct({{0, 1, 2, 3, 4, 5}, {0, 1, 2, 3}, {0, 1}})
    ->ArgNames({"method", "rho", "scene"})
    ->UseManualTime()
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_MAIN();
