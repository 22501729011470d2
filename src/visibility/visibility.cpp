#include "visibility/visibility.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <limits>
#include <cmath>
#include <map>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "util/error.h"

namespace photometria {

namespace {

// Eigen's AlignedBox::intersects, inlined: it is called tens of millions of times per fill.
inline bool boxes_meet(const Eigen::AlignedBox3d& a, const Eigen::AlignedBox3d& b) {
  return a.min().x() <= b.max().x() && b.min().x() <= a.max().x() && a.min().y() <= b.max().y() &&
         b.min().y() <= a.max().y() && a.min().z() <= b.max().z() && b.min().z() <= a.max().z();
}

double bounding_diagonal(const std::vector<Vec3>& v) {
  if (v.empty()) return 0.0;
  Vec3 lo = v[0], hi = v[0];
  for (const Vec3& x : v) { lo = lo.cwiseMin(x); hi = hi.cwiseMax(x); }
  return (hi - lo).norm();
}

// splitmix64 (Steele, Lea & Flood 2014): a tiny, well-mixed generator for per-pair streams.
struct SplitMix64 {
  uint64_t state;
  uint64_t next() {
    uint64_t z = (state += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }
  double uniform() { return double(next() >> 11) * 0x1.0p-53; }
};

// Latin-hypercube samples in the unit square: one sample in each of K columns and K rows.
void latin_hypercube(int k, SplitMix64& rng, std::vector<std::pair<double, double>>& out) {
  std::vector<int> perm(k);
  for (int i = 0; i < k; ++i) perm[i] = i;
  for (int i = k - 1; i > 0; --i) std::swap(perm[i], perm[rng.next() % uint64_t(i + 1)]);
  out.resize(k);
  for (int i = 0; i < k; ++i) out[i] = {(i + rng.uniform()) / k, (perm[i] + rng.uniform()) / k};
}

// Jittered (stratified) samples: one in each cell of an m × m grid, k = m². An indicator with a
// smooth boundary then has error O(k^(-3/4)) instead of O(k^(-1/2)) (Mitchell 1996, "Consequences
// of stratified sampling in graphics").
void jittered_grid(int m, SplitMix64& rng, std::vector<std::pair<double, double>>& out) {
  out.resize(size_t(m) * m);
  for (int a = 0; a < m; ++a)
    for (int b = 0; b < m; ++b) out[size_t(a) * m + b] = {(a + rng.uniform()) / m, (b + rng.uniform()) / m};
}

// Uniform (area-preserving for triangles and parallelograms) map of the unit square to a patch.
Vec3 map_to_patch(const Vec3* c, int n, double s, double t) {
  if (n == 4) return (1 - s) * (1 - t) * c[0] + s * (1 - t) * c[1] + s * t * c[2] + (1 - s) * t * c[3];
  const double r = std::sqrt(s);  // Shirley's square-to-triangle map
  return (1 - r) * c[0] + r * (1 - t) * c[1] + r * t * c[2];
}

// The form-factor integrand between two surface points, cos θx cos θy / r²: each segment's
// visibility counts in proportion to the light it carries, so that V·F estimates the occluded
// factor ∫∫ v cos cos / (π r²) rather than an area-average that ignores where F comes from.
double transfer_weight(const Vec3& x, const Vec3& nx, const Vec3& y, const Vec3& ny) {
  const Vec3 d = y - x;
  const double r2 = d.squaredNorm();
  if (r2 == 0.0) return 0.0;
  const double cx = nx.dot(d), cy = -ny.dot(d);
  if (cx <= 0.0 || cy <= 0.0) return 0.0;
  return cx * cy / (r2 * r2);
}

}  // namespace

uint64_t pair_stream(uint64_t seed, uint64_t i, uint64_t j) {
  SplitMix64 g{seed ^ (i * 0x9e3779b97f4a7c15ULL) ^ (j * 0xc2b2ae3d27d4eb4fULL)};
  return g.next();
}

bool scene_needs_no_visibility(const Scene& scene, std::string* reason) {
  const double tol = 1e-9 * bounding_diagonal(scene.vertices);
  for (size_t f = 0; f < scene.faces.size(); ++f) {
    const Polygon poly = scene.face_polygon(static_cast<int>(f));
    const Vec3 n = polygon_normal(poly);
    for (size_t v = 0; v < scene.vertices.size(); ++v) {
      if (n.dot(scene.vertices[v] - poly[0]) < -tol) {
        if (reason) {
          std::ostringstream s;
          s << "face " << scene.faces[f].source_face << " has vertex " << v
            << " behind its plane, so faces may block each other";
          *reason = s.str();
        }
        return false;
      }
    }
  }
  if (reason) *reason = "every vertex lies in front of every face: a convex enclosure, no face can block any pair";
  return true;
}

struct RayVisibility::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
};

RayVisibility::RayVisibility(const Scene& scene) : impl_(std::make_unique<Impl>()) {
  offset_ = 1e-7 * std::max(bounding_diagonal(scene.vertices), 1e-30);
  impl_->device = rtcNewDevice("verbose=0");
  if (!impl_->device) throw Error(ErrorKind::Io, "embree: cannot create a device");
  impl_->scene = rtcNewScene(impl_->device);
  rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_HIGH);
  // Watertight triangle tests: a segment through an edge shared by two faces cannot slip through.
  rtcSetSceneFlags(impl_->scene, RTC_SCENE_FLAG_ROBUST);
  RTCGeometry geom = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                         3 * sizeof(float), scene.vertices.size()));
  for (size_t i = 0; i < scene.vertices.size(); ++i)
    for (int k = 0; k < 3; ++k) vb[3 * i + k] = static_cast<float>(scene.vertices[i][k]);
  size_t tris = 0;
  for (const Face& f : scene.faces) tris += f.vertices.size() - 2;
  auto* ib = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                            3 * sizeof(unsigned), tris));
  size_t t = 0;
  for (const Face& f : scene.faces)
    for (size_t k = 1; k + 1 < f.vertices.size(); ++k, ++t) {
      ib[3 * t] = f.vertices[0];
      ib[3 * t + 1] = f.vertices[k];
      ib[3 * t + 2] = f.vertices[k + 1];
    }
  rtcCommitGeometry(geom);
  rtcAttachGeometry(impl_->scene, geom);
  rtcReleaseGeometry(geom);
  rtcCommitScene(impl_->scene);
  if (rtcGetDeviceError(impl_->device) != RTC_ERROR_NONE)
    throw Error(ErrorKind::Io, "embree: failed to build the occluder scene");
}

RayVisibility::~RayVisibility() {
  if (impl_->scene) rtcReleaseScene(impl_->scene);
  if (impl_->device) rtcReleaseDevice(impl_->device);
}

bool RayVisibility::blocked(const Vec3& a, const Vec3& b) const {
  const Vec3 d = b - a;
  const double len = d.norm();
  if (len <= 2 * offset_) return false;
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRay ray;
  ray.org_x = float(a.x()); ray.org_y = float(a.y()); ray.org_z = float(a.z());
  ray.dir_x = float(d.x() / len); ray.dir_y = float(d.y() / len); ray.dir_z = float(d.z() / len);
  // Leave the end points' own surfaces alone: float storage of the occluders costs ~1e-7 relative.
  ray.tnear = float(offset_);
  ray.tfar = float(len - offset_);
  ray.time = 0.0f;
  ray.mask = 0xFFFFFFFFu;
  ray.id = 0;
  ray.flags = 0;
  rtcOccluded1(impl_->scene, &context, &ray);
  return ray.tfar < 0.0f;  // Embree sets tfar = -inf on a hit
}

double RayVisibility::patch_to_patch(const Vec3* r, int rn, const Vec3& r_normal, const Vec3* s, int sn,
                                     const Vec3& s_normal, int rays, uint64_t stream) const {
  SplitMix64 rng{stream};
  std::vector<std::pair<double, double>> a, b;
  latin_hypercube(rays, rng, a);
  latin_hypercube(rays, rng, b);
  double seen = 0.0, total = 0.0;
  for (int k = 0; k < rays; ++k) {
    const Vec3 x = map_to_patch(r, rn, a[k].first, a[k].second);
    const Vec3 y = map_to_patch(s, sn, b[k].first, b[k].second);
    const double w = transfer_weight(x, r_normal, y, s_normal);
    if (w == 0.0) continue;
    total += w;
    // Lift the end points off their surfaces towards their front sides.
    if (!blocked(x + 10 * offset_ * r_normal, y + 10 * offset_ * s_normal)) seen += w;
  }
  return total > 0 ? seen / total : 1.0;
}

