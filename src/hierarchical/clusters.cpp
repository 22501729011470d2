// The cluster tree and the clusters' transfer (clusters.h).
#include "hierarchical/clusters.h"

#include <algorithm>
#include <cmath>

namespace photometria {

namespace {

struct FacePlane {
  Vec3 normal;
  double offset;  // normal · (a point of the plane)
};

class TreeBuilder {
 public:
  TreeBuilder(const std::vector<ClusterFace>& faces, double tolerance, ClusterTree& tree)
      : faces_(faces), tol_(tolerance), tree_(tree) {
    Eigen::AlignedBox3d box;
    for (const ClusterFace& f : faces) box.extend(f.centroid);
    normal_scale_ = box.isEmpty() ? 0.0 : 0.5 * box.diagonal().norm();
  }

  // The node over order[first, first + count); `planes` receives its faces' distinct planes while
  // it is convex (empty otherwise).
  int build(int first, int count, std::vector<FacePlane>& planes, bool& convex) {
    if (count == 1) {
      const ClusterFace& f = faces_[size_t(tree_.order[size_t(first)])];
      planes.assign(1, FacePlane{f.normal, f.normal.dot(f.corners[0])});
      convex = true;
      return tree_.order[size_t(first)];
    }
    // The longest axis of the faces' keys: centroid and normal (scaled to the scene's size), so
    // that faces turned differently part early and the clusters below are flat or convex pieces
    // of one surface, which cluster links can join (clusters.h).
    Eigen::Matrix<double, 6, 1> lo = Eigen::Matrix<double, 6, 1>::Constant(1e300), hi = -lo;
    for (int k = first; k < first + count; ++k) {
      const Eigen::Matrix<double, 6, 1> key = key_of(tree_.order[size_t(k)]);
      lo = lo.cwiseMin(key);
      hi = hi.cwiseMax(key);
    }
    int axis = 0;
    (hi - lo).maxCoeff(&axis);
    const int half = count / 2;
    const auto begin = tree_.order.begin() + first;
    std::nth_element(begin, begin + half, begin + count,
                     [&](int a, int b) { return key_of(a)[axis] < key_of(b)[axis]; });
    std::vector<FacePlane> left_planes, right_planes;
    bool left_convex = false, right_convex = false;
    const int left = build(first, half, left_planes, left_convex);
    const int right = build(first + half, count - half, right_planes, right_convex);

    Cluster c;
    c.first = first;
    c.count = count;
    c.children[0] = left;
    c.children[1] = right;
    for (int k = first; k < first + count; ++k) {
      const ClusterFace& f = faces_[size_t(tree_.order[size_t(k)])];
      for (int i = 0; i < f.corner_count; ++i) c.box.extend(f.corners[i]);
      c.area += f.area;
      c.centre += f.area * f.centroid;
      c.vector_area += f.area * f.normal;
      c.reflectance = std::max(c.reflectance, f.reflectance);
    }
    c.centre /= c.area;
    const double length = c.vector_area.norm();
    c.normal_spread = length > 1e-12 * c.area ? 0.0 : M_PI;
    for (int k = first; k < first + count; ++k) {
      const ClusterFace& f = faces_[size_t(tree_.order[size_t(k)])];
      for (int i = 0; i < f.corner_count; ++i) c.radius = std::max(c.radius, (f.corners[i] - c.centre).norm());
      if (c.normal_spread < M_PI)
        c.normal_spread =
            std::max(c.normal_spread, std::acos(std::clamp(f.normal.dot(c.vector_area) / length, -1.0, 1.0)));
    }
    add_moments(c);
    convex = left_convex && right_convex && behind(first + half, count - half, left_planes) &&
             behind(first, half, right_planes);
    planes.clear();
    if (convex) {
      planes = std::move(left_planes);
      for (const FacePlane& p : right_planes)
        if (std::none_of(planes.begin(), planes.end(), [&](const FacePlane& q) {
              return (q.normal - p.normal).norm() <= 1e-9 && std::abs(q.offset - p.offset) <= tol_;
            }))
          planes.push_back(p);
      if (planes.size() > size_t(kMaxConvexPlanes)) {
        convex = false;
        planes.clear();
      }
    }
    c.convex = convex;
    const int id = static_cast<int>(tree_.clusters.size());
    tree_.clusters.push_back(c);
    for (int child : {left, right}) {
      if (child >= 0) tree_.parent[size_t(child)] = id;
      else tree_.clusters[size_t(cluster_of_node(child))].parent = id;
    }
    return cluster_node(id);
  }

