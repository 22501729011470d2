// Visibility between patches: which pairs need it, and the visible part of a form factor.
//
// Occluders are the scene's surfaces, two-sided (docs/theory.md "Units and conventions": emission
// and reflection are one-sided, occlusion is two-sided): convex polygons, each the union of
// coplanar, edge-connected scene faces of one orientation (ShaftCuller). A wall, floor or table
// top that arrives meshed into hundreds of small quads is one occluder (or a few convex pieces),
// a box meshed into quads is 6 and one convex solid: the cost of exact visibility (3.) grows
// with the surfaces that matter, not with the face count (an occluder's shadow volume costs
// what a face's does, the clipping's cuts and pieces go with the occluders met). The occluders
// cover exactly the points the faces cover, so what they block is what the faces block. Scene
// faces stay what the patches belong to (GroupedShaftCuller groups by them) and what rays hit.
// Three pieces, used per receiver point x (a quadrature point of a patch, or an output vertex)
// and source patch P:
//
//  1. Shaft culling (Haines & Wallace, "Shaft culling for efficient ray-cast radiosity", 1994):
//     the shaft of a pair is the convex hull of the two patches (or of the point and the patch).
//     An occluder that does not meet it cannot block any segment between them, so a pair whose
//     shaft meets none needs no visibility work at all. Candidates come from an AABB tree over
//     the occluders' bounding boxes, so a query costs O(log N_occluders + candidates), not
//     O(N_occluders); a point's shaft also prunes the subtrees outside one of its planes.
//  2. Ray casting (Embree 3, over the scene faces): V(x, P) = Σ_k w_k v_k / Σ_k w_k over K segments from x to
//     stratified points y_k on P, v_k = 1 if no face blocks the segment, w_k = cos θx cos θy / r²
//     the form-factor integrand at y_k (Wallace, Elmquist & Haines 1989 weight each ray by its
//     differential form factor the same way); the visible factor is F(dA_x -> P) · V(x, P).
//  3. Exact (Nishita & Nakamae 1985, in 3-D): P is clipped against the shadow volume of every
//     candidate occluder W seen from x (the cone from x through W's edges, beyond W's plane),
//     and Lambert's closed form (kernels/lambert.h; M. M. Stark, "Vertex-Based Formulations of
//     Irradiance from Polygonal Sources", University of Utah UUCS-00-012, 2000, eq. 3) is summed
//     over the visible convex fragments (Stark 2000 sec. 1.1: occluded irradiance by clipping
//     the source against the occluders, which is why vertex-based sums suit clipped polygons).
//     Clipping against wedge planes through x in 3-D, not projecting onto an image plane, keeps
//     occluders that touch the receiver's plane exact: the image-plane form needs the projected
//     polygon bounded, i.e. strictly above the receiver plane (Stark 2000 sec. 2.2; sec. 6 for the
//     fix).
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "kernels/lambert.h"
#include "patching/patching.h"
#include "scene/scene.h"

namespace photometria {

// True when no face can block the segment between any two points of the scene's faces: every
// vertex lies on or in front of every face's plane, so the faces bound one convex region seen
// from inside and any segment between two boundary points runs through its interior (or along a
// face's plane, where the form factor is 0 anyway). Explains the verdict in `reason`.
bool scene_needs_no_visibility(const Scene& scene, std::string* reason = nullptr);

// Shaft culling over the scene's occluders (see 1. above).
//
// An occluder is a convex polygon, the union of scene faces that are coplanar (unit plane
// normals within 1e-9 rad, plane offsets within tolerance()), of one orientation and joined by
// shared edges (the same two scene vertices; load_scene welds corners within 1e-9 of the scene
// diagonal, the tolerance), when that union is one convex polygon without
// holes: its boundary one loop, convex once collinear corners are removed, of the faces' summed
// area within 1e-9 relative. A group of such faces whose union is not convex (an L-shaped
// floor, a wall round a door) is split into convex pieces: neighbouring pieces, starting from
// the faces, are merged while their union is convex. A face joined to none is its own occluder,
// unchanged. So the occluders cover exactly the points the faces cover: they block the same
// segments (a segment whose open interior crosses one). Occluders are numbered in the order of
// their first scene faces: with nothing to merge, occluder f is scene face f.
// The 8 corners of an axis-aligned box, in the order ShaftCuller::occluders recognises as a box:
// each corner after the first joined to the one before by an edge of the box.
void box_corners(const Eigen::AlignedBox3d& box, Vec3 corners[8]);

class ShaftCuller {
 public:
  explicit ShaftCuller(const Scene& scene);

