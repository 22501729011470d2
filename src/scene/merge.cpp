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

int add_group(RawScene& raw, const std::string& name) {
  std::vector<std::string>& groups = raw.scene.groups;
  if (raw.group_index.size() != groups.size()) {  // groups added without add_group: index them
    raw.group_index.clear();
    for (size_t i = 0; i < groups.size(); ++i) raw.group_index.emplace(groups[i], static_cast<int>(i));
  }
  const auto [it, added] = raw.group_index.emplace(name, static_cast<int>(groups.size()));
  if (added) groups.push_back(name);
  return it->second;
}

void append_scene(RawScene& into, RawScene&& part) {
  Scene& s = into.scene;
  Scene& p = part.scene;
  std::vector<int> material(p.materials.size()), group(p.groups.size());
  for (size_t i = 0; i < p.materials.size(); ++i)
    material[i] = add_material(into, p.materials[i], part.material_origin[i]);
  for (size_t i = 0; i < p.groups.size(); ++i) group[i] = add_group(into, p.groups[i]);

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
