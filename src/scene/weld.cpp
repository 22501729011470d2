// Welding coincident vertices with a hash grid: expected O(n) instead of comparing all pairs.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <unordered_map>

#include "scene/loaders.h"

namespace photometria::scene_detail {
namespace {

struct Cell {
  std::int64_t x, y, z;
  bool operator==(const Cell&) const = default;
};

struct CellHash {
  size_t operator()(const Cell& c) const {
    // Large odd multipliers spread neighbouring cells over the table.
    const auto h = static_cast<std::uint64_t>(c.x) * 0x9E3779B97F4A7C15ull ^
                   static_cast<std::uint64_t>(c.y) * 0xC2B2AE3D27D4EB4Full ^
                   static_cast<std::uint64_t>(c.z) * 0x165667B19E3779F9ull;
    return static_cast<size_t>(h ^ (h >> 29));
  }
};

}  // namespace

std::vector<int> weld_points(const std::vector<Vec3>& points, const std::vector<bool>& used, double tolerance,
                             int& merged) {
  merged = 0;
  std::vector<int> map(points.size(), -1);
  const double inf = std::numeric_limits<double>::infinity();
  Vec3 lo = Vec3::Constant(inf), hi = Vec3::Constant(-inf);
  for (size_t i = 0; i < points.size(); ++i) {
    if (!used[i]) continue;
    lo = lo.cwiseMin(points[i]);
    hi = hi.cwiseMax(points[i]);
  }
  if (!(lo.array() <= hi.array()).all()) return map;  // no used point

  // Cells at least `tolerance` wide, so a partner lies in one of the 27 cells around a point;
  // never so small that cell numbers overflow (below 1e-12 of the extent welding is exact).
  const double extent = (hi - lo).maxCoeff();
  const double cell = std::max({tolerance, extent * 1e-12, 1e-300});
  auto cell_of = [&](const Vec3& p) {
    const Vec3 c = ((p - lo) / cell).array().floor();
    return Cell{static_cast<std::int64_t>(c.x()), static_cast<std::int64_t>(c.y()), static_cast<std::int64_t>(c.z())};
  };

  std::unordered_map<Cell, std::vector<int>, CellHash> grid;  // cell -> points kept (not welded away)
  for (size_t i = 0; i < points.size(); ++i) {
    if (!used[i]) continue;
    const Cell c = cell_of(points[i]);
    int partner = -1;
    for (std::int64_t dx = -1; dx <= 1; ++dx)
      for (std::int64_t dy = -1; dy <= 1; ++dy)
        for (std::int64_t dz = -1; dz <= 1; ++dz) {
          const auto it = grid.find({c.x + dx, c.y + dy, c.z + dz});
          if (it == grid.end()) continue;
          for (int j : it->second)
            if ((partner < 0 || j < partner) && (points[static_cast<size_t>(j)] - points[i]).norm() <= tolerance)
              partner = j;
        }
    if (partner >= 0) {
      map[i] = partner;
      ++merged;
    } else {
      map[i] = static_cast<int>(i);
      grid[c].push_back(static_cast<int>(i));
    }
  }
  return map;
}

}  // namespace photometria::scene_detail