double RayVisibility::point_to_patch(const Vec3& p, const Vec3& normal, const Vec3* s, int sn,
                                     const Vec3& s_normal, int rays, uint64_t stream, int* rays_used) const {
  SplitMix64 rng{stream};
  std::vector<std::pair<double, double>> b;
  const Vec3 x = p + 10 * offset_ * normal;
  int used = 0;
  auto estimate = [&](int k, bool& unanimous) {
    const int m = static_cast<int>(std::lround(std::sqrt(double(k))));
    if (m * m == k) jittered_grid(m, rng, b);
    else latin_hypercube(k, rng, b);
    double seen = 0.0, total = 0.0;
    int hits = 0, misses = 0;
    for (int q = 0; q < k; ++q) {
      const Vec3 y = map_to_patch(s, sn, b[q].first, b[q].second);
      const double w = transfer_weight(p, normal, y, s_normal);
      if (w == 0.0) continue;
      total += w;
      ++used;
      if (!blocked(x, y + 10 * offset_ * s_normal)) { seen += w; ++misses; }
      else ++hits;
    }
    unanimous = hits == 0 || misses == 0;
    return total > 0 ? seen / total : 1.0;
  };
  bool unanimous = false;
  const double v = estimate(rays, unanimous);
  if (rays_used) *rays_used = used;
  return v;
}

// ---------------------------------------------------------------------------------------------
// Shaft culling (Haines & Wallace 1994).

namespace {

struct Plane {
  Vec3 m;    // unit normal, pointing out of the shaft
  double d;  // the plane is m·y = d; the shaft lies in m·y <= d
};

// The shaft of A and B (each a polygon or a point; A ∪ B at most kMaxShaftPoints points): its
// bounding box, and the planes of the convex hull of A ∪ B, built on first need (most queries are
// settled by bounding boxes alone). A hull face of two convex polygons contains either a whole
// polygon, or an edge of one and a vertex of the other, so these candidates are complete; a
// candidate is kept when every point lies on one closed side. For a non-convex B (a scene face
// used as a group of patches) the kept planes still each bound A ∪ B, so their intersection
// contains the hull: culling stays conservative.
constexpr int kMaxShaftPoints = 24;

class Shaft {
 public:
  Shaft(const Vec3* a, int na, const Vec3* b, int nb, double tol) : a_(a), b_(b), na_(na), nb_(nb), tol_(tol) {
    for (int k = 0; k < na; ++k) box_.extend(a[k]);
    for (int k = 0; k < nb; ++k) box_.extend(b[k]);
    box_.min().array() -= tol;
    box_.max().array() += tol;
  }
  const Eigen::AlignedBox3d& box() const { return box_; }

  // True when face w (unit plane normal `normal`) cannot meet the open shaft: every corner of A
  // and B on one closed side of its plane (no open segment crosses it; this leaves out the faces
  // A and B lie in and faces they only touch), or w wholly on the outer side of one hull plane.
  bool misses(const Polygon& w, const Vec3& normal) {
    bool below = true, above = true;
    for (int k = 0; k < na_ + nb_; ++k) {
      const double s = normal.dot((k < na_ ? a_[k] : b_[k - na_]) - w[0]);
      below = below && s <= tol_;
      above = above && s >= -tol_;
    }
    if (below || above) return true;
    if (!have_planes_) build_planes();
    for (int i = 0; i < plane_count_; ++i) {
      const Plane& p = planes_[i];
      bool outside = true;
      for (const Vec3& v : w)
        if (!(p.m.dot(v) - p.d >= -tol_)) {
          outside = false;
          break;
        }
      if (outside) return true;
    }
    return false;
  }

 private:
  // A point and a convex polygon it does not lie in the plane of (the gathers' and the centroid
  // rule's shafts): the hull is a pyramid whose planes are known, one per base edge through the
  // apex plus the base, so no candidate needs checking against every point.
  bool build_pyramid_planes() {
    if (na_ != 1 || nb_ < 3 || nb_ > 4) return false;
    const Vec3& x = a_[0];
    const Vec3 nb = newell_vector(b_, nb_);
    const double nlen = nb.norm();
    if (!(nlen > 0.0)) return false;
    const Vec3 n = nb / nlen;
    const double h = n.dot(x - b_[0]);
    if (!(std::abs(h) > tol_)) return false;  // apex (nearly) in the base plane
    Vec3 centre = Vec3::Zero();
    for (int k = 0; k < nb_; ++k) {
      const Vec3 turn = (b_[(k + 1) % nb_] - b_[k]).cross(b_[(k + 2) % nb_] - b_[(k + 1) % nb_]);
      if (!(turn.dot(n) > 0.0)) return false;  // not strictly convex: the general hull
      centre += b_[k] / nb_;
    }
    for (int k = 0; k < nb_; ++k) {
      Vec3 m = (b_[k] - x).cross(b_[(k + 1) % nb_] - x);
      const double len = m.norm();
      if (!(len > 0.0)) return false;
      m /= len;
      if (m.dot(centre - x) > 0.0) m = -m;  // pointing out of the pyramid
      planes_[plane_count_++] = {m, m.dot(x)};
    }
    const Vec3 out = h > 0.0 ? Vec3(-n) : n;  // beyond the base, away from the apex
    planes_[plane_count_++] = {out, out.dot(b_[0])};
    return true;
  }

  void build_planes() {
    have_planes_ = true;
    if (build_pyramid_planes()) return;
    plane_count_ = 0;
    Vec3 pts[kMaxShaftPoints];
    int np = 0;
    for (int k = 0; k < na_; ++k) pts[np++] = a_[k];
    for (int k = 0; k < nb_; ++k) pts[np++] = b_[k];
    auto try_plane = [&](Vec3 m, const Vec3& p0) {
      const double len = m.norm();
      if (!(len > 0.0) || plane_count_ == kMaxPlanes) return;
      m /= len;
      const double d = m.dot(p0);
      bool below = true, above = true;
      for (int k = 0; k < np; ++k) {
        const double s = m.dot(pts[k]) - d;
        below = below && s <= tol_;
        above = above && s >= -tol_;
      }
      if (below) planes_[plane_count_++] = {m, d};
      else if (above) planes_[plane_count_++] = {-m, -d};
    };
    auto edges_with_vertices = [&](const Vec3* p, int n, const Vec3* q, int nq) {
      if (n < 2) return;
      for (int e = 0; e < n; ++e) {
        const Vec3& e0 = p[e];
        const Vec3& e1 = p[(e + 1) % n];
        for (int v = 0; v < nq; ++v) try_plane((e1 - e0).cross(q[v] - e0), e0);
      }
    };
    edges_with_vertices(a_, na_, b_, nb_);
    edges_with_vertices(b_, nb_, a_, na_);
    if (na_ >= 3) try_plane(newell_vector(a_, na_), a_[0]);
    if (nb_ >= 3) try_plane(newell_vector(b_, nb_), b_[0]);
  }

  // Enough for every candidate of a quad against a 20-corner group (2·4·20 + 2); dropping a
  // plane beyond it would only cull less.
  static constexpr int kMaxPlanes = 2 * 4 * (kMaxShaftPoints - 4) + 2;
  const Vec3 *a_, *b_;
  int na_, nb_;
  double tol_;
  Eigen::AlignedBox3d box_;
  bool have_planes_ = false;
  int plane_count_ = 0;
  Plane planes_[kMaxPlanes];
};

}  // namespace

ShaftCuller::ShaftCuller(const Scene& scene) {
  tol_ = 1e-9 * std::max(bounding_diagonal(scene.vertices), 1e-30);
  const int n = static_cast<int>(scene.faces.size());
  faces_.reserve(n);
  for (int f = 0; f < n; ++f) {
    faces_.push_back(scene.face_polygon(f));
    normals_.push_back(polygon_normal(faces_.back()));
    Eigen::AlignedBox3d box;
    for (const Vec3& v : faces_.back()) box.extend(v);
    boxes_.push_back(box);
  }
  order_.resize(n);
  std::iota(order_.begin(), order_.end(), 0);
  if (n > 0) {
    nodes_.reserve(2 * n);
    build(0, n);
  }
  find_convex_solids(scene);
}

