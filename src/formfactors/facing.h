// The fill's facing test (formfactors.h facing_away) decided for many sources at once.
//
// facing_away(mesh, i, j, tol) reads patch j's corners for every pair, N² times in a fill. Most
// sources come in runs of consecutive patches with one normal (the patches of one scene face,
// patching/patching.h); each run is split at the median of its centroids' longest extent into
// groups of at most kFacingGroup neighbouring patches, and a group's bounding boxes decide the
// test for all of its patches together: if even the box's farthest corner is on or below the receiver's plane, all of
// them face away; if the box of the patches' corner means is wholly above it (each mean is a convex combination of its
// patch's corners, so some corner is at least as high), none does; the same for the receiver against the group's plane,
// through the range of the group's centroids along it. Only groups the receiver's plane passes through are left to the
// pair test (small groups, so that a receiver whose plane cuts a floor leaves only the floor's patches near that line).
//
// The answers are those of facing_away: a group is decided only when its bound clears the
// tolerance by tol / 2, far more than the rounding that separates the bound from the pair test's
// own arithmetic (a few ulp of the scene's size; tol is 1e-12 of it, formfactors.h
// plane_tolerance).
#pragma once

#include <Eigen/Geometry>
#include <vector>

#include "kernels/lambert_batch.h"
#include "patching/patching.h"

namespace photometria {

enum class Facing : unsigned char {
  Away,    // facing_away is true: the pair exchanges no light
  Toward,  // facing_away is false
  Test,    // not decided by the group's bounds: ask facing_away
};

constexpr int kFacingGroup = 16;

class FacingGroups {
 public:
  struct Range {  // a least and a greatest value
    double low, high;
  };

  // tol: the fill's plane tolerance (plane_tolerance(mesh)); mesh must outlive this object.
  FacingGroups(const PatchMesh& mesh, double tol);

  // out[j] for every patch j of the mesh, as the source of a pair whose receiver is patch i.
  // out: mesh.size() entries (out[i] is set too, to a meaningless value).
  void classify(int i, Facing* out) const;

  // The same for the vertex gather's test (formfactors.h point_facing_away) from point x with
  // unit normal `normal`: out[j] says whether point_facing_away(mesh, x, normal, j, tol) holds.
  void classify_point(const Vec3& x, const Vec3& normal, Facing* out) const;

  int group_count() const { return static_cast<int>(groups_.size()); }

 private:
  struct Group {
    int first = 0, end = 0;  // its patches: order_[first, end), with one normal
    Vec3 normal = Vec3::Zero();
    Eigen::AlignedBox3d corners, means;  // of its patches' corners and corner means
    // Ranges along the group's own normal, exact rather than a box's: of its corners and corner
    // means (for a receiver in the same plane, where a box of a tilted plane is far too thick)
    // and of its centroids (the pair test measures from them).
    double corner_high = -1e300, mean_low = 1e300, centroid_low = 1e300, centroid_high = -1e300;
  };
  static Range height_above(const Group& g, const Vec3& n, double d);
  void add_groups(int first, int end);  // splits order_[first, end) of one run into groups
  const PatchMesh* mesh_;
  double tol_;
  std::vector<int> order_;  // patch indices, group by group
  std::vector<Group> groups_;
};

// lambert_form_factors(receiver, sources, out) for the sources whose class in `facing` is not
// Away; runs of at least 8 consecutive Away sources are skipped (their out[j] is 0 — the pair
// exchanges no light, and the caller does not read it), isolated ones are evaluated with their
// neighbours (SIMD blocks are 4 wide). Each value is the batched kernel's for that source alone,
// so they equal lambert_form_factors' bit for bit. out: sources.size entries.
void lambert_form_factors_facing(const Receiver& receiver, const PolygonBatch& sources, const Facing* facing,
                                 double* out);

}  // namespace photometria