  int occluder_count() const { return static_cast<int>(occluders_.size()); }
  const std::vector<Polygon>& occluder_polygons() const { return occluders_; }
  const std::vector<Vec3>& occluder_normals() const { return normals_; }  // unit plane normals (polygon_normal)
  // The scene faces an occluder is the union of (ascending), and the occluder of a scene face.
  const std::vector<int>& occluder_faces(int o) const { return occluder_faces_[size_t(o)]; }
  int occluder_of_face(int f) const { return occluder_of_face_[size_t(f)]; }
  // The scene faces themselves (Scene::face_polygon), what patches and tiles belong to.
  int scene_face_count() const { return static_cast<int>(scene_faces_.size()); }
  const std::vector<Polygon>& scene_faces() const { return scene_faces_; }
  double tolerance() const { return tol_; }  // metres, 1e-9 × scene diagonal

  // Replaces `out` with the occluders that may meet the open shaft of A and B: convex planar
  // polygons (3 or 4 corners), a single point (a count of 1), or an axis-aligned box given as
  // its 8 corners in box_corners' order (then, when both are boxes, the hull's planes are Haines
  // & Wallace's box-to-box planes, at most 12, instead of every edge-and-corner candidate). An occluder is left out
  // when its bounding box misses the shaft's, when every corner of A and B lies on one closed side of its plane (this
  // leaves out the occluders A and B lie in and those they only touch), or when it lies wholly on the outer closed side
  // of one of the hull's planes. Conservative: an occluder kept may still miss the shaft (edge–edge separating axes are
  // not tried); one left out cannot block. A and B together have at most 24 points (std::invalid_argument otherwise).
  // With `drop_hidden` (A a single point x, na = 1), drop_hidden_occluders(x, out, on_face) is applied as well,
  // cheaply, during the search.
  void occluders(const Vec3* a, int na, const Vec3* b, int nb, std::vector<int>& out, bool drop_hidden = false,
                 int on_face = -1) const;

  // The same test over `candidates` only (sorted occluder indices), into `out` in their order: exact
  // when the candidates are the occluders of a wider shaft that contains this one (an occluder that
  // misses the wider shaft misses this one too).
  void occluders_among(const Vec3* a, int na, const Vec3* b, int nb, const std::vector<int>& candidates,
                       std::vector<int>& out) const;

  // True when occluder o alone blocks every segment between convex polygons A and B: they lie
  // strictly on opposite sides of its plane and every segment crosses it clearly inside its
  // polygon (checked on the corner-to-corner segments, whose crossings span all the others'). The
  // pair's form factor is then 0 exactly (a floor patch under a table top and a ceiling patch).
  bool blocks_every_segment(const Vec3* a, int na, const Vec3* b, int nb, int o) const;