void ShaftCuller::find_convex_solids(const Scene& scene) {
  const int n = static_cast<int>(scene.faces.size());
  solid_of_.assign(size_t(n), -1);
  // Faces joined by shared edges (vertex index pairs), union–find.
  std::vector<int> parent(static_cast<size_t>(n));
  std::iota(parent.begin(), parent.end(), 0);
  auto root = [&](int f) {
    while (parent[size_t(f)] != f) f = parent[size_t(f)] = parent[size_t(parent[size_t(f)])];
    return f;
  };
  std::map<std::pair<int, int>, std::vector<int>> edge_faces;  // directed edge -> faces using it
  for (int f = 0; f < n; ++f) {
    const std::vector<int>& v = scene.faces[size_t(f)].vertices;
    for (size_t k = 0; k < v.size(); ++k) edge_faces[{v[k], v[(k + 1) % v.size()]}].push_back(f);
  }
  // The face across each edge (the one using its reverse), where there is exactly one.
  neighbours_.assign(size_t(n), {});
  for (int f = 0; f < n; ++f) {
    const std::vector<int>& v = scene.faces[size_t(f)].vertices;
    neighbours_[size_t(f)].assign(v.size(), -1);
    for (size_t k = 0; k < v.size(); ++k) {
      const auto twin = edge_faces.find({v[(k + 1) % v.size()], v[k]});
      if (twin != edge_faces.end() && twin->second.size() == 1) neighbours_[size_t(f)][k] = twin->second[0];
    }
  }
  std::vector<char> manifold(static_cast<size_t>(n), 1);
  for (const auto& [edge, faces] : edge_faces) {
    const auto twin = edge_faces.find({edge.second, edge.first});
    // Closed and consistently oriented: each directed edge once, its reverse once, in another face.
    if (faces.size() != 1 || twin == edge_faces.end() || twin->second.size() != 1 || twin->second[0] == faces[0]) {
      for (int f : faces) manifold[size_t(f)] = 0;
      continue;
    }
    const int a = root(faces[0]), b = root(twin->second[0]);
    if (a != b) parent[size_t(a)] = b;
  }
  std::map<int, std::vector<int>> components;
  for (int f = 0; f < n; ++f) components[root(f)].push_back(f);
  for (const auto& [r, faces] : components) {
    (void)r;
    bool eligible = faces.size() >= 4;
    for (int f : faces) eligible = eligible && manifold[size_t(f)] && !normals_[size_t(f)].isZero();
    // Convex with outward normals: every vertex of the solid on or behind every face's plane.
    for (size_t i = 0; i < faces.size() && eligible; ++i)
      for (int g : faces)
        for (const Vec3& v : faces_[size_t(g)])
          eligible = eligible && normals_[size_t(faces[i])].dot(v - faces_[size_t(faces[i])][0]) <= tol_;
    if (!eligible) continue;
    const int id = static_cast<int>(solids_.size());
    solids_.push_back(faces);
    for (int f : faces) solid_of_[size_t(f)] = id;
  }
}

bool ShaftCuller::hidden_from(const Vec3& x, int f, std::vector<signed char>& outside_state,
                              std::vector<int>& touched) const {
  const int solid = solid_of_[size_t(f)];
  // Signed distance of x in front of face g's plane.
  auto height = [&](int g) { return normals_[size_t(g)].dot(x - faces_[size_t(g)][0]); };
  if (solid < 0 || !(height(f) < -tol_)) return false;
  signed char& state = outside_state[size_t(solid)];
  if (state == 0) {
    bool outside = false;
    for (int g : solids_[size_t(solid)]) outside = outside || height(g) > tol_;
    state = outside ? 1 : 2;
    touched.push_back(solid);
  }
  return state == 1;
}

void ShaftCuller::drop_hidden_faces(const Vec3& x, std::vector<int>& faces) const {
  if (solids_.empty()) return;
  thread_local std::vector<signed char> outside_state;
  thread_local std::vector<int> touched;
  outside_state.resize(solids_.size(), 0);
  size_t kept = 0;
  for (int f : faces)
    if (!hidden_from(x, f, outside_state, touched)) faces[kept++] = f;
  faces.resize(kept);
  for (int solid : touched) outside_state[size_t(solid)] = 0;
  touched.clear();
}

// Median split on the longest axis of the box centres; leaves hold up to 4 faces.
int ShaftCuller::build(int first, int count) {
  const int id = static_cast<int>(nodes_.size());
  nodes_.emplace_back();
  Eigen::AlignedBox3d box, centres;
  for (int k = first; k < first + count; ++k) {
    box.extend(boxes_[order_[k]]);
    centres.extend(boxes_[order_[k]].center());
  }
  nodes_[id].box = box;
  if (count <= 4) {
    nodes_[id].first = first;
    nodes_[id].count = count;
    return id;
  }
  int axis = 0;
  centres.sizes().maxCoeff(&axis);
  const int half = count / 2;
  std::nth_element(order_.begin() + first, order_.begin() + first + half, order_.begin() + first + count,
                   [&](int x, int y) { return boxes_[x].center()[axis] < boxes_[y].center()[axis]; });
  const int left = build(first, half);
  const int right = build(first + half, count - half);
  nodes_[id].left = left;
  nodes_[id].right = right;
  return id;
}

void ShaftCuller::occluders(const Vec3* a, int na, const Vec3* b, int nb, std::vector<int>& out,
                            bool drop_hidden) const {
  out.clear();
  if (nodes_.empty()) return;
  if (na + nb > kMaxShaftPoints) throw std::invalid_argument("ShaftCuller: a shaft of more than 24 points");
  if (drop_hidden && na != 1) throw std::invalid_argument("ShaftCuller: drop_hidden needs a point receiver");
  Shaft shaft(a, na, b, nb, tol_);
  // drop_hidden: the faces the point is clearly behind, of convex solids it is clearly outside
  // of, are skipped before the costlier shaft tests (drop_hidden_faces() during the search).
  thread_local std::vector<signed char> outside_state;
  thread_local std::vector<int> touched;
  if (drop_hidden) outside_state.resize(solids_.size(), 0);
  auto hidden = [&](int f) { return hidden_from(a[0], f, outside_state, touched); };
  int stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& node = nodes_[stack[--top]];
    if (!boxes_meet(node.box, shaft.box())) continue;
    if (node.left < 0) {
      for (int k = node.first; k < node.first + node.count; ++k) {
        const int f = order_[k];
        if (boxes_meet(boxes_[f], shaft.box()) && !(drop_hidden && hidden(f)) && !shaft.misses(faces_[f], normals_[f]))
          out.push_back(f);
      }
    } else {
      stack[top++] = node.left;
      stack[top++] = node.right;
    }
  }
  if (drop_hidden) {
    for (int solid : touched) outside_state[size_t(solid)] = 0;
    touched.clear();
  }
  std::sort(out.begin(), out.end());  // a fixed order: results do not depend on the traversal
}

void ShaftCuller::occluders_among(const Vec3* a, int na, const Vec3* b, int nb, const std::vector<int>& candidates,
                                  std::vector<int>& out) const {
  out.clear();
  if (candidates.empty()) return;
  if (na + nb > kMaxShaftPoints) throw std::invalid_argument("ShaftCuller: a shaft of more than 24 points");
  Shaft shaft(a, na, b, nb, tol_);
  for (int f : candidates)
    if (boxes_meet(boxes_[f], shaft.box()) && !shaft.misses(faces_[f], normals_[f])) out.push_back(f);
}

namespace {

// Splits patches[first, first + count) (indices of one face's patches, with their centroids'
// in-plane coordinates uv) at the median of the longer extent until each part has at most
// tile_patches; appends the parts' ranges.
void split_tiles(std::vector<int>& patches, const std::vector<Eigen::Vector2d>& uv, int first, int count,
                 int tile_patches, std::vector<std::pair<int, int>>& ranges) {
  if (count <= tile_patches) {
    ranges.emplace_back(first, count);
    return;
  }
  Eigen::AlignedBox2d box;
  for (int k = first; k < first + count; ++k) box.extend(uv[size_t(patches[size_t(k)])]);
  const int axis = box.sizes().x() >= box.sizes().y() ? 0 : 1;
  const int half = count / 2;
  std::nth_element(patches.begin() + first, patches.begin() + first + half, patches.begin() + first + count,
                   [&](int x, int y) { return uv[size_t(x)][axis] < uv[size_t(y)][axis]; });
  split_tiles(patches, uv, first, half, tile_patches, ranges);
  split_tiles(patches, uv, first + half, count - half, tile_patches, ranges);
}

}  // namespace

