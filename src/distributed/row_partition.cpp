// Rows split over ranks along the Morton curve, balanced by cost (row_partition.h).
#include "distributed/row_partition.h"

#include <algorithm>
#include <cstdint>
#include <numeric>

#include "formfactors/formfactors.h"

namespace photometria {

namespace {

// The 21 low bits of v spread to every third bit (a 63-bit Morton key per point).
uint64_t spread_bits(uint64_t v) {
  v &= 0x1fffff;
  v = (v | v << 32) & 0x1f00000000ffffULL;
  v = (v | v << 16) & 0x1f0000ff0000ffULL;
  v = (v | v << 8) & 0x100f00f00f00f00fULL;
  v = (v | v << 4) & 0x10c30c30c30c30c3ULL;
  v = (v | v << 2) & 0x1249249249249249ULL;
  return v;
}

constexpr double kCells = double((1 << 21) - 1);  // quantisation steps per axis

}  // namespace

std::vector<int> morton_order(const std::vector<Vec3>& points) {
  const size_t n = points.size();
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  if (n == 0) return order;
  Eigen::AlignedBox3d box;
  for (const Vec3& p : points) box.extend(p);
  const Vec3 extent = box.sizes().cwiseMax(1e-300);
  std::vector<uint64_t> key(n);
  for (size_t i = 0; i < n; ++i) {
    const Vec3 u = ((points[i] - box.min()).array() / extent.array()).matrix() * kCells;
    const auto q = [](double x) { return uint64_t(std::clamp(x, 0.0, kCells)); };
    key[i] = spread_bits(q(u.x())) | spread_bits(q(u.y())) << 1 | spread_bits(q(u.z())) << 2;
  }
  std::sort(order.begin(), order.end(),
            [&](int a, int b) { return key[size_t(a)] != key[size_t(b)] ? key[size_t(a)] < key[size_t(b)] : a < b; });
  return order;
}

std::vector<double> estimate_row_costs(const PatchMesh& mesh) {
  const int n = mesh.size();
  std::vector<double> cost(size_t(n), 1.0);
  if (n == 0) return cost;
  const int sample = std::min(n, kCostSample);
  const double tol = plane_tolerance(mesh);
#pragma omp parallel for schedule(static)
  for (int i = 0; i < n; ++i) {
    int facing = 0;
    for (int s = 0; s < sample; ++s) {
      const int j = int((long long)s * n / sample);  // an even sample, the same for every row
      if (j != i && !facing_away(mesh, i, j, tol)) ++facing;
    }
    cost[size_t(i)] += double(facing) * n / sample;
  }
  return cost;
}

std::vector<std::vector<int>> partition_rows(const std::vector<Vec3>& centroids, const std::vector<double>& costs,
                                             int parts, int chunks_per_part) {
  parts = std::max(parts, 1);
  const int chunks = parts * std::max(chunks_per_part, 1);
  std::vector<std::vector<int>> out(static_cast<size_t>(parts));
  const std::vector<int> order = morton_order(centroids);
  const double total = std::accumulate(costs.begin(), costs.end(), 0.0);
  double before = 0.0;  // the cost of the rows before this one along the curve
  for (int i : order) {
    // The chunk whose share of the total holds this row's midpoint along the running cost; the
    // chunks go to the parts in turn.
    const double middle = before + 0.5 * costs[size_t(i)];
    const int chunk = total > 0.0 ? std::min(chunks - 1, int(middle / total * chunks)) : 0;
    out[size_t(chunk % parts)].push_back(i);
    before += costs[size_t(i)];
  }
  return out;
}

}  // namespace photometria