  // Removes from `occluders` those that cannot add to the shadow seen from x: the occluders of a
  // closed solid (a closed, consistently oriented component of occluders joined by shared edges,
  // its normals outward) that x lies clearly behind, when x lies outside the solid. Any segment
  // from outside that meets the solid enters it through an occluder x is in front of first (at
  // the entry the segment runs against the outward normal), so the solid's shadow is that of its
  // occluders toward x; convexity is not needed. Outside means: for a convex solid (every corner
  // on or behind every occluder's plane: a box), clearly in front of one of its occluders; for
  // any other (a scanned object), clearly outside its bounding box, or an even count of clean
  // crossings of a segment from x to beyond it (Jordan), or x inside scene face `on_face`
  // (>= 0) when that face is part of the solid (x on its surface, its sources in front of the
  // face). A point inside a solid, or one on its surface without `on_face` (a vertex, where a
  // segment may start into the solid), keeps every occluder.
  // With the receiver's `normal` (unit), a point on a solid's surface (a vertex of a scanned
  // object) counts as outside it where every face of the solid touching x lies on or behind x's
  // tangent plane and one faces along the normal (a convex vertex): what lies just in front of
  // the plane there borders that face's front, so segments to sources in front start outside.
  void drop_hidden_occluders(const Vec3& x, std::vector<int>& occluders, int on_face = -1,
                             const Vec3* normal = nullptr) const;
  // The same for several lists seen from one point (x, on_face and normal unchanged between the
  // calls): whether x is outside each solid is learnt once and kept in `outside_state` (resized
  // here; per solid 0 unknown, 1 outside, 2 not) until the caller resets the entries of the solids
  // listed in `touched` to 0 and clears it, for a new point.
  void drop_hidden_occluders(const Vec3& x, std::vector<int>& occluders, int on_face, const Vec3* normal,
                             std::vector<signed char>& outside_state, std::vector<int>& touched) const;
  // True when x lies on the surface of a closed solid that is not convex (within tolerance()):
  // then what drop_hidden_occluders leaves depends on the receiver's normal as well.
  bool on_closed_solid(const Vec3& x) const {
    thread_local std::vector<int> touching;
    touching_closed_solids(x, touching);
    return !touching.empty();
  }
  int convex_solid_count() const { return static_cast<int>(solids_.size()); }
  // Closed solids that are not convex (see drop_hidden_occluders), and the one of occluder o (-1: none).
  int closed_solid_count() const { return static_cast<int>(closed_solids_.size()); }
  int closed_solid_of(int o) const { return closed_of_[size_t(o)]; }
  // The convex solid of occluder o (-1: none), a solid's occluders, and the occluder across edge k
  // (corner k to k + 1) of occluder o (-1 where the edge is not shared by exactly one other).
  int solid_of(int o) const { return solid_of_[size_t(o)]; }
  const std::vector<int>& solid_occluders(int solid) const { return solids_[size_t(solid)]; }
  int neighbour(int o, int k) const { return neighbours_[size_t(o)][size_t(k)]; }

