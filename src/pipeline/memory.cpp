#include "pipeline/memory.h"

#include <algorithm>
#include <cctype>
#include <climits>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <random>
#include <sstream>
#include <vector>

#include "formfactors/formfactors.h"
#include "pipeline/solve.h"
#include "util/error.h"

namespace photometria {
namespace {

constexpr long long kSamples = 16384;

// Bytes per patch besides the matrix. Counted from the arrays solve_scene, the solver and the
// .vtu writer allocate; output points are at most 4 per patch (one per corner when every corner
// is split), which is what is assumed.
double per_patch_bytes() {
  const double rgb = 3 * sizeof(double);
  const double patch = sizeof(Patch) + sizeof(Vec3);  // patch + about one shared point
  const double channels = 6 * rgb;                    // emission, reflectance, radiosity, irradiance, direct, F·B
  const double solver = 5 * sizeof(double) + sizeof(double);  // per-channel vectors + row sums
  const double cell = sizeof(std::vector<int>) + 4 * sizeof(int);
  const double point = sizeof(OutputPoint) + 2 * rgb  // point irradiance, radiosity
                       + sizeof(Vec3) + 2 * rgb;      // the .vtu copy of them
  const double vtu_cell = cell + 4 * sizeof(long long) + 4 * rgb + 3 * sizeof(double);
  return patch + channels + solver + cell + 4 * point + vtu_cell;
}

// A patch as the facing test sees it.
struct PatchShape {
  Vec3 corners[4];
  int corner_count = 0;
  Vec3 normal;    // unit front normal
  Vec3 centroid;  // area centroid
};

// formfactors.h facing_away, on shapes: true when neither patch is in front of the other.
bool shapes_face_away(const PatchShape& a, const PatchShape& b, double tol) {
  double above_a = -1.0, front_of_b = -1.0;
  for (int k = 0; k < b.corner_count; ++k) above_a = std::max(above_a, a.normal.dot(b.corners[k] - a.centroid));
  if (above_a <= tol) return true;
  for (int k = 0; k < a.corner_count; ++k) front_of_b = std::max(front_of_b, b.normal.dot(a.corners[k] - b.centroid));
  return front_of_b <= tol;
}

// The estimate for n patches, `shape_of(i)` giving patch i: every ordered pair tested when
// there are at most kSamples, else kSamples random pairs (the same sequence for the same n and
// seed, whichever way the patches are given).
template <class ShapeOf>
MemoryEstimate estimate_from(long long n, double tol, uint64_t seed, const ShapeOf& shape_of) {
  MemoryEstimate e;
  e.patches = static_cast<int>(n);
  e.pairs_total = n * (n - 1);
  if (n >= 2) {
    if (e.pairs_total <= kSamples) {
      std::vector<PatchShape> shapes;
      for (int i = 0; i < n; ++i) shapes.push_back(shape_of(i));
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j)
          if (i != j && !shapes_face_away(shapes[size_t(i)], shapes[size_t(j)], tol)) ++e.nonzero_pairs;
    } else {
      std::mt19937_64 rng(seed);
      std::uniform_int_distribution<int> pick(0, static_cast<int>(n) - 1);
      long long hits = 0;
      for (long long s = 0; s < kSamples; ++s) {
        const int i = pick(rng);
        int j = pick(rng);
        while (j == i) j = pick(rng);
        if (!shapes_face_away(shape_of(i), shape_of(j), tol)) ++hits;
      }
      e.nonzero_pairs = std::llround(double(hits) / double(kSamples) * double(e.pairs_total));
    }
  }
  e.per_patch_bytes = per_patch_bytes();
  const double rest = e.per_patch_bytes * double(n);
  e.dense_bytes = double(n) * double(n) * sizeof(double) + rest;
  e.sparse_bytes =
      double(e.nonzero_pairs) * (sizeof(double) + sizeof(int32_t)) + double(n + 1) * sizeof(int64_t) + rest;
  return e;
}

}  // namespace

