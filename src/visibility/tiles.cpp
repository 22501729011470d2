// Tiles: a mesh's patches grouped per scene face into tiles of neighbouring patches, each
// bounded by a rectangle in the face's plane (or a box), and the hierarchical shaft culling of
// one receiver against them: face, then tile, then patch (GroupedShaftCuller, visibility.h).
// Tiles and the face level are over scene faces (what patches belong to); the lists they find
// hold occluders (ShaftCuller: scene faces merged into convex polygons).
#include <algorithm>
#include <stdexcept>
#include <utility>
#include <vector>

#include "visibility/visibility.h"
#include "visibility/visibility_internal.h"

namespace photometria {

using namespace visibility_detail;

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
  const int faces = culler.scene_face_count();
  std::vector<std::vector<int>> by_face(static_cast<size_t>(faces));
  for (int j = 0; j < mesh.size(); ++j)
    if (mesh.patches[size_t(j)].face >= 0 && mesh.patches[size_t(j)].face < faces)
      by_face[size_t(mesh.patches[size_t(j)].face)].push_back(j);
  std::vector<Eigen::Vector2d> uv(size_t(mesh.size()), Eigen::Vector2d::Zero());
  for (int f = 0; f < faces; ++f) {
    std::vector<int>& patches = by_face[size_t(f)];
    if (patches.empty()) continue;
    // An orthonormal frame (u, v, w) with w the face's normal (any frame if it has none).
    Vec3 w = polygon_normal(culler.scene_faces()[size_t(f)]);
    if (w.isZero()) w = Vec3::UnitZ();
    const Vec3 u = w.unitOrthogonal(), v = w.cross(u);
    for (int j : patches)
      uv[size_t(j)] = Eigen::Vector2d(u.dot(mesh.patches[size_t(j)].centroid), v.dot(mesh.patches[size_t(j)].centroid));
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
      // A face that is one patch, corner for corner: the patch's shaft is the face's, so its list
      // is the face's (occluders()), with no tile or patch shaft built again.
      if (patches.size() == 1) {
        const Patch& p = mesh.patches[size_t(patches[0])];
        const Polygon& face = culler.scene_faces()[size_t(f)];
        tile.whole_face = p.corner_count == static_cast<int>(face.size());
        for (int c = 0; c < p.corner_count && tile.whole_face; ++c)
          tile.whole_face =
              std::find(face.begin(), face.end(), mesh.points[size_t(p.corners[size_t(c)])]) != face.end();
      }
      const int t = static_cast<int>(tiles_.size());
      tiles_.push_back(tile);
      tile_corner_counts_.push_back(static_cast<unsigned char>(tile.corner_count));
      for (int k = first; k < first + count; ++k) tile_of_patch_[size_t(patches[size_t(k)])] = t;
    }
  }
  build_face_groups();
  stamp_.assign(size_t(faces) + tiles_.size() + face_groups_.size(), -1);
  groups_.resize(size_t(faces) + tiles_.size() + face_groups_.size());
}