 private:
  struct Node {
    Eigen::AlignedBox3d box;
    int left = -1, right = -1;  // children (-1 on leaves)
    int first = 0, count = 0;   // leaves: range in order_
  };
  int build(int first, int count);
  void find_convex_solids();
  // True when x is clearly behind occluder o of a convex solid it is clearly outside of.
  // outside_state caches per solid whether x is outside it (0 unknown, 1 yes, 2 no); touched lists
  // the solids set, for the caller to reset.
  bool hidden_from(const Vec3& x, int o, int on_face, const Vec3* normal, std::vector<signed char>& outside_state,
                   std::vector<int>& touched) const;
  // True when segments from x toward the front of `normal` start outside closed (non-convex)
  // solid `solid` (drop_hidden_occluders).
  bool outside_closed_solid(const Vec3& x, int solid, int on_face, const Vec3* normal) const;
  // The occluders of closed, non-convex solids whose polygons x lies on (within tol_).
  void touching_closed_solids(const Vec3& x, std::vector<int>& out) const;
  std::vector<Polygon> scene_faces_;                // per scene face: its polygon
  std::vector<Polygon> occluders_;                  // per occluder: its convex polygon
  std::vector<std::vector<int>> occluder_faces_;    // per occluder: its scene faces
  std::vector<std::vector<int>> occluder_corners_;  // per occluder: its corners as vertex ids (shared edges)
  std::vector<int> occluder_of_face_;               // per scene face: its occluder
  std::vector<std::vector<int>> solids_;            // occluders of each convex solid
  std::vector<int> solid_of_;                       // per occluder: its convex solid, or -1
  std::vector<std::vector<int>> closed_solids_;     // occluders of each closed solid that is not convex
  std::vector<Eigen::AlignedBox3d> closed_boxes_;   // per closed solid: its bounding box
  std::vector<int> closed_of_;                      // per occluder: its closed, non-convex solid, or -1
  std::vector<int> solid_state_of_;                 // per occluder: its solid's index among both kinds, or -1
  std::vector<std::vector<int>> neighbours_;        // per occluder and edge: the occluder across it, or -1
  std::vector<Vec3> normals_;                       // per occluder: unit plane normal
  std::vector<Eigen::AlignedBox3d> boxes_;          // per occluder
  std::vector<int> order_;                          // occluder indices, leaf ranges point into it
  std::vector<Node> nodes_;                         // nodes_[0] is the root
  double tol_ = 0.0;
};

// Shaft culling of one receiver (a patch or a point) against every patch of a mesh, in a
// hierarchy (Haines & Wallace 1994 cull hierarchically the same way): face group (up to
// kFaceGroupFaces neighbouring scene faces of one occluder, bounded by a rectangle in its plane:
// a wall that arrives as 1,000 quads is culled 16 quads at a time), scene face (the patches'
// Patch::face; ShaftCuller::scene_faces), then tiles of at most tile_patches of the face's
// patches (each bounded by a rectangle in the face's plane, or a box if the face is not flat),
// then the patch. A wider shaft contains the narrower ones below it, so a level's candidate
// occluders are found among its parent's only: the face group's by the BVH once per receiver and
// group, a face's among its group's (by the BVH for a face in no group), a tile's once per
// receiver and tile, and each patch is tested against its tile's list — usually empty. Lists hold occluder indices. The
// result is ShaftCuller::occluders() of the pair or a subset of it (an occluder outside one plane of a wider hull is
// left out even where no single plane of the pair's hull separates it; for a point receiver, the back occluders of
// convex solids it is outside of, see ShaftCuller::drop_hidden_occluders), never leaving out an
// occluder that can add to the shadow.
// One per thread; not thread-safe.
// Patches per tile: for a patch receiver's per-patch culling (each patch tests its tile's list),
// and for PointVisibility, which clips a whole tile per point and settles most patches by
// bounding boxes. Larger tiles mean fewer tile shafts, cones and clippings per point but more
// patches per clipped tile; 64 took the fewest instructions of 16 / 64 / 128 / 256 on the bench
// rooms (docs/performance.md "What did not work").
constexpr int kTilePatches = 16;
constexpr int kPointTilePatches = 64;
// Scene faces per face group: an occluder's faces (coplanar, joined by edges) split at the median
// of their centroids until each part has at most this many. A group's shaft replaces as many BVH
// searches by one, and where it meets no occluder (most pairs of a room) its faces need no shaft
// of their own.
constexpr int kFaceGroupFaces = 32;

class GroupedShaftCuller {
 public:
  // tile_patches: the most patches of a tile (>= 1, else std::invalid_argument). Larger tiles
  // mean fewer tile shafts per receiver but longer candidate lists per patch.
  GroupedShaftCuller(const ShaftCuller& culler, const PatchMesh& mesh, int tile_patches = kTilePatches);
  // The receiver of the following queries: 1 to 4 points (a point, or a patch's corners).
  void set_receiver(const Vec3* a, int na);
  // The occluders of the shaft of the receiver and patch `patch` of the mesh (corners b, nb).
  void occluders(int patch, const Vec3* b, int nb, std::vector<int>& out);

