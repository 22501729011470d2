#include "formfactors/facing.h"

#include <algorithm>

namespace photometria {

namespace {

// The least and the greatest value of n·y − d over box b.
FacingGroups::Range range_over(const Eigen::AlignedBox3d& b, const Vec3& n, double d) {
  const Vec3 centre = b.center();
  const Vec3 half = 0.5 * (b.max() - b.min());
  const double mid = n.dot(centre) - d;
  const double spread = n.cwiseAbs().dot(half);
  return {mid - spread, mid + spread};
}

}  // namespace

// Bounds on max over a source's corners of n·y − d, for every source of g: at most the highest
// corner, at least the lowest corner mean (some corner is at least as high as its patch's mean).
// In g's own plane the exact ranges along the normal; elsewhere over the boxes.
FacingGroups::Range FacingGroups::height_above(const Group& g, const Vec3& n, double d) {
  if (g.normal == n) return {g.mean_low - d, g.corner_high - d};
  return {range_over(g.means, n, d).low, range_over(g.corners, n, d).high};
}

FacingGroups::FacingGroups(const PatchMesh& mesh, double tol) : mesh_(&mesh), tol_(tol) {
  order_.resize(size_t(mesh.size()));
  for (int j = 0; j < mesh.size(); ++j) order_[size_t(j)] = j;
  for (int first = 0; first < mesh.size();) {
    int end = first + 1;
    while (end < mesh.size() && mesh.patches[size_t(end)].normal == mesh.patches[size_t(first)].normal) ++end;
    add_groups(first, end);
    first = end;
  }
}

void FacingGroups::add_groups(int first, int end) {
  const PatchMesh& mesh = *mesh_;
  auto centroid = [&](int j) -> const Vec3& { return mesh.patches[size_t(j)].centroid; };
  if (end - first > kFacingGroup) {
    Eigen::AlignedBox3d box;
    for (int k = first; k < end; ++k) box.extend(centroid(order_[size_t(k)]));
    int axis = 0;
    (box.max() - box.min()).maxCoeff(&axis);
    const int mid = first + (end - first) / 2;
    std::nth_element(order_.begin() + first, order_.begin() + mid, order_.begin() + end,
                     [&](int a, int b) { return centroid(a)[axis] < centroid(b)[axis]; });
    add_groups(first, mid);
    add_groups(mid, end);
    return;
  }
  Group g;
  g.first = first;
  g.end = end;
  g.normal = mesh.patches[size_t(order_[size_t(first)])].normal;
  for (int k = first; k < end; ++k) {
    const Patch& p = mesh.patches[size_t(order_[size_t(k)])];
    Vec3 mean = Vec3::Zero();
    for (int c = 0; c < p.corner_count; ++c) {
      const Vec3& y = mesh.points[size_t(p.corners[size_t(c)])];
      g.corners.extend(y);
      g.corner_high = std::max(g.corner_high, g.normal.dot(y));
      mean += y;
    }
    mean /= std::max(p.corner_count, 1);
    g.means.extend(mean);
    g.mean_low = std::min(g.mean_low, g.normal.dot(mean));
    g.centroid_low = std::min(g.centroid_low, g.normal.dot(p.centroid));
    g.centroid_high = std::max(g.centroid_high, g.normal.dot(p.centroid));
  }
  groups_.push_back(g);
}

void FacingGroups::classify(int i, Facing* out) const {
  const Patch& a = mesh_->patches[size_t(i)];
  Vec3 mean = Vec3::Zero();
  for (int k = 0; k < a.corner_count; ++k) mean += mesh_->points[size_t(a.corners[size_t(k)])];
  mean /= std::max(a.corner_count, 1);
  const double margin = 0.5 * tol_;
  const double d_a = a.normal.dot(a.centroid);
  for (const Group& g : groups_) {
    // The source above the receiver's plane: max over j's corners of n_a·(y − c_a) > tol.
    const Range above = height_above(g, a.normal, d_a);
    // The receiver in front of the source's plane: max over i's corners of n_j·(y − c_j) > tol,
    // with n_j·c_j anywhere in the group's centroid range.
    double front_high = -1e300;
    for (int k = 0; k < a.corner_count; ++k)
      front_high = std::max(front_high, g.normal.dot(mesh_->points[size_t(a.corners[size_t(k)])]));
    front_high -= g.centroid_low;
    const double front_low = g.normal.dot(mean) - g.centroid_high;
    Facing f = Facing::Test;
    if (above.high <= tol_ - margin || front_high <= tol_ - margin) f = Facing::Away;
    else if (above.low > tol_ + margin && front_low > tol_ + margin) f = Facing::Toward;
    for (int k = g.first; k < g.end; ++k) out[order_[size_t(k)]] = f;
  }
}

void FacingGroups::classify_point(const Vec3& x, const Vec3& normal, Facing* out) const {
  const double margin = 0.5 * tol_;
  const double d_x = normal.dot(x);
  for (const Group& g : groups_) {
    // The source above x's plane: max over j's corners of n_x·(y − x) > tol.
    const Range above = height_above(g, normal, d_x);
    // x not behind the source's plane: n_j·(x − c_j) >= −tol, with n_j·c_j in the centroid range.
    const double ahead_high = g.normal.dot(x) - g.centroid_low, ahead_low = g.normal.dot(x) - g.centroid_high;
    Facing f = Facing::Test;
    if (above.high <= tol_ - margin || ahead_high < -tol_ - margin) f = Facing::Away;
    else if (above.low > tol_ + margin && ahead_low >= -tol_ + margin) f = Facing::Toward;
    for (int k = g.first; k < g.end; ++k) out[order_[size_t(k)]] = f;
  }
}

void lambert_form_factors_facing(const Receiver& receiver, const PolygonBatch& sources, const Facing* facing,
                                 double* out) {
  constexpr int kMinSkip = 8;  // shorter runs of Away sources are cheaper to evaluate than to split at
  const int n = sources.size;
  int begin = 0;  // start of the sources still to evaluate
  int j = 0;
  while (j < n) {
    if (facing[j] != Facing::Away) {
      ++j;
      continue;
    }
    int end = j;
    while (end < n && facing[end] == Facing::Away) ++end;
    if (end - j >= kMinSkip || end == n) {
      lambert_form_factors(receiver, sources, begin, j, out + begin);
      std::fill(out + j, out + end, 0.0);
      begin = end;
    }
    j = end;
  }
  lambert_form_factors(receiver, sources, begin, n, out + begin);
}

}  // namespace photometria
