#include "pipeline/solve.h"

#include <omp.h>
#include <sys/resource.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <map>
#include <memory>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <tuple>

#include "distributed/distributed_gmres.h"
#include "distributed/fill_stats.h"
#include "distributed/ranks.h"
#include "distributed/row_partition.h"
#include "formfactors/facing.h"
#include "formfactors/point_factors.h"
#include "formfactors/quadrature.h"
#include "kernels/lambert.h"
#include "kernels/lambert_batch.h"
#include "pipeline/direct_light.h"
#include "solver/block_gauss_seidel.h"
#include "util/error.h"
#include "util/huge_pages.h"
#include "util/per_thread.h"

namespace photometria {

double peak_memory_bytes() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return double(usage.ru_maxrss) * 1024.0;  // Linux reports kilobytes
}

namespace {

class StageTimer {
 public:
  explicit StageTimer(SolveSummary& s) : summary_(s), start_(std::chrono::steady_clock::now()) {}
  void lap(const std::string& stage) {
    const auto now = std::chrono::steady_clock::now();
    summary_.stage_seconds.emplace_back(stage, std::chrono::duration<double>(now - start_).count());
    start_ = now;
  }

 private:
  SolveSummary& summary_;
  std::chrono::steady_clock::time_point start_;
};

// The patch count, area range and total, and pair count of r.mesh into the summary.
void record_patches(SolveResult& r) {
  SolveSummary& s = r.summary;
  s.patches = r.mesh.size();
  s.min_patch_area = r.mesh.size() ? r.mesh.patches[0].area : 0.0;
  s.max_patch_area = 0.0;
  s.total_area = 0.0;
  for (const Patch& p : r.mesh.patches) {
    s.min_patch_area = std::min(s.min_patch_area, p.area);
    s.max_patch_area = std::max(s.max_patch_area, p.area);
    s.total_area += p.area;
  }
  s.pairs_total = (long long)s.patches * (s.patches - 1);
}

void fill_materials(const Scene& scene, SolveResult& r) {
  const int n = r.mesh.size();
  r.emission.resize(n, 3);
  r.reflectance.resize(n, 3);
  for (int i = 0; i < n; ++i) {
    const Material& m = scene.materials[scene.faces[r.mesh.patches[i].face].material];
    r.emission.row(i) = m.emission.matrix().transpose();
    r.reflectance.row(i) = m.reflectance.matrix().transpose();
  }
}

// Two shading normals from the file (unit vectors) count as equal within this distance (about
// 0.00006°): vn meant as one normal (the same vn line, or the same corners' vn interpolated along
// an edge from either face) agree to rounding, far closer than any crease the file means.
constexpr double kSameVertexNormal = 1e-6;

// The shading normal the file gives (OBJ vn, Face::corner_normals) at patch p's corner k, or
// zero when it gives none there. At a face's vertex it is that corner's vn; elsewhere on the
// face (patch corners on its edges or inside it) the corners' vn interpolated as Phong shading
// does (Bui Tuong Phong, "Illumination for computer generated pictures", Commun. ACM 18(6),
// 1975), with mean value coordinates (Floater, "Mean value coordinates", Computer Aided
// Geometric Design 20(1), 2003, eq. (5.1): w_i = (tan(α_{i-1}/2) + tan(α_i/2)) / |v_i − x|,
// α_i the angle at x between v_i and v_{i+1}), which are the barycentric coordinates on a
// triangle and linear along every edge, so two faces sharing an edge interpolate alike along it.
// A vn pointing into the back of the face (n · face normal <= 0: a file whose vn disagree with
// its winding; flipping negates the vn with the face, Face::reverse) is not usable as a shading
// normal there (the point would look into the surface and its own patches' gap would be
// meaningless): the patch corners it touches count as having no vn, and the smoothing groups or
// the crease angle decide.
Vec3 given_normal(const Scene& scene, const PatchMesh& mesh, const Patch& p, int k) {
  const Face& f = scene.faces[size_t(p.face)];
  if (f.corner_normals.empty()) return Vec3::Zero();
  const Vec3& x = mesh.points[size_t(p.corners[size_t(k)])];
  const size_t n = f.vertices.size();
  std::array<double, 8> w{};  // faces are triangles or quads after loading
  if (n > w.size()) return Vec3::Zero();
  auto vertex = [&](size_t i) -> const Vec3& { return scene.vertices[size_t(f.vertices[i % n])]; };
  double diameter = 0.0;
  for (size_t i = 0; i < n; ++i) diameter = std::max(diameter, (vertex(i + 1) - vertex(i)).norm());
  const double eps = 1e-9 * diameter;
  bool placed = false;
  for (size_t i = 0; i < n && !placed; ++i)  // at a vertex
    if ((x - vertex(i)).norm() <= eps) w[i] = 1.0, placed = true;
  for (size_t i = 0; i < n && !placed; ++i) {  // on an edge: linear along it
    const Vec3 e = vertex(i + 1) - vertex(i);
    const double t = (x - vertex(i)).dot(e) / e.squaredNorm();
    if (t > 0.0 && t < 1.0 && (x - vertex(i) - t * e).norm() <= eps) w[i] = 1.0 - t, w[(i + 1) % n] = t, placed = true;
  }
  if (!placed) {  // inside: mean value coordinates
    double sum = 0.0;
    for (size_t i = 0; i < n; ++i) {
      const Vec3 a = vertex(i + n - 1) - x, b = vertex(i) - x, c = vertex(i + 1) - x;
      // tan(α/2) = |u × v| / (|u||v| + u · v)
      auto tan_half = [](const Vec3& u, const Vec3& v) { return u.cross(v).norm() / (u.norm() * v.norm() + u.dot(v)); };
      w[i] = (tan_half(a, b) + tan_half(b, c)) / b.norm();
      sum += w[i];
    }
    if (!(sum > 0.0) || !std::isfinite(sum)) return Vec3::Zero();
    for (size_t i = 0; i < n; ++i) w[i] /= sum;
  }
  Vec3 normal = Vec3::Zero();
  for (size_t i = 0; i < n; ++i) {
    if (w[i] <= 0.0) continue;
    const Vec3& vn = f.corner_normals[i];
    if (!(vn.dot(p.normal) > 0.0)) return Vec3::Zero();  // no vn at that corner, or into the face's back
    normal += w[i] * vn;
  }
  // A convex combination of vectors in the face's front half-space stays there.
  return normal.norm() > 1e-12 ? Vec3(normal.normalized()) : Vec3(Vec3::Zero());
}

// Whether the corners of patches a and b at one vertex share an output point (solve.h
// SolveOptions::crease_angle_degrees): the same material, and then (the first rule that applies)
// the same face; where both corners carry a vn from the file (given_normal; zero = none), equal
// vn; the same plane; the same nonzero smoothing group where the file gave groups; normals
// within the crease angle.
bool smooth_across(const Scene& scene, const Patch& a, const Patch& b, const Vec3& vn_a, const Vec3& vn_b,
                   double cos_crease) {
  const Face &fa = scene.faces[size_t(a.face)], &fb = scene.faces[size_t(b.face)];
  if (fa.material != fb.material) return false;
  if (a.face == b.face) return true;
  if (!vn_a.isZero(0.0) && !vn_b.isZero(0.0)) return (vn_a - vn_b).norm() <= kSameVertexNormal;
  const double cos_ab = a.normal.dot(b.normal);
  if (cos_ab > 1.0 - 1e-9) return true;
  if (fa.smoothing_group >= 0 && fb.smoothing_group >= 0)
    return fa.smoothing_group > 0 && fa.smoothing_group == fb.smoothing_group;
  return cos_ab >= cos_crease;
}

// The interior angle of patch p at its corner k, radians.
double corner_angle(const PatchMesh& mesh, const Patch& p, int k) {
  const Vec3& v = mesh.points[size_t(p.corners[size_t(k)])];
  const Vec3 prev = mesh.points[size_t(p.corners[size_t((k + p.corner_count - 1) % p.corner_count)])] - v;
  const Vec3 next = mesh.points[size_t(p.corners[size_t((k + 1) % p.corner_count)])] - v;
  return std::atan2(prev.cross(next).norm(), prev.dot(next));
}

// Output points: at each patch vertex, the corners of the patches there are joined into clusters
// (smooth_across, closed transitively: a smooth fan is one cluster, a cube corner three), one
// point per cluster. Two clusters whose corners carry different vn are not joined through corners
// without one: the file's vn win over the angle and the groups. The point's normal is the file's
// vn where every corner of the cluster carries one (their normalised mean: they agree to
// kSameVertexNormal), else the angle-weighted mean of the cluster's patch normals,
// n = normalize(Σ α_i n_i) with α_i the patch's interior angle at the vertex (Thürmer & Wüthrich,
// "Computing vertex normals from polygonal facets", J. Graphics Tools 3(1), 1998): it does not
// depend on how the faces around the vertex are split into triangles.
void split_output_points(const Scene& scene, double crease_angle_degrees, SolveResult& r) {
  const PatchMesh& mesh = r.mesh;
  const double cos_crease = crease_angle_degrees > 0.0 ? std::cos(crease_angle_degrees * M_PI / 180.0) : 2.0;
  std::vector<std::vector<std::pair<int, int>>> at_vertex(mesh.points.size());  // (patch, corner)
  r.cells.assign(size_t(mesh.size()), {});
  for (int i = 0; i < mesh.size(); ++i) {
    const Patch& p = mesh.patches[size_t(i)];
    r.cells[size_t(i)].assign(size_t(p.corner_count), -1);
    for (int k = 0; k < p.corner_count; ++k) at_vertex[size_t(p.corners[size_t(k)])].emplace_back(i, k);
  }
  std::vector<int> parent;
  std::vector<Vec3> vn, cluster_vn;  // per corner at the vertex: its vn; per root: its cluster's (zero = none)
  for (size_t v = 0; v < at_vertex.size(); ++v) {
    const auto& corners = at_vertex[v];
    const int n = static_cast<int>(corners.size());
    parent.resize(size_t(n));
    vn.resize(size_t(n));
    for (int a = 0; a < n; ++a) {
      parent[size_t(a)] = a;
      vn[size_t(a)] =
          given_normal(scene, mesh, mesh.patches[size_t(corners[size_t(a)].first)], corners[size_t(a)].second);
    }
    cluster_vn = vn;
    auto root = [&](int a) {
      while (parent[size_t(a)] != a) a = parent[size_t(a)] = parent[size_t(parent[size_t(a)])];
      return a;
    };
    for (int a = 0; a < n; ++a)
      for (int b = a + 1; b < n; ++b) {
        const int ra = root(a), rb = root(b);
        if (ra == rb ||
            !smooth_across(scene, mesh.patches[size_t(corners[size_t(a)].first)],
                           mesh.patches[size_t(corners[size_t(b)].first)], vn[size_t(a)], vn[size_t(b)], cos_crease))
          continue;
        const Vec3 &na = cluster_vn[size_t(ra)], &nb = cluster_vn[size_t(rb)];
        if (!na.isZero(0.0) && !nb.isZero(0.0) && (na - nb).norm() > kSameVertexNormal) continue;
        parent[size_t(ra)] = rb;
        if (nb.isZero(0.0)) cluster_vn[size_t(rb)] = na;
      }
    for (int a = 0; a < n; ++a) {
      if (root(a) != a) continue;
      Vec3 normal_sum = Vec3::Zero(), vn_sum = Vec3::Zero(), approach_sum = Vec3::Zero();
      bool all_vn = true;
      const int o = static_cast<int>(r.points.size());
      int material = 0;
      for (int b = 0; b < n; ++b) {
        if (root(b) != a) continue;
        const auto [i, k] = corners[size_t(b)];
        const Patch& p = mesh.patches[size_t(i)];
        normal_sum += corner_angle(mesh, p, k) * p.normal;
        vn_sum += vn[size_t(b)];
        all_vn = all_vn && !vn[size_t(b)].isZero(0.0);
        approach_sum += p.centroid - mesh.points[v];
        material = scene.faces[size_t(p.face)].material;
        r.cells[size_t(i)][size_t(k)] = o;
      }
      // A cluster whose normals cancel (a two-sided sheet in one smoothing group) keeps one of them.
      const Vec3 normal = all_vn                      ? Vec3(vn_sum.normalized())
                          : normal_sum.norm() > 1e-12 ? Vec3(normal_sum.normalized())
                                                      : mesh.patches[size_t(corners[size_t(a)].first)].normal;
      const Vec3 u = approach_sum - approach_sum.dot(normal) * normal;
      r.points.push_back({mesh.points[v], normal, u.norm() > 0 ? Vec3(u.normalized()) : Vec3::Zero(), material});
    }
  }
}

// The part of x's hemisphere (normal `normal`) between its tangent plane and the plane of patch
// `patch`, one of x's own patches with x at a corner, within that corner's wedge: the directions
// that leave the tessellated surface there when the smoothed normal tilts the patch above x's
// horizon (a concave surface). Seen from x they lead into the patch's side of the surface, so
// they take the patch's radiosity; without them a smooth point's factors would not sum to 1 in a
// closed enclosure. As a form factor, Lambert's formula F = (1/2π) Σ_k Θ_k (n · Γ̂_k) (Lambert
// 1760; Stark, "Vertex-Based Formulations of Irradiance from Polygonal Sources", UUCS-00-012,
// 2000, eq. (3); kernels/lambert.h) over the edges of the region's outline, as unit directions.
// 0 when the patch lies in or below the tangent plane.
double own_patch_gap(const PatchMesh& mesh, int patch, const Vec3& x, const Vec3& normal) {
  const Patch& p = mesh.patches[size_t(patch)];
  if (p.normal.dot(normal) > 1.0 - 1e-9) return 0.0;  // x's tangent plane is the patch's
  const int n = p.corner_count;
  int k = 0;
  while (k < n && mesh.points[size_t(p.corners[size_t(k)])] != x) ++k;
  if (k == n) return 0.0;
  const Vec3 e1 = (mesh.points[size_t(p.corners[size_t((k + 1) % n)])] - x).normalized();
  const Vec3 e2 = (mesh.points[size_t(p.corners[size_t((k + n - 1) % n)])] - x).normalized();
  const double h1 = normal.dot(e1), h2 = normal.dot(e2);
  const auto on_horizon = [&](const Vec3& d) { return Vec3(d - normal.dot(d) * normal); };
  Vec3 d[4];
  int m = 0;
  if (h1 > 0 && h2 > 0) {
    d[m++] = e1, d[m++] = e2, d[m++] = on_horizon(e2), d[m++] = on_horizon(e1);
  } else if (h1 > 0 || h2 > 0) {
    const Vec3& up = h1 > 0 ? e1 : e2;
    const Vec3 crossing = e1 + h1 / (h1 - h2) * (e2 - e1);  // where the patch's edge arc meets the horizon
    d[m++] = up, d[m++] = crossing, d[m++] = on_horizon(up);
  } else {
    return 0.0;
  }
  double sum = 0.0;
  for (int i = 0; i < m; ++i) {
    const Vec3 c = d[i].cross(d[(i + 1) % m]);
    const double len = c.norm();
    if (len > 0) sum += std::atan2(len, d[i].dot(d[(i + 1) % m])) * normal.dot(c) / len;
  }
  return std::abs(sum) / (2.0 * M_PI);
}

// H(x) = Σ_j F_vis(dA_x -> P_j) B_j at every output point (Baum et al. 1989), with the same
// shaft culling and visibility method as the fill (visibility/visibility.h).
void gather_at_points(const Scene& scene, const Visibility* vis, const DirectLighting& direct, const SolveOptions& opt,
                      SolveResult& r) {
  const PatchMesh& mesh = r.mesh;
  const int np = static_cast<int>(r.points.size());
  const double tol = plane_tolerance(mesh);
  r.point_irradiance = ChannelMatrix::Zero(np, 3);
  r.point_radiosity = ChannelMatrix::Zero(np, 3);
  long long evaluated = 0, rays = 0, tested = 0, culled = 0;
  // Every patch as one SIMD batch: a point's kernel to all patches in one call (lambert_batch.h).
  const PolygonBatch sources = patch_batch(mesh);
  // The facing test per group of coplanar sources (formfactors/facing.h).
  const FacingGroups facing_runs(mesh, tol);
  // The factors from each point (formfactors/point_factors.h): one per thread.
  PerThread<PointFactors> point_factors(
      [&] { return std::make_unique<PointFactors>(mesh, sources, facing_runs, vis, tol, opt.rays); });
  // Points at one position (split at a crease or a material change) in a row, handled by one
  // thread: the visibility from a position is computed once (PointVisibility::set_receiver).
  std::vector<int> order(size_t(np), 0), group_start;
  for (int o = 0; o < np; ++o) order[size_t(o)] = o;
  auto position_less = [&](int a, int b) {
    const Vec3 &pa = r.points[size_t(a)].position, &pb = r.points[size_t(b)].position;
    return std::tie(pa.x(), pa.y(), pa.z(), a) < std::tie(pb.x(), pb.y(), pb.z(), b);
  };
  std::sort(order.begin(), order.end(), position_less);
  // Each point's own patches (those whose cells name it), as one list per point.
  std::vector<int> own_start(size_t(np) + 1, 0), own_patches;
  for (const std::vector<int>& cell : r.cells)
    for (int o : cell) ++own_start[size_t(o) + 1];
  for (int o = 0; o < np; ++o) own_start[size_t(o) + 1] += own_start[size_t(o)];
  own_patches.resize(size_t(own_start[size_t(np)]));
  {
    std::vector<int> fill(own_start.begin(), own_start.end() - 1);
    for (int i = 0; i < static_cast<int>(r.cells.size()); ++i)
      for (int o : r.cells[size_t(i)]) own_patches[size_t(fill[size_t(o)]++)] = i;
  }
  for (int k = 0; k < np; ++k)
    if (k == 0 || r.points[size_t(order[size_t(k)])].position != r.points[size_t(order[size_t(k - 1)])].position)
      group_start.push_back(k);
  group_start.push_back(np);
  const int groups = static_cast<int>(group_start.size()) - 1;
  std::atomic<int> groups_done{0};
  // On MPI ranks each rank gathers every R-th group (neighbouring points cost alike, so dealt in
  // turn they balance), and the results are summed over the ranks below.
  const int parts = ranks::size(), part = ranks::rank();
#pragma omp parallel for schedule(dynamic, 16) reduction(+ : evaluated, rays, tested, culled)
  for (int g = 0; g < groups; ++g) {
    if (g % parts != part) continue;
    PointFactors& factors = point_factors.local();
    PointFactors::Counts counts;
    for (int k = group_start[size_t(g)]; k < group_start[size_t(g) + 1]; ++k) {
      const int o = order[size_t(k)];
      const OutputPoint& x = r.points[o];
      Eigen::RowVector3d h = Eigen::RowVector3d::Zero();
      const Receiver receiver{x.position, x.normal, x.approach};
      // Only rays use the pair's stream.
      auto stream_of = [&](int j) { return pair_stream(opt.seed ^ 0x5eedULL, uint64_t(o), uint64_t(j)); };
      // The point's own patches (its cluster) are the surface it lies on: not sources (with a
      // smoothed normal they may rise above its horizon, and Lambert's boundary limit would count
      // them); where they do, the gap below them takes their radiosity (own_patch_gap).
      const int* own = own_patches.data() + own_start[size_t(o)];
      const int* own_end = own_patches.data() + own_start[size_t(o) + 1];
      factors.for_each_visible(receiver, stream_of, counts, [&](int j, double f) {
        if (std::find(own, own_end, j) == own_end) h += f * r.radiosity.row(j);
      });
      for (const int* j = own; j != own_end; ++j)
        h += own_patch_gap(r.mesh, *j, x.position, x.normal) * r.radiosity.row(*j);
      if (!direct.empty()) h += direct.at(x.position, x.normal).matrix().transpose();
      const Material& m = scene.materials[x.material];
      r.point_irradiance.row(o) = h;
      r.point_radiosity.row(o) = m.emission.matrix().transpose() + m.reflectance.matrix().transpose().cwiseProduct(h);
    }
    evaluated += counts.evaluated;
    tested += counts.tested;
    culled += counts.culled;
    rays += counts.rays.cast;
    const int done = ++groups_done;
    if (opt.progress && omp_get_thread_num() == 0)
      opt.progress("vertex gather", std::min(1.0, double(done) * parts / groups));
  }
  if (opt.progress) opt.progress("vertex gather", 1.0);
  if (parts > 1) {
    for (ChannelMatrix* m : {&r.point_irradiance, &r.point_radiosity}) {
      std::vector<double> v(m->data(), m->data() + m->size());
      ranks::sum(v);
      std::copy(v.begin(), v.end(), m->data());
    }
    std::vector<long long> counts = {evaluated, rays, tested, culled};
    ranks::sum(counts);
    evaluated = counts[0], rays = counts[1], tested = counts[2], culled = counts[3];
  }
  r.summary.vertex_pairs_evaluated = evaluated;
  r.summary.vertex_rays_cast = rays;
  r.summary.vertex_pairs_tested = tested;
  r.summary.vertex_pairs_culled = culled;
}

// The energy balance (theory.md "Energy balance"). Escape, A_i B_i (1 − Σ_j F_ij), is counted
// per patch and only where positive; with `per_face`, summed over each scene face's patches
// first: the hierarchy's leaves take their ancestors' mean factors, so their rows scatter about
// their true rows, and only the sums over the elements that carry links cancel that scatter.
EnergyBalance energy_balance(const Eigen::VectorXd& row_sums, const ChannelMatrix& direct, const SolveResult& r,
                             bool per_face = false) {
  EnergyBalance e;
  std::map<int, Rgb> face_escape;  // per_face: Σ A B (1 − row) over the face's patches
  for (int i = 0; i < r.mesh.size(); ++i) {
    const double a = r.mesh.patches[i].area;
    for (int c = 0; c < 3; ++c) {
      e.emitted[c] += a * r.emission(i, c);
      e.direct_in[c] += a * direct(i, c);
      e.absorbed[c] += a * (1.0 - r.reflectance(i, c)) * r.irradiance(i, c);
    }
    const Rgb escape = a * (1.0 - row_sums[i]) * r.radiosity.row(i).transpose().array();
    if (per_face) face_escape.try_emplace(r.mesh.patches[size_t(i)].face, Rgb::Zero()).first->second += escape;
    else e.escaped += escape.max(0.0);
  }
  for (const auto& [face, escape] : face_escape) e.escaped += escape.max(0.0);
  for (int c = 0; c < 3; ++c)
    if (e.emitted[c] + e.direct_in[c] > 0)
      e.relative_imbalance =
          std::max(e.relative_imbalance, std::abs(e.emitted[c] + e.direct_in[c] - e.absorbed[c] - e.escaped[c]) /
                                             (e.emitted[c] + e.direct_in[c]));
  return e;
}

// The storage and the memory check (memory.h check_storage), recorded in the summary.
StorageChoice check_memory(const MemoryEstimate& estimate, double patches, const SolveOptions& opt, SolveSummary& s) {
  const StorageChoice c = check_storage(estimate, patches, 0.0, opt.matrix_layout, opt.matrix_precision,
                                        opt.max_memory_bytes, "needs", "", "use --method hierarchical");
  s.memory = estimate;
  s.matrix_storage = c.storage;
  s.matrix_storage_reason = c.reason;
  s.estimated_bytes = c.estimated_bytes;
  s.memory_limit_bytes = c.limit_bytes;
  s.memory_limit_source = c.limit_source;
  return c;
}

std::unique_ptr<HierarchicalRadiosity> solve_by_hierarchy(const Scene& scene, const PatchMesh& roots,
                                                          const Visibility* vis, const DirectLighting& lights,
                                                          const SolveOptions& opt, SolveResult& r);
void gather_from_hierarchy(const Scene& scene, const HierarchicalRadiosity& hierarchy, const DirectLighting& direct,
                           const SolveOptions& opt, SolveResult& r);
void solve_dense(const Scene& scene, const Visibility* vis, const DirectLighting& lights, const SolveOptions& opt,
                 SolveResult& r, StageTimer& timer);
void solve_dense_on_ranks(const Scene& scene, const Visibility* vis, const DirectLighting& lights,
                          const SolveOptions& opt, SolveResult& r, StageTimer& timer);

}  // namespace