  // The tile of a patch (-1 for a patch of no scene face), and per tile: its scene face, its
  // corners (4 for a rectangle in a flat face's plane, containing its patches; 8 for a box) and
  // the occluders of the receiver–tile shaft.
  int tile_of(int patch) const;
  const std::vector<int>& tile_of_patches() const { return tile_of_patch_; }  // tile_of for every patch
  int tile_corner_count(int tile) const { return tile_corner_counts_[size_t(tile)]; }
  int tile_face(int tile) const { return tiles_[size_t(tile)].face; }
  const Vec3* tile_corners(int tile) const { return tiles_[size_t(tile)].corners; }
  const std::vector<int>& tile_occluders(int tile) { return group(culler_->scene_face_count() + tile); }
  int tile_count() const { return static_cast<int>(tiles_.size()); }
  // The face group of scene face f (-1: culled on its own), and how many groups there are.
  int face_group_of(int f) const { return face_group_of_face_[size_t(f)]; }
  int face_group_count() const { return static_cast<int>(face_groups_.size()); }

 private:
  struct Tile {
    int face = 0;
    int corner_count = 0;     // 4 (a rectangle in the face's plane) or 8 (a box)
    bool whole_face = false;  // its one patch is its whole face: the patch's occluders are the face's
    Vec3 corners[8];
  };
  struct FaceGroup {
    Vec3 corners[4];  // a rectangle in the faces' plane containing them, counter-clockwise about its normal
  };
  // The candidate occluders of group g (scene faces first, then tiles, then face groups),
  // computed on first need per receiver.
  const std::vector<int>& group(int g);
  void build_face_groups();
  const ShaftCuller* culler_;
  std::vector<Tile> tiles_;
  // Each tile's corner_count again, compact: read for every (point, patch) pair, where a Tile
  // (200 bytes) would be a cache miss on large meshes.
  std::vector<unsigned char> tile_corner_counts_;
  std::vector<int> tile_of_patch_;
  std::vector<FaceGroup> face_groups_;
  std::vector<int> face_group_of_face_;  // per scene face, -1 for none
  Vec3 receiver_[4];
  int receiver_count_ = 0;
  long long generation_ = 0;              // one per receiver
  std::vector<long long> stamp_;          // per group: the receiver its list belongs to
  std::vector<std::vector<int>> groups_;  // per group: occluders of the receiver–group shaft
};

// Exact visible form factor F(dA_x -> P minus the shadows of occluders[which]), dimensionless in
// [0, F(dA_x -> P)]. `source` has n >= 3 corners, convex, counter-clockwise from its front.
// `occluders`: convex planar polygons (ShaftCuller::occluder_polygons, or any others, such as
// scene faces). Occluders are two-sided; one seen edge-on from x (x in its plane, within 1e-12
// of the scene size) blocks nothing, and nothing on or in front of an occluder's plane (seen from
// x) is hidden by it, so coplanar neighbours of the source do not shadow it.
// `normals` (optional): the occluders' unit plane normals (polygon_normal), so they are not recomputed.
// `solids` (optional; the culler these occluders and normals are from): the listed occluders of a
// convex solid x is clearly outside of cast one shadow volume, the solid's (the cone through its
// silhouette, behind its front occluders), rather than one each; the same set is hidden.
double exact_visible_form_factor(const Receiver& receiver, const Vec3* source, int n,
                                 const std::vector<Polygon>& occluders, const std::vector<int>& which,
                                 const std::vector<Vec3>* normals = nullptr, const ShaftCuller* solids = nullptr);

// How many segments ray visibility casts per (point, patch).
//  - A fixed count (`rays` > 0 in the calls below): that many, stratified.
//  - Adaptive (`rays` == kAdaptiveRays): levels of 8², 16², 32², ... jittered segments, each level
//    a fresh stratified estimate, stopping at the first level whose segments all agree (all
//    blocked or all clear), or whose estimated standard error of V is at most
//    tolerance × max(V, kRayErrorFloor), or at max_rays (the last level that fits). An occluder
//    that every one of the 64 strata of the first level misses (smaller than about a 64th of the
//    patch as seen from the point) can go unseen: that error is not in the estimate.
// The estimated error: the variance of the weighted ratio estimator from the level's own segments,
// Σ w_k² (v_k − V)² / (Σ w_k)², that of a ratio estimator from independent samples (Cochran,
// "Sampling Techniques", 3rd ed., Wiley 1977, ch. 6); jittered samples err less (Mitchell
// 1996, "Consequences of stratified sampling in graphics", SIGGRAPH '96), so it overstates.
inline constexpr int kAdaptiveRays = 0;
inline constexpr double kRayErrorFloor = 1e-3;
struct RaySampling {
  double tolerance = 1e-2;  // relative standard error of V at which adaptive sampling stops
  int max_rays = 1024;      // largest adaptive level (32²); a fixed count is not capped
};

// What ray visibility did, added up by the callers: segments cast, and the estimated variance of
// the visible form factors it returned (Σ F(dA_x -> P)² var(V) over the (point, patch) pairs).
struct RayTally {
  long long cast = 0;
  double variance = 0.0;
};

// Ray-cast visibility with Embree 3 (see 2. above), over the scene faces. Thread-safe after construction; results
// depend only on (seed, pair), never on the thread count.
class RayVisibility {
 public:
  explicit RayVisibility(const Scene& scene, RaySampling sampling = {});
  ~RayVisibility();
  RayVisibility(const RayVisibility&) = delete;
  RayVisibility& operator=(const RayVisibility&) = delete;

