#include "pipeline/report.h"

#include <iomanip>
#include <sstream>

#include "distributed/fill_stats.h"
#include "pipeline/output_cells.h"

namespace photometria {
namespace {

VtuArray rgb_array(const std::string& name, const ChannelMatrix& m) {
  VtuArray a{name, 3, {}, false};
  a.values.reserve(m.rows() * 3);
  for (int i = 0; i < m.rows(); ++i)
    for (int c = 0; c < 3; ++c) a.values.push_back(m(i, c));
  return a;
}

nlohmann::json rgb_json(const Rgb& v) { return {v[0], v[1], v[2]}; }

}  // namespace

VtuGrid result_grid(const Scene& scene, const SolveResult& r) {
  VtuGrid g;
  for (const OutputPoint& p : r.points) g.points.push_back(p.position);
  // Patches cut at T-junctions (output_cells.h) repeat their values in each of their pieces.
  OutputCells cells = conforming_cells(scene, r);
  g.cells = std::move(cells.cells);
  const auto per_cell = [&](const std::string& name, const ChannelMatrix& per_patch) {
    ChannelMatrix m(static_cast<Eigen::Index>(cells.patch.size()), 3);
    for (size_t c = 0; c < cells.patch.size(); ++c) m.row(Eigen::Index(c)) = per_patch.row(cells.patch[c]);
    return rgb_array(name, m);
  };
  g.point_arrays.push_back(rgb_array("radiosity", r.point_radiosity));
  g.point_arrays.push_back(rgb_array("irradiance", r.point_irradiance));
  g.cell_arrays.push_back(per_cell("radiosity", r.radiosity));
  g.cell_arrays.push_back(per_cell("irradiance", r.irradiance));
  g.cell_arrays.push_back(per_cell("emission", r.emission));
  g.cell_arrays.push_back(per_cell("reflectance", r.reflectance));
  VtuArray area{"area", 1, std::move(cells.area), false}, face{"face", 1, {}, true}, group{"group", 1, {}, true};
  for (const int i : cells.patch) {
    const Patch& p = r.mesh.patches[size_t(i)];
    face.values.push_back(scene.faces[p.face].source_face);
    group.values.push_back(scene.faces[p.face].group);
  }
  g.cell_arrays.push_back(area);
  g.cell_arrays.push_back(face);
  g.cell_arrays.push_back(group);
  return g;
}

nlohmann::json summary_json(const Scene& scene, const SolveSummary& s) {
  nlohmann::json j;
  j["scene"] = scene.source;
  j["load"] = {{"input_vertices", scene.stats.input_vertices},
               {"input_faces", scene.stats.input_faces},
               {"welded_vertices", scene.stats.welded_vertices},
               {"dropped_degenerate", scene.stats.dropped_degenerate},
               {"split_nonplanar", scene.stats.split_nonplanar},
               {"split_polygons", scene.stats.split_polygons},
               {"missing_material_files", scene.stats.missing_material_files},
               {"duplicate_faces", scene.stats.duplicate_faces},
               {"flipped_faces", scene.stats.flipped_faces},
               {"enclosure_faces_outward", scene.stats.enclosure_faces_outward},
               {"flipped_all", scene.stats.flipped_all}};
  j["warnings"] = load_warnings(scene.stats);
  j["faces"] = s.faces;
  j["patches"] = s.patches;
  j["method"] = s.method;
  j["method_reason"] = s.method_reason;
  if (s.method == "hierarchical") {
    const HierarchicalStats& h = s.hierarchical;
    j["hierarchical"] = {{"error", h.error},
                         {"min_element_edge", h.min_edge},
                         {"roots", h.roots},
                         {"clusters", h.clusters},
                         {"cluster_links", h.cluster_links},
                         {"elements", h.elements},
                         {"leaves", h.leaves},
                         {"links", h.links},
                         {"links_evaluated", h.links_evaluated},
                         {"rounds", h.rounds},
                         {"sweeps", h.sweeps},
                         {"bytes", h.bytes},
                         {"stopped_by_memory", h.stopped_by_memory},
                         {"stopped_by_rounds", h.stopped_by_rounds}};
  }
  j["patch_area"] = {{"min", s.min_patch_area}, {"max", s.max_patch_area}, {"total", s.total_area}};
  j["pairs"] = {{"total", s.pairs_total},
                {"evaluated", s.fill.pairs_evaluated},
                {"skipped_backfacing", s.fill.pairs_backfacing},
                {"tested", s.fill.pairs_tested},
                {"culled", s.fill.pairs_culled},
                {"fully_occluded", s.fill.pairs_occluded}};
  j["form_factor_checks"] = {{"min_entry", s.checks.min_entry},
                             {"max_entry", s.checks.max_entry},
                             {"min_row_sum", s.checks.min_row_sum},
                             {"max_row_sum", s.checks.max_row_sum},
                             {"reciprocity_error", s.checks.reciprocity_error},
                             {"above_unoccluded", s.fill.above_unoccluded},
                             {"max_point_row_sum", s.fill.max_point_row_sum},
                             {"points_rescaled", s.fill.points_rescaled}};
  j["visibility"] = {{"mode", s.visibility_mode},
                     {"reason", s.visibility_reason},
                     {"ray_sampling", s.ray_sampling},
                     {"rays_cast", s.fill.rays_cast + s.vertex_rays_cast},
                     {"row_ray_error_max", s.fill.max_row_ray_error}};
  j["quadrature"] = s.quadrature;
  j["lights"] = s.lights;
  j["pair_rules"] = {{"accuracy", s.accuracy},
                     {"fixed", s.fill.pairs_fixed_rule},
                     {"gauss", s.fill.pairs_gauss},
                     {"adaptive", s.fill.pairs_adaptive},
                     {"exact_rectangles", s.fill.pairs_exact_rectangles},
                     {"kernel_evaluations", s.fill.kernel_evaluations}};
  j["matrix"] = {{"storage", s.matrix_storage},
                 {"reason", s.matrix_storage_reason},
                 {"bytes", s.matrix_bytes},
                 {"estimated_bytes", s.estimated_bytes}};
  j["memory_estimate"] = {{"dense_bytes", s.memory.dense_bytes},     {"sparse_bytes", s.memory.sparse_bytes},
                          {"nonzero_pairs", s.memory.nonzero_pairs}, {"per_patch_bytes", s.memory.per_patch_bytes},
                          {"limit_bytes", s.memory_limit_bytes},     {"limit_source", s.memory_limit_source}};
  j["solver"] = {
      {"method", method_name(s.solver.method)}, {"seconds", s.solver.seconds}, {"iterations", s.solver.iterations},
      {"residual", s.solver.residual},          {"tolerance", s.tolerance},    {"channels", s.solver.channels_solved},
      {"converged", s.solver.converged},        {"detail", s.solver.detail}};
  j["output_points"] = s.output_points;
  j["crease_angle_degrees"] = s.crease_angle_degrees;
  j["vertex_gather"] = {{"pairs_evaluated", s.vertex_pairs_evaluated},
                        {"pairs_tested", s.vertex_pairs_tested},
                        {"pairs_culled", s.vertex_pairs_culled},
                        {"rays_cast", s.vertex_rays_cast}};
  j["threads"] = s.threads;
  j["ranks"] = {{"count", s.ranks},
                {"threads_per_rank", s.threads},
                {"rows_per_rank", s.rows_per_rank},
                {"fill_seconds_per_rank", s.fill_seconds_per_rank},
                {"load_imbalance", load_imbalance(s.fill_seconds_per_rank)}};
  nlohmann::json t = nlohmann::json::object();
  double total = 0.0;
  for (const auto& [stage, sec] : s.stage_seconds) {
    t[stage] = sec;
    total += sec;
  }
  t["total"] = total;
  j["seconds"] = t;
  j["peak_memory_bytes"] = peak_memory_bytes();
  j["energy_w"] = {{"emitted", rgb_json(s.energy.emitted)},
                   {"absorbed", rgb_json(s.energy.absorbed)},
                   {"escaped", rgb_json(s.energy.escaped)},
                   {"direct_in", rgb_json(s.energy.direct_in)},
                   {"relative_imbalance", s.energy.relative_imbalance}};
  return j;
}

std::string summary_table(const Scene& scene, const SolveSummary& s) {
  std::ostringstream o;
  auto row = [&](const std::string& k) -> std::ostream& { return o << "  " << std::left << std::setw(22) << k; };
  auto rgb = [](const Rgb& v) {
    std::ostringstream t;
    t << std::setprecision(6) << v[0] << " " << v[1] << " " << v[2];
    return t.str();
  };
  o << "photometria solve " << scene.source << "\n";
  row("faces") << s.faces << " (welded " << scene.stats.welded_vertices << " vertices, dropped "
               << scene.stats.dropped_degenerate << " degenerate, split " << scene.stats.split_nonplanar
               << " non-planar, dropped " << scene.stats.duplicate_faces << " duplicate, flipped "
               << scene.stats.flipped_faces << (scene.stats.flipped_all ? " + all (--flip-normals)" : "") << ")\n";
  row("method") << s.method << " (" << s.method_reason << ")\n";
  if (s.method == "hierarchical") {
    const HierarchicalStats& h = s.hierarchical;
    row("hierarchy") << "error " << h.error << ", elements down to " << std::setprecision(4) << h.min_edge
                     << " m: " << h.roots << " roots, " << h.clusters << " clusters, " << h.elements << " elements, "
                     << h.leaves << " leaves, " << format_count(h.links) << " links (" << format_count(h.cluster_links)
                     << " from or to clusters; " << format_count(h.links_evaluated) << " evaluated), " << h.rounds
                     << " rounds, " << format_bytes(h.bytes)
                     << (h.stopped_by_memory ? "; refinement stopped at the memory limit" : "")
                     << (h.stopped_by_rounds ? "; links still above the error after the last round" : "") << "\n";
  }
  row("patches") << s.patches << " (area " << std::setprecision(4) << s.min_patch_area << " .. " << s.max_patch_area
                 << " m²)\n";
  row("visibility") << s.visibility_mode << " — " << s.visibility_reason << "\n";
  if (!s.ray_sampling.empty())
    row("rays") << s.fill.rays_cast + s.vertex_rays_cast << " cast (" << s.ray_sampling
                << "); estimated error of a row sum from the rays, max " << std::setprecision(3)
                << s.fill.max_row_ray_error << "\n";
  // The hierarchy fills no matrix: its links, their count and bytes are in the "hierarchy" row.
  if (s.method != "hierarchical") {
    row("pairs") << s.fill.pairs_evaluated << " evaluated, " << s.fill.pairs_backfacing << " skipped back-facing, "
                 << s.fill.pairs_occluded << " fully occluded\n";
    if (s.fill.pairs_tested)
      row("shaft culling") << s.fill.pairs_culled << " of " << s.fill.pairs_tested << " pairs need no visibility ("
                           << std::setprecision(3) << 100.0 * s.fill.pairs_culled / s.fill.pairs_tested << "%)\n";
    row("form factors") << "F in [" << std::setprecision(3) << s.checks.min_entry << ", " << s.checks.max_entry
                        << "], row sums " << std::setprecision(10) << s.checks.min_row_sum << " .. "
                        << s.checks.max_row_sum;
    if (s.checks.reciprocity_error >= 0.0) o << ", reciprocity " << std::setprecision(3) << s.checks.reciprocity_error;
    else o << ", reciprocity not measured (no MPI rank holds both F_ij and F_ji)";
    o << "\n";
    if (s.fill.pairs_gauss + s.fill.pairs_adaptive + s.fill.pairs_exact_rectangles > 0)
      row("pair rules") << "accuracy " << s.accuracy << ": " << s.fill.pairs_gauss << " Gauss (far), "
                        << s.fill.pairs_adaptive << " adaptive (near/touching), " << s.fill.pairs_exact_rectangles
                        << " exact (aligned rectangles), " << s.fill.pairs_fixed_rule << " fixed-rule (occluded)\n";
    else row("quadrature") << s.quadrature << (s.quadrature == 1 ? " (centroid)" : " (Gauss)") << "\n";
    row("matrix") << s.matrix_storage << ", " << format_bytes(s.matrix_bytes) << " (" << s.matrix_storage_reason
                  << ")\n";
    row("memory estimate") << format_bytes(s.estimated_bytes) << " for this run; " << format_bytes(s.memory.dense_bytes)
                           << " dense, " << format_bytes(s.memory.sparse_bytes) << " sparse ("
                           << format_count(s.memory.nonzero_pairs) << " pairs facing); limit "
                           << format_bytes(s.memory_limit_bytes) << " (" << s.memory_limit_source << ")\n";
  } else {
    row("memory limit") << format_bytes(s.memory_limit_bytes) << " (" << s.memory_limit_source << ")\n";
  }
  row("solver") << method_name(s.solver.method) << ", " << s.solver.iterations
                << (s.solver.method == SolverMethod::GaussSeidel || s.solver.method == SolverMethod::Sor ? " sweeps"
                    : s.solver.method == SolverMethod::Direct                                            ? " LU solves"
                                                                                                         : " products")
                << ", residual " << std::setprecision(3) << s.solver.residual << ", " << s.solver.channels_solved
                << (s.solver.channels_solved == 1 ? " channel (all grey)" : " channels")
                << (s.solver.detail.empty() ? "" : "; " + s.solver.detail) << "\n";
  row("output points") << s.output_points << " (crease angle " << s.crease_angle_degrees << "°)\n";
  row("emitted W") << rgb(s.energy.emitted) << "\n";
  if (s.lights) row("from lights W") << rgb(s.energy.direct_in) << " (" << s.lights << " analytic lights)\n";
  else row("lights") << "none: direct-light pass skipped\n";
  row("absorbed W") << rgb(s.energy.absorbed) << "\n";
  row("escaped W") << rgb(s.energy.escaped) << "\n";
  row("energy imbalance") << std::setprecision(3) << s.energy.relative_imbalance << "\n";
  double total = 0.0;
  std::ostringstream st;
  for (const auto& [stage, sec] : s.stage_seconds) {
    st << " " << stage << " " << std::setprecision(3) << sec;
    total += sec;
  }
  row("time s") << std::setprecision(3) << total << " (" << st.str().substr(1) << ")\n";
  row("threads") << s.threads << "\n";
  if (s.ranks > 1) {
    row("MPI") << s.ranks << " ranks x " << s.threads << " threads; rows per rank";
    for (int n : s.rows_per_rank) o << " " << n;
    o << "; fill seconds per rank";
    for (double t : s.fill_seconds_per_rank) o << " " << std::setprecision(3) << t;
    o << " (imbalance " << std::setprecision(3) << load_imbalance(s.fill_seconds_per_rank) << ")\n";
  }
  row("peak memory") << std::setprecision(4) << peak_memory_bytes() / 1048576.0 << " MiB\n";
  return o.str();
}

}  // namespace photometria