MemoryEstimate estimate_memory(const PatchMesh& mesh, uint64_t seed) {
  return estimate_from(mesh.size(), plane_tolerance(mesh), seed, [&](int i) {
    const Patch& p = mesh.patches[size_t(i)];
    PatchShape s;
    s.corner_count = p.corner_count;
    mesh.polygon(i, s.corners);
    s.normal = p.normal;
    s.centroid = p.centroid;
    return s;
  });
}

MemoryEstimate estimate_memory(const Scene& scene, const PatchGrid& grid, uint64_t seed) {
  if (!grid.fits_int()) {
    // Beyond what a mesh can index: every figure from the counts alone (no pair is sampled;
    // dense and sparse are both far above any machine's memory).
    MemoryEstimate e;
    e.patches = INT_MAX;
    e.per_patch_bytes = per_patch_bytes();
    const double n = grid.patches, rest = e.per_patch_bytes * n;
    e.pairs_total = LLONG_MAX;
    e.nonzero_pairs = LLONG_MAX;
    e.dense_bytes = n * n * sizeof(double) + rest;
    e.sparse_bytes = e.dense_bytes;
    return e;
  }
  const ImplicitPatches patches(scene, grid);
  double extent = 0.0;  // plane_tolerance's: the mesh's points are the scene's vertices and points between them
  for (const Vec3& v : scene.vertices) extent = std::max(extent, v.lpNorm<Eigen::Infinity>());
  const double tol = 1e-12 * std::max(extent, 1e-300);
  std::vector<Vec3> face_normal(scene.faces.size());
  for (size_t f = 0; f < scene.faces.size(); ++f)
    if (!scene.faces[f].obstruction_only) face_normal[f] = polygon_normal(scene.face_polygon(static_cast<int>(f)));
  return estimate_from(patches.size(), tol, seed, [&](int i) {
    const ImplicitPatch p = patches[i];
    PatchShape s;
    s.corner_count = p.corner_count;
    std::copy(p.corners, p.corners + p.corner_count, s.corners);
    s.normal = face_normal[size_t(p.face)];
    Polygon poly(p.corners, p.corners + p.corner_count);
    s.centroid = polygon_centroid(poly);
    return s;
  });
}

StorageChoice choose_storage(MatrixLayout layout, MatrixPrecision precision, double n, double nonzeros,
                             double other_bytes, double max_memory_bytes) {
  StorageChoice c;
  c.limit_bytes = max_memory_bytes > 0 ? max_memory_bytes : available_memory_bytes();
  c.limit_source = max_memory_bytes > 0 ? "--max-memory" : "MemAvailable";
  auto fits = [&](MatrixPrecision p) {
    const MatrixLayout l = choose_layout(layout, p, n, nonzeros);
    return c.limit_bytes <= 0 || matrix_bytes(l, p, n, nonzeros) + other_bytes <= c.limit_bytes;
  };
  c.precision = precision;
  if (precision == MatrixPrecision::Auto)
    c.precision = fits(MatrixPrecision::Double) || !fits(MatrixPrecision::Float) ? MatrixPrecision::Double
                                                                                 : MatrixPrecision::Float;
  c.layout = choose_layout(layout, c.precision, n, nonzeros);
  c.storage = std::string(layout_name(c.layout)) + " " + precision_name(c.precision);
  std::ostringstream why;
  if (layout != MatrixLayout::Auto) why << "requested (--matrix " << layout_name(c.layout) << ")";
  else
    why << "auto: " << std::setprecision(3) << (n > 1 ? 100.0 * nonzeros / (n * (n - 1)) : 0.0)
        << "% of pairs face each other, so " << layout_name(c.layout) << " is smaller";
  if (precision == MatrixPrecision::Auto && c.precision == MatrixPrecision::Float)
    why << "; float entries, because double ("
        << format_bytes(matrix_bytes(choose_layout(layout, MatrixPrecision::Double, n, nonzeros),
                                     MatrixPrecision::Double, n, nonzeros) +
                        other_bytes)
        << " in all) would exceed " << c.limit_source << " (" << format_bytes(c.limit_bytes) << ")";
  c.reason = why.str();
  c.matrix_bytes = matrix_bytes(c.layout, c.precision, n, nonzeros);
  c.estimated_bytes = c.matrix_bytes + other_bytes;
  c.fits = c.limit_bytes <= 0 || c.estimated_bytes <= c.limit_bytes;
  return c;
}