  // Visible fraction between two patches (polygons of 3 or 4 corners with unit front normals):
  // `rays` (>= 1; no adaptive sampling) segments between Latin-hypercube stratified points on each, seeded by `stream`,
  // weighted by the form-factor integrand. 1 if no segment carries light.
  double patch_to_patch(const Vec3* receiver, int receiver_count, const Vec3& receiver_normal, const Vec3* source,
                        int source_count, const Vec3& source_normal, int rays, uint64_t stream) const;

  // Visible fraction V(x, P) from a point (on a surface with normal `normal`) to a patch:
  // segments to jittered-stratified points on P (√rays × √rays strata when rays is a square,
  // Latin hypercube otherwise; kAdaptiveRays: the levels above), seeded by `stream`, weighted by
  // the form-factor integrand. The error of a partly occluded pair falls as rays^(-3/4)
  // (jittered sampling of a shadow with a smooth outline, Mitchell 1996): about 0.5% rms at 576
  // (tests/test_visibility_rays). `variance` (optional) receives the estimated variance of V,
  // `rays_used` (optional) the number of segments cast.
  double point_to_patch(const Vec3& point, const Vec3& normal, const Vec3* source, int source_count,
                        const Vec3& source_normal, int rays, uint64_t stream, int* rays_used = nullptr,
                        double* variance = nullptr) const;

  // True if the open segment between a and b meets a face.
  bool blocked(const Vec3& a, const Vec3& b) const;
  // blocked(a, b[k]) for k < count <= 8 into out[k], as one packet of rays (segments from one
  // point to one patch are coherent: Embree traces such packets faster than single rays).
  void blocked_from(const Vec3& a, const Vec3* b, int count, bool* out) const;

