#include "pipeline/report.h"

#include <iomanip>
#include <sstream>

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
  g.cells = r.cells;
  g.point_arrays.push_back(rgb_array("radiosity", r.point_radiosity));
  g.point_arrays.push_back(rgb_array("irradiance", r.point_irradiance));
  g.cell_arrays.push_back(rgb_array("radiosity", r.radiosity));
  g.cell_arrays.push_back(rgb_array("irradiance", r.irradiance));
  g.cell_arrays.push_back(rgb_array("emission", r.emission));
  g.cell_arrays.push_back(rgb_array("reflectance", r.reflectance));
  VtuArray area{"area", 1, {}, false}, face{"face", 1, {}, true}, group{"group", 1, {}, true};
  for (const Patch& p : r.mesh.patches) {
    area.values.push_back(p.area);
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
  j["load"] = {{"input_vertices", scene.stats.input_vertices}, {"input_faces", scene.stats.input_faces},
               {"welded_vertices", scene.stats.welded_vertices}, {"dropped_degenerate", scene.stats.dropped_degenerate},
               {"split_nonplanar", scene.stats.split_nonplanar}, {"split_polygons", scene.stats.split_polygons},
               {"missing_material_files", scene.stats.missing_material_files}};
  j["faces"] = s.faces;
  j["patches"] = s.patches;
  j["patch_area"] = {{"min", s.min_patch_area}, {"max", s.max_patch_area}, {"total", s.total_area}};
  j["pairs"] = {{"total", s.pairs_total}, {"evaluated", s.fill.pairs_evaluated},
                {"skipped_backfacing", s.fill.pairs_backfacing}, {"culled", 0},
                {"fully_occluded", s.fill.pairs_occluded}};
  j["visibility"] = {{"mode", s.visibility_mode}, {"reason", s.visibility_reason}, {"rays_per_pair", s.rays},
                     {"rays_cast", s.fill.rays_cast + s.vertex_rays_cast}};
  j["quadrature"] = s.quadrature;
  j["matrix"] = {{"storage", s.matrix_storage}, {"bytes", s.matrix_bytes}};
  j["solver"] = {{"method", "gauss-seidel"}, {"iterations", s.solver.iterations}, {"residual", s.solver.residual},
                 {"tolerance", s.tolerance}, {"channels", s.solver.channels_solved}, {"converged", s.solver.converged}};
  j["output_points"] = s.output_points;
  j["vertex_gather"] = {{"pairs_evaluated", s.vertex_pairs_evaluated}, {"rays_cast", s.vertex_rays_cast}};
  j["threads"] = s.threads;
  nlohmann::json t = nlohmann::json::object();
  double total = 0.0;
  for (const auto& [stage, sec] : s.stage_seconds) { t[stage] = sec; total += sec; }
  t["total"] = total;
  j["seconds"] = t;
  j["peak_memory_bytes"] = peak_memory_bytes();
  j["energy_w"] = {{"emitted", rgb_json(s.energy.emitted)}, {"absorbed", rgb_json(s.energy.absorbed)},
                   {"escaped", rgb_json(s.energy.escaped)}, {"relative_imbalance", s.energy.relative_imbalance}};
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
               << " non-planar)\n";
  row("patches") << s.patches << " (area " << std::setprecision(4) << s.min_patch_area << " .. " << s.max_patch_area
                 << " m²)\n";
  row("pairs") << s.fill.pairs_evaluated << " evaluated, " << s.fill.pairs_backfacing << " skipped back-facing, "
               << s.fill.pairs_occluded << " fully occluded\n";
  row("visibility") << s.visibility_mode << " — " << s.visibility_reason << "\n";
  if (s.rays) row("rays") << s.fill.rays_cast + s.vertex_rays_cast << " cast (" << s.rays << " per pair)\n";
  row("quadrature") << s.quadrature << (s.quadrature == 1 ? " (centroid)" : " (Gauss)") << "\n";
  row("matrix") << s.matrix_storage << ", " << std::setprecision(3) << s.matrix_bytes / 1048576.0 << " MiB\n";
  row("solver") << "gauss-seidel, " << s.solver.iterations << " sweeps, residual " << std::setprecision(3)
                << s.solver.residual << ", " << s.solver.channels_solved
                << (s.solver.channels_solved == 1 ? " channel (all grey)" : " channels") << "\n";
  row("output points") << s.output_points << "\n";
  row("emitted W") << rgb(s.energy.emitted) << "\n";
  row("absorbed W") << rgb(s.energy.absorbed) << "\n";
  row("escaped W") << rgb(s.energy.escaped) << "\n";
  row("energy imbalance") << std::setprecision(3) << s.energy.relative_imbalance << "\n";
  double total = 0.0;
  std::ostringstream st;
  for (const auto& [stage, sec] : s.stage_seconds) { st << " " << stage << " " << std::setprecision(3) << sec; total += sec; }
  row("time s") << std::setprecision(3) << total << " (" << st.str().substr(1) << ")\n";
  row("threads") << s.threads << "\n";
  row("peak memory") << std::setprecision(4) << peak_memory_bytes() / 1048576.0 << " MiB\n";
  return o.str();
}

}  // namespace photometria