GroupedShaftCuller::GroupedShaftCuller(const ShaftCuller& culler, const PatchMesh& mesh, int tile_patches)
    : culler_(&culler), tile_of_patch_(size_t(mesh.size()), -1) {
  if (tile_patches < 1) throw std::invalid_argument("GroupedShaftCuller: tile_patches must be at least 1");
  const int faces = culler.face_count();
  std::vector<std::vector<int>> by_face(static_cast<size_t>(faces));
  for (int j = 0; j < mesh.size(); ++j)
    if (mesh.patches[size_t(j)].face >= 0 && mesh.patches[size_t(j)].face < faces)
      by_face[size_t(mesh.patches[size_t(j)].face)].push_back(j);
  std::vector<Eigen::Vector2d> uv(size_t(mesh.size()), Eigen::Vector2d::Zero());
  for (int f = 0; f < faces; ++f) {
    std::vector<int>& patches = by_face[size_t(f)];
    if (patches.empty()) continue;
    // An orthonormal frame (u, v, w) with w the face's normal (any frame if it has none).
    Vec3 w = polygon_normal(culler.faces()[size_t(f)]);
    if (w.isZero()) w = Vec3::UnitZ();
    const Vec3 u = w.unitOrthogonal(), v = w.cross(u);
    for (int j : patches) uv[size_t(j)] = Eigen::Vector2d(u.dot(mesh.patches[size_t(j)].centroid), v.dot(mesh.patches[size_t(j)].centroid));
    std::vector<std::pair<int, int>> ranges;
    split_tiles(patches, uv, 0, static_cast<int>(patches.size()), tile_patches, ranges);
    for (const auto& [first, count] : ranges) {
      Eigen::AlignedBox3d box;  // in (u, v, w) coordinates
      for (int k = first; k < first + count; ++k) {
        const Patch& p = mesh.patches[size_t(patches[size_t(k)])];
        for (int c = 0; c < p.corner_count; ++c) {
          const Vec3& x = mesh.points[size_t(p.corners[size_t(c)])];
          box.extend(Vec3(u.dot(x), v.dot(x), w.dot(x)));
        }
      }
      // Grown by the culler's tolerance: the rectangle must contain the patches, not just touch them.
      box.min().array() -= culler.tolerance();
      box.max().array() += culler.tolerance();
      Tile tile;
      tile.face = f;
      const bool flat = box.sizes().z() <= 4.0 * culler.tolerance();
      const double w_mid = 0.5 * (box.min().z() + box.max().z());
      const double us[2] = {box.min().x(), box.max().x()}, vs[2] = {box.min().y(), box.max().y()};
      const double ws[2] = {box.min().z(), box.max().z()};
      for (int iw = 0; iw < (flat ? 1 : 2); ++iw) {
        const double wc = flat ? w_mid : ws[iw];
        // Counter-clockwise around w: (u0,v0), (u1,v0), (u1,v1), (u0,v1).
        const double cu[4] = {us[0], us[1], us[1], us[0]}, cv[4] = {vs[0], vs[0], vs[1], vs[1]};
        for (int c = 0; c < 4; ++c) tile.corners[tile.corner_count++] = cu[c] * u + cv[c] * v + wc * w;
      }
      const int t = static_cast<int>(tiles_.size());
      tiles_.push_back(tile);
      tile_corner_counts_.push_back(static_cast<unsigned char>(tile.corner_count));
      for (int k = first; k < first + count; ++k) tile_of_patch_[size_t(patches[size_t(k)])] = t;
    }
  }
  stamp_.assign(size_t(faces) + tiles_.size(), -1);
  groups_.resize(size_t(faces) + tiles_.size());
}

void GroupedShaftCuller::set_receiver(const Vec3* a, int na) {
  if (na < 1 || na > 4) throw std::invalid_argument("GroupedShaftCuller: a receiver of 1 to 4 points");
  std::copy(a, a + na, receiver_);
  receiver_count_ = na;
  ++generation_;
}

const std::vector<int>& GroupedShaftCuller::group(int g) {
  std::vector<int>& list = groups_[size_t(g)];
  if (stamp_[size_t(g)] == generation_) return list;
  stamp_[size_t(g)] = generation_;
  const int faces = culler_->face_count();
  if (g < faces) {
    const Polygon& face = culler_->faces()[size_t(g)];
    // From a point, a convex solid's back faces cast no shadow of their own (drop_hidden_faces):
    // leaving them out here shortens every list below.
    culler_->occluders(receiver_, receiver_count_, face.data(), static_cast<int>(face.size()), list,
                       /*drop_hidden=*/receiver_count_ == 1);
    return list;
  }
  const Tile& tile = tiles_[size_t(g - faces)];
  if (static_cast<int>(culler_->faces()[size_t(tile.face)].size()) + 4 > kMaxShaftPoints)
    culler_->occluders(receiver_, receiver_count_, tile.corners, tile.corner_count, list);  // a face of many corners: no face level
  else
    culler_->occluders_among(receiver_, receiver_count_, tile.corners, tile.corner_count, group(tile.face), list);
  return list;
}

void GroupedShaftCuller::occluders(int patch, const Vec3* b, int nb, std::vector<int>& out) {
  const int t = patch >= 0 && patch < static_cast<int>(tile_of_patch_.size()) ? tile_of_patch_[size_t(patch)] : -1;
  if (t < 0) {
    culler_->occluders(receiver_, receiver_count_, b, nb, out);
    return;
  }
  culler_->occluders_among(receiver_, receiver_count_, b, nb, group(culler_->face_count() + t), out);
}

// ---------------------------------------------------------------------------------------------
// Exact visibility: clip the source against shadow volumes in 3-D (Nishita & Nakamae 1985).

namespace {

// Keeps the part of convex polygon `in` where s(y) = m·y − d >= 0, given the values `s` at its
// vertices (Sutherland–Hodgman, one plane).
void clip_keep(const Vec3* in, size_t n, const std::vector<double>& s, Polygon& out) {
  out.clear();
  for (size_t i = 0; i < n; ++i) {
    const size_t j = i + 1 == n ? 0 : i + 1;  // not (i + 1) % n: a division per vertex
    const double si = s[i], sj = s[j];
    if (si >= 0) out.push_back(in[i]);
    if ((si > 0 && sj < 0) || (si < 0 && sj > 0)) out.push_back(in[i] + (si / (si - sj)) * (in[j] - in[i]));
  }
  if (out.size() < 3) out.clear();
}

// Both parts at once: inside as clip_keep(in, s, inside), outside the same for −s (the crossing
// si / (si − sj) is the same number with both signs flipped).
void split_keep(const Polygon& in, const std::vector<double>& s, Polygon& inside, Polygon& outside) {
  inside.clear();
  outside.clear();
  const size_t n = in.size();
  for (size_t i = 0; i < n; ++i) {
    const size_t j = i + 1 == n ? 0 : i + 1;
    const double si = s[i], sj = s[j];
    if (si >= 0) inside.push_back(in[i]);
    if (si <= 0) outside.push_back(in[i]);
    if ((si > 0 && sj < 0) || (si < 0 && sj > 0)) {
      const Vec3 y = in[i] + (si / (si - sj)) * (in[j] - in[i]);
      inside.push_back(y);
      outside.push_back(y);
    }
  }
  if (inside.size() < 3) inside.clear();
  if (outside.size() < 3) outside.clear();
}

// A list of polygons that keeps its polygons' storage between uses (clear() forgets the count only).
class PiecePool {
 public:
  void clear() { size_ = 0; }
  size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  Polygon& operator[](size_t i) { return store_[i]; }
  const Polygon& operator[](size_t i) const { return store_[i]; }
  Polygon& push() {
    if (size_ == store_.size()) store_.emplace_back();
    return store_[size_++];
  }
  void truncate(size_t n) { size_ = std::min(size_, n); }  // forgets the polygons from n on
  friend void swap(PiecePool& a, PiecePool& b) noexcept {
    a.store_.swap(b.store_);
    std::swap(a.size_, b.size_);
  }

 private:
  std::vector<Polygon> store_;
  size_t size_ = 0;
};

// The shadow volume of convex solid `solid` of `culler` seen from x, relative to x (m·y >= d
// inside), when x is clearly outside it (false otherwise: then its faces cast their shadows one
// by one). A segment from x meets the solid exactly when it crosses the cone from x through the
// solid's silhouette (the edges between a face x is in front of and one it is not), and beyond
// the entry point it is behind every front face's plane; so the shadow is one convex volume: a
// wedge plane per silhouette edge and the plane of each front face (Crow 1977, "Shadow
// algorithms for computer graphics": a shadow volume bounded by planes through the light and
// the occluder's silhouette edges; here the "light" is the receiver point, as in Nishita &
// Nakamae 1985). One volume instead of one per front face (three for a box) cuts the pieces
// fewer times. reach: the largest distance from x to the solid's corners (its classification
// tolerance is 1e-12 × the configuration's size, which includes it).
bool solid_volume(const ShaftCuller& culler, int solid, const Vec3& x, std::vector<Plane>& volume, double& reach) {
  const std::vector<int>& faces = culler.solid_faces(solid);
  const double tol = culler.tolerance();
  thread_local std::vector<int> front;
  front.clear();
  Vec3 centre = Vec3::Zero();
  int corners = 0;
  reach = 0.0;
  for (int g : faces) {
    const Polygon& w = culler.faces()[size_t(g)];
    if (culler.normals()[size_t(g)].dot(x - w[0]) > tol) front.push_back(g);
    for (const Vec3& v : w) {
      centre += v - x;
      ++corners;
      reach = std::max(reach, (v - x).norm());
    }
  }
  if (front.empty() || corners == 0) return false;
  centre /= corners;
  auto is_front = [&](int g) { return std::find(front.begin(), front.end(), g) != front.end(); };
  for (int g : front) {
    const Polygon& w = culler.faces()[size_t(g)];
    const Vec3& n = culler.normals()[size_t(g)];
    volume.push_back({-n, -n.dot(w[0] - x)});  // behind the face, away from x
    for (size_t k = 0; k < w.size(); ++k) {
      const int across = culler.neighbour(g, static_cast<int>(k));
      if (across >= 0 && is_front(across)) continue;  // an inner edge of the front surface
      Vec3 m = (w[k] - x).cross(w[(k + 1) % w.size()] - x);
      const double len = m.norm();
      if (!(len > 0.0)) continue;
      m /= len;
      if (m.dot(centre) < 0) m = -m;
      volume.push_back({m, 0.0});
    }
  }
  return true;
}

// The shadow volumes cast from one point x: of single faces and of convex solids, each built on
// first use and kept until the next point. A point's tiles share most of their occluders, so a
// volume is built once per point rather than once per tile and occluder.
class ShadowVolumes {
 public:
  struct Volume {
    long long stamp = -1;
    bool casts = false;     // false: no volume (a face seen edge-on, a solid x is not outside)
    double reach = 0.0;     // largest distance from x to the occluder's corners
    double edge_on = 0.0;   // a face: the distance of its plane from x (it blocks nothing when <= eps)
    std::vector<Plane> planes;  // m·y >= d inside the shadow, relative to x
  };