  double surface_offset() const { return offset_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  double offset_ = 0.0;  // how far sample points are lifted off their surface, metres
  RaySampling sampling_;
};

enum class VisibilityMethod { Rays, Exact };

class Visibility;

// Visible form factors from one point to the patches of a mesh: what the centroid rule's fill,
// the vertex gather and the point view factors ask for, patch after patch. Tiles are those of
// GroupedShaftCuller, of up to kPointTilePatches patches. In exact mode, the rectangle of each
// tile whose shaft holds occluders is clipped against their shadow volumes once per point
// (exact_visible_form_factor's subtraction; each volume built once per point), not each of its
// patches: a patch that no hidden piece overlaps keeps its unoccluded factor, and any other sums
// Lambert's closed form over its intersections with the hidden pieces (subtracted) or the
// visible ones (the formula is additive over a partition). The result equals
// exact_visible_form_factor(x, patch, occluders of the pair) up to rounding (the pieces are cut
// along other lines; tests/test_visibility_scenes.cpp). Patches of no tile or of a box tile (a
// face that is not flat), and ray mode, take Visibility::point_to_patch.
//
// A tile's occluders, in exact mode, come from one of two cullings that find the same shadows:
//  - Tree: GroupedShaftCuller's hierarchy (scene face's occluders by the AABB tree, then tile).
//  - Cones: once per point, every occluder but the back occluders of convex solids x is outside
//    of (ShaftCuller::drop_hidden_occluders) and occluders with every scene corner on one side of
//    their plane (a room's walls) gets the cone from x that bounds it (axis and half-angle, the
//    cone around the corners' directions, which bounds the convex polygon's spherical
//    projection); a tile's candidates are the occluders whose cone meets the tile's (angle between
//    axes <= sum of half-angles), found first for its block of up to 8 neighbouring tiles, then
//    ShaftCuller's shaft test of x and the tile. O(occluders) per block and point, with no tree
//    walk: the faster for scenes of few occluders (furnished rooms).
//  - Auto: Cones up to kConeCullingOccluders occluders, Tree above.
// One per thread; not thread-safe.
enum class PointCulling { Auto, Cones, Tree };
constexpr int kConeCullingOccluders = 1024;

class PointVisibility {
 public:
  PointVisibility(const Visibility& vis, const PatchMesh& mesh, PointCulling culling = PointCulling::Auto);
  ~PointVisibility();
  PointVisibility(PointVisibility&&) noexcept;
  PointVisibility& operator=(PointVisibility&&) noexcept;

  // The point of the following queries (a surface point with its normal and approach). The
  // culling and the tiles' clipping depend on the point only, so a receiver at the same point as
  // the previous one (another normal, as at a crease) reuses them: give such receivers in a row.
  // on_face: the scene face whose interior holds the point (a patch's quadrature point), or -1
  // (a vertex, or not known): lets the back occluders of a closed solid the point lies on go
  // (ShaftCuller::drop_hidden_occluders).
  void set_receiver(const Receiver& x, int on_face = -1);
  // F_vis(dA_x -> P) for patch `patch` of the mesh (corners b, nb; unit normal), given
  // `unoccluded` = F(dA_x -> P). `unshadowed` is set when no occluder shadows any of it (the
  // result is then `unoccluded` itself). Ray mode casts `rays` segments (kAdaptiveRays: as
  // many as RaySampling asks) seeded by `stream`, added to `tally`; exact mode ignores all three.
  double visible(int patch, const Vec3* b, int nb, const Vec3& normal, double unoccluded, int rays, uint64_t stream,
                 RayTally& tally, bool& unshadowed);
  // What patch `patch`'s tile alone tells of the patch's shadow from the point (exact mode, a
  // flat tile): None, its shaft from the point holds no occluder, so visible() returns
  // `unoccluded` with `unshadowed` set; Full, its clipping left no visible piece, so visible()
  // returns 0 (for unoccluded > 0) with `unshadowed` cleared. Either way a caller may skip
  // visible() and the patch's corners. Unknown says nothing (visible() decides). Full clips the
  // tile, as visible() would for any of its patches.
  // Inline: the fill and the gather ask for every pair. The answer depends on the patch's tile
  // alone, so it is kept for the last tile asked: patches visited in index order cost a lookup
  // per run of one tile's patches (a tile is a block of neighbours on a face: in a face's
  // row-by-row patch order, a run is typically one row of the tile).
  enum class TileShadow { Unknown, None, Full };
  TileShadow tile_shadow(int patch) {
    if (const int t = tile_of_patch_[size_t(patch)]; t != last_tile_) {
      last_tile_ = t;
      last_shadow_ = shadow_of_tile(t);
    }
    return last_shadow_;
  }