void GroupedShaftCuller::build_face_groups() {
  const ShaftCuller& culler = *culler_;
  face_group_of_face_.assign(size_t(culler.scene_face_count()), -1);
  std::vector<Eigen::Vector2d> uv(size_t(culler.scene_face_count()), Eigen::Vector2d::Zero());
  for (int o = 0; o < culler.occluder_count(); ++o) {
    std::vector<int> faces = culler.occluder_faces(o);
    if (faces.size() < 2) continue;
    const Vec3 w = culler.occluder_normals()[size_t(o)];
    if (w.isZero()) continue;
    const Vec3 u = w.unitOrthogonal(), v = w.cross(u);
    for (int f : faces) {
      const Polygon& p = culler.scene_faces()[size_t(f)];
      Vec3 centroid = Vec3::Zero();
      for (const Vec3& x : p) centroid += x / double(p.size());
      uv[size_t(f)] = Eigen::Vector2d(u.dot(centroid), v.dot(centroid));
    }
    std::vector<std::pair<int, int>> ranges;
    split_tiles(faces, uv, 0, static_cast<int>(faces.size()), kFaceGroupFaces, ranges);
    for (const auto& [first, count] : ranges) {
      if (count < 2) continue;  // one face: its own shaft is as wide
      Eigen::AlignedBox3d box;  // in (u, v, w) coordinates
      for (int k = first; k < first + count; ++k)
        for (const Vec3& x : culler.scene_faces()[size_t(faces[size_t(k)])])
          box.extend(Vec3(u.dot(x), v.dot(x), w.dot(x)));
      // Grown by the culler's tolerance, so the rectangle contains its faces (as tiles do).
      box.min().array() -= culler.tolerance();
      box.max().array() += culler.tolerance();
      if (box.sizes().z() > 4.0 * culler.tolerance()) continue;  // not flat after all: no group
      const double wc = 0.5 * (box.min().z() + box.max().z());
      const double cu[4] = {box.min().x(), box.max().x(), box.max().x(), box.min().x()};
      const double cv[4] = {box.min().y(), box.min().y(), box.max().y(), box.max().y()};
      FaceGroup group;
      for (int c = 0; c < 4; ++c) group.corners[c] = cu[c] * u + cv[c] * v + wc * w;
      for (int k = first; k < first + count; ++k)
        face_group_of_face_[size_t(faces[size_t(k)])] = static_cast<int>(face_groups_.size());
      face_groups_.push_back(group);
    }
  }
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
  const int faces = culler_->scene_face_count();
  const int first_face_group = faces + static_cast<int>(tiles_.size());
  // From a point, a convex solid's back occluders cast no shadow of their own
  // (drop_hidden_occluders): leaving them out at the widest level shortens every list below.
  const bool drop_hidden = receiver_count_ == 1;
  if (g >= first_face_group) {
    culler_->occluders(receiver_, receiver_count_, face_groups_[size_t(g - first_face_group)].corners, 4, list,
                       drop_hidden);
    return list;
  }
  if (g < faces) {
    const Polygon& face = culler_->scene_faces()[size_t(g)];
    const int face_group = face_group_of_face_[size_t(g)];
    if (face_group >= 0 && static_cast<int>(face.size()) + receiver_count_ <= kMaxShaftPoints)
      culler_->occluders_among(receiver_, receiver_count_, face.data(), static_cast<int>(face.size()),
                               group(first_face_group + face_group), list);
    else culler_->occluders(receiver_, receiver_count_, face.data(), static_cast<int>(face.size()), list, drop_hidden);
    return list;
  }
  const Tile& tile = tiles_[size_t(g - faces)];
  if (static_cast<int>(culler_->scene_faces()[size_t(tile.face)].size()) + 4 > kMaxShaftPoints)
    culler_->occluders(receiver_, receiver_count_, tile.corners, tile.corner_count,
                       list);  // a face of many corners: no face level
  else culler_->occluders_among(receiver_, receiver_count_, tile.corners, tile.corner_count, group(tile.face), list);
  return list;
}

void GroupedShaftCuller::occluders(int patch, const Vec3* b, int nb, std::vector<int>& out) {
  const int t = patch >= 0 && patch < static_cast<int>(tile_of_patch_.size()) ? tile_of_patch_[size_t(patch)] : -1;
  if (t < 0) {
    culler_->occluders(receiver_, receiver_count_, b, nb, out);
    return;
  }
  if (tiles_[size_t(t)].whole_face) {
    out = group(tiles_[size_t(t)].face);
    return;
  }
  culler_->occluders_among(receiver_, receiver_count_, b, nb, group(culler_->scene_face_count() + t), out);
}

int GroupedShaftCuller::tile_of(int patch) const {
  return patch >= 0 && patch < static_cast<int>(tile_of_patch_.size()) ? tile_of_patch_[size_t(patch)] : -1;
}

}  // namespace photometria
