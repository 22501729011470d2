// `photometria solve`: parse options, load, solve, write, print the summary.
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <optional>

#include "commands.h"
#include "distributed/ranks.h"
#include "io/atomic_file.h"
#include "io/vtu.h"
#include "options.h"
#include "pipeline/memory.h"
#include "pipeline/report.h"
#include "pipeline/solve.h"
#include "scene/scene.h"
#include "util/error.h"
#include "util/progress.h"

namespace pm = photometria;

namespace {

// "0.5" or "0.5,0.4,0.3" -> RGB.
pm::Rgb parse_rgb(const std::string& text, const std::string& option) {
  std::vector<double> v;
  std::stringstream s(text);
  std::string item;
  while (std::getline(s, item, ',')) {
    try {
      size_t used = 0;
      v.push_back(std::stod(item, &used));
      if (used != item.size()) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      pm::throw_bad_input(option + ": '" + text + "' is not a number or an R,G,B triple");
    }
  }
  for (double x : v)
    if (!std::isfinite(x)) pm::throw_bad_input(option + ": '" + text + "' is not a finite number");
  if (v.size() == 1) return pm::Rgb::Constant(v[0]);
  if (v.size() == 3) return pm::Rgb(v[0], v[1], v[2]);
  pm::throw_bad_input(option + ": '" + text + "' must be one value or three (R,G,B)");
}

struct SolveArgs {
  std::string scene, output;
  std::optional<double> max_edge, max_area, tolerance;
  std::optional<int> quadrature, max_iterations;
  std::optional<std::string> rays;
  std::optional<double> accuracy, crease_angle;
  std::optional<std::string> visibility;
  std::optional<std::string> solver;
  std::optional<std::string> method;
  std::optional<double> error, min_element;
  std::optional<int> cluster_above;
  std::optional<std::string> max_memory;
  std::string matrix = "auto", matrix_precision = "auto";
  bool flip_normals = false, keep_orientation = false;
  int threads = 0;
  uint64_t seed = 1;
  std::string reflectance = "0.5", emission = "0";
  bool json = false, quiet = false;
};

// A value from the command line wins over the scene file's "settings", which wins over the default.
template <class T>
T setting(const std::optional<T>& cli, const nlohmann::json& settings, const char* key, T fallback) {
  if (cli) return *cli;
  if (settings.contains(key)) {
    try {
      return settings.at(key).get<T>();
    } catch (const std::exception&) {
      pm::throw_bad_input(std::string("scene settings: '") + key + "' has the wrong type");
    }
  }
  return fallback;
}

double bounding_diagonal(const pm::Scene& scene) {
  pm::Vec3 lo = scene.vertices.at(0), hi = lo;
  for (const auto& v : scene.vertices) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  return (hi - lo).norm();
}

pm::Scene load_and_configure(const SolveArgs& a, pm::SolveOptions& opt, bool warn);

// Under mpirun the solve is split over the ranks (pipeline/solve.h); rank 0 alone holds the
// output, shows progress and prints. A failure on any rank is agreed (distributed/ranks.h) before
// the solve, after it and around the write, so that every rank ends with the same error.
int run_solve(const SolveArgs& a) {
  const bool root = pm::ranks::is_root(), on_ranks = pm::ranks::distributed();
  std::exception_ptr failure;
  auto agree = [&] {
    if (!on_ranks || !failure) {
      if (on_ranks) pm::ranks::agree(failure);
      else if (failure) std::rethrow_exception(failure);
      return;
    }
    try {
      std::rethrow_exception(failure);
    } catch (const pm::ranks::SharedError&) {
      throw;  // agreed already, inside the solve: every rank has it
    } catch (...) { pm::ranks::agree(failure); }
  };
  std::optional<pm::AtomicOutput> out;
  std::string output;
  pm::Scene scene;
  pm::SolveOptions opt;
  try {
    output = a.output.empty() ? std::filesystem::path(a.scene).stem().string() + ".vtu" : a.output;
    if (root) out.emplace(output);  // fail on an unwritable path before the long work
    scene = load_and_configure(a, opt, root);
  } catch (...) { failure = std::current_exception(); }
  agree();
  // Progress and the time left on stderr: a bar on a terminal, a line every 5 s elsewhere.
  pm::ProgressReporter progress(std::cerr, isatty(STDERR_FILENO));
  if (!a.quiet && root) opt.progress = progress.callback();
  pm::SolveResult result;
  try {
    result = pm::solve_scene(scene, opt);
  } catch (...) { failure = std::current_exception(); }
  progress.clear();
  agree();
  const auto t0 = std::chrono::steady_clock::now();
  try {
    if (root) {
      pm::write_vtu(*out, pm::result_grid(scene, result));
      out->commit();
    }
  } catch (...) { failure = std::current_exception(); }
  agree();
  result.summary.stage_seconds.emplace_back(
      "write", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  if (!root) return 0;
  if (!a.quiet) std::cerr << pm::summary_table(scene, result.summary) << "  output                " << output << "\n";
  if (a.json) {
    nlohmann::json j = pm::summary_json(scene, result.summary);
    j["output"] = output;
    std::cout << j.dump(2) << "\n";
  }
  return 0;
}

// Loads the scene and fills the solve's options from the command line and the scene's settings.
pm::Scene load_and_configure(const SolveArgs& a, pm::SolveOptions& opt, bool warn) {
  pm::LoadOptions load;
  load.default_reflectance = parse_rgb(a.reflectance, "--reflectance");
  load.default_emission = parse_rgb(a.emission, "--emission");
  load.flip_normals = a.flip_normals;
  load.fix_orientation = !a.keep_orientation;
  double max_memory = 0.0;  // 0 = MemAvailable
  if (a.max_memory && !pm::parse_memory_size(*a.max_memory, max_memory))
    pm::throw_bad_input("--max-memory: '" + *a.max_memory + "' is not a size (e.g. 512M, 2G, 1.5GiB)");
  pm::Scene scene = pm::load_scene(a.scene, load);
  if (!a.quiet && warn)
    for (const std::string& w : pm::load_warnings(scene.stats))
      std::cerr << "photometria: warning: " << scene.source << ": " << w << "\n";
  const nlohmann::json& st = scene.settings;
  // Default patch size: 1/16 of the scene's bounding diagonal (about 10 × 10 patches per wall).
  opt.patching.max_edge = setting(a.max_edge, st, "max_edge", bounding_diagonal(scene) / 16.0);
  opt.patching.max_area = setting(a.max_area, st, "max_area", 0.0);
  opt.quadrature = setting(a.quadrature, st, "quadrature", 1);
  opt.accuracy = setting(a.accuracy, st, "accuracy", 0.0);
  if (opt.accuracy < 0 || opt.accuracy >= 1) pm::throw_bad_input("--accuracy must be in [0, 1)");
  opt.crease_angle_degrees = setting(a.crease_angle, st, "crease_angle", 30.0);
  if (!(opt.crease_angle_degrees >= 0 && opt.crease_angle_degrees < 180))
    pm::throw_bad_input("crease_angle must be in [0, 180) degrees");
  // A scene file may give "rays" as a number or as "auto".
  const bool rays_number = st.contains("rays") && st.at("rays").is_number_integer();
  opt.rays = pm::parse_ray_count(rays_number && !a.rays ? st.at("rays").dump()
                                                        : setting(a.rays, st, "rays", std::string("auto")));
  opt.solver.tolerance = setting(a.tolerance, st, "tolerance", 1e-8);
  opt.solver.max_iterations = setting(a.max_iterations, st, "max_iterations", 100000);
  opt.solver.method = pm::parse_method(setting(a.solver, st, "solver", std::string("auto")));
  opt.visibility = pm::parse_visibility_mode(setting(a.visibility, st, "visibility", std::string("auto")));
  // Written so that NaN fails too.
  if (!(opt.patching.max_edge >= 0 && opt.patching.max_area >= 0) || !std::isfinite(opt.patching.max_edge) ||
      !std::isfinite(opt.patching.max_area))
    pm::throw_bad_input("--max-edge/--max-area must be finite and >= 0");
  if (opt.quadrature < 1 || opt.quadrature > 16) pm::throw_bad_input("--quadrature must be in 1..16");
  if (!(opt.solver.tolerance > 0) || !std::isfinite(opt.solver.tolerance))
    pm::throw_bad_input("--tolerance must be finite and > 0");
  const std::string method = setting(a.method, st, "method", std::string("dense"));
  if (!pm::solve_method_from_name(method, opt.method))
    pm::throw_bad_input("--method: '" + method + "' is not dense, hierarchical or auto");
  opt.hierarchical_error = setting(a.error, st, "error", 1e-2);
  opt.min_element_edge = setting(a.min_element, st, "min_element", 0.0);
  opt.cluster_above = setting(a.cluster_above, st, "cluster_above", 512);
  if (!(opt.hierarchical_error > 0 && opt.hierarchical_error < 1)) pm::throw_bad_input("--error must be in (0, 1)");
  if (!(opt.min_element_edge >= 0) || !std::isfinite(opt.min_element_edge))
    pm::throw_bad_input("--min-element must be finite and >= 0");
  opt.max_memory_bytes = max_memory;
  opt.threads = a.threads;
  opt.matrix_layout = pm::parse_layout(a.matrix);
  opt.matrix_precision = pm::parse_precision(a.matrix_precision);
  opt.seed = a.seed;
  return scene;
}

}  // namespace

Command add_solve_command(CLI::App& app) {
  auto args = std::make_shared<SolveArgs>();
  SolveArgs& s = *args;
  CLI::App* solve = app.add_subcommand("solve", "Solve a room mesh and write per-vertex results (.vtu)");
  solve->add_option("scene", s.scene, "Mesh (.obj+.mtl .off .ply .stl .om) or scene file (.json)")->required();
  solve->add_option("-o,--output", s.output, "Output .vtu (default: <scene name>.vtu)");
  solve->add_option("--max-edge", s.max_edge, "Longest patch edge, metres (default: bounding diagonal / 16)")
      ->check(options::real_in(0, options::kInf));
  solve->add_option("--max-area", s.max_area, "Largest patch area, m² (default: no limit)")
      ->check(options::real_in(0, options::kInf));
  solve->add_option("--quadrature", s.quadrature, "Receiver rule: 1 = centroid, n = n×n Gauss points (default 1)")
      ->check(options::integer_in(1, 16));
  solve
      ->add_option("--accuracy", s.accuracy,
                   "Relative accuracy of patch-to-patch factors: rule chosen per pair (overrides --quadrature "
                   "for pairs nothing can block; default 0 = off)")
      ->check(options::real_in(0, 1, false, true));
  solve
      ->add_option("--crease-angle", s.crease_angle,
                   "Faces meeting at less than this angle (degrees) share output points with a smoothed normal; "
                   "0 = every crease sharp; OBJ smoothing groups win over it (default 30)")
      ->check(options::real_in(0, 180, false, true));
  solve->add_option("--visibility", s.visibility, "auto | none | rays | exact (default auto)");
  solve
      ->add_option("--rays", s.rays,
                   "Rays per receiver point and patch in ray visibility: auto (default: 8² to 32², until the "
                   "estimated error meets --accuracy, else 1e-2) or a count in 1..2²⁴")
      ->check(options::auto_or_integer_in(1, 1 << 24));
  solve->add_option("--seed", s.seed, "Ray sampling seed (default 1)")
      ->check(options::integer_in(0, std::numeric_limits<long long>::max()));
  solve->add_option("--tolerance", s.tolerance, "Solver relative residual (default 1e-8)")
      ->check(options::real_in(0, options::kInf, true));
  solve->add_option("--max-iterations", s.max_iterations, "Solver sweep cap (default 100000)")
      ->check(options::integer_in(1, std::numeric_limits<int>::max()));
  solve->add_option("--solver", s.solver, "auto | gauss-seidel | sor | cg | gmres | direct (default auto)");
  solve->add_option(
      "--method", s.method,
      "dense | hierarchical | auto (default dense; hierarchical: links refined to --error, memory following the "
      "links; auto: dense when its memory estimate fits --max-memory, else hierarchical)");
  solve
      ->add_option("--error", s.error,
                   "Hierarchical method: relative radiosity error at which links stop refining (default 1e-2)")
      ->check(options::real_in(0, 1, true, true));
  solve
      ->add_option("--min-element", s.min_element,
                   "Hierarchical method: elements with a longest edge at most this (metres) are not split "
                   "(default: bounding diagonal / 256)")
      ->check(options::real_in(0, options::kInf));
  solve
      ->add_option("--cluster-above", s.cluster_above,
                   "Hierarchical method: with more faces than this, the first links are made down a tree of "
                   "clusters instead of between every facing pair of faces (default 512; 0: always; -1: never)")
      ->check(options::integer_in(-1, std::numeric_limits<int>::max()));
  solve->add_option("--threads", s.threads, "Threads (default: all cores)")
      ->check(options::integer_in(0, options::kMaxThreads));
  solve->add_option("--reflectance", s.reflectance, "Default reflectance for formats without materials: r or r,g,b");
  solve->add_option("--emission", s.emission, "Default emission (W/m²) for formats without materials: e or r,g,b");
  solve->add_option("--max-memory", s.max_memory,
                    "Refuse to solve when the memory estimate exceeds this: 512M, 2G, ... (default: MemAvailable)");
  solve->add_option("--matrix", s.matrix,
                    "Form-factor storage: auto | dense | sparse (default auto: the smaller for the scene)");
  solve->add_option("--matrix-precision", s.matrix_precision,
                    "Form-factor entries: auto | double | float (default auto: double unless only float fits the "
                    "memory limit; float halves the matrix)");
  solve->add_flag("--flip-normals", s.flip_normals, "Reverse every face's winding (inside-out exports)");
  solve->add_flag("--keep-orientation", s.keep_orientation, "Do not flip faces wound against their closed surface");
  solve->add_flag("--json", s.json, "Print a machine-readable summary on stdout");
  solve->add_flag("--quiet", s.quiet, "No summary table or progress on stderr");
  return {solve, [args] { return run_solve(*args); }};
}