StorageChoice check_storage(const MemoryEstimate& estimate, double patches, double extra_bytes, MatrixLayout layout,
                            MatrixPrecision precision, double max_memory_bytes, const std::string& subject,
                            const std::string& what_else, const std::string& more_ways) {
  const StorageChoice c = choose_storage(layout, precision, patches, double(estimate.nonzero_pairs),
                                         estimate.per_patch_bytes * patches + extra_bytes, max_memory_bytes);
  if (c.fits) return c;
  std::string ways = "raise --max-edge";
  if (c.precision == MatrixPrecision::Double) ways += ", try --matrix-precision float";
  if (!more_ways.empty()) ways += ", " + more_ways;
  throw_bad_input(subject + " " + format_bytes(c.estimated_bytes) + " for " + format_patch_count(patches) +
                  " patches (" + c.storage + " form factors" + what_else + ") but " + c.limit_description() + "; " +
                  ways + " or raise --max-memory");
}

std::string memory_limit_description(double limit_bytes, const std::string& limit_source) {
  return limit_source == "--max-memory" ? "--max-memory is " + format_bytes(limit_bytes)
                                        : "only " + format_bytes(limit_bytes) + " is available (" + limit_source +
                                              "; set --max-memory to override)";
}

std::string StorageChoice::limit_description() const { return memory_limit_description(limit_bytes, limit_source); }

double available_memory_bytes() {
  std::ifstream in("/proc/meminfo");
  std::string key, unit;
  double value = 0;
  while (in >> key >> value) {
    std::getline(in, unit);
    if (key == "MemAvailable:") return value * 1024.0;  // reported in kB (kibibytes)
  }
  return 0.0;
}

std::string format_bytes(double bytes) {
  static const char* units[] = {"bytes", "KiB", "MiB", "GiB", "TiB", "PiB"};
  int u = 0;
  while (bytes >= 1024.0 && u < 5) {
    bytes /= 1024.0;
    ++u;
  }
  char buf[32];
  if (u == 0) std::snprintf(buf, sizeof buf, "%.0f bytes", bytes);
  else if (bytes < 10) std::snprintf(buf, sizeof buf, "%.1f %s", bytes, units[u]);
  else std::snprintf(buf, sizeof buf, "%.0f %s", bytes, units[u]);
  std::string s = buf;
  // "1.0 GiB" reads better as "1 GiB".
  const size_t dot0 = s.find(".0 ");
  if (dot0 != std::string::npos) s.erase(dot0, 2);
  return s;
}

std::string format_patch_count(double patches) {
  if (patches < 1e15) return format_count(std::llround(patches));
  char text[32];
  std::snprintf(text, sizeof text, "%.3g", patches);
  return text;
}

std::string format_count(long long n) {
  std::string digits = std::to_string(n < 0 ? -n : n), out;
  for (size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) out += ',';
    out += digits[i];
  }
  return (n < 0 ? "-" : "") + out;
}

bool parse_memory_size(const std::string& text, double& bytes) {
  size_t used = 0;
  double x = 0;
  try {
    x = std::stod(text, &used);
  } catch (const std::exception&) { return false; }
  std::string unit = text.substr(used);
  std::transform(unit.begin(), unit.end(), unit.begin(), [](unsigned char c) { return std::toupper(c); });
  double scale = 1;
  if (!unit.empty() && unit != "B") {
    const std::string prefixes = "KMGT";
    const size_t p = prefixes.find(unit[0]);
    const std::string rest = unit.substr(1);
    if (p == std::string::npos || !(rest.empty() || rest == "B" || rest == "IB")) return false;
    scale = std::pow(1024.0, double(p + 1));
  }
  bytes = x * scale;
  return std::isfinite(bytes) && bytes > 0;
}

}  // namespace photometria
