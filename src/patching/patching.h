// Patching: split every scene face into patches small enough for the requested accuracy.
//
// Quads become nu × nv grids (bilinear), triangles n² similar triangles (barycentric grid).
// The split is conforming: an edge shared by two faces is cut into the same number of segments
// on both sides, so neighbouring patches share vertices. To keep that true, the segment counts
// of opposite quad edges and of all three triangle edges are tied together (union–find over the
// mesh edges) and each tied set takes the largest count any member needs.
#pragma once

#include <array>
#include <vector>

#include "scene/scene.h"

namespace photometria {

struct PatchingOptions {
  double max_edge = 0.0;  // metres; every patch edge is at most this long (0 = no limit)
  double max_area = 0.0;  // m²; every patch is at most this large (0 = no limit)
};

struct Patch {
  std::array<int, 4> corners{};  // indices into PatchMesh::points, counter-clockwise from the front
  int corner_count = 0;          // 3 or 4
  int face = 0;                  // index into Scene::faces
  Vec3 normal = Vec3::Zero();    // unit front normal (the face's)
  Vec3 centroid = Vec3::Zero();  // area centroid, metres
  double area = 0.0;             // m²
};

struct PatchMesh {
  std::vector<Vec3> points;  // shared patch vertices
  std::vector<Patch> patches;

  int size() const { return static_cast<int>(patches.size()); }
  Polygon polygon(int patch) const;
  // Inline: the fill and the gather call it once per pair.
  void polygon(int patch, Vec3 out[4]) const {
    const Patch& p = patches[size_t(patch)];
    for (int k = 0; k < p.corner_count; ++k) out[k] = points[size_t(p.corners[size_t(k)])];
  }
  // Asks the CPU to fetch patch `ahead`'s record into the cache (no effect on results). A fill
  // row or a gather point visits every patch once, with visibility work in between that evicts
  // what it read, so a large mesh's patch records arrive from memory one miss at a time unless
  // asked for early. Out-of-range indices are ignored. Worth it only where the patches outgrow
  // the core's cache (prefetch_pays()); below, it costs instructions only. The patches' corner
  // points are not fetched: most pairs are settled by their tile (PointVisibility::tile_shadow)
  // without corners, so fetching them for every patch costs more than it saves
  // (docs/performance.md "What did not work").
  bool prefetch_pays() const { return size() >= 4096; }  // 4,096 patches: 320 KiB of records
  void prefetch(int ahead) const {
    if (ahead >= size()) return;
    // As an asm statement: GCC treats __builtin_prefetch as free of side effects, so a function
    // made only of them counts as pure and its calls are deleted.
    auto prefetch_line = [](const void* address) {
#if defined(__x86_64__) || defined(__i386__)
      asm volatile("prefetcht0 %0" : : "m"(*static_cast<const char*>(address)));
#else
      __builtin_prefetch(address);
#endif
    };
    const char* record = reinterpret_cast<const char*>(&patches[size_t(ahead)]);
    prefetch_line(record);
    prefetch_line(record + sizeof(Patch) - 1);
  }
};

// The patch mesh of `scene`. Throws Error(BadInput) when it would have more patches or points
// than an int can index (count_patches() tells beforehand).
PatchMesh subdivide(const Scene& scene, const PatchingOptions& options);

// What subdivide() would make, counted without making it: memory and time grow with the input
// faces and edges only, so that a request for 10^12 patches (a typo in --max-edge) is counted,
// and refused, in a moment instead of exhausting the machine.
struct PatchGrid {
  // Per scene face: the grid subdivide() cuts it into, {nu, nv} segments for a quad (nu along
  // its first edge, nu·nv patches), {n, n} for a triangle (n² patches); {0, 0} for a face that
  // only obstructs (no patches).
  std::vector<std::array<double, 2>> segments;
  double patches = 0.0;   // Σ patches, in patch order (face by face); a double: it may exceed any int
  double points = 0.0;    // shared patch vertices (PatchMesh::points)
  bool fits_int() const;  // both counts small enough for subdivide()
};
PatchGrid count_patches(const Scene& scene, const PatchingOptions& options);

// Patch `index` (0 ≤ index < grid.patches, in subdivide()'s order) of the mesh subdivide() would
// make, from its face's parametrisation alone: the same corners as the mesh's up to rounding.
// For sampling a mesh that is never built (pipeline/memory.h). Needs grid.fits_int().
struct ImplicitPatch {
  int face = 0;          // index into Scene::faces
  int corner_count = 0;  // 3 or 4
  Vec3 corners[4];       // counter-clockwise from the front, metres
};
class ImplicitPatches {
 public:
  ImplicitPatches(const Scene& scene, const PatchGrid& grid);
  long long size() const { return patches_; }
  ImplicitPatch operator[](long long index) const;

 private:
  const Scene& scene_;
  const PatchGrid& grid_;
  std::vector<long long> face_end_;  // patches of faces 0..f, for the binary search
  long long patches_ = 0;
};

}  // namespace photometria
