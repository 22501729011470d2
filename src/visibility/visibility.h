// Visibility between patches: which scenes need it, and the visible fraction by ray casting.
//
// Occluders are every scene face, two-sided (DESIGN.md: emission and reflection are one-sided,
// occlusion is two-sided). The unoccluded form factor is multiplied by the visible fraction:
//   F_ij ≈ F_ij(unoccluded) · V_ij,  V_ij = Σ_k w_k v_k / Σ_k w_k  over K segments between
//   stratified sample points x_k on patch i and y_k on patch j, v_k = 1 if no face blocks the
//   segment, w_k = cos θx cos θy / r² its share of the form-factor integrand (Wallace, Elmquist &
//   Haines 1989 weight each ray by its differential form factor the same way).
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "scene/scene.h"

namespace photometria {

// True when no face can block the segment between any two points of the scene's faces: every
// vertex lies on or in front of every face's plane, so the faces bound one convex region seen
// from inside and any segment between two boundary points runs through its interior (or along a
// face's plane, where the form factor is 0 anyway). Explains the verdict in `reason`.
bool scene_needs_no_visibility(const Scene& scene, std::string* reason = nullptr);

// Ray-cast visibility with Embree 3. Thread-safe after construction; results depend only on
// (seed, pair), never on the thread count.
class RayVisibility {
 public:
  explicit RayVisibility(const Scene& scene);
  ~RayVisibility();
  RayVisibility(const RayVisibility&) = delete;
  RayVisibility& operator=(const RayVisibility&) = delete;

  // Visible fraction between two patches (polygons of 3 or 4 corners with unit front normals):
  // `rays` segments between Latin-hypercube stratified points on each, seeded by `stream`,
  // weighted by the form-factor integrand. 1 if no segment carries light.
  double patch_to_patch(const Vec3* receiver, int receiver_count, const Vec3& receiver_normal,
                        const Vec3* source, int source_count, const Vec3& source_normal,
                        int rays, uint64_t stream) const;

  // Visible fraction from a point (on a surface with normal `normal`) to a patch.
  double point_to_patch(const Vec3& point, const Vec3& normal, const Vec3* source, int source_count,
                        const Vec3& source_normal, int rays, uint64_t stream) const;

  // True if the open segment between a and b meets a face.
  bool blocked(const Vec3& a, const Vec3& b) const;

  double surface_offset() const { return offset_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  double offset_ = 0.0;  // how far sample points are lifted off their surface, metres
};

// Deterministic stream id for a pair of indices and a user seed (splitmix64 mixing).
uint64_t pair_stream(uint64_t seed, uint64_t i, uint64_t j);

}  // namespace photometria
