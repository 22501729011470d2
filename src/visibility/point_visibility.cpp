// Visible form factors from one point: Visibility::point_to_patch (the point and one patch, by
// rays or exactly) and PointVisibility (the point and every patch of a mesh, exactly by one
// clipping per tile of patches, with tree or cone culling of the tiles' occluders; visibility.h).
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <vector>

#include "kernels/lambert.h"
#include "visibility/shadow_clipping.h"
#include "visibility/visibility.h"
#include "visibility/visibility_internal.h"

namespace photometria {

using namespace visibility_detail;

Visibility::Visibility(const Scene& scene, VisibilityMethod method, RaySampling sampling)
    : method_(method), culler_(scene) {
  if (method == VisibilityMethod::Rays) rays_ = std::make_unique<RayVisibility>(scene, sampling);
}

double Visibility::point_to_patch(const Receiver& x, const Vec3* source, int n, const Vec3& source_normal,
                                  double unoccluded, const std::vector<int>& occluders, int rays, uint64_t stream,
                                  RayTally& tally, bool narrow, int on_face) const {
  if (occluders.empty() || unoccluded <= 0.0) return unoccluded;
  // The shaft of the point and the patch is narrower than the pair's: test it too.
  thread_local std::vector<int> narrowed;
  if (!narrow) {
    culler_.occluders_among(&x.point, 1, source, n, occluders, narrowed);  // ⊆ the wider shaft's
    if (narrowed.empty()) return unoccluded;
  }
  if (method_ == VisibilityMethod::Exact) {
    // Only the occluders of each convex solid that face x cast its shadow (see ShaftCuller).
    thread_local std::vector<int> casting;
    casting = narrow ? occluders : narrowed;
    culler_.drop_hidden_occluders(x.point, casting, on_face, &x.normal);
    return std::min(unoccluded, exact_visible_form_factor(x, source, n, culler_.occluder_polygons(), casting,
                                                          &culler_.occluder_normals(), &culler_));
  }
  // Start just inside the point's own surface when it sits on an edge or corner, so rays leave cleanly.
  const Vec3 start = x.approach.isZero() ? x.point : Vec3(x.point + 10 * rays_->surface_offset() * x.approach);
  int used = 0;
  double variance = 0.0;
  const double v = rays_->point_to_patch(start, x.normal, source, n, source_normal, rays, stream, &used, &variance);
  tally.cast += used;
  tally.variance += unoccluded * unoccluded * variance;
  return unoccluded * v;
}

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
    if (in_count == out.n) continue;    // all on or inside
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
    bool cut = false;  // false: no occluder shadows any of the tile
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
  // Cones of occluders, structure of arrays for the filter loops below. A wide cone is stored with
  // a zero axis and cos = −1e9, so that it passes every test against a cone that is not wide.
  struct ConeSet {
    std::vector<double> ax, ay, az, cos, sin;
    std::vector<int> occluder;
    size_t size() const { return occluder.size(); }
    void resize(size_t n) {
      for (auto* v : {&ax, &ay, &az, &cos, &sin}) v->resize(n);
      occluder.resize(n);
    }
    void set(size_t k, const Cone& c, int f) {
      ax[k] = c.wide ? 0.0 : c.axis.x();
      ay[k] = c.wide ? 0.0 : c.axis.y();
      az[k] = c.wide ? 0.0 : c.axis.z();
      cos[k] = c.wide ? -1e9 : c.cos;
      sin[k] = c.wide ? 0.0 : c.sin;
      occluder[k] = f;
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
  int on_face = -1;  // the scene face whose interior holds x, or -1
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
  ShadowVolumes volumes;         // seen from x, shared by its tiles
  Polygon rel, part, work, tmp;  // scratch of visible()
  std::vector<double> values;
  // Cone culling (see the header): the occluders that may shadow from x and their cones.
  bool cones;
  long long candidates_for = -1;  // the point they belong to
  ConeSet candidates;
  std::vector<int> shadowing, near;
  std::vector<Vec3> directions;  // scratch of cone_of
  // A block: up to kBlockTiles consecutive tiles of one face (split_tiles makes them
  // neighbours), culled first, so a tile tests only its block's candidates.
  static constexpr int kBlockTiles = 8;
  struct Block {
    std::vector<Vec3> corners;  // its tiles' corners, or the 4 of a rectangle in their plane that contains them
    long long stamp = -1;
    std::vector<int> near;  // the candidates (indices) whose cones may meet the block's
  };
  std::vector<Block> blocks;
  std::vector<int> block_of;  // per tile
  // Per tile, compact (read for every patch, where a TileClip would be a cache miss on large
  // meshes): the point its cone-culled occluder list belongs to, and whether that list is empty.
  std::vector<long long> listed;
  std::vector<unsigned char> no_occluders;
  std::vector<unsigned char> bounding;  // per occluder: every scene corner on one side of its plane

  Impl(const Visibility& v, const PatchMesh& mesh, PointCulling culling)
      : vis(&v), grouped(v.culler(), mesh, kPointTilePatches) {
    tiles.resize(size_t(grouped.tile_count()));
    cones = culling == PointCulling::Cones ||
            (culling == PointCulling::Auto && v.culler().occluder_count() <= kConeCullingOccluders);
    // Occluders with every scene corner on one closed side of their plane (a room's walls) block no
    // segment between scene points: never candidates.
    const ShaftCuller& culler = v.culler();
    bounding.assign(size_t(culler.occluder_count()), 0);
    if (cones)
      for (int f = 0; f < culler.occluder_count(); ++f) {
        const Vec3& n = culler.occluder_normals()[size_t(f)];
        const Vec3& w0 = culler.occluder_polygons()[size_t(f)][0];
        bool below = true, above = true;
        for (const Polygon& g : culler.occluder_polygons())
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
      if (blocks.empty() || blocks.back().corners.size() >= 4 * kBlockTiles || block_face != face)
        blocks.emplace_back();
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
    shadowing.clear();
    for (int f = 0; f < culler.occluder_count(); ++f)
      if (!bounding[size_t(f)]) shadowing.push_back(f);
    culler.drop_hidden_occluders(x.point, shadowing, on_face, &x.normal);
    candidates.resize(shadowing.size());
    for (size_t k = 0; k < shadowing.size(); ++k) {
      const Polygon& w = culler.occluder_polygons()[size_t(shadowing[k])];
      const int n = static_cast<int>(w.size());
      candidates.set(k, n <= kMaxShaftPoints ? cone_of(w.data(), n, 0.0) : Cone{}, shadowing[k]);
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
    if (block.near.empty()) {  // no occluder's cone meets the block's: nothing shadows its tiles
      c.occluders.clear();
      no_occluders[size_t(t)] = 1;
      return c.occluders;
    }
    const Vec3* corners = grouped.tile_corners(t);
    const Cone ct = cone_of(corners, 4, offset);
    near.resize(block.near.size());
    size_t count = 0;
    for (int k : block.near) {
      near[count] = candidates.occluder[size_t(k)];
      count += ct.wide || candidates.may_meet(size_t(k), ct);
    }
    near.resize(count);
    // In occluder order, as the candidates are: occluders_among keeps it, so the clipping's order is fixed.
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
    if (!cones) vis->culler().drop_hidden_occluders(x.point, casting, on_face, &x.normal);  // cone candidates have none
    Polygon& rect = clip_visible.push();
    rect.resize(4);
    double scale = 0.0;
    for (int k = 0; k < 4; ++k) {
      rect[size_t(k)] = grouped.tile_corners(t)[k] - x.point;
      scale = std::max(scale, rect[size_t(k)].norm());
    }
    c.eps = 1e-12 * scale;
    c.normal = newell_vector(rect.data(), 4).normalized();  // before `rect` is clipped away
    c.cut = !casting.empty() &&
            subtract_shadows(scale, vis->culler().occluder_polygons(), casting, &vis->culler().occluder_normals(),
                             clip_visible, &clip_hidden, &vis->culler(), volumes);
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
    : mesh_(&mesh),
      impl_(std::make_unique<Impl>(vis, mesh, culling)),
      tile_of_patch_(impl_->grouped.tile_of_patches().data()) {}
PointVisibility::~PointVisibility() = default;
PointVisibility::PointVisibility(PointVisibility&&) noexcept = default;
PointVisibility& PointVisibility::operator=(PointVisibility&&) noexcept = default;

void PointVisibility::set_receiver(const Receiver& x, int on_face) {
  last_tile_ = -2;  // tile_shadow's kept answer was for the last point
  // Culling and clipping depend on the point alone: a receiver at the same point (another
  // normal, as at a crease) keeps them.
  // On the surface of a non-convex solid, the culling depends on the normal too.
  if (impl_->generation > 0 && x.point == impl_->x.point && on_face == impl_->on_face &&
      (x.normal == impl_->x.normal || !impl_->vis->culler().on_closed_solid(x.point))) {
    impl_->x = x;
    return;
  }
  impl_->x = x;
  impl_->on_face = on_face;
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
                                uint64_t stream, RayTally& tally, bool& unshadowed) {
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
    return m.vis->point_to_patch(m.x, b, nb, normal, unoccluded, m.occluders, rays, stream, tally,
                                 /*narrow=*/true, m.on_face);  // culled from the point itself
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
  // Stark 2000 sec. 1.1, full reference in visibility.h, clips the source the same way). Parts
  // are moved along the tile's normal into the patch's own plane (they differ by rounding on a
  // flat face, by at most the flatness tolerance on a nearly flat one).
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
