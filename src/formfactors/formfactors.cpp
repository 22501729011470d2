#include "formfactors/formfactors.h"

#include <omp.h>

#include <algorithm>
#include <atomic>

#include "formfactors/pair_integration.h"
#include "formfactors/quadrature.h"
#include "kernels/lambert.h"

namespace photometria {

double plane_tolerance(const PatchMesh& mesh) {
  double m = 0.0;
  for (const Vec3& p : mesh.points) m = std::max(m, p.lpNorm<Eigen::Infinity>());
  return 1e-12 * std::max(m, 1e-300);
}

bool facing_away(const PatchMesh& mesh, int i, int j, double tol) {
  const Patch& a = mesh.patches[i];
  const Patch& b = mesh.patches[j];
  double above_a = -1.0, front_of_b = -1.0;
  for (int k = 0; k < b.corner_count; ++k)
    above_a = std::max(above_a, a.normal.dot(mesh.points[b.corners[k]] - a.centroid));
  if (above_a <= tol) return true;
  for (int k = 0; k < a.corner_count; ++k)
    front_of_b = std::max(front_of_b, b.normal.dot(mesh.points[a.corners[k]] - b.centroid));
  return front_of_b <= tol;
}

FormFactors fill_form_factors(const PatchMesh& mesh, const FillOptions& options, FillStats& stats) {
  const int n = mesh.size();
  FormFactors F(n, options.layout == MatrixLayout::Sparse ? MatrixLayout::Sparse : MatrixLayout::Dense, options.precision);
  const double tol = plane_tolerance(mesh);
  const Visibility* vis = options.visibility;
  const bool rays_mode = vis && vis->method() == VisibilityMethod::Rays;
  std::atomic<int> rows_done{0};
  long long evaluated = 0, backfacing = 0, tested = 0, culled = 0, occluded = 0, rays = 0, above = 0, rescaled = 0;
  long long fixed_rule = 0, gauss = 0, adaptive = 0, kernels = 0;
  // The per-pair rule integrates the unoccluded kernel; it applies when nothing can block.
  const bool per_pair = options.tolerance > 0.0 && !vis;
  double max_point_sum = 0.0;

#pragma omp parallel for schedule(dynamic, 4) \
    reduction(+ : evaluated, backfacing, tested, culled, occluded, rays, above, rescaled, fixed_rule, gauss, adaptive, kernels) \
    reduction(max : max_point_sum)
  for (int i = 0; i < n; ++i) {
    Vec3 ri[4], sj[4];
    mesh.polygon(i, ri);
    const Patch& pi = mesh.patches[i];
    const auto rule = patch_quadrature(ri, pi.corner_count, options.quadrature);
    const int nq = static_cast<int>(rule.size());
    // Per receiver point: its visible factor to each source (for the row-sum check and scaling),
    // and the part of that which rays estimated (the only part that may need scaling).
    std::vector<double> point_sum(nq, 0.0), ray_part;
    if (rays_mode) ray_part.assign(size_t(nq) * n, 0.0);
    std::vector<double> unoccluded(nq);
    std::vector<int> occluders;
    std::vector<double> row(n, 0.0);  // F_i,· before it is stored
    for (int j = 0; j < n; ++j) {
      if (j == i || facing_away(mesh, i, j, tol)) { backfacing += (j != i); continue; }
      const Patch& pj = mesh.patches[j];
      mesh.polygon(j, sj);
      if (per_pair) {
        const PairResult r = pair_form_factor(ri, pi.corner_count, pi.normal, sj, pj.corner_count, pj.normal,
                                              options.tolerance);
        ++evaluated;
        kernels += r.evaluations;
        gauss += r.rule == PairRule::Gauss;
        adaptive += r.rule == PairRule::Adaptive;
        row[j] = r.form_factor;
        point_sum[0] += r.form_factor;  // the row sum stands in for the per-point check
        continue;
      }
      ++fixed_rule;
      kernels += nq;
      double f0 = 0.0;
      for (int q = 0; q < nq; ++q) {
        // A receiver point in P_j's plane sees P_j edge-on. Lambert's kernel returns its limit
        // from P_j's front when the point is on P_j's boundary (right for vertices at creases);
        // an interior quadrature point lands there only where a face of an occluder stands on
        // patch i (a table leg on the floor), and then that limit and the occlusion seen from
        // the point itself would count half a hemisphere twice. With visibility on, take 0.
        unoccluded[q] = vis && std::abs(pj.normal.dot(rule[q].point - pj.centroid)) <= vis->culler().tolerance()
                            ? 0.0
                            : lambert_form_factor(Receiver{rule[q].point, pi.normal}, sj, pj.corner_count);
        f0 += rule[q].weight * unoccluded[q];
      }
      ++evaluated;
      double f = f0;
      if (vis && f0 > 0.0) {
        ++tested;
        vis->culler().occluders(ri, pi.corner_count, sj, pj.corner_count, occluders);
        if (occluders.empty()) {
          ++culled;
        } else {
          f = 0.0;
          const uint64_t stream = pair_stream(options.seed, uint64_t(i), uint64_t(j));
          for (int q = 0; q < nq; ++q) {
            const double v = vis->point_to_patch(Receiver{rule[q].point, pi.normal}, sj, pj.corner_count, pj.normal,
                                                 unoccluded[q], occluders, options.rays,
                                                 pair_stream(stream, uint64_t(q), 0), rays);
            if (rays_mode) ray_part[size_t(q) * n + j] = v;
            unoccluded[q] = v;  // now the visible factor
            f += rule[q].weight * v;
          }
          if (f == 0.0) ++occluded;
          if (f > f0) ++above;
        }
      }
      for (int q = 0; q < nq; ++q) point_sum[q] += unoccluded[q];
      row[j] = f;
    }
    // A receiver point sees at most its hemisphere: Σ_j F_vis(x_q -> P_j) <= 1. Scale the
    // ray-estimated terms of a point whose sum exceeds that (see the header).
    for (int q = 0; q < nq; ++q) {
      max_point_sum = std::max(max_point_sum, point_sum[q]);
      if (!rays_mode || point_sum[q] <= 1.0) continue;
      double ray_sum = 0.0;
      for (int j = 0; j < n; ++j) ray_sum += ray_part[size_t(q) * n + j];
      if (ray_sum <= 0.0) continue;
      // Keep the unoccluded (culled) terms, shrink the ray terms so the point's sum becomes 1.
      const double keep = std::max(0.0, 1.0 - (point_sum[q] - ray_sum)) / ray_sum;
      if (keep >= 1.0) continue;
      ++rescaled;
      for (int j = 0; j < n; ++j) {
        const double v = ray_part[size_t(q) * n + j];
        if (v > 0.0) row[j] = std::max(0.0, row[j] - rule[q].weight * v * (1.0 - keep));
      }
    }
    F.set_row(i, row.data());
    const int done = ++rows_done;
    if (options.progress && omp_get_thread_num() == 0) options.progress(double(done) / n);
  }
  stats.pairs_evaluated += evaluated;
  stats.pairs_backfacing += backfacing;
  stats.pairs_tested += tested;
  stats.pairs_culled += culled;
  stats.pairs_occluded += occluded;
  stats.rays_cast += rays;
  stats.pairs_fixed_rule += fixed_rule;
  stats.pairs_gauss += gauss;
  stats.pairs_adaptive += adaptive;
  stats.kernel_evaluations += kernels;
  stats.above_unoccluded += above;
  stats.max_point_row_sum = std::max(stats.max_point_row_sum, max_point_sum);
  stats.points_rescaled += rescaled;
  return F;
}

FormFactorChecks check_form_factors(const PatchMesh& mesh, const FormFactors& F) {
  FormFactorChecks c;
  const int n = mesh.size();
  if (n == 0) return c;
  double min_entry = 1.0, max_entry = 0.0, min_row = F.row_sum(0), max_row = min_row, recip = 0.0;
  const bool sparse = F.layout() == MatrixLayout::Sparse;
#pragma omp parallel for schedule(dynamic, 16) reduction(min : min_entry, min_row) reduction(max : max_entry, max_row, recip)
  for (int i = 0; i < n; ++i) {
    double row = 0.0;
    int stored = 0;
    const double ai = mesh.patches[i].area;
    F.for_each_in_row(i, [&](int j, double f) {
      row += f;
      if (j == i) return;
      ++stored;
      min_entry = std::min(min_entry, f);
      max_entry = std::max(max_entry, f);
      // Each unordered pair once: from its smaller index, or from the row that stores it when
      // the transposed entry is a (sparse) zero.
      if (j < i && !sparse) return;
      const double fji = F(j, i);
      if (j > i || fji == 0.0) {
        const double aj = mesh.patches[j].area;
        recip = std::max(recip, std::abs(ai * f - aj * fji) / std::min(ai, aj));
      }
    });
    if (sparse && stored < n - 1) min_entry = std::min(min_entry, 0.0);  // unstored entries are 0
    min_row = std::min(min_row, row);
    max_row = std::max(max_row, row);
  }
  c.min_entry = n == 1 ? 0.0 : min_entry;
  c.max_entry = max_entry;
  c.min_row_sum = min_row;
  c.max_row_sum = max_row;
  c.reciprocity_error = recip;
  return c;
}

}  // namespace photometria