  // Forgets every volume: the following ones are seen from x.
  void start(const Vec3& x) {
    x_ = x;
    ++generation_;
  }

  // The squared distance from x to face f's nearest corner (the order of subtraction).
  double nearest(const std::vector<Polygon>& faces, int f) {
    if (size_t(f) >= nearest_.size()) nearest_.resize(faces.size(), {-1, 0.0});
    auto& [stamp, d] = nearest_[size_t(f)];
    if (stamp != generation_) {
      stamp = generation_;
      d = std::numeric_limits<double>::infinity();
      for (const Vec3& v : faces[size_t(f)]) d = std::min(d, (v - x_).squaredNorm());
    }
    return d;
  }

  // Face f's own shadow volume: beyond its plane, inside the cone from x through its edges.
  const Volume& face(const std::vector<Polygon>& faces, const std::vector<Vec3>* normals, int f) {
    if (size_t(f) >= faces_.size()) faces_.resize(faces.size());
    Volume& v = faces_[size_t(f)];
    if (v.stamp == generation_) return v;
    v.stamp = generation_;
    v.planes.clear();
    const Polygon& w = faces[size_t(f)];
    const int wn = static_cast<int>(w.size());
    Polygon& wr = relative_;
    wr.resize(size_t(wn));
    Vec3 centre = Vec3::Zero();
    v.reach = 0.0;
    for (int k = 0; k < wn; ++k) {
      wr[size_t(k)] = w[size_t(k)] - x_;
      centre += wr[size_t(k)] / wn;
      v.reach = std::max(v.reach, wr[size_t(k)].norm());
    }
    const Vec3 nw = normals ? (*normals)[size_t(f)] : polygon_normal(w);
    const double h = nw.dot(wr[0]);  // signed distance of W's plane from x along nw
    v.casts = !nw.isZero();
    v.edge_on = std::abs(h);
    if (!v.casts) return v;
    // Beyond W's plane, on the side away from x.
    v.planes.push_back({h > 0 ? nw : Vec3(-nw), std::abs(h)});
    // Inside the cone from x through W: one wedge plane through x per edge, oriented to W.
    for (int k = 0; k < wn; ++k) {
      Vec3 m = wr[size_t(k)].cross(wr[size_t((k + 1) % wn)]);
      const double len = m.norm();
      if (!(len > 0.0)) continue;
      m /= len;
      if (m.dot(centre) < 0) m = -m;
      v.planes.push_back({m, 0.0});
    }
    return v;
  }

  // Convex solid s's one shadow volume (solid_volume).
  const Volume& solid(const ShaftCuller& culler, int s) {
    if (size_t(s) >= solids_.size()) solids_.resize(size_t(culler.convex_solid_count()));
    Volume& v = solids_[size_t(s)];
    if (v.stamp == generation_) return v;
    v.stamp = generation_;
    v.planes.clear();
    v.casts = solid_volume(culler, s, x_, v.planes, v.reach);
    return v;
  }

 private:
  Vec3 x_ = Vec3::Zero();
  long long generation_ = 0;
  std::vector<std::pair<long long, double>> nearest_;
  std::vector<Volume> faces_, solids_;
  Polygon relative_;  // scratch of face(): its corners relative to x
};

// Subtracts from `pieces` (convex polygons relative to x, at most `scale` from it) the shadow
// volumes of faces[which] seen from x: what is left is the part of them x sees. `shadows`
// (optional) receives the hidden parts; they are disjoint, and with what is left they partition
// the input. Returns true when any face cut or hid a piece (false: the pieces are unchanged).
// With `solids` (the culler whose faces these are), the listed faces of a convex solid that x is
// clearly outside of are replaced by the solid's one shadow volume (see solid_volume).
// `volumes`: the shadow volumes seen from x (started at x), reused across calls from one point.
bool subtract_shadows(double scale, const std::vector<Polygon>& faces, const std::vector<int>& which,
                      const std::vector<Vec3>* normals, PiecePool& pieces, PiecePool* shadows,
                      const ShaftCuller* solids, ShadowVolumes& volumes) {
  thread_local PiecePool next;
  thread_local std::vector<double> s;
  thread_local Polygon inside, outside, cur;
  thread_local std::vector<int> done_solids;
  bool cut = false;
  // Nearest occluders first: their shadows are the widest, and what they hide is not cut again
  // by the others.
  thread_local std::vector<std::pair<double, int>> order;
  order.clear();
  for (int f : which) order.emplace_back(volumes.nearest(faces, f), f);
  std::sort(order.begin(), order.end());
  done_solids.clear();
  for (const auto& [distance, f] : order) {
    if (pieces.empty()) break;
    const int solid = solids ? solids->solid_of(f) : -1;
    if (solid >= 0 && std::find(done_solids.begin(), done_solids.end(), solid) != done_solids.end()) continue;
    const ShadowVolumes::Volume* v = solid >= 0 ? &volumes.solid(*solids, solid) : nullptr;
    if (v && v->casts) {
      done_solids.push_back(solid);
    } else {
      v = &volumes.face(faces, normals, f);
      if (!v->casts || v->edge_on <= 1e-12 * std::max(scale, v->reach)) continue;  // seen edge-on: blocks nothing
    }
    // Classification tolerance: 1e-12 × the configuration's size.
    const double eps = 1e-12 * std::max(scale, v->reach);
    const std::vector<Plane>& volume = v->planes;
    // Whether polygon q lies on or outside plane p of the volume (then the volume hides none of it).
    auto outside_of = [&](const Polygon& q, const Plane& p) {
      bool all_out = true;
      for (const Vec3& y : q) all_out = all_out && p.m.dot(y) - p.d <= eps;
      return all_out;
    };
    // Every piece outside one plane of the volume (the usual case for the back faces of a box
    // and for occluders behind the source): it hides none of them.
    bool separated = false;
    for (size_t p = 0; p < volume.size() && !separated; ++p) {
      bool all_out = true;
      for (size_t pi = 0; pi < pieces.size() && all_out; ++pi) all_out = outside_of(pieces[pi], volume[p]);
      separated = all_out;
    }
    if (separated) continue;
    // Subtract the volume from every piece: the part outside plane 1, then the part inside 1
    // but outside 2, ... are visible; what lies inside every plane is in the shadow.
    next.clear();
    for (size_t pi = 0; pi < pieces.size(); ++pi) {
      // Outside one plane of the volume: not in the shadow; kept whole, with no split.
      if (std::any_of(volume.begin(), volume.end(), [&](const Plane& p) { return outside_of(pieces[pi], p); })) {
        next.push().swap(pieces[pi]);
        continue;
      }
      // The piece itself until a plane cuts it, then what is left inside (in `cur`). Pieces are
      // moved, not copied, into `next`: `pieces` is replaced by it.
      Polygon* rest = &pieces[pi];
      bool shadowed = true, split = false;
      const size_t first_part = next.size();
      for (const Plane& p : volume) {
        s.resize(rest->size());
        bool all_out = true, all_in = true;
        for (size_t k = 0; k < rest->size(); ++k) {
          s[k] = p.m.dot((*rest)[k]) - p.d;
          all_out = all_out && s[k] <= eps;
          all_in = all_in && s[k] >= -eps;
        }
        if (all_out) {  // on or outside this plane (a coplanar piece counts as outside): visible
          next.push().swap(*rest);
          shadowed = false;
          break;
        }
        if (all_in) continue;
        split = true;
        split_keep(*rest, s, inside, outside);
        if (!outside.empty()) next.push().swap(outside);
        cur.swap(inside);
        rest = &cur;
        if (cur.empty()) { shadowed = false; break; }
      }
      if (shadowed) {
        cut = true;
        if (shadows) shadows->push().swap(*rest);
      } else if (split) {
        // Nothing of it was in the shadow after all (a later plane had all of the part inside the
        // earlier ones outside it): keep the piece whole rather than the parts the splits made.
        next.truncate(first_part);
        next.push().swap(pieces[pi]);
      }
    }
    swap(pieces, next);
  }
  return cut;
}

}  // namespace

