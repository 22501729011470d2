#include "formfactors/formfactors.h"

#include <omp.h>

#include <algorithm>
#include <atomic>

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

FormFactorMatrix fill_form_factors(const PatchMesh& mesh, const FillOptions& options, FillStats& stats) {
  const int n = mesh.size();
  FormFactorMatrix F = FormFactorMatrix::Zero(n, n);
  const double tol = plane_tolerance(mesh);
  std::atomic<int> rows_done{0};
  long long evaluated = 0, backfacing = 0, occluded = 0, rays = 0;

#pragma omp parallel for schedule(dynamic, 4) reduction(+ : evaluated, backfacing, occluded, rays)
  for (int i = 0; i < n; ++i) {
    Vec3 ri[4], sj[4];
    mesh.polygon(i, ri);
    const Patch& pi = mesh.patches[i];
    const auto rule = patch_quadrature(ri, pi.corner_count, options.quadrature);
    for (int j = 0; j < n; ++j) {
      if (j == i || facing_away(mesh, i, j, tol)) { backfacing += (j != i); continue; }
      const Patch& pj = mesh.patches[j];
      mesh.polygon(j, sj);
      double f = 0.0;
      for (const QuadraturePoint& q : rule)
        f += q.weight * lambert_form_factor(Receiver{q.point, pi.normal}, sj, pj.corner_count);
      ++evaluated;
      if (options.visibility && f > 0.0) {
        // Sample the pair in index order so that V_ij == V_ji (reciprocity survives the rays).
        const bool ordered = i < j;
        const double v = options.visibility->patch_to_patch(
            ordered ? ri : sj, ordered ? pi.corner_count : pj.corner_count, ordered ? pi.normal : pj.normal,
            ordered ? sj : ri, ordered ? pj.corner_count : pi.corner_count, ordered ? pj.normal : pi.normal,
            options.rays, pair_stream(options.seed, std::min(i, j), std::max(i, j)));
        rays += options.rays;
        if (v == 0.0) ++occluded;
        f *= v;
      }
      F(i, j) = f;
    }
    const int done = ++rows_done;
    if (options.progress && omp_get_thread_num() == 0) options.progress(double(done) / n);
  }
  stats.pairs_evaluated += evaluated;
  stats.pairs_backfacing += backfacing;
  stats.pairs_occluded += occluded;
  stats.rays_cast += rays;
  return F;
}

}  // namespace photometria
