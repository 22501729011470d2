// A scene: welded vertices, planar faces (triangles or convex planar quads), materials, groups.
//
// Loading (load_scene) accepts
//   .obj (+ .mtl through tinyobjloader: Kd = diffuse reflectance, Ke = emitted exitance in W/m²,
//        usemtl, g / o names become groups),
//   .off .ply .stl .om (through OpenMesh; every face gets LoadOptions' default material),
//   .json scene files (meshes + material overrides by OBJ material or group name + settings).
//   .vs3 View3D input (load_view3d.cpp: F 3 and F 3a; each surface is a group; O surfaces are
//        obstruction-only faces; combined surfaces share a group; subsurfaces, null and mask
//        surfaces carry Face::base_group),
// and cleans the geometry so that later stages can trust it:
//   - coincident vertices are welded (distance <= weld_tolerance × bounding-box diagonal),
//   - zero-area faces are dropped and counted,
//   - non-planar polygons, non-convex polygons and polygons with more than four vertices are
//     split into triangles and counted; triangles and planar convex quads are kept as they are,
//   - duplicate faces (the same vertices in the same cyclic order and winding, after welding)
//     are dropped and counted; back-to-back pairs (reverse winding) are kept as a two-sided sheet,
//   - within every closed surface (each edge shared by exactly two faces, connected through
//     those edges), faces wound against the rest of the surface are flipped and counted: the
//     orientation covering the larger area wins (orient.cpp),
//   - a closed surface enclosing the whole scene whose faces all point out is reported
//     (LoadStats::enclosure_faces_outward): LoadOptions::flip_normals (`--flip-normals`)
//     reverses every face to fix such an export.
// Bad input throws photometria::Error naming the file, the line (text formats) and the value.
#pragma once

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "geometry/polygon.h"

namespace photometria {

using Rgb = Eigen::Array3d;

struct Material {
  std::string name;
  Rgb reflectance = Rgb::Constant(0.5);  // diffuse reflectance ρ per channel, each in [0, 1)
  Rgb emission = Rgb::Zero();            // emitted exitance E per channel, W/m², >= 0
  bool is_grey() const {
    return reflectance.isApproxToConstant(reflectance[0], 0.0) && emission.isApproxToConstant(emission[0], 0.0);
  }
};

struct Face {
  std::vector<int> vertices;      // 3 or 4 indices into Scene::vertices, counter-clockwise from the front
  int material = 0;               // index into Scene::materials
  int group = 0;                  // index into Scene::groups (OBJ g/o name, or one group per mesh file)
  int source_face = 0;            // index of the face in the input (split faces share it)
  bool obstruction_only = false;  // blocks light but neither emits nor receives (View3D `O` surface):
                                  // no patches, still an occluder for visibility
  // OBJ smoothing group (`s N`): -1 when the file gives none (the crease angle decides), 0 for
  // `s off` (sharp against every other face), N > 0: faces of one group share output points.
  long smoothing_group = -1;
  // OBJ `vn` per corner, parallel to `vertices`: the unit shading normal the file gives at that
  // corner, meant to point to the face's front; Vec3::Zero() at a corner without one. Empty when
  // no corner has one (every other format). Kept through welding, splitting and flipping
  // (reverse()). Where two faces' corners at a vertex both carry one, they decide whether the
  // faces share an output point (pipeline/solve.h SolveOptions::crease_angle_degrees).
  std::vector<Vec3> corner_normals = {};
  // View3D subsurface (`base` field): at --by group, this face's factors and area are also taken
  // out of group `base_group` (the base surface's), which so becomes the base minus its
  // subsurfaces (at --by face, out of the face of that group that holds this one); -1 when none.
  int base_group = -1;
  bool null_surface = false;  // View3D `N` surface: only taken out of base_group, no group of its own
  // View3D `M` surface: taken out of base_group, which also keeps its area; its own group sees
  // only the base (F = 1) and is seen only by it.
  bool mask_surface = false;

  // Reverses the winding (the front becomes the back) together with the corner normals, which
  // are negated: a vn is meant to point to the front the file's winding gave the face, so once
  // the front is the other side the shading normal follows it (else the face's output points
  // would look into its back and gather nothing).
  void reverse();
};

// What loading did to the input, reported in the solve summary.
struct LoadStats {
  int input_vertices = 0;
  int input_faces = 0;
  int welded_vertices = 0;               // vertices merged into an earlier coincident one
  int dropped_degenerate = 0;            // zero-area faces removed
  int split_nonplanar = 0;               // non-planar polygons split into triangles
  int split_polygons = 0;                // convex-planar n-gons (n > 4) or non-convex polygons triangulated
  int missing_material_files = 0;        // mtllib files that could not be read (defaults used)
  int duplicate_faces = 0;               // faces equal to an earlier one (same vertices and winding), dropped
  int flipped_faces = 0;                 // faces wound against the rest of their closed surface, flipped
  bool enclosure_faces_outward = false;  // the closed surface around the scene faces out (see flip_normals)
  bool flipped_all = false;              // LoadOptions::flip_normals was applied
};

// One line per counted warning ("3 duplicate faces dropped"), empty when loading changed nothing
// worth telling. For the CLI to print on stderr.
std::vector<std::string> load_warnings(const LoadStats& stats);

struct Scene {
  std::string source;  // path it was loaded from
  std::vector<Vec3> vertices;
  std::vector<Face> faces;
  std::vector<Material> materials;
  std::vector<std::string> groups;
  LoadStats stats;
  nlohmann::json settings = nlohmann::json::object();  // "settings" block of a .json scene file

  Polygon face_polygon(int f) const;
};

struct LoadOptions {
  Rgb default_reflectance = Rgb::Constant(0.5);  // for formats without materials
  Rgb default_emission = Rgb::Zero();            // for formats without materials, W/m²
  double weld_tolerance = 1e-9;                  // relative to the bounding-box diagonal
  double planarity_tolerance = 1e-6;  // max vertex distance from the face plane, relative to the face's diameter
  bool flip_normals = false;          // reverse the winding of every face (inside-out exports)
  bool fix_orientation = true;        // flip faces wound against their closed surface
};

// Loads and cleans a scene. Throws photometria::Error (file, line, value) on bad input; checks
// that every material has 0 <= ρ < 1 and E >= 0.
Scene load_scene(const std::string& path, const LoadOptions& options = {});

// Signed volume (m³) enclosed by the given faces of `scene` (divergence theorem, summing the
// tetrahedra of each face's fan with the origin): positive when the faces of a closed surface
// face outward, negative when inward. Loading uses it to tell an enclosure's orientation.
double signed_volume(const Scene& scene, const std::vector<int>& faces);

}  // namespace photometria