double exact_visible_form_factor(const Receiver& receiver, const Vec3* source, int n,
                                 const std::vector<Polygon>& faces, const std::vector<int>& which,
                                 const std::vector<Vec3>* normals, const ShaftCuller* solids) {
  const Vec3& x = receiver.point;
  // Work relative to x: every wedge plane then passes through the origin.
  // Per-thread scratch: this runs once per occluded pair, and allocation was a tenth of its cost.
  thread_local PiecePool pieces;
  pieces.clear();
  Polygon& src = pieces.push();
  src.resize(size_t(n));
  double scale = 0.0;
  for (int k = 0; k < n; ++k) {
    src[size_t(k)] = source[k] - x;
    scale = std::max(scale, src[size_t(k)].norm());
  }
  thread_local ShadowVolumes volumes;  // one call per point here
  volumes.start(x);
  if (!subtract_shadows(scale, faces, which, normals, pieces, nullptr, solids, volumes))
    return lambert_form_factor(receiver, source, n);
  // Lambert's formula is additive over a partition of the source (an integral over directions).
  const Receiver at_origin{Vec3::Zero(), receiver.normal, receiver.approach};
  double f = 0.0;
  for (size_t pi = 0; pi < pieces.size(); ++pi)
    f += lambert_form_factor(at_origin, pieces[pi].data(), static_cast<int>(pieces[pi].size()));
  return std::clamp(f, 0.0, 1.0);
}

// ---------------------------------------------------------------------------------------------

Visibility::Visibility(const Scene& scene, VisibilityMethod method) : method_(method), culler_(scene) {
  if (method == VisibilityMethod::Rays) rays_ = std::make_unique<RayVisibility>(scene);
}

double Visibility::point_to_patch(const Receiver& x, const Vec3* source, int n, const Vec3& source_normal,
                                  double unoccluded, const std::vector<int>& occluders, int rays, uint64_t stream,
                                  long long& rays_cast, bool narrow) const {
  if (occluders.empty() || unoccluded <= 0.0) return unoccluded;
  // The shaft of the point and the patch is narrower than the pair's: test it too.
  thread_local std::vector<int> narrowed;
  if (!narrow) {
    culler_.occluders_among(&x.point, 1, source, n, occluders, narrowed);  // ⊆ the wider shaft's
    if (narrowed.empty()) return unoccluded;
  }
  if (method_ == VisibilityMethod::Exact) {
    // Only the faces of each convex solid that face x cast its shadow (see ShaftCuller).
    thread_local std::vector<int> casting;
    casting = narrow ? occluders : narrowed;
    culler_.drop_hidden_faces(x.point, casting);
    return std::min(unoccluded, exact_visible_form_factor(x, source, n, culler_.faces(), casting, &culler_.normals(), &culler_));
  }
  // Start just inside the point's own surface when it sits on an edge or corner, so rays leave cleanly.
  const Vec3 start = x.approach.isZero() ? x.point : Vec3(x.point + 10 * rays_->surface_offset() * x.approach);
  int used = 0;
  const double v = rays_->point_to_patch(start, x.normal, source, n, source_normal, rays, stream, &used);
  rays_cast += used;
  return unoccluded * v;
}

// ---------------------------------------------------------------------------------------------

int GroupedShaftCuller::tile_of(int patch) const {
  return patch >= 0 && patch < static_cast<int>(tile_of_patch_.size()) ? tile_of_patch_[size_t(patch)] : -1;
}

namespace {

// Corners of a convex polygon held elsewhere: n of them from p (n = 0: none).
struct Span {
  const Vec3* p = nullptr;
  size_t n = 0;
};

// The part of convex polygon `in` inside every half-space m_k·y >= d_k of `planes`, with
// vertices within eps of a plane counted as on it: `in` itself when no plane cuts it, else
// `work` holding the part, or an empty span when nothing of positive width is left. tmp, s: scratch.
Span clip_to_planes(Span in, const Plane* planes, int count, double eps, Polygon& work, Polygon& tmp,
                    std::vector<double>& s) {
  Span out = in;
  for (int p = 0; p < count; ++p) {
    s.resize(out.n);
    // Counted, not and-ed: no branch per vertex (the sides are unpredictable).
    size_t in_count = 0, out_count = 0;
    for (size_t k = 0; k < out.n; ++k) {
      s[k] = planes[p].m.dot(out.p[k]) - planes[p].d;
      in_count += s[k] >= -eps;
      out_count += s[k] <= eps;
    }
    if (in_count == out.n) continue;  // all on or inside
    if (out_count == out.n) return {};  // all on or outside
    clip_keep(out.p, out.n, s, tmp);
    work.swap(tmp);
    if (work.empty()) return {};
    out = {work.data(), work.size()};
  }
  return out;
}

}  // namespace

struct PointVisibility::Impl {
  // One tile's clipping from the current point: the visible and the hidden pieces (relative to
  // the point) and their bounding boxes, pieces [first, first + visible + hidden) of the point's
  // arena (below), visible ones first.
  struct TileClip {
    long long stamp = -1;
    bool cut = false;  // false: no face shadows any of the tile
    int first = 0, visible = 0, hidden = 0;
    Vec3 normal;  // the tile's unit normal
    double eps = 0.0;
    std::vector<int> occluders;  // cone culling: listed in `listed` (below)
  };
  // The cone from x around a polygon's corners: unit axis, cosine and sine of the half-angle;
  // wide when the half-angle may reach 90° (or x is on a corner): then it bounds nothing.
  struct Cone {
    Vec3 axis = Vec3::Zero();
    double cos = -1.0, sin = 0.0;
    bool wide = true;
  };
  // Cones of faces, structure of arrays for the filter loops below. A wide cone is stored with
  // a zero axis and cos = −1e9, so that it passes every test against a cone that is not wide.
  struct ConeSet {
    std::vector<double> ax, ay, az, cos, sin;
    std::vector<int> face;
    size_t size() const { return face.size(); }
    void resize(size_t n) {
      for (auto* v : {&ax, &ay, &az, &cos, &sin}) v->resize(n);
      face.resize(n);
    }
    void set(size_t k, const Cone& c, int f) {
      ax[k] = c.wide ? 0.0 : c.axis.x();
      ay[k] = c.wide ? 0.0 : c.axis.y();
      az[k] = c.wide ? 0.0 : c.axis.z();
      cos[k] = c.wide ? -1e9 : c.cos;
      sin[k] = c.wide ? 0.0 : c.sin;
      face[k] = f;
    }
    // True when cone k may meet cone c (not wide): the angle between the axes at most the sum
    // of the half-angles (both below 90°: cos(α + β) = cos α cos β − sin α sin β), with 1e-12
    // for rounding.
    bool may_meet(size_t k, const Cone& c) const {
      return ax[k] * c.axis.x() + ay[k] * c.axis.y() + az[k] * c.axis.z() >= c.cos * cos[k] - c.sin * sin[k] - 1e-12;
    }
  };
  const Visibility* vis;
  GroupedShaftCuller grouped;
  Receiver x;
  bool receiver_set = false;
  long long generation = 0;
  std::vector<TileClip> tiles;
  // The pieces of the tiles clipped from the current point, one tile after another, emptied per
  // point: a tile's pieces are contiguous and recently written. With storage per tile, every
  // point swept all of it (in a large room most of clip()'s time went to the first touch
  // of a tile's own polygons).
  struct Piece {
    int first, count;  // corners arena_corners[first, first + count)
  };
  std::vector<Vec3> arena_corners;
  std::vector<Piece> arena_pieces;
  std::vector<Eigen::AlignedBox3d> arena_boxes;  // per piece, grown by the tile's margin
  PiecePool clip_visible, clip_hidden;           // scratch of clip()
  std::vector<int> occluders, casting;
  ShadowVolumes volumes;  // seen from x, shared by its tiles
  Polygon rel, part, work, tmp;  // scratch of visible()
  std::vector<double> values;
  // Cone culling (see the header): the faces that may shadow from x and their cones.
  bool cones;
  long long candidates_for = -1;  // the point they belong to
  ConeSet candidates;
  std::vector<int> faces, near;
  std::vector<Vec3> directions;  // scratch of cone_of
  // A block: up to kBlockTiles consecutive tiles of one face (split_tiles makes them
  // neighbours), culled first, so a tile tests only its block's candidates.
  static constexpr int kBlockTiles = 8;
  struct Block {
    std::vector<Vec3> corners;  // its tiles' corners, or the 4 of a rectangle in their plane that contains them
    long long stamp = -1;
    std::vector<int> near;      // the candidates (indices) whose cones may meet the block's
  };
  std::vector<Block> blocks;
  std::vector<int> block_of;            // per tile
  // Per tile, compact (read for every patch, where a TileClip would be a cache miss on large
  // meshes): the point its cone-culled occluder list belongs to, and whether that list is empty.
  std::vector<long long> listed;
  std::vector<unsigned char> no_occluders;
  std::vector<unsigned char> bounding;  // per face: every scene corner on one side of its plane