std::string solve_method_name(SolveMethod method) {
  switch (method) {
    case SolveMethod::Hierarchical: return "hierarchical";
    case SolveMethod::Auto: return "auto";
    default: return "dense";
  }
}

bool solve_method_from_name(const std::string& name, SolveMethod& out) {
  for (SolveMethod m : {SolveMethod::Dense, SolveMethod::Hierarchical, SolveMethod::Auto})
    if (name == solve_method_name(m)) {
      out = m;
      return true;
    }
  return false;
}

SolveResult solve_scene(const Scene& scene, const SolveOptions& opt) {
  if (opt.threads > 0) omp_set_num_threads(opt.threads);
  SolveResult r;
  SolveSummary& s = r.summary;
  s.threads = omp_get_max_threads();
  StageTimer timer(s);

  const DirectLighting lights(scene);
  bool emits = !lights.empty();
  for (const Face& f : scene.faces) emits = emits || (scene.materials[f.material].emission > 0).any();
  if (!emits)
    throw_bad_input(scene.source +
                    ": nothing to solve: no face emits light and there are no lights "
                    "(set Ke in the .mtl, --emission, or \"lights\" in a scene file)");

  bool hierarchical = opt.method == SolveMethod::Hierarchical;
  s.method_reason = "requested (--method " + solve_method_name(opt.method) + ")";
  // On several MPI ranks the rows of F are split over the ranks (solve_dense_on_ranks); the
  // whole matrix is never held, so its memory is checked per rank there.
  const bool on_ranks = ranks::distributed();
  s.ranks = ranks::size();
  if (on_ranks) {
    if (hierarchical)
      throw_bad_input(
          "--method hierarchical runs as one process; on several MPI ranks the solve is dense, its "
          "rows split over the ranks");
    s.method_reason = opt.method == SolveMethod::Auto
                          ? "auto: on " + std::to_string(s.ranks) + " MPI ranks, the dense method with its rows split"
                          : s.method_reason;
  } else if (!hierarchical) {
    const PatchGrid grid = count_patches(scene, opt.patching);
    const MemoryEstimate estimate = estimate_memory(scene, grid, opt.seed);
    if (opt.method == SolveMethod::Auto) {
      const StorageChoice c =
          choose_storage(opt.matrix_layout, opt.matrix_precision, grid.patches, double(estimate.nonzero_pairs),
                         estimate.per_patch_bytes * grid.patches, opt.max_memory_bytes);
      hierarchical = !c.fits;
      s.method_reason = "auto: the dense method needs " + format_bytes(c.estimated_bytes) + " for " +
                        format_patch_count(grid.patches) + " patches (" + c.storage + " form factors), " +
                        (c.fits ? "within " : "over ") + c.limit_description();
    }
    if (!hierarchical) check_memory(estimate, grid.patches, opt, s);
  }
  s.method = hierarchical ? "hierarchical" : "dense";
  // The hierarchy's roots are the scene's faces (its elements are split as the links need);
  // the dense method's patches are the patching's.
  r.mesh = subdivide(scene, hierarchical ? PatchingOptions{} : opt.patching);
  s.faces = static_cast<int>(scene.faces.size());
  record_patches(r);
  fill_materials(scene, r);
  timer.lap("patching");

  const VisibilityChoice visibility = choose_visibility(scene, opt.visibility, opt.rays);
  s.visibility_mode = visibility.name();
  s.visibility_reason = visibility.reason;
  const RaySampling sampling = ray_sampling_for(opt.accuracy);
  const std::unique_ptr<Visibility> vis = make_visibility(scene, visibility, sampling);
  if (visibility.mode == VisibilityMode::Rays) s.ray_sampling = ray_sampling_name(opt.rays, sampling);
  timer.lap("visibility_setup");
  const PatchMesh roots = hierarchical ? r.mesh : PatchMesh();
  std::unique_ptr<HierarchicalRadiosity> hierarchy;
  if (hierarchical) {
    hierarchy = solve_by_hierarchy(scene, roots, vis.get(), lights, opt, r);
    timer.lap("hierarchical_solve");
  } else if (on_ranks) {
    solve_dense_on_ranks(scene, vis.get(), lights, opt, r, timer);
  } else {
    solve_dense(scene, vis.get(), lights, opt, r, timer);
  }

  split_output_points(scene, opt.crease_angle_degrees, r);
  s.output_points = static_cast<int>(r.points.size());
  s.crease_angle_degrees = opt.crease_angle_degrees;
  if (hierarchy) gather_from_hierarchy(scene, *hierarchy, lights, opt, r);
  else gather_at_points(scene, vis.get(), lights, opt, r);
  timer.lap("vertex_gather");
  // Never hand a NaN on to a result file: with finite, checked inputs this is a bug (exit 4).
  if (!r.radiosity.allFinite() || !r.irradiance.allFinite() || !r.point_radiosity.allFinite() ||
      !r.point_irradiance.allFinite())
    throw std::logic_error(scene.source + ": the solution contains a non-finite value");
  return r;
}

