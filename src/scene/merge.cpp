// Putting mesh files together: materials and groups are shared by name, indices offset.
#include "scene/loaders.h"

namespace photometria::scene_detail {

int add_material(RawScene& raw, const Material& m, const std::string& origin) {
  auto& materials = raw.scene.materials;
  for (size_t i = 0; i < materials.size(); ++i) {
    const Material& o = materials[i];
    // Exact comparison on purpose: only the very same values may be shared.
    if (o.name == m.name && (o.reflectance == m.reflectance).all() && (o.emission == m.emission).all())
      return static_cast<int>(i);
  }
  materials.push_back(m);
  raw.material_origin.push_back(origin);
  return static_cast<int>(materials.size() - 1);
}

int add_group(Scene& scene, const std::string& name) {
  for (size_t i = 0; i < scene.groups.size(); ++i)
    if (scene.groups[i] == name) return static_cast<int>(i);
  scene.groups.push_back(name);
  return static_cast<int>(scene.groups.size() - 1);
}

void append_scene(RawScene& into, RawScene&& part) {
  Scene& s = into.scene;
  Scene& p = part.scene;
  std::vector<int> material(p.materials.size()), group(p.groups.size());
  for (size_t i = 0; i < p.materials.size(); ++i)
    material[i] = add_material(into, p.materials[i], part.material_origin[i]);
  for (size_t i = 0; i < p.groups.size(); ++i) group[i] = add_group(s, p.groups[i]);

  const int vertex_offset = static_cast<int>(s.vertices.size());
  const int face_offset = s.stats.input_faces;
  s.vertices.insert(s.vertices.end(), p.vertices.begin(), p.vertices.end());
  for (Face& f : p.faces) {
    for (int& v : f.vertices) v += vertex_offset;
    f.material = material[static_cast<size_t>(f.material)];
    f.group = group[static_cast<size_t>(f.group)];
    f.source_face += face_offset;
    s.faces.push_back(std::move(f));
  }
  s.stats.input_vertices += p.stats.input_vertices;
  s.stats.input_faces += p.stats.input_faces;
  s.stats.dropped_degenerate += p.stats.dropped_degenerate;
  s.stats.missing_material_files += p.stats.missing_material_files;
}

}  // namespace photometria::scene_detail