  Impl(const Visibility& v, const PatchMesh& mesh, PointCulling culling)
      : vis(&v), grouped(v.culler(), mesh, kPointTilePatches) {
    tiles.resize(size_t(grouped.tile_count()));
    cones = culling == PointCulling::Cones ||
            (culling == PointCulling::Auto && v.culler().face_count() <= kConeCullingFaces);
    // Faces with every scene corner on one closed side of their plane (a room's walls) block no
    // segment between scene points: never candidates.
    const ShaftCuller& culler = v.culler();
    bounding.assign(size_t(culler.face_count()), 0);
    if (cones)
      for (int f = 0; f < culler.face_count(); ++f) {
        const Vec3& n = culler.normals()[size_t(f)];
        const Vec3& w0 = culler.faces()[size_t(f)][0];
        bool below = true, above = true;
        for (const Polygon& g : culler.faces())
          for (const Vec3& y : g) {
            const double s = n.dot(y - w0);
            below = below && s <= culler.tolerance();
            above = above && s >= -culler.tolerance();
          }
        bounding[size_t(f)] = !n.isZero() && (below || above);
      }
    block_of.assign(tiles.size(), -1);
    listed.assign(tiles.size(), -1);
    no_occluders.assign(tiles.size(), 0);
    int block_face = -1;
    for (int t = 0; t < grouped.tile_count(); ++t) {
      if (grouped.tile_corner_count(t) != 4) continue;
      const int face = grouped.tile_face(t);
      if (blocks.empty() || blocks.back().corners.size() >= 4 * kBlockTiles || block_face != face) blocks.emplace_back();
      block_face = face;
      block_of[size_t(t)] = static_cast<int>(blocks.size()) - 1;
      for (int k = 0; k < 4; ++k) blocks.back().corners.push_back(grouped.tile_corners(t)[k]);
    }
    // A block's cone from the rectangle around its tiles (the same plane, up to the tiles' own
    // flatness tolerance) rather than from their 32 corners: a cone around a convex polygon's
    // corners bounds all of it, and 4 corners are an eighth of the work per point.
    for (Block& b : blocks) {
      if (b.corners.size() <= 4) continue;
      Vec3 w = newell_vector(b.corners.data(), 4);
      if (!(w.norm() > 0.0)) continue;
      w.normalize();
      const Vec3 u = w.unitOrthogonal(), v = w.cross(u);
      Eigen::AlignedBox3d box;
      for (const Vec3& y : b.corners) box.extend(Vec3(u.dot(y), v.dot(y), w.dot(y)));
      if (box.sizes().z() > 4.0 * culler.tolerance()) continue;  // not one plane: keep every corner
      const double wc = 0.5 * (box.min().z() + box.max().z());
      const double cu[4] = {box.min().x(), box.max().x(), box.max().x(), box.min().x()};
      const double cv[4] = {box.min().y(), box.min().y(), box.max().y(), box.max().y()};
      b.corners.resize(4);
      for (int k = 0; k < 4; ++k) b.corners[size_t(k)] = cu[k] * u + cv[k] * v + wc * w;
    }
  }

  // The cone from x around corners c[0, n), its half-angle widened by margin_times_distance / (the
  // distance from x to the nearest corner) radians: what moving the corners by that much can turn.
  Cone cone_of(const Vec3* c, int n, double margin_times_distance) {
    Cone k;
    directions.resize(size_t(n));
    Vec3 sum = Vec3::Zero();
    double nearest = std::numeric_limits<double>::infinity();
    for (int i = 0; i < n; ++i) {
      const Vec3 d = c[i] - x.point;
      const double len = d.norm();
      if (!(len > 0.0)) return k;  // x on a corner
      nearest = std::min(nearest, len);
      sum += directions[size_t(i)] = d * (1.0 / len);  // one division, not three (the margins below cover the rounding)
    }
    // An offset of the corners by up to margin_times_distance turns directions by at most that
    // over the distance to the nearest corner.
    const double margin = margin_times_distance / nearest;
    const double len = sum.norm();
    if (!(len > 1e-6)) return k;
    k.axis = sum / len;
    double cmin = 1.0;
    for (int i = 0; i < n; ++i) cmin = std::min(cmin, k.axis.dot(directions[size_t(i)]));
    // Widened by the margin and by rounding (cos(α + m) = cos α cos m − sin α sin m, with
    // cos m >= 1 − m²/2 and sin m <= m); below cos 89.9° the cone is taken as wide.
    const double m = margin + 1e-12;
    const double s = std::sqrt(std::max(0.0, 1.0 - cmin * cmin));
    k.cos = cmin * (1.0 - 0.5 * m * m) - s * m;
    k.sin = std::min(1.0, s + cmin * m);
    k.wide = !(k.cos > 1.7e-3);
    return k;
  }

  // Cone culling's candidates for the current point.
  void find_candidates() {
    candidates_for = generation;
    const ShaftCuller& culler = vis->culler();
    faces.clear();
    for (int f = 0; f < culler.face_count(); ++f)
      if (!bounding[size_t(f)]) faces.push_back(f);
    culler.drop_hidden_faces(x.point, faces);
    candidates.resize(faces.size());
    for (size_t k = 0; k < faces.size(); ++k) {
      const Polygon& w = culler.faces()[size_t(faces[k])];
      const int n = static_cast<int>(w.size());
      candidates.set(k, n <= kMaxShaftPoints ? cone_of(w.data(), n, 0.0) : Cone{}, faces[k]);
    }
  }

  // The occluders of tile t's shaft from x (see the header).
  const std::vector<int>& tile_occluders(int t) {
    if (!cones || block_of[size_t(t)] < 0) {
      if (!receiver_set) grouped.set_receiver(&x.point, 1), receiver_set = true;
      return grouped.tile_occluders(t);
    }
    TileClip& c = tiles[size_t(t)];
    if (listed[size_t(t)] == generation) return c.occluders;
    listed[size_t(t)] = generation;
    if (candidates_for != generation) find_candidates();
    // The tile's patches lie within the culler's tolerance of its rectangle: widen cones by
    // what that offset can turn a direction (cone_of divides by the nearest corner's distance).
    const double offset = 8.0 * vis->culler().tolerance();
    // The block's candidates first, then the tile's among them.
    Block& block = blocks[size_t(block_of[size_t(t)])];
    if (block.stamp != generation) {
      block.stamp = generation;
      // Widened further for the rectangle's offset from the tiles' planes (at most 2 tolerances).
      const Cone cb = cone_of(block.corners.data(), static_cast<int>(block.corners.size()), 2.0 * offset);
      block.near.resize(candidates.size());
      size_t count = 0;
      for (size_t k = 0; k < candidates.size(); ++k) {
        block.near[count] = static_cast<int>(k);
        count += cb.wide || candidates.may_meet(k, cb);  // no branch
      }
      block.near.resize(count);
    }
    if (block.near.empty()) {  // no face's cone meets the block's: nothing shadows its tiles
      c.occluders.clear();
      no_occluders[size_t(t)] = 1;
      return c.occluders;
    }
    const Vec3* corners = grouped.tile_corners(t);
    const Cone ct = cone_of(corners, 4, offset);
    near.resize(block.near.size());
    size_t count = 0;
    for (int k : block.near) {
      near[count] = candidates.face[size_t(k)];
      count += ct.wide || candidates.may_meet(size_t(k), ct);
    }
    near.resize(count);
    // In face order, as the candidates are: occluders_among keeps it, so the clipping's order is fixed.
    vis->culler().occluders_among(&x.point, 1, corners, 4, near, c.occluders);
    no_occluders[size_t(t)] = c.occluders.empty();
    return c.occluders;
  }

  // tile_occluders(t).empty(), from the compact arrays once the list is known.
  bool tile_unoccluded(int t) {
    if (cones && listed[size_t(t)] == generation) return no_occluders[size_t(t)];
    return tile_occluders(t).empty();
  }

  // Appends `pieces` and their boxes, grown by `margin`, to the arena.
  void append_pieces(const PiecePool& pieces, double margin) {
    for (size_t k = 0; k < pieces.size(); ++k) {
      Eigen::AlignedBox3d b;
      for (const Vec3& y : pieces[k]) b.extend(y);
      b.min().array() -= margin;
      b.max().array() += margin;
      arena_boxes.push_back(b);
      arena_pieces.push_back({static_cast<int>(arena_corners.size()), static_cast<int>(pieces[k].size())});
      arena_corners.insert(arena_corners.end(), pieces[k].begin(), pieces[k].end());
    }
  }
  Span piece(int k) const {
    const Piece& p = arena_pieces[size_t(k)];
    return {arena_corners.data() + p.first, size_t(p.count)};
  }

  // The tile's clipping from x, done on first need per point.
  TileClip& clip(int t) {
    TileClip& c = tiles[size_t(t)];
    if (c.stamp == generation) return c;
    c.stamp = generation;
    clip_visible.clear();
    clip_hidden.clear();
    casting = tile_occluders(t);
    if (!cones) vis->culler().drop_hidden_faces(x.point, casting);  // cone candidates have none
    Polygon& rect = clip_visible.push();
    rect.resize(4);
    double scale = 0.0;
    for (int k = 0; k < 4; ++k) {
      rect[size_t(k)] = grouped.tile_corners(t)[k] - x.point;
      scale = std::max(scale, rect[size_t(k)].norm());
    }
    c.eps = 1e-12 * scale;
    c.normal = newell_vector(rect.data(), 4).normalized();  // before `rect` is clipped away
    c.cut = !casting.empty() && subtract_shadows(scale, vis->culler().faces(), casting,
                                                 &vis->culler().normals(), clip_visible, &clip_hidden, &vis->culler(), volumes);
    if (c.cut) {
      // Boxes grown by what a flat tile allows out of its plane (GroupedShaftCuller), so a patch
      // a hair off the tile's plane still meets the pieces over it.
      const double margin = c.eps + 4.0 * vis->culler().tolerance();
      c.first = static_cast<int>(arena_pieces.size());
      c.visible = static_cast<int>(clip_visible.size());
      c.hidden = static_cast<int>(clip_hidden.size());
      append_pieces(clip_visible, margin);
      append_pieces(clip_hidden, margin);
    }
    return c;
  }
};

