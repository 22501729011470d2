// `photometria viewfactors SCENE -o VF.csv [--by group|face|patch] [--format ...] [--enforce ...]
// [--points FILE] [--max-memory SIZE] [--matrix ...]`: view-factor matrices for radiative heat transfer
// (docs/viewfactors.md).
#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>

#include "commands.h"
#include "options.h"
#include "io/atomic_file.h"
#include "io/viewfactor_output.h"
#include "pipeline/memory.h"
#include "pipeline/solve.h"
#include "scene/scene.h"
#include "util/error.h"
#include "viewfactors/viewfactors.h"

namespace pm = photometria;

namespace {

struct ViewFactorArgs {
  std::string scene, output, by = "group", format = "csv", enforce = "none", visibility = "auto", points,
                             points_output, max_memory, matrix = "auto", matrix_precision = "auto";
  double threshold = 0.0, max_edge = 0.0, accuracy = 1e-7;
  int rays = 576, threads = 0;
  bool json = false, flip_normals = false;
};

nlohmann::json checks_json(const pm::MatrixChecks& c, const std::vector<std::string>& names) {
  return {{"row_sum_min", c.min_row_sum},
          {"row_sum_max", c.max_row_sum},
          {"row_sum_mean", c.mean_row_sum},
          {"worst_row", c.worst_row},
          {"worst_row_name", names.empty() ? "" : names[static_cast<size_t>(c.worst_row)]},
          {"reciprocity_error_max", c.reciprocity_error},
          {"min_entry", c.min_entry},
          {"max_entry", c.max_entry}};
}

// Per output surface, the emissivity of its View3D surface when the input is a .vs3 file (the
// last line of View3D's output); empty otherwise (the writer then puts 1.000).
std::vector<double> view3d_emissivities_of(const std::string& path, const pm::Scene& scene, const pm::PatchMesh& mesh,
                                           const pm::Aggregation& agg) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext != ".vs3") return {};
  const std::vector<double> by_surface = pm::view3d_emissivities(path);
  std::vector<double> out(static_cast<size_t>(agg.size()), 1.0);
  for (int i = 0; i < mesh.size(); ++i) {
    const int source = scene.faces[static_cast<size_t>(mesh.patches[i].face)].source_face;
    if (source >= 0 && source < static_cast<int>(by_surface.size()))
      out[static_cast<size_t>(agg.of_patch[i])] = by_surface[static_cast<size_t>(source)];
  }
  return out;
}