 private:
  // Every corner of the faces order[first, first + count) on or behind every plane.
  bool behind(int first, int count, const std::vector<FacePlane>& planes) const {
    for (int k = first; k < first + count; ++k) {
      const ClusterFace& f = faces_[size_t(tree_.order[size_t(k)])];
      for (const FacePlane& p : planes)
        for (int i = 0; i < f.corner_count; ++i)
          if (p.normal.dot(f.corners[i]) - p.offset > tol_) return false;
    }
    return true;
  }

  // The cluster's second moment of area M and normal-offset sum T about its centre (clusters.h);
  // a face's second moment from its triangles, ∫_t δ δᵀ dA = (A_t / 12)(Σ_i v_i v_iᵀ + s sᵀ) with
  // v_i its corners' offsets and s their sum: the edge-midpoint rule, exact for quadratics on a
  // triangle (Strang & Fix, "An Analysis of the Finite Element Method", 1973, ch. 4),
  // (A_t / 3) Σ m mᵀ over the midpoints m = (v_i + v_j) / 2, expanded.
  void add_moments(Cluster& c) const {
    for (int k = c.first; k < c.first + c.count; ++k) {
      const ClusterFace& f = faces_[size_t(tree_.order[size_t(k)])];
      c.normal_offset += f.area * f.normal * (f.centroid - c.centre).transpose();
      for (int t = 1; t + 1 < f.corner_count; ++t) {
        const Vec3 v[3] = {f.corners[0] - c.centre, f.corners[t] - c.centre, f.corners[t + 1] - c.centre};
        const double area = 0.5 * (v[1] - v[0]).cross(v[2] - v[0]).norm();
        const Vec3 sum = v[0] + v[1] + v[2];
        c.area_moment += (area / 12.0) * (v[0] * v[0].transpose() + v[1] * v[1].transpose() + v[2] * v[2].transpose() +
                                          sum * sum.transpose());
      }
    }
  }

  Eigen::Matrix<double, 6, 1> key_of(int f) const {
    Eigen::Matrix<double, 6, 1> key;
    key << faces_[size_t(f)].centroid, normal_scale_ * faces_[size_t(f)].normal;
    return key;
  }