namespace {

// The hierarchical method (hierarchical/hierarchical.h): its leaves become the result's patches.
std::unique_ptr<HierarchicalRadiosity> solve_by_hierarchy(const Scene& scene, const PatchMesh& roots,
                                                          const Visibility* vis, const DirectLighting& lights,
                                                          const SolveOptions& opt, SolveResult& r) {
  SolveSummary& s = r.summary;
  HierarchicalOptions h;
  h.error = opt.hierarchical_error;
  h.min_edge = opt.min_element_edge;
  h.cluster_above = opt.cluster_above;
  h.tolerance = opt.solver.tolerance;
  h.max_iterations = opt.solver.max_iterations;
  h.max_memory_bytes = opt.max_memory_bytes > 0.0 ? opt.max_memory_bytes : available_memory_bytes();
  h.rays = opt.rays;
  h.seed = opt.seed;
  h.progress = opt.progress;
  auto hierarchy = std::make_unique<HierarchicalRadiosity>(scene, roots, vis, lights, h);
  HierarchicalSolution sol = hierarchy->solve();
  s.hierarchical = sol.stats;
  r.mesh = std::move(sol.leaves);
  record_patches(r);
  fill_materials(scene, r);
  r.radiosity = sol.radiosity;
  r.irradiance = sol.irradiance;
  s.lights = lights.count();
  s.tolerance = opt.solver.tolerance;
  s.solver.iterations = sol.stats.sweeps;
  s.solver.residual = sol.stats.residual;
  s.solver.converged = sol.stats.converged;
  s.solver.channels_solved = 3;
  s.solver.method = SolverMethod::GaussSeidel;
  s.solver.detail = "hierarchical: gathering over links with push-pull";
  s.memory_limit_bytes = h.max_memory_bytes;
  s.memory_limit_source = opt.max_memory_bytes > 0.0 ? "--max-memory" : "MemAvailable";
  s.matrix_storage = "links";
  s.matrix_bytes = sol.stats.bytes;
  s.energy = energy_balance(sol.row_sums, sol.direct, r, true);
  return hierarchy;
}

// The vertex gather over the hierarchy's links (HierarchicalRadiosity::irradiance_at): each
// output point takes the links of the first leaf it is a corner of and their ancestors.
void gather_from_hierarchy(const Scene& scene, const HierarchicalRadiosity& hierarchy, const DirectLighting& direct,
                           const SolveOptions& opt, SolveResult& r) {
  const int np = static_cast<int>(r.points.size());
  std::vector<int> leaf_of(size_t(np), -1);
  for (int i = 0; i < static_cast<int>(r.cells.size()); ++i)
    for (int o : r.cells[size_t(i)])
      if (leaf_of[size_t(o)] < 0) leaf_of[size_t(o)] = i;
  r.point_irradiance = ChannelMatrix::Zero(np, 3);
  r.point_radiosity = ChannelMatrix::Zero(np, 3);
  long long gathered = 0, rays = 0;
  std::atomic<int> done{0};
#pragma omp parallel for schedule(dynamic, 64) reduction(+ : gathered, rays)
  for (int o = 0; o < np; ++o) {
    const OutputPoint& x = r.points[size_t(o)];
    RayTally tally;
    long long links = 0;
    Rgb h = leaf_of[size_t(o)] < 0
                ? Rgb::Zero()
                : hierarchy.irradiance_at(Receiver{x.position, x.normal, x.approach}, leaf_of[size_t(o)], tally, links);
    if (!direct.empty()) h += direct.at(x.position, x.normal);
    const Material& m = scene.materials[size_t(x.material)];
    r.point_irradiance.row(o) = h.matrix().transpose();
    r.point_radiosity.row(o) = (m.emission + m.reflectance * h).matrix().transpose();
    gathered += links;
    rays += tally.cast;
    const int d = ++done;
    if (opt.progress && omp_get_thread_num() == 0 && d % 256 == 0) opt.progress("vertex gather", double(d) / np);
  }
  if (opt.progress) opt.progress("vertex gather", 1.0);
  r.summary.vertex_pairs_evaluated = gathered;
  r.summary.vertex_rays_cast = rays;
}

[[noreturn]] void throw_not_converged(const Scene& scene, const SolverReport& report, double tolerance) {
  std::ostringstream m;
  m << scene.source << ": the solver did not converge in " << report.iterations << " sweeps (relative residual "
    << report.residual << " > tolerance " << tolerance << "); raise --max-iterations";
  throw Error(ErrorKind::NotConverged, m.str());
}

// The fill's options from the solve's, its progress reported as the "form factors" stage.
FillOptions fill_options(const SolveOptions& opt, const Visibility* vis) {
  FillOptions fill;
  fill.quadrature = opt.quadrature;
  fill.tolerance = opt.accuracy;
  fill.visibility = vis;
  fill.rays = opt.rays;
  fill.seed = opt.seed;
  if (opt.progress) fill.progress = [progress = opt.progress](double f) { progress("form factors", f); };
  return fill;
}

// H_direct of the given patches (N × 3, zero elsewhere): the mean over the receiver rule's points
// of the lights' irradiance (pipeline/direct_light.h); all zero without lights.
ChannelMatrix direct_irradiance(const PatchMesh& mesh, const DirectLighting& lights, int quadrature,
                                const std::vector<int>& patches) {
  ChannelMatrix direct = ChannelMatrix::Zero(mesh.size(), 3);
  if (lights.empty()) return direct;
#pragma omp parallel for schedule(dynamic, 16)
  for (size_t k = 0; k < patches.size(); ++k) {
    const int i = patches[k];
    Vec3 c[4];
    mesh.polygon(i, c);
    const Patch& p = mesh.patches[size_t(i)];
    for (const QuadraturePoint& q : patch_quadrature(c, p.corner_count, quadrature))
      direct.row(i) += q.weight * lights.at(q.point, p.normal).matrix().transpose();
  }
  return direct;
}

// The dense method: the N × N form factors, then the linear solve.
void solve_dense(const Scene& scene, const Visibility* vis_ptr, const DirectLighting& lights, const SolveOptions& opt,
                 SolveResult& r, StageTimer& timer) {
  SolveSummary& s = r.summary;
  FillOptions fill = fill_options(opt, vis_ptr);
  s.quadrature = opt.quadrature;
  s.accuracy = opt.accuracy;
  const StorageChoice storage = check_memory(estimate_memory(r.mesh, opt.seed), r.mesh.size(), opt, s);
  fill.layout = storage.layout;
  fill.precision = storage.precision;
  const FormFactors F = fill_form_factors(r.mesh, fill, s.fill);
  s.matrix_storage = F.description();
  s.matrix_bytes = F.bytes();
  // A convex enclosure (auto mode): the scene-wide test culled every pair's shaft at once.
  if (!vis_ptr && opt.visibility == VisibilityMode::Auto) s.fill.pairs_culled = s.fill.pairs_evaluated;
  s.checks = check_form_factors(r.mesh, F);
  timer.lap("form_factors");

  bool grey = true;  // every material grey (solve_radiosity also checks the direct light)
  for (const Material& m : scene.materials) grey = grey && m.is_grey();
  // H_direct per patch: the mean over the receiver rule's points. Skipped without lights.
  s.lights = lights.count();
  std::vector<int> every_patch(size_t(s.patches));
  std::iota(every_patch.begin(), every_patch.end(), 0);
  const ChannelMatrix direct = direct_irradiance(r.mesh, lights, opt.quadrature, every_patch);
  s.tolerance = opt.solver.tolerance;
  SolverOptions solver = opt.solver;  // + the patch areas, for the symmetric (cg) formulation
  solver.areas.resize(s.patches);
  for (int i = 0; i < s.patches; ++i) solver.areas[i] = r.mesh.patches[i].area;
  s.solver = solve_radiosity(F, r.emission, r.reflectance, direct, grey, solver, r.radiosity);
  if (!s.solver.converged) throw_not_converged(scene, s.solver, opt.solver.tolerance);
  // H = H_direct + F B per channel (one when the solve was grey: the channels are equal) and F's
  // row sums, in one pass over F: a row read for the first product is still in the cache for the others.
  const bool grey_solve = s.solver.channels_solved == 1;
  r.irradiance = direct;
  const Eigen::VectorXd radiosity[3] = {r.radiosity.col(0), r.radiosity.col(1), r.radiosity.col(2)};
  Eigen::VectorXd row_sums(s.patches);
#pragma omp parallel for schedule(static)
  for (int i = 0; i < s.patches; ++i) {
    for (int c = 0; c < (grey_solve ? 1 : 3); ++c) r.irradiance(i, c) += F.row_dot(i, radiosity[c]);
    if (grey_solve) r.irradiance(i, 1) = r.irradiance(i, 2) = r.irradiance(i, 0);
    row_sums[i] = F.row_sum(i);
  }
  s.energy = energy_balance(row_sums, direct, r);
  timer.lap("solve");
}

// The dense method on MPI ranks (distributed/ranks.h): each rank fills the rows of F a spatial
// partition balanced by the rows' estimated costs gives it (distributed/row_partition.h) and
// holds only those, the solve is block Jacobi–Gauss–Seidel over the ranks' rows
// (solver/block_gauss_seidel.h) or GMRES through PETSc (distributed/distributed_gmres.h), and
// every rank ends with all of B, H and the checks, summed over the ranks, so that the vertex
// gather can be split by point (gather_at_points).
void solve_dense_on_ranks(const Scene& scene, const Visibility* vis_ptr, const DirectLighting& lights,
                          const SolveOptions& opt, SolveResult& r, StageTimer& timer) {
  SolveSummary& s = r.summary;
  const int n = s.patches, R = ranks::size();
  // Gauss–Seidel (block Jacobi–Gauss–Seidel) and GMRES (PETSc) split over the ranks; auto picks
  // as for one process, GMRES where that would be the direct LU of a small stiff scene.
  double max_rho = 0.0;
  for (int i = 0; i < n; ++i) max_rho = std::max(max_rho, r.reflectance.row(i).maxCoeff());
  SolverMethod method = opt.solver.method == SolverMethod::Auto ? choose_method(max_rho, n, true) : opt.solver.method;
  if (opt.solver.method == SolverMethod::Auto && method == SolverMethod::Direct) method = SolverMethod::Gmres;
  // (distributed_gmres_available loads the PETSc module: only where GMRES is asked for.)
  if (method != SolverMethod::GaussSeidel && !(method == SolverMethod::Gmres && distributed_gmres_available())) {
    const std::string on_ranks_methods =
        distributed_gmres_available()
            ? "block Gauss–Seidel or GMRES (--solver gauss-seidel or gmres)"
            : "block Gauss–Seidel (--solver gauss-seidel; GMRES: " + distributed_gmres_unavailable_reason() + ")";
    throw_bad_input(std::string("--solver ") + method_name(method) +
                    (opt.solver.method == SolverMethod::Auto ? " (what auto picks for this scene's reflectance)" : "") +
                    " runs as one process; on several MPI ranks the solve is " + on_ranks_methods);
  }
  // The rows of this rank and their memory: rows × N doubles, plus the per-patch arrays.
  std::vector<Vec3> centroids;
  for (const Patch& p : r.mesh.patches) centroids.push_back(p.centroid);
  const std::vector<std::vector<int>> parts = partition_rows(centroids, estimate_row_costs(r.mesh), R);
  RowBlock block;
  block.rows = parts[size_t(ranks::rank())];
  for (const std::vector<int>& part : parts) s.rows_per_rank.push_back(static_cast<int>(part.size()));
  const MemoryEstimate estimate = estimate_memory(r.mesh, opt.seed);
  s.memory = estimate;
  s.estimated_bytes = double(block.rows.size()) * n * sizeof(double) + estimate.per_patch_bytes * n;
  s.memory_limit_bytes =
      opt.max_memory_bytes > 0 ? opt.max_memory_bytes : available_memory_bytes() / std::max(1, ranks::local_size());
  s.memory_limit_source = opt.max_memory_bytes > 0
                              ? "--max-memory"
                              : "MemAvailable shared by " + std::to_string(ranks::local_size()) + " ranks";
  s.matrix_storage = "dense double, rows split over " + std::to_string(R) + " ranks";
  s.matrix_storage_reason = "on MPI ranks each holds its rows";
  std::exception_ptr failure;
  if (s.memory_limit_bytes > 0 && s.estimated_bytes > s.memory_limit_bytes)
    failure = std::make_exception_ptr(
        Error(ErrorKind::BadInput, "this rank needs " + format_bytes(s.estimated_bytes) + " for its " +
                                       format_count(static_cast<long long>(block.rows.size())) + " rows of " +
                                       format_patch_count(n) + " patches (dense double) but " +
                                       memory_limit_description(s.memory_limit_bytes, s.memory_limit_source) +
                                       "; raise --max-edge, use more ranks or raise --max-memory"));
  ranks::agree(failure);  // every rank past its memory check (MemAvailable differs between machines)

  block.F.resize(Eigen::Index(block.rows.size()), n);
  advise_huge_pages(block.F.data(), size_t(block.F.size()) * sizeof(double));  // before the fill touches it
  std::vector<int> place(size_t(n), -1);
  for (size_t k = 0; k < block.rows.size(); ++k) place[size_t(block.rows[k])] = static_cast<int>(k);
  FillOptions fill = fill_options(opt, vis_ptr);
  fill.rows = &block.rows;
  fill.row_sink = [&](int i, const double* row) {
    std::copy(row, row + n, block.F.row(place[size_t(i)]).data());
    return true;
  };
  s.quadrature = opt.quadrature;
  s.accuracy = opt.accuracy;
  const auto fill_start = std::chrono::steady_clock::now();
  fill_form_factors(r.mesh, fill, s.fill);
  s.fill_seconds_per_rank =
      ranks::all_values(std::chrono::duration<double>(std::chrono::steady_clock::now() - fill_start).count());
  s.matrix_bytes = double(block.F.size()) * sizeof(double);
  if (!vis_ptr && opt.visibility == VisibilityMode::Auto) s.fill.pairs_culled = s.fill.pairs_evaluated;
  sum_over_ranks(s.fill);
  // The checks of the whole matrix from the ranks' rows; reciprocity would need F_ji beside F_ij,
  // which no rank holds, so it is not measured (−1).
  double min_entry = 1.0, max_entry = 0.0, min_sum = 1e300, max_sum = -1e300;
  Eigen::VectorXd row_sums = Eigen::VectorXd::Zero(n);
  for (size_t k = 0; k < block.rows.size(); ++k) {
    const int i = block.rows[k];
    for (int j = 0; j < n; ++j)
      if (j != i)
        min_entry = std::min(min_entry, block.F(Eigen::Index(k), j)),
        max_entry = std::max(max_entry, block.F(Eigen::Index(k), j));
    row_sums[i] = block.F.row(Eigen::Index(k)).sum();
    min_sum = std::min(min_sum, row_sums[i]);
    max_sum = std::max(max_sum, row_sums[i]);
  }
  s.checks.min_entry = ranks::min(min_entry);
  s.checks.max_entry = ranks::max(max_entry);
  s.checks.min_row_sum = ranks::min(min_sum);
  s.checks.max_row_sum = ranks::max(max_sum);
  s.checks.reciprocity_error = -1.0;
  timer.lap("form_factors");

  // H_direct per patch (the mean over the receiver rule's points), each rank its rows.
  s.lights = lights.count();
  ChannelMatrix direct = direct_irradiance(r.mesh, lights, opt.quadrature, block.rows);
  const SumOverProcesses sum = [](std::vector<double>& v) { ranks::sum(v); };
  auto sum_matrix = [&](ChannelMatrix& m) {
    std::vector<double> v(m.data(), m.data() + m.size());
    sum(v);
    std::copy(v.begin(), v.end(), m.data());
  };
  sum_matrix(direct);
  std::vector<double> sums(row_sums.data(), row_sums.data() + n);
  sum(sums);
  std::copy(sums.begin(), sums.end(), row_sums.data());

  // The solve, one channel when every channel's E, ρ and H_direct agree (solver.h).
  s.tolerance = opt.solver.tolerance;
  const auto solve_start = std::chrono::steady_clock::now();
  const bool grey = r.emission.col(0) == r.emission.col(1) && r.emission.col(0) == r.emission.col(2) &&
                    r.reflectance.col(0) == r.reflectance.col(1) && r.reflectance.col(0) == r.reflectance.col(2) &&
                    direct.col(0) == direct.col(1) && direct.col(0) == direct.col(2);
  if (r.reflectance.minCoeff() < 0.0 || max_rho >= 1.0 || r.emission.minCoeff() < 0.0)
    throw_bad_input(scene.source + ": reflectance must lie in [0, 1) and emission be >= 0 for the solve");
  SolverReport& report = s.solver;
  report.method = method;
  report.channels_solved = grey ? 1 : 3;
  report.converged = true;
  r.radiosity = ChannelMatrix::Zero(n, 3);
  for (int c = 0; c < report.channels_solved; ++c) {
    Eigen::VectorXd B;
    const ChannelResult cr = method == SolverMethod::Gmres
                                 ? distributed_gmres_channel(block, parts, r.emission.col(c), r.reflectance.col(c),
                                                             direct.col(c), opt.solver, B)
                                 : block_gauss_seidel_channel(block, r.emission.col(c), r.reflectance.col(c),
                                                              direct.col(c), opt.solver, sum, B);
    r.radiosity.col(c) = B;
    report.iterations = std::max(report.iterations, cr.iterations);
    report.residual = std::max(report.residual, cr.residual);
    report.converged = report.converged && cr.converged;
  }
  if (grey) r.radiosity.col(1) = r.radiosity.col(2) = r.radiosity.col(0);
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - solve_start).count();
  report.detail = method == SolverMethod::Gmres
                      ? "PETSc GMRES(30), unpreconditioned, on a shell operator: each of " + std::to_string(R) +
                            " ranks forms its rows of (I − ρF)x, x gathered on every rank for each product"
                      : "block Jacobi–Gauss–Seidel: each of " + std::to_string(R) +
                            " ranks sweeps its rows, the ranks' values exchanged after every sweep";
  if (!report.converged) throw_not_converged(scene, report, opt.solver.tolerance);
  // H = H_direct + F B per channel, each rank its rows, summed.
  r.irradiance = ChannelMatrix::Zero(n, 3);
  for (size_t k = 0; k < block.rows.size(); ++k) {
    const int i = block.rows[k];
    for (int c = 0; c < 3; ++c)
      r.irradiance(i, c) = direct(i, c) + block.F.row(Eigen::Index(k)).dot(r.radiosity.col(c));
  }
  sum_matrix(r.irradiance);
  s.energy = energy_balance(row_sums, direct, r);
  timer.lap("solve");
}

}  // namespace

}  // namespace photometria
