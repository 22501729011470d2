// Visible form factors from one receiver point to every patch of a mesh: what the vertex gather
// (pipeline/solve.cpp) and the point view factors (viewfactors/viewfactors.h) compute at each of
// their points, F_vis(dA_x -> P_j) for j = 0 .. N-1 (Baum, Rushmeier & Winget, "Improving
// radiosity solutions through the use of analytically determined form-factors", SIGGRAPH 1989:
// the point-to-polygon factor in closed form at the vertices).
//
// Per point: Lambert's closed form for every source facing the point, batched
// (kernels/lambert_batch.h, lambert_form_factors_facing); the point's facing test per group of
// coplanar sources (formfactors/facing.h, the test of formfactors.h point_facing_away: a source
// must rise above the point's horizon and the point must not be behind it); then, with
// visibility, each source's visible part by PointVisibility::visible_factor (the source's tile
// where that settles it, else exact clipping or rays). The fill's one-point rule takes the same
// last step (formfactors.h); its facing test is the pair's, not the point's.
//
// One object per thread. Give points at one position in a row: the visibility from a position
// is worked out once (PointVisibility::set_receiver).
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "formfactors/facing.h"
#include "formfactors/formfactors.h"
#include "kernels/lambert_batch.h"
#include "patching/patching.h"
#include "visibility/visibility.h"

namespace photometria {

class PointFactors {
 public:
  // What the loop did, summed over calls (the summaries report them).
  struct Counts {
    long long evaluated = 0;  // sources facing the point with a non-zero unoccluded factor
    long long tested = 0;     // of those, asked for their visible part (visibility on)
    long long culled = 0;     // of those, found unshadowed (no occluder in the way)
    RayTally rays;            // rays cast and their estimated variance (ray visibility)
  };

  // mesh; sources = patch_batch(mesh); facing = FacingGroups(mesh, tol); vis = null without
  // visibility; tol = plane_tolerance(mesh); rays = rays per (point, patch) in ray mode. All
  // referenced objects outlive this one.
  PointFactors(const PatchMesh& mesh, const PolygonBatch& sources, const FacingGroups& facing, const Visibility* vis,
               double tol, int rays)
      : mesh_(mesh),
        sources_(sources),
        facing_groups_(facing),
        tol_(tol),
        rays_(rays),
        rays_mode_(vis && vis->method() == VisibilityMethod::Rays) {
    if (vis) from_point_.emplace(*vis, mesh);
    facing_.resize(size_t(mesh.size()));
    kernel_.resize(size_t(mesh.size()));
  }

  // Calls visit(j, f) with f = F_vis(dA_x -> P_j), in index order, for every patch j whose
  // unoccluded factor from x is non-zero and that faces x (f may be 0 where it is hidden, and a
  // source hidden by its tile alone is left out). stream_of(j): the ray stream of the pair
  // (called in ray mode only).
  template <class StreamOf, class Visit>
  void for_each_visible(const Receiver& x, const StreamOf& stream_of, Counts& counts, const Visit& visit) {
    if (from_point_) from_point_->set_receiver(x);
    facing_groups_.classify_point(x.point, x.normal, facing_.data());
    // The kernel for the sources that face the point (0 for the others, which are skipped).
    lambert_form_factors_facing(x, sources_, facing_.data(), kernel_.data());
    const bool prefetch = mesh_.prefetch_pays();
    for (int j = 0; j < mesh_.size(); ++j) {
      if (prefetch) mesh_.prefetch(j + 16);
      double f = kernel_[size_t(j)];
      if (f == 0.0) continue;  // behind the patch, below the horizon, or edge-on: nothing to add
      if (facing_[size_t(j)] == Facing::Away ||
          (facing_[size_t(j)] == Facing::Test && point_facing_away(mesh_, x.point, x.normal, j, tol_)))
        continue;
      ++counts.evaluated;
      if (f > 0.0 && from_point_) {
        ++counts.tested;
        const PointVisibility::VisibleFactor v =
            from_point_->visible_factor(j, f, rays_, rays_mode_ ? stream_of(j) : 0, counts.rays);
        counts.culled += v.unshadowed;
        if (v.by_tile && !v.unshadowed) continue;  // the tile is hidden: nothing to add
        f = v.value;
      }
      visit(j, f);
    }
  }

 private:
  const PatchMesh& mesh_;
  const PolygonBatch& sources_;
  const FacingGroups& facing_groups_;
  double tol_;
  int rays_;
  bool rays_mode_;
  std::optional<PointVisibility> from_point_;
  std::vector<Facing> facing_;  // per source, of the current point
  std::vector<double> kernel_;  // per source: the unoccluded factor from the current point
};

}  // namespace photometria
