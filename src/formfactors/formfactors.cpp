#include "formfactors/formfactors.h"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <memory>

#include "formfactors/aligned_rectangles.h"
#include "formfactors/facing.h"
#include "formfactors/pair_integration.h"
#include "formfactors/quadrature.h"
#include "kernels/lambert.h"
#include "kernels/lambert_batch.h"

namespace photometria {

double plane_tolerance(const PatchMesh& mesh) {
  double m = 0.0;
  for (const Vec3& p : mesh.points) m = std::max(m, p.lpNorm<Eigen::Infinity>());
  return 1e-12 * std::max(m, 1e-300);
}

PolygonBatch patch_batch(const PatchMesh& mesh) {
  PolygonBatch batch;
  batch.reserve(mesh.size());
  Vec3 v[4];
  for (int j = 0; j < mesh.size(); ++j) {
    mesh.polygon(j, v);
    batch.push_back(v, mesh.patches[j].corner_count);
  }
  batch.share_edges();  // neighbouring patches share corners: each edge's term once per point
  return batch;
}

FormFactors fill_form_factors(const PatchMesh& mesh, const FillOptions& options, FillStats& stats) {
  const int n = mesh.size();
  FormFactors F(n, options.layout == MatrixLayout::Sparse ? MatrixLayout::Sparse : MatrixLayout::Dense, options.precision);
  const double tol = plane_tolerance(mesh);
  const Visibility* vis = options.visibility;
  const bool rays_mode = vis && vis->method() == VisibilityMethod::Rays;
  std::atomic<int> rows_done{0};
  long long evaluated = 0, backfacing = 0, tested = 0, culled = 0, occluded = 0, rays = 0, above = 0, rescaled = 0;
  long long fixed_rule = 0, gauss = 0, adaptive = 0, kernels = 0, exact_rectangles = 0;
  // Accuracy mode: every pair nothing can block (no visibility, or an empty shaft) gets the
  // per-pair rule, and pairs of aligned rectangles their closed form; blocked pairs the fixed rule.
  const bool per_pair = options.tolerance > 0.0;
  std::unique_ptr<AlignedRectangles> rects;
  if (per_pair && options.exact_rectangles) rects = std::make_unique<AlignedRectangles>(mesh);
  // Every patch as one SIMD batch: a receiver point's kernel to all sources in one call.
  const PolygonBatch sources = patch_batch(mesh);
  // Without visibility, a closed-form pair is computed once, from its lower-index patch, and the
  // other entry follows by reciprocity (dense storage: filled in place after the loop).
  const bool mirror = rects && !vis && F.layout() == MatrixLayout::Dense;
  double max_point_sum = 0.0;
  // The facing test per group of coplanar sources, so most pairs skip facing_away (facing.h).
  const FacingGroups facing_runs(mesh, tol);
  const bool prefetch = mesh.prefetch_pays() && !mirror;  // (mirrored rows read no patch records)

  std::vector<GroupedShaftCuller> grouped_cullers;
  std::vector<PointVisibility> point_visibility;  // one-point rules: visibility from the point (see below)
  if (vis) {
    grouped_cullers.assign(size_t(omp_get_max_threads()), GroupedShaftCuller(vis->culler(), mesh));
    for (int t = 0; t < omp_get_max_threads(); ++t) point_visibility.emplace_back(*vis, mesh);
  }

#pragma omp parallel for schedule(dynamic, 4) \
    reduction(+ : evaluated, backfacing, tested, culled, occluded, rays, above, rescaled, fixed_rule, gauss, adaptive, kernels, exact_rectangles) \
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
    // Shaft culling in a hierarchy (face, tile, patch; visibility.h); one per thread, reused across rows.
    GroupedShaftCuller* grouped = vis ? &grouped_cullers[size_t(omp_get_thread_num())] : nullptr;
    // With a one-point rule and no per-pair rule, visibility is taken from that point alone
    // (PointVisibility: the point's shafts, narrower than the patch's, and in exact mode one
    // clipping per tile of patches rather than per patch).
    const bool point_shafts = !per_pair && nq == 1;
    PointVisibility* from_point = vis && point_shafts ? &point_visibility[size_t(omp_get_thread_num())] : nullptr;
    if (from_point) from_point->set_receiver(Receiver{rule[0].point, pi.normal});
    else if (grouped) grouped->set_receiver(ri, pi.corner_count);
    using TileShadow = PointVisibility::TileShadow;
    // F_i,·: written in place into a dense double matrix (zero until now), else into a buffer.
    std::vector<double> row_buffer;
    double* row = F.dense_double_row(i);
    if (!row) {
      row_buffer.assign(size_t(n), 0.0);
      row = row_buffer.data();
    }
    // The facing classes of the row, on first need (closed-form pairs do not use them).
    std::vector<Facing> facing;
    auto classify_row = [&]() {
      if (facing.empty()) {
        facing.resize(static_cast<size_t>(n));
        facing_runs.classify(i, facing.data());
      }
    };
    // Lambert's kernel from each receiver point to every patch (nq × n), batched, on first need.
    std::vector<double> kernel;
    auto kernel_at = [&](int q, int j) {
      if (kernel.empty()) {
        kernel.resize(size_t(nq) * n);
        // Only for the sources that face the receiver: the others are never read, except that
        // closed-form pairs (which skip the facing test) may be read, so then for all.
        if (!rects) classify_row();
        for (int k = 0; k < nq; ++k) {
          const Receiver at{rule[k].point, pi.normal};
          double* out = kernel.data() + size_t(k) * n;
          if (rects) lambert_form_factors(at, sources, 0, n, out);
          else lambert_form_factors_facing(at, sources, facing.data(), out);
        }
      }
      return kernel[size_t(q) * n + j];
    };
    for (int j = 0; j < n; ++j) {
      if (prefetch) mesh.prefetch(j + 16);
      if (j == i) continue;
      const bool analytic = rects && rects->eligible(i, j);
      double area_factor = 0.0;
      if (analytic) {
        if (mirror && j < i) continue;  // from row j's entry after the loop (reciprocity)
        area_factor = rects->area_factor(i, j);  // 0 exactly when the pair cannot exchange light
        const int count = mirror ? 2 : 1;        // with mirroring this stands for (i, j) and (j, i)
        if (!(area_factor > 0.0)) { backfacing += count; continue; }
        if (mirror) {
          row[j] = area_factor / pi.area;
          evaluated += 2;
          exact_rectangles += 2;
          continue;
        }
      } else if (classify_row(); facing[size_t(j)] == Facing::Away ||
                                 (facing[size_t(j)] == Facing::Test && facing_away(mesh, i, j, tol))) {
        ++backfacing;
        continue;
      }
      const Patch& pj = mesh.patches[j];
      bool have_sj = false;  // P_j's corners, fetched only where needed (not for closed forms)
      auto source = [&]() {
        if (!have_sj) mesh.polygon(j, sj);
        have_sj = true;
        return sj;
      };
      bool shaft_known = false;
      if (per_pair) {
        if (vis) {
          source();
          ++tested;
          grouped->occluders(j, sj, pj.corner_count, occluders);
          shaft_known = true;
        }
        if (!vis || occluders.empty()) {
          culled += vis != nullptr;
          double f;
          if (analytic) {
            f = area_factor / pi.area;
            ++exact_rectangles;
          } else {
            const PairResult r = pair_form_factor(ri, pi.corner_count, pi.normal, source(), pj.corner_count, pj.normal,
                                                  options.tolerance);
            f = r.form_factor;
            kernels += r.evaluations;
            gauss += r.rule == PairRule::Gauss;
            adaptive += r.rule == PairRule::Adaptive;
          }
          ++evaluated;
          row[j] = f;
          for (int q = 0; q < nq; ++q) point_sum[q] += f;  // the pair's value stands in for each point's
          continue;
        }
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
                            : kernel_at(q, j);
        f0 += rule[q].weight * unoccluded[q];
      }
      ++evaluated;
      double f = f0;
      const TileShadow shadow = from_point && f0 > 0.0 ? from_point->tile_shadow(j) : TileShadow::Unknown;
      if (shadow == TileShadow::None) {
        ++tested, ++culled;  // the patch's tile is unshadowed: f stands, without the patch's corners
      } else if (shadow == TileShadow::Full) {
        ++tested, ++occluded;  // the patch's tile is hidden: f = 0, without the patch's corners
        f = unoccluded[0] = 0.0;
      } else if (from_point && f0 > 0.0) {
        ++tested;
        bool unshadowed = true;
        // Only rays use the pair's stream.
        const uint64_t stream = rays_mode ? pair_stream(pair_stream(options.seed, uint64_t(i), uint64_t(j)), 0, 0) : 0;
        const double v = from_point->visible(j, source(), pj.corner_count, pj.normal, unoccluded[0], options.rays,
                                             stream, rays, unshadowed);
        if (unshadowed) ++culled;
        if (rays_mode && !unshadowed) ray_part[size_t(j)] = v;
        unoccluded[0] = v;
        f = rule[0].weight * v;
        if (f == 0.0) ++occluded;
        if (f > f0) ++above;
      } else if (vis && f0 > 0.0) {
        if (!shaft_known) {
          ++tested;
          grouped->occluders(j, source(), pj.corner_count, occluders);
        }
        if (occluders.empty()) {
          ++culled;
        } else {
          f = 0.0;
          const uint64_t stream = pair_stream(options.seed, uint64_t(i), uint64_t(j));
          for (int q = 0; q < nq; ++q) {
            const double v = vis->point_to_patch(Receiver{rule[q].point, pi.normal}, source(), pj.corner_count, pj.normal,
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
    F.set_row(i, row);
    const int done = ++rows_done;
    if (options.progress && omp_get_thread_num() == 0) options.progress(double(done) / n);
  }
  if (mirror) {
    std::vector<double> areas(n);
    for (int i = 0; i < n; ++i) areas[i] = mesh.patches[i].area;
    F.mirror_lower([&](int i, int j) { return rects->eligible(i, j); }, areas.data());
    // The rows are complete only now; without visibility every point's sum is its row's sum.
    max_point_sum = 0.0;
#pragma omp parallel for schedule(static) reduction(max : max_point_sum)
    for (int i = 0; i < n; ++i) max_point_sum = std::max(max_point_sum, F.row_sum(i));
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
  stats.pairs_exact_rectangles += exact_rectangles;
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
  double min_entry = 1.0, max_entry = 0.0, recip = 0.0;
  std::vector<double> row_sums(size_t(n), 0.0);
  if (F.layout() == MatrixLayout::Dense) {
    // One pass over F in 64 × 64 tiles (I, J >= I), so that F_ji is read from a cached tile, not
    // a far row: each entry is read once, as F_ij or F_ji of a pair i < j or on the diagonal. A
    // dense matrix is read from memory once rather than twice (entries and row sums, then
    // reciprocity); the row sums gather per thread, a row's entries coming from many tiles.
    constexpr int kTile = 64;
    const int tiles = (n + kTile - 1) / kTile;
    std::vector<std::vector<double>> partial(static_cast<size_t>(omp_get_max_threads()));
#pragma omp parallel reduction(max : recip, max_entry) reduction(min : min_entry)
    {
      std::vector<double>& rows = partial[size_t(omp_get_thread_num())];
      rows.assign(size_t(n), 0.0);
#pragma omp for schedule(dynamic, 1)
      for (int bi = 0; bi < tiles; ++bi)
        for (int bj = bi; bj < tiles; ++bj) {
          const int i1 = std::min(n, (bi + 1) * kTile), j1 = std::min(n, (bj + 1) * kTile);
          for (int i = bi * kTile; i < i1; ++i) {
            const double ai = mesh.patches[i].area;
            if (bj == bi) rows[size_t(i)] += F(i, i);
            for (int j = std::max(i + 1, bj * kTile); j < j1; ++j) {
              const double aj = mesh.patches[j].area, fij = F(i, j), fji = F(j, i);
              rows[size_t(i)] += fij;
              rows[size_t(j)] += fji;
              min_entry = std::min(min_entry, std::min(fij, fji));
              max_entry = std::max(max_entry, std::max(fij, fji));
              recip = std::max(recip, std::abs(ai * fij - aj * fji) / std::min(ai, aj));
            }
          }
        }
    }
    for (const std::vector<double>& rows : partial)
      if (!rows.empty())
        for (int i = 0; i < n; ++i) row_sums[size_t(i)] += rows[size_t(i)];
  } else {
    // Sparse: entries and row sums row by row; reciprocity from each stored entry (a pair stored
    // only one way is seen from that side).
#pragma omp parallel for schedule(dynamic, 16) reduction(min : min_entry) reduction(max : max_entry, recip)
    for (int i = 0; i < n; ++i) {
      const double ai = mesh.patches[i].area;
      double row = 0.0;
      int stored = 0;
      F.for_each_in_row(i, [&](int j, double f) {
        row += f;
        if (j == i) return;
        ++stored;
        min_entry = std::min(min_entry, f);
        max_entry = std::max(max_entry, f);
        const double fji = F(j, i);
        if (j < i && fji != 0.0) return;  // counted from row j
        const double aj = mesh.patches[j].area;
        recip = std::max(recip, std::abs(ai * f - aj * fji) / std::min(ai, aj));
      });
      if (stored < n - 1) min_entry = std::min(min_entry, 0.0);  // unstored entries are 0
      row_sums[size_t(i)] = row;
    }
  }
  c.min_entry = n == 1 ? 0.0 : min_entry;
  c.max_entry = max_entry;
  c.min_row_sum = *std::min_element(row_sums.begin(), row_sums.end());
  c.max_row_sum = *std::max_element(row_sums.begin(), row_sums.end());
  c.reciprocity_error = recip;
  return c;
}

}  // namespace photometria