int run(const ViewFactorArgs& a) {
  const auto t0 = std::chrono::steady_clock::now();
  pm::AggregateLevel level;
  if (a.by == "group") level = pm::AggregateLevel::Group;
  else if (a.by == "face") level = pm::AggregateLevel::Face;
  else if (a.by == "patch") level = pm::AggregateLevel::Patch;
  else pm::throw_bad_input("--by: unknown level '" + a.by + "' (group, face or patch)");
  pm::ViewFactorFormat format;
  if (!pm::view_factor_format_from_name(a.format, format))
    pm::throw_bad_input("--format: unknown format '" + a.format + "' (csv, sparse, binary or view3d)");
  pm::Enforcement enforcement;
  if (a.enforce == "none") enforcement = pm::Enforcement::None;
  else if (a.enforce == "reciprocity") enforcement = pm::Enforcement::Reciprocity;
  else if (a.enforce == "closure") enforcement = pm::Enforcement::Closure;
  else if (a.enforce == "both") enforcement = pm::Enforcement::Both;
  else pm::throw_bad_input("--enforce: unknown mode '" + a.enforce + "' (none, reciprocity, closure or both)");
  pm::ViewFactorOptions opt;
  if (a.visibility == "auto") opt.visibility = pm::VisibilityMode::Auto;
  else if (a.visibility == "none") opt.visibility = pm::VisibilityMode::None;
  else if (a.visibility == "rays") opt.visibility = pm::VisibilityMode::Rays;
  else if (a.visibility == "exact") opt.visibility = pm::VisibilityMode::Exact;
  else pm::throw_bad_input("--visibility: unknown mode '" + a.visibility + "' (auto, none, rays or exact)");
  if (!(a.accuracy > 0.0 && a.accuracy < 1.0)) pm::throw_bad_input("--accuracy must lie in (0, 1)");
  if (!(a.max_edge >= 0.0)) pm::throw_bad_input("--max-edge must be >= 0");
  if (!(a.threshold >= 0.0)) pm::throw_bad_input("--threshold must be >= 0");
  if (a.rays < 1) pm::throw_bad_input("--rays must be >= 1");
  opt.accuracy = a.accuracy;
  opt.patching.max_edge = a.max_edge;
  opt.rays = a.rays;
  opt.threads = a.threads;
  if (!a.max_memory.empty() && !pm::parse_memory_size(a.max_memory, opt.max_memory_bytes))
    pm::throw_bad_input("--max-memory: '" + a.max_memory + "' is not a size (e.g. 512M, 2G, 1.5GiB)");
  opt.matrix_layout = pm::parse_layout(a.matrix);
  opt.matrix_precision = pm::parse_precision(a.matrix_precision);
  opt.level = level;
  opt.enforcement = enforcement != pm::Enforcement::None;

  // Every output is opened (its temporary file created) before the long work, so that an
  // unwritable path fails in a second, and committed only when all of them were written, so
  // that a failed run leaves none (io/atomic_file.h).
  const std::string points_path =
      a.points.empty() ? std::string() : a.points_output.empty() ? a.output + ".points.csv" : a.points_output;
  if (!points_path.empty()) {
    namespace fs = std::filesystem;
    if (fs::absolute(points_path).lexically_normal() == fs::absolute(a.output).lexically_normal())
      pm::throw_bad_input("--points-output: '" + points_path + "' is also the -o output");
  }
  pm::AtomicOutput main_out(a.output);
  std::optional<pm::AtomicOutput> points_out;
  if (!points_path.empty()) points_out.emplace(points_path);

  pm::LoadOptions lo;
  lo.flip_normals = a.flip_normals;
  const pm::Scene scene = pm::load_scene(a.scene, lo);
  for (const std::string& w : pm::load_warnings(scene.stats))
    std::cerr << "photometria: warning: " << scene.source << ": " << w << "\n";
  // Points are read before the (long) fill so that a bad file fails fast.
  std::vector<pm::SurfacePoint> points;
  if (!a.points.empty()) points = pm::load_points(a.points);
  opt.points = static_cast<int>(points.size());

  const pm::PatchViewFactors r = pm::compute_view_factors(scene, opt);
  const pm::Aggregation agg = pm::make_aggregation(scene, r.mesh, level);
  pm::ViewFactorMatrix F = pm::aggregate(r.F, r.mesh, agg);
  pm::EnforcementReport rep;
  if (enforcement != pm::Enforcement::None) rep = pm::enforce(F, agg.areas, enforcement);
  const pm::MatrixChecks checks = pm::check_matrix(F, agg.areas);
  pm::View3dOutput v3;
  if (format == pm::ViewFactorFormat::View3d) {
    v3.enclosure = enforcement == pm::Enforcement::Closure || enforcement == pm::Enforcement::Both ? 1 : 0;
    v3.emissivities = view3d_emissivities_of(a.scene, scene, r.mesh, agg);
  }
  const pm::SparseWriteStats ws = pm::write_view_factors(main_out, format, agg.names, agg.areas, F, a.threshold, v3);
  if (points_out) {
    const pm::ViewFactorMatrix P = pm::point_view_factors(points, r.mesh, agg, r.visibility.get(), opt);
    std::vector<std::string> ids;
    for (const pm::SurfacePoint& p : points) ids.push_back(p.id);
    pm::write_point_factors(*points_out, ids, agg.names, P);
  }
  main_out.commit();
  if (points_out) {
    try {
      points_out->commit();
    } catch (...) {
      std::remove(main_out.target().c_str());  // all or nothing
      throw;
    }
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  nlohmann::json j;
  j["scene"] = a.scene;
  j["output"] = a.output;
  j["format"] = a.format;
  j["level"] = a.by;
  j["surfaces"] = agg.size();
  j["patches"] = r.mesh.size();
  j["faces"] = scene.faces.size();
  j["accuracy"] = opt.accuracy;
  j["visibility"] = r.visibility_mode;
  j["visibility_reason"] = r.visibility_reason;
  j["checks"] = checks_json(checks, agg.names);
  const pm::ViewFactorMemory& m = r.memory;
  j["matrix"] = {{"storage", r.F.description()}, {"reason", m.storage_reason}, {"bytes", r.F.bytes()}};
  j["memory_estimate"] = {{"estimated_bytes", m.estimated_bytes},   {"matrix_bytes", m.matrix_bytes},
                          {"output_bytes", m.output_bytes},         {"per_patch_bytes", m.patches.per_patch_bytes},
                          {"dense_bytes", m.patches.dense_bytes},   {"sparse_bytes", m.patches.sparse_bytes},
                          {"nonzero_pairs", m.patches.nonzero_pairs}, {"limit_bytes", m.limit_bytes},
                          {"limit_source", m.limit_source}};
  j["pairs"] = {{"evaluated", r.fill.pairs_evaluated},     {"backfacing", r.fill.pairs_backfacing},
                {"per_pair_gauss", r.fill.pairs_gauss},     {"per_pair_adaptive", r.fill.pairs_adaptive},
                {"exact_rectangles", r.fill.pairs_exact_rectangles},
                {"fixed_rule", r.fill.pairs_fixed_rule},     {"fixed_rule_order", opt.quadrature},
                {"visibility_tested", r.fill.pairs_tested}, {"visibility_culled", r.fill.pairs_culled},
                {"occluded", r.fill.pairs_occluded},         {"rays_cast", r.fill.rays_cast},
                {"kernel_evaluations", r.fill.kernel_evaluations}};
  j["enforce"] = a.enforce;
  if (enforcement != pm::Enforcement::None)
    j["enforcement"] = {{"before", checks_json(rep.before, agg.names)},
                        {"after", checks_json(rep.after, agg.names)},
                        {"iterations", rep.iterations},
                        {"max_change", rep.max_change}};
  if (format == pm::ViewFactorFormat::Sparse)
    j["sparse"] = {{"threshold", a.threshold},           {"written", ws.written},
                   {"dropped", ws.dropped},               {"dropped_row_sum_max", ws.max_dropped_row_sum},
                   {"dropped_worst_row", ws.worst_row},   {"dropped_total", ws.total_dropped}};
  if (!points_path.empty()) j["points"] = {{"count", points.size()}, {"output", points_path}};
  j["seconds"] = seconds;
  j["peak_memory_bytes"] = pm::peak_memory_bytes();
  if (a.json) {
    std::cout << j.dump(2) << std::endl;
    return 0;
  }
  std::cout << "view factors: " << agg.size() << " " << a.by << "s from " << r.mesh.size() << " patches -> " << a.output
            << " (" << a.format << ")\n"
            << "  visibility: " << r.visibility_mode << " (" << r.visibility_reason << ")\n"
            << "  row sums: min " << checks.min_row_sum << ", max " << checks.max_row_sum << ", mean "
            << checks.mean_row_sum << "; worst row " << checks.worst_row << " (" << agg.names[checks.worst_row]
            << ")\n"
            << "  reciprocity error max: " << checks.reciprocity_error << "\n"
            << "  matrix: " << r.F.description() << ", " << pm::format_bytes(r.F.bytes()) << " (" << m.storage_reason
            << ")\n"
            << "  memory estimate: " << pm::format_bytes(m.estimated_bytes) << " for this run ("
            << pm::format_bytes(m.matrix_bytes) << " patch matrix, " << pm::format_bytes(m.output_bytes)
            << " output); limit " << pm::format_bytes(m.limit_bytes) << " (" << m.limit_source << ")\n"
            << "  pairs: " << r.fill.pairs_gauss << " per-pair Gauss, " << r.fill.pairs_adaptive << " adaptive, " << r.fill.pairs_exact_rectangles << " exact rectangles, "
            << r.fill.pairs_fixed_rule << " fixed order " << opt.quadrature << " (visibility), "
            << r.fill.pairs_backfacing << " facing away; " << r.fill.pairs_tested << " shaft-tested, "
            << r.fill.pairs_culled << " culled, " << r.fill.pairs_occluded << " fully occluded, " << r.fill.rays_cast
            << " rays\n";
  if (enforcement != pm::Enforcement::None)
    std::cout << "  enforcement " << a.enforce << ": reciprocity error " << rep.before.reciprocity_error << " -> "
              << rep.after.reciprocity_error << ", row sums [" << rep.before.min_row_sum << ", "
              << rep.before.max_row_sum << "] -> [" << rep.after.min_row_sum << ", " << rep.after.max_row_sum
              << "], max change " << rep.max_change << "\n";
  if (format == pm::ViewFactorFormat::Sparse)
    std::cout << "  sparse: " << ws.written << " entries written, " << ws.dropped << " below " << a.threshold
              << " dropped; largest dropped row sum " << ws.max_dropped_row_sum << " (row " << ws.worst_row << ")\n";
  if (!points_path.empty()) std::cout << "  point factors: " << points.size() << " points -> " << points_path << "\n";
  std::cout << "  time " << seconds << " s, peak memory " << pm::peak_memory_bytes() / 1048576.0 << " MiB\n";
  return 0;
}

}  // namespace

