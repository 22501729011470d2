// The summary of a view-factor job (report.h).
#include "viewfactors/report.h"

#include <sstream>

#include "pipeline/memory.h"
#include "pipeline/solve.h"

namespace photometria {
namespace {

nlohmann::json checks_json(const MatrixChecks& c, const std::vector<std::string>& names) {
  return {{"row_sum_min", c.min_row_sum},
          {"row_sum_max", c.max_row_sum},
          {"row_sum_mean", c.mean_row_sum},
          {"worst_row", c.worst_row},
          {"worst_row_name", names.empty() ? "" : names[static_cast<size_t>(c.worst_row)]},
          {"reciprocity_error_max", c.reciprocity_checked ? nlohmann::json(c.reciprocity_error) : nlohmann::json()},
          {"min_entry", c.min_entry},
          {"max_entry", c.max_entry}};
}

}  // namespace

nlohmann::json viewfactor_summary_json(const ViewFactorJobResult& r) {
  const ViewFactorJob& job = r.job;
  nlohmann::json j;
  j["scene"] = job.scene;
  j["output"] = job.output;
  j["format"] = view_factor_format_name(job.format);
  j["level"] = aggregate_level_name(job.level);
  j["surfaces"] = r.surfaces();
  j["patches"] = r.patches;
  j["faces"] = r.faces;
  j["accuracy"] = job.fill.accuracy;
  j["occluded_accuracy"] = job.fill.occluded_accuracy;
  j["visibility"] = r.visibility_mode;
  j["visibility_reason"] = r.visibility_reason;
  j["factors"] = r.exchange_factors ? "script-F" : "geometric";
  j["checks"] = checks_json(r.checks, r.names);
  if (r.exchange_factors)
    j["exchange"] = {{"definition",
                      "Hottel's total exchange factors (Hottel & Sarofim 1967): sF = diag(eps) X, "
                      "(I - F diag(1 - eps)) X = F diag(eps)"},
                     {"source", "C emit=1"},
                     {"emissivities", r.emissivities},
                     {"geometric_checks", checks_json(r.geometric_checks, r.names)}};
  const ViewFactorMemory& m = r.memory;
  j["matrix"] = {{"storage", r.matrix_storage},
                 {"reason", m.storage_reason},
                 {"bytes", r.matrix_bytes},
                 {"streamed", r.streamed},
                 {"stream_reason", r.stream_reason}};
  j["memory_estimate"] = {{"estimated_bytes", m.estimated_bytes},
                          {"matrix_bytes", m.matrix_bytes},
                          {"output_bytes", m.output_bytes},
                          {"per_patch_bytes", m.patches.per_patch_bytes},
                          {"dense_bytes", m.patches.dense_bytes},
                          {"sparse_bytes", m.patches.sparse_bytes},
                          {"nonzero_pairs", m.patches.nonzero_pairs},
                          {"limit_bytes", m.limit_bytes},
                          {"limit_source", m.limit_source}};
  j["pairs"] = {{"evaluated", r.fill.pairs_evaluated},
                {"backfacing", r.fill.pairs_backfacing},
                {"per_pair_gauss", r.fill.pairs_gauss},
                {"per_pair_adaptive", r.fill.pairs_adaptive},
                {"exact_rectangles", r.fill.pairs_exact_rectangles},
                {"mirrored_by_reciprocity", r.fill.mirrored},
                {"fixed_rule", r.fill.pairs_fixed_rule},
                {"fixed_rule_order", job.fill.quadrature},
                {"visibility_tested", r.fill.pairs_tested},
                {"visibility_culled", r.fill.pairs_culled},
                {"occluded", r.fill.pairs_occluded},
                {"blocked_by_one_occluder", r.fill.pairs_blocked_whole},
                {"occluded_adaptive", r.fill.pairs_occluded_adaptive},
                {"occluded_evaluations", r.fill.occluded_evaluations},
                {"occluded_budget_exhausted", r.fill.occluded_budget_exhausted},
                {"row_error_estimate_max", r.fill.max_row_error_estimate},
                {"rays_cast", r.fill.rays_cast},
                {"row_ray_error_max", r.fill.max_row_ray_error},
                {"kernel_evaluations", r.fill.kernel_evaluations}};
  j["enforce"] = enforcement_name(job.enforcement);
  const EnforcementReport& rep = r.enforcement_report;
  if (job.enforcement != Enforcement::None)
    j["enforcement"] = {{"before", checks_json(rep.before, r.names)},
                        {"after", checks_json(rep.after, r.names)},
                        {"iterations", rep.iterations},
                        {"max_change", rep.max_change}};
  const SparseWriteStats& ws = r.sparse;
  if (job.format == ViewFactorFormat::Sparse)
    j["sparse"] = {{"threshold", job.threshold},
                   {"written", ws.written},
                   {"dropped", ws.dropped},
                   {"dropped_row_sum_max", ws.max_dropped_row_sum},
                   {"dropped_worst_row", ws.worst_row},
                   {"dropped_total", ws.total_dropped},
                   {"streamed", r.streamed},
                   {"stream_reason", r.stream_reason}};
  if (!job.points_output.empty()) j["points"] = {{"count", job.fill.points}, {"output", job.points_output}};
  if (!r.view3d_control.empty()) j["view3d_control"] = r.view3d_control;
  j["seconds"] = r.seconds;
  j["peak_memory_bytes"] = peak_memory_bytes();
  j["ranks"] = {{"count", r.ranks},
                {"threads_per_rank", r.threads_per_rank},
                {"rows_per_rank", r.rows_per_rank},
                {"estimated_cost_per_rank", r.estimated_cost_per_rank},
                {"fill_seconds_per_rank", r.fill_seconds_per_rank},
                {"peak_memory_bytes_per_rank", r.peak_memory_per_rank},
                {"load_imbalance", r.load_imbalance()}};
  return j;
}

std::string viewfactor_summary_text(const ViewFactorJobResult& r) {
  const ViewFactorJob& job = r.job;
  const MatrixChecks& checks = r.checks;
  const ViewFactorMemory& m = r.memory;
  const FillStats& fill = r.fill;
  std::ostringstream o;
  o << "view factors: " << r.surfaces() << " " << aggregate_level_name(job.level) << "s from " << r.patches
    << " patches -> " << job.output << " (" << view_factor_format_name(job.format) << ")\n"
    << "  visibility: " << r.visibility_mode << " (" << r.visibility_reason << ")\n";
  if (r.exchange_factors) {
    const MatrixChecks& g = r.geometric_checks;
    o << "  script-F (C emit=1): Hottel's total exchange factors with the surfaces' emissivities (a closed "
         "enclosure's row sums are the emissivities); geometric factors: row sums ["
      << g.min_row_sum << ", " << g.max_row_sum << "], reciprocity error max " << g.reciprocity_error << "\n";
  }
  o << "  row sums: min " << checks.min_row_sum << ", max " << checks.max_row_sum << ", mean " << checks.mean_row_sum
    << "; worst row " << checks.worst_row << " (" << r.names[static_cast<size_t>(checks.worst_row)] << ")\n"
    << "  reciprocity error max: ";
  if (checks.reciprocity_checked) o << checks.reciprocity_error << "\n";
  else o << "not checked (the rows were streamed, never held together)\n";
  o << "  matrix: " << r.matrix_storage << ", " << format_bytes(r.matrix_bytes) << " (" << m.storage_reason << ")\n"
    << "  memory estimate: " << format_bytes(m.estimated_bytes) << " for this run (" << format_bytes(m.matrix_bytes)
    << " patch matrix, " << format_bytes(m.output_bytes) << " output); limit " << format_bytes(m.limit_bytes) << " ("
    << m.limit_source << ")\n"
    << "  pairs: " << fill.pairs_gauss << " per-pair Gauss, " << fill.pairs_adaptive << " adaptive, "
    << fill.pairs_exact_rectangles << " exact rectangles, " << fill.pairs_fixed_rule << " fixed order "
    << job.fill.quadrature << " (visibility), " << fill.pairs_backfacing << " facing away; " << fill.pairs_tested
    << " shaft-tested, " << fill.pairs_culled << " culled, " << fill.pairs_occluded << " fully occluded, "
    << fill.rays_cast << " rays\n";
  if (fill.rays_cast > 0)
    o << "  rays: estimated error of a row sum from the rays, max " << fill.max_row_ray_error << "\n";
  if (fill.pairs_occluded_adaptive > 0)
    o << "  occluded pairs: " << fill.pairs_occluded_adaptive << " adaptive, rows to " << job.fill.occluded_accuracy
      << " (" << fill.occluded_evaluations << " point-source evaluations, " << fill.occluded_budget_exhausted
      << " rows stopped by the budget); estimated row error max " << fill.max_row_error_estimate << "\n";
  const EnforcementReport& rep = r.enforcement_report;
  if (job.enforcement != Enforcement::None)
    o << "  enforcement " << enforcement_name(job.enforcement) << ": reciprocity error " << rep.before.reciprocity_error
      << " -> " << rep.after.reciprocity_error << ", row sums [" << rep.before.min_row_sum << ", "
      << rep.before.max_row_sum << "] -> [" << rep.after.min_row_sum << ", " << rep.after.max_row_sum
      << "], max change " << rep.max_change << "\n";
  const SparseWriteStats& ws = r.sparse;
  if (job.format == ViewFactorFormat::Sparse)
    o << "  sparse: " << ws.written << " entries written, " << ws.dropped << " below " << job.threshold
      << " dropped; largest dropped row sum " << ws.max_dropped_row_sum << " (row " << ws.worst_row << "); "
      << (r.streamed ? "rows streamed" : "matrix stored") << " (" << r.stream_reason << ")\n";
  if (!job.points_output.empty())
    o << "  point factors: " << job.fill.points << " points -> " << job.points_output << "\n";
  if (!r.view3d_control.empty()) {
    o << "  View3D C line:";
    for (size_t k = 0; k < r.view3d_control.size(); ++k) o << (k ? "; " : " ") << r.view3d_control[k];
    o << "\n";
  }
  if (r.ranks > 1) {
    o << "  MPI: " << r.ranks << " ranks x " << r.threads_per_rank << " threads; rows per rank";
    for (size_t k = 0; k < r.rows_per_rank.size(); ++k) o << (k ? ", " : " ") << r.rows_per_rank[k];
    o << "; fill s per rank";
    for (size_t k = 0; k < r.fill_seconds_per_rank.size(); ++k) o << (k ? ", " : " ") << r.fill_seconds_per_rank[k];
    o << "; load imbalance (max / mean) " << r.load_imbalance() << "\n";
  }
  o << "  time " << r.seconds << " s, peak memory " << peak_memory_bytes() / 1048576.0 << " MiB\n";
  return o.str();
}

}  // namespace photometria
