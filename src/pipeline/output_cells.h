// The cells of the written result: each patch's polygon over its output points, cut into
// triangles where a finer neighbour's corner lies inside one of its edges.
//
// Where patches of different sizes meet along an edge (the hierarchical method's leaves, split
// at their edges' midpoints where their links need it), the smaller patches' corners lie inside
// the larger patch's edge: T-junctions. Every output point carries the value gathered at it
// (Baum et al. 1989), but a viewer interpolates the point arrays over each cell from the cell's
// own points only, so across such an edge the field drawn would jump: a seam. Cutting the
// larger patch into triangles through those corners makes every cell edge an edge of the
// cells on both sides, and the drawn field continuous (Baum, Mann, Smith & Winget, "Making
// Radiosity Usable: Automatic Preprocessing and Meshing Techniques for the Generation of
// Accurate Radiosity Solutions", SIGGRAPH 1991, discuss such T-vertices and the shading
// discontinuities they cause).
//
// A point is taken as a corner inside patch p's edge (a, b) when it lies at the edge's midpoint,
// or recursively at a midpoint of a half, exactly (splitting at midpoints puts it there, and
// welded points share coordinates), carries p's material, and its normal lies within the arc of
// the normals at a and b (1e-6 rad): so the corner of a table leg standing on the edge of a
// floor patch is not one, and neither is a point across a crease. Patches of a conforming mesh
// (every dense patching of one face, welded faces) keep their polygon as it is.
#pragma once

#include <vector>

#include "pipeline/solve.h"

namespace photometria {

struct OutputCells {
  std::vector<std::vector<int>> cells;  // 3 or 4 indices into the result's points each
  std::vector<int> patch;               // per cell: the patch it is (part of)
  std::vector<double> area;             // per cell: its area, m² (a patch's pieces sum to its area)
  int patches_cut = 0;                  // patches cut into triangles at T-junctions
};

// The cells of `result` (result.mesh, result.points and result.cells as solve_scene leaves them).
OutputCells conforming_cells(const Scene& scene, const SolveResult& result);

}  // namespace photometria