Command add_viewfactors_command(CLI::App& app) {
  auto a = std::make_shared<ViewFactorArgs>();
  CLI::App* sub = app.add_subcommand("viewfactors", "View-factor matrix between groups, faces or patches (radiative heat transfer)");
  sub->add_option("scene", a->scene, "Mesh (.obj .off .ply .stl .om), View3D input (.vs3) or scene file (.json)")->required();
  sub->add_option("-o,--output", a->output, "Output file")->required();
  sub->add_option("--by", a->by, "Aggregation level: group, face or patch (default group)");
  sub->add_option("--format", a->format, "csv (dense, default), sparse (i,j,F triplets), binary or view3d");
  sub->add_option("--threshold", a->threshold, "Sparse output: drop factors below this (the summary reports the dropped row sums)")
      ->check(options::real_in(0, 1));
  sub->add_option("--enforce", a->enforce, "none (default), reciprocity, closure or both (closed enclosures)");
  sub->add_option("--points", a->points, "Points with normals (.json or .csv): factors from each point to each surface");
  sub->add_option("--points-output", a->points_output, "Where to write the point factors (default OUTPUT.points.csv)");
  sub->add_option("--max-edge", a->max_edge, "Split faces into patches with edges at most this long, metres (default: no split)")
      ->check(options::real_in(0, options::kInf));
  sub->add_option("--accuracy", a->accuracy, "Per-pair relative tolerance for unblocked pairs (default 1e-7)")
      ->check(options::real_in(0, 1, true, true));
  sub->add_option("--visibility", a->visibility, "auto (default), none, rays or exact");
  sub->add_option("--rays", a->rays, "Rays per (point, patch) in ray visibility (default 576)")
      ->check(options::integer_in(1, 1 << 24));
  sub->add_option("--max-memory", a->max_memory,
                  "Refuse before the fill when the memory estimate exceeds this: 512M, 2G, ... (default: MemAvailable)");
  sub->add_option("--matrix", a->matrix, "Patch form-factor storage: auto | dense | sparse (default auto: the smaller for the scene)");
  sub->add_option("--matrix-precision", a->matrix_precision, "Patch form-factor entries: auto | double | float (default auto: double unless only float fits the memory limit; float halves the matrix)");
  sub->add_option("--threads", a->threads, "Threads for the fill (default: all cores)")
      ->check(options::integer_in(0, options::kMaxThreads));
  sub->add_flag("--flip-normals", a->flip_normals, "Reverse every face (inside-out exports)");
  sub->add_flag("--json", a->json, "Print a machine-readable summary on stdout");
  return {sub, [a]() { return run(*a); }};
}