  const std::vector<ClusterFace>& faces_;
  double tol_, normal_scale_ = 0.0;
  ClusterTree& tree_;
};

}  // namespace

ClusterTree build_cluster_tree(const std::vector<ClusterFace>& faces, double tolerance) {
  ClusterTree tree;
  const int n = static_cast<int>(faces.size());
  tree.order.resize(size_t(n));
  for (int i = 0; i < n; ++i) tree.order[size_t(i)] = i;
  tree.parent.assign(size_t(n), -1);
  if (n > 1) {
    tree.clusters.reserve(size_t(n - 1));
    std::vector<FacePlane> planes;
    bool convex = false;
    TreeBuilder(faces, tolerance, tree).build(0, n, planes, convex);
  }
  tree.face_radius.assign(size_t(n), 0.0);
  for (int i = 0; i < n; ++i) {
    const ClusterFace& f = faces[size_t(i)];
    for (int k = 0; k < f.corner_count; ++k)
      tree.face_radius[size_t(i)] = std::max(tree.face_radius[size_t(i)], (f.corners[k] - f.centroid).norm());
  }
  tree.position.resize(size_t(n));
  for (int k = 0; k < n; ++k) tree.position[size_t(tree.order[size_t(k)])] = k;
  return tree;
}

Vec3 node_centre(const ClusterTree& tree, const std::vector<ClusterFace>& faces, int node) {
  return node >= 0 ? faces[size_t(node)].centroid : tree.clusters[size_t(cluster_of_node(node))].centre;
}

double node_radius(const ClusterTree& tree, const std::vector<ClusterFace>&, int node) {
  return node < 0 ? tree.clusters[size_t(cluster_of_node(node))].radius : tree.face_radius[size_t(node)];
}

ClusterTransfer cluster_transfer(const ClusterTree& tree, const std::vector<ClusterFace>& faces, int receiver,
                                 int source) {
  ClusterTransfer t;
  const Vec3 ca = node_centre(tree, faces, receiver), cb = node_centre(tree, faces, source);
  const double ra = node_radius(tree, faces, receiver), rb = node_radius(tree, faces, source);
  t.distance = (cb - ca).norm();
  const double d = t.distance, reach = ra + rb;
  if (!(d > 2.0 * reach)) return t;
  // Every face of the source turned toward every point of the receiver's ball.
  const int first = source >= 0 ? 0 : tree.clusters[size_t(cluster_of_node(source))].first;
  const int count = source >= 0 ? 1 : tree.clusters[size_t(cluster_of_node(source))].count;
  for (int k = first; k < first + count; ++k) {
    const ClusterFace& q = faces[size_t(source >= 0 ? source : tree.order[size_t(k)])];
    if (!(q.normal.dot(ca - q.centroid) > ra)) return t;
  }
  t.valid = true;
  const Vec3 u = (cb - ca) / d;
  const Vec3 vector_area = source >= 0 ? Vec3(faces[size_t(source)].area * faces[size_t(source)].normal)
                                       : tree.clusters[size_t(cluster_of_node(source))].vector_area;
  const double spread = source >= 0 ? 0.0 : tree.clusters[size_t(cluster_of_node(source))].normal_spread;
  // The factor at A's centre with the receiver's normal along u (clusters.h).
  t.factor = std::max(0.0, -vector_area.dot(u)) / (M_PI * d * d);
  // Second order in the sides' extent, first order in the source's spread of normals (clusters.h).
  const double s = reach / d;
  t.error = t.factor * (s * s + (rb / d) * spread);
  return t;
}

double cluster_factor_at(const Vec3& x, const Vec3& n, const Cluster& source) {
  const Vec3 w = source.centre - x;
  const double d2 = w.squaredNorm();
  const double a = n.dot(w), b_total = -source.vector_area.dot(w);
  if (!(d2 > 0.0) || a <= 0.0 || b_total <= 0.0) return 0.0;
  const double d4 = d2 * d2, d6 = d4 * d2, d8 = d4 * d4;
  // The expansion of clusters.h, term by term (Cohen & Wallace 1993, ch. 4, the kernel).
  const double f0 = a * b_total / (M_PI * d4);
  const Eigen::Matrix3d& T = source.normal_offset;
  const double f1 = (-w.dot(T * n) - a * T.trace()) / (M_PI * d4) + 4.0 * a * w.dot(T * w) / (M_PI * d6);
  const Eigen::Matrix3d& M = source.area_moment;
  const Vec3 m = source.vector_area / source.area;
  const double b = -m.dot(w);
  const double trace_hm = -2.0 * n.dot(M * m) / d4 - 8.0 * w.dot(M * (n * b - m * a)) / d6 -
                          4.0 * a * b * M.trace() / d6 + 24.0 * a * b * w.dot(M * w) / d8;
  return std::max(0.0, f0 + f1 + 0.5 * trace_hm / M_PI);
}

}  // namespace photometria
