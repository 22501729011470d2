// load_scene: pick the reader by extension, then clean the geometry and check the materials.
#include "scene/scene.h"

#include <algorithm>

#include "scene/loaders.h"
#include "util/error.h"

namespace photometria {

using namespace scene_detail;

Polygon Scene::face_polygon(int f) const {
  Polygon p;
  for (int v : faces[static_cast<size_t>(f)].vertices) p.push_back(vertices[static_cast<size_t>(v)]);
  return p;
}

void Face::reverse() {
  std::reverse(vertices.begin(), vertices.end());
  std::reverse(corner_normals.begin(), corner_normals.end());
  for (Vec3& n : corner_normals) n = -n;
}

namespace scene_detail {

RawScene read_mesh_file(const std::string& path, const LoadOptions& options) {
  const std::string ext = lower_extension(path);
  RawScene raw;
  if (ext == ".obj") {
    raw = read_obj(path, options);
  } else if (ext == ".off" || ext == ".ply" || ext == ".stl" || ext == ".om") {
    raw = read_openmesh(path, options);
  } else if (ext == ".vs3") {
    raw = read_view3d(path, options);
  } else if (ext == ".json") {
    throw_bad_input(at(path) + ": a scene file cannot be used as a mesh");
  } else {
    throw_bad_input(at(path) + ": unknown mesh format " + in_quotes(ext.empty() ? "(no extension)" : ext) +
                    " (expected .obj, .off, .ply, .stl, .om, .vs3 or a .json scene)");
  }
  if (raw.scene.faces.empty()) throw_bad_input(at(path) + ": no faces");
  return raw;
}

}  // namespace scene_detail

std::vector<std::string> load_warnings(const LoadStats& s) {
  std::vector<std::string> w;
  auto count = [&](int n, const std::string& what) {
    if (n > 0) w.push_back(std::to_string(n) + " " + what);
  };
  count(s.dropped_degenerate, "zero-area or degenerate face(s) dropped");
  count(s.duplicate_faces, "duplicate face(s) dropped (same vertices and winding as an earlier face)");
  count(s.split_nonplanar, "non-planar polygon(s) split into triangles");
  count(s.missing_material_files, "material file(s) (mtllib) missing: their materials get the default values");
  count(s.flipped_faces, "face(s) wound against the rest of their closed surface flipped");
  if (s.enclosure_faces_outward)
    w.push_back(std::string("the closed surface around the scene faces outward (inside-out export?)") +
                (s.flipped_all ? " even after --flip-normals" : ": if it is a room, use --flip-normals"));
  return w;
}

Scene load_scene(const std::string& path, const LoadOptions& options) {
  RawScene raw = lower_extension(path) == ".json" ? read_json_scene(path, options) : read_mesh_file(path, options);
  clean_geometry(raw.scene, options);
  if (raw.scene.faces.empty())
    throw_bad_input(at(path) + ": no face has a non-zero area (" + std::to_string(raw.scene.stats.input_faces) +
                    " faces read)");
  drop_duplicate_faces(raw.scene);
  if (options.flip_normals) {
    for (Face& f : raw.scene.faces) f.reverse();
    raw.scene.stats.flipped_all = true;
  }
  fix_orientation(raw.scene, options.fix_orientation);
  drop_unused_materials(raw);
  check_materials(raw);
  raw.scene.source = path;
  return std::move(raw.scene);
}

}  // namespace photometria