  // F_vis(dA_x -> P) for patch `patch`, the whole way, given `unoccluded` = F(dA_x -> P) > 0:
  // the patch's tile first (tile_shadow: None keeps `unoccluded`, Full gives 0, both without
  // the patch's corners), else visible() on the patch's corners. This is the step every
  // per-point loop takes: the fill's one-point rule (formfactors.h), the vertex gather and the
  // point view factors (formfactors/point_factors.h). rays, stream, tally: as visible().
  struct VisibleFactor {
    double value = 0.0;       // F_vis(dA_x -> P)
    bool unshadowed = false;  // no occluder shadows any of the patch: value == unoccluded
    bool by_tile = false;     // settled by the patch's tile alone (its corners were not read)
  };
  VisibleFactor visible_factor(int patch, double unoccluded, int rays, uint64_t stream, RayTally& tally) {
    switch (tile_shadow(patch)) {
      case TileShadow::None: return {unoccluded, true, true};
      case TileShadow::Full: return {0.0, false, true};
      case TileShadow::Unknown: break;
    }
    Vec3 corners[4];
    mesh_->polygon(patch, corners);
    const Patch& p = mesh_->patches[size_t(patch)];
    VisibleFactor v;
    v.unshadowed = true;
    v.value = visible(patch, corners, p.corner_count, p.normal, unoccluded, rays, stream, tally, v.unshadowed);
    return v;
  }

 private:
  struct Impl;
  TileShadow shadow_of_tile(int tile);  // tile_shadow's answer, worked out (tile -1: none)
  const PatchMesh* mesh_ = nullptr;     // the mesh of the patches asked about
  std::unique_ptr<Impl> impl_;
  const int* tile_of_patch_ = nullptr;  // the culler's, in impl_ (which moves with its owner)
  int last_tile_ = -2;                  // tile_shadow's last tile (-2: none since set_receiver)
  TileShadow last_shadow_ = TileShadow::Unknown;
};

// What the form-factor fill and the vertex gather use: the culler plus one of the two methods.
class Visibility {
 public:
  // sampling: ray mode's adaptive sampling (RaySampling); exact mode ignores it.
  Visibility(const Scene& scene, VisibilityMethod method, RaySampling sampling = {});

  VisibilityMethod method() const { return method_; }
  const ShaftCuller& culler() const { return culler_; }
  const RayVisibility* rays() const { return rays_.get(); }  // null in exact mode

  // Visible part of F(dA_x -> P), given `unoccluded` = F(dA_x -> P) and the candidate occluders
  // of a shaft containing x and P (an empty list returns `unoccluded`). The narrower shaft of x
  // and P is culled again first (the pair's shaft, from the fill, is tested once per pair), unless
  // `narrow` says the occluders are already those of x's own shaft. Ray mode
  // casts `rays` segments (kAdaptiveRays: as RaySampling asks; added to `tally` with the
  // result's estimated variance) from x lifted off its surface (along receiver.approach when
  // set, else along the normal); exact mode ignores rays, stream and tally. on_face: the scene
  // face whose interior holds x, or -1 (ShaftCuller::drop_hidden_occluders).
  double point_to_patch(const Receiver& receiver, const Vec3* source, int n, const Vec3& source_normal,
                        double unoccluded, const std::vector<int>& occluders, int rays, uint64_t stream,
                        RayTally& tally, bool narrow = false, int on_face = -1) const;

 private:
  VisibilityMethod method_;
  ShaftCuller culler_;
  std::unique_ptr<RayVisibility> rays_;
};

// Deterministic stream id for a pair of indices and a user seed (splitmix64 mixing).
uint64_t pair_stream(uint64_t seed, uint64_t i, uint64_t j);

}  // namespace photometria