PointVisibility::PointVisibility(const Visibility& vis, const PatchMesh& mesh, PointCulling culling)
    : impl_(std::make_unique<Impl>(vis, mesh, culling)), tile_of_patch_(impl_->grouped.tile_of_patches().data()) {}
PointVisibility::~PointVisibility() = default;
PointVisibility::PointVisibility(PointVisibility&&) noexcept = default;
PointVisibility& PointVisibility::operator=(PointVisibility&&) noexcept = default;

void PointVisibility::set_receiver(const Receiver& x) {
  last_tile_ = -2;  // tile_shadow's kept answer was for the last point
  // Culling and clipping depend on the point alone: a receiver at the same point (another
  // normal, as at a crease) keeps them.
  if (impl_->generation > 0 && x.point == impl_->x.point) {
    impl_->x = x;
    return;
  }
  impl_->x = x;
  impl_->receiver_set = false;  // the culler's receiver is set on first need
  impl_->volumes.start(x.point);
  impl_->arena_corners.clear();
  impl_->arena_pieces.clear();
  impl_->arena_boxes.clear();
  ++impl_->generation;
}

PointVisibility::TileShadow PointVisibility::shadow_of_tile(int t) {
  Impl& m = *impl_;
  if (m.vis->method() == VisibilityMethod::Rays || t < 0 || m.grouped.tile_corner_count(t) != 4)
    return TileShadow::Unknown;
  if (!m.receiver_set) m.grouped.set_receiver(&m.x.point, 1), m.receiver_set = true;
  if (m.tile_unoccluded(t)) return TileShadow::None;
  const Impl::TileClip& c = m.clip(t);
  if (!c.cut) return TileShadow::None;
  return c.visible == 0 ? TileShadow::Full : TileShadow::Unknown;
}

double PointVisibility::visible(int patch, const Vec3* b, int nb, const Vec3& normal, double unoccluded, int rays,
                                uint64_t stream, long long& rays_cast, bool& unshadowed) {
  Impl& m = *impl_;
  unshadowed = true;
  if (unoccluded <= 0.0) return unoccluded;
  const int t = m.grouped.tile_of(patch);
  if (!m.receiver_set) m.grouped.set_receiver(&m.x.point, 1), m.receiver_set = true;
  // Culling and clipping of this patch alone.
  auto by_patch = [&]() {
    m.grouped.occluders(patch, b, nb, m.occluders);
    if (m.occluders.empty()) return unoccluded;
    unshadowed = false;
    return m.vis->point_to_patch(m.x, b, nb, normal, unoccluded, m.occluders, rays, stream, rays_cast,
                                 /*narrow=*/true);  // culled from the point itself
  };
  if (m.vis->method() == VisibilityMethod::Rays || t < 0 || m.grouped.tile_corner_count(t) != 4 || nb < 3 || nb > 4)
    return by_patch();
  // The fast exit first: a tile with no occluders in its shaft needs no clipping at all.
  if (m.tile_unoccluded(t)) return unoccluded;
  Impl::TileClip& c = m.clip(t);
  if (!c.cut) return unoccluded;
  // Every piece hidden (they cover the tile): so is the patch.
  if (c.visible == 0) {
    unshadowed = false;
    return 0.0;
  }
  // The patch relative to x and its box: most patches are settled by boxes alone.
  Polygon &rel = m.rel, &part = m.part;
  rel.resize(size_t(nb));
  // The box from scalars: AlignedBox::extend kept its corners on the stack and reloaded them
  // across two stores, a stalled store forward per corner (a visible share of this function).
  rel[0] = b[0] - m.x.point;
  double lo[3] = {rel[0].x(), rel[0].y(), rel[0].z()}, hi[3] = {lo[0], lo[1], lo[2]};
  for (int k = 1; k < nb; ++k) {
    const Vec3 y = b[k] - m.x.point;
    rel[size_t(k)] = y;
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], y[a]);
      hi[a] = std::max(hi[a], y[a]);
    }
  }
  const Eigen::AlignedBox3d box(Vec3(lo[0], lo[1], lo[2]), Vec3(hi[0], hi[1], hi[2]));
  const Eigen::AlignedBox3d* boxes = m.arena_boxes.data() + c.first;  // the tile's, visible ones first
  const size_t visible_count = size_t(c.visible), piece_count = size_t(c.visible + c.hidden);
  // No visible piece near the patch: all of it is hidden (the pieces cover the tile).
  size_t near_visible = 0;
  for (size_t k = 0; k < visible_count; ++k) near_visible += boxes_meet(boxes[k], box);
  if (near_visible == 0) {
    unshadowed = false;
    return 0.0;
  }
  // No hidden piece near it: unshadowed.
  size_t first_hidden = visible_count, near_hidden = 0;
  while (first_hidden < piece_count && !boxes_meet(boxes[first_hidden], box)) ++first_hidden;
  if (first_hidden == piece_count) return unoccluded;
  for (size_t k = first_hidden; k < piece_count; ++k) near_hidden += boxes_meet(boxes[k], box);
  // The patch's edges' inward planes (each contains the edge and the patch's normal; m·y >= d
  // inside). Pieces are cut to the patch by these planes: a patch's edges are well shaped, while
  // a piece may have an edge of almost no length, whose direction rounding leaves undefined.
  const Vec3 n = newell_vector(rel.data(), nb).normalized();
  if (!(std::abs(n.dot(c.normal)) > 0.5)) return by_patch();  // not in the tile's plane (a degenerate patch)
  Plane edges[4];
  int edge_count = 0;
  for (int k = 0; k < nb; ++k) {
    Vec3 e = n.cross(rel[size_t((k + 1) % nb)] - rel[size_t(k)]);  // inward for a counter-clockwise patch
    const double len = e.norm();
    if (!(len > c.eps)) continue;
    e /= len;
    edges[edge_count++] = {e, e.dot(rel[size_t(k)])};
  }
  auto piece = [&](size_t k) { return m.piece(c.first + static_cast<int>(k)); };
  // Lambert's formula is additive over a partition of the patch (an integral over directions;
  // Stark 2000 sec. 1.1 clips the source the same way). Parts are moved along the
  // tile's normal into the patch's own plane (they differ by rounding on a flat face, by at most
  // the flatness tolerance on a nearly flat one).
  const Receiver at_origin{Vec3::Zero(), m.x.normal, m.x.approach};
  const double offset = n.dot(rel[0]), along = n.dot(c.normal);
  auto part_factor = [&](Span q) {
    part.assign(q.p, q.p + q.n);
    for (Vec3& y : part) y -= ((n.dot(y) - offset) / along) * c.normal;
    return lambert_form_factor(at_origin, part.data(), static_cast<int>(part.size()));
  };
  // The sum over the visible parts (accurate for any result, see below).
  auto visible_sum = [&]() {
    double f = 0.0;
    for (size_t k = 0; k < visible_count; ++k) {
      if (!boxes_meet(boxes[k], box)) continue;
      const Span q = clip_to_planes(piece(k), edges, edge_count, c.eps, m.work, m.tmp, m.values);
      if (q.n) f += part_factor(q);
    }
    return std::min(unoccluded, std::clamp(f, 0.0, 1.0));
  };
  // No more visible pieces than hidden ones near the patch: their sum takes no more cuts than the
  // hidden one, which may have to be followed by it anyway (below).
  if (near_visible <= near_hidden) {
    unshadowed = false;  // a shadow is near; the hidden pieces are not cut to tell whether it touches
    return visible_sum();
  }
  // The hidden parts of the patch: none of positive area, and the patch is unshadowed.
  bool overlaps = false;
  double hidden = 0.0;
  for (size_t k = first_hidden; k < piece_count; ++k) {
    if (!boxes_meet(boxes[k], box)) continue;
    const Span q = clip_to_planes(piece(k), edges, edge_count, c.eps, m.work, m.tmp, m.values);
    if (!q.n) continue;
    overlaps = true;
    hidden += part_factor(q);
  }
  if (!overlaps) return unoccluded;
  unshadowed = false;
  // At most half hidden: the visible factor is the unoccluded one less the hidden parts', with
  // an error of a few ulp of the result. Otherwise sum the visible parts, which keeps the
  // relative accuracy of a factor far smaller than the unoccluded one.
  if (hidden <= 0.5 * unoccluded) return std::clamp(unoccluded - hidden, 0.0, unoccluded);
  return visible_sum();
}

}  // namespace photometria
