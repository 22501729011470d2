// Wavefront OBJ + MTL through tinyobjloader (polygons kept as polygons). The text has been
// validated by scan_obj first; vertex positions come from that pass (std::from_chars, correctly
// rounded), tinyobjloader supplies the structure: shapes (g / o groups), materials, usemtl.
#include <tiny_obj_loader.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>

#include "scene/loaders.h"
#include "util/error.h"

namespace photometria::scene_detail {
namespace {

// Reads the .mtl files named by `mtllib` relative to the OBJ's folder (or absolute), validates
// them with scan_mtl and remembers where each material came from. A missing file is counted,
// not fatal: the faces keep their usemtl names with the default values.
class MtlReader : public tinyobj::MaterialReader {
 public:
  explicit MtlReader(std::filesystem::path folder) : folder_(std::move(folder)) {}

  bool operator()(const std::string& name, std::vector<tinyobj::material_t>* materials,
                  std::map<std::string, int>* index, std::string* /*warn*/, std::string* err) override {
    const std::filesystem::path p(name);
    const std::string file = (p.is_absolute() ? p : folder_ / p).string();
    if (!is_readable_file(file)) {
      missing_.insert(file);
      return false;
    }
    const std::string text = read_file_text(file);
    const std::vector<MtlEntry> entries = scan_mtl(file, text);
    const size_t first = materials->size();
    std::istringstream in(text);
    std::string mtl_warn;
    tinyobj::LoadMtl(index, materials, &in, &mtl_warn, err);
    match(entries, *materials, first, file);
    return true;
  }

  int missing() const { return static_cast<int>(missing_.size()); }
  const MtlEntry* entry(size_t material) const {
    return material < entries_.size() && entries_[material] ? &*entries_[material] : nullptr;
  }
  const std::string& file(size_t material) const { return files_.at(material); }

 private:
  // tinyobjloader appends one material per `newmtl` in file order (plus an unnamed one for a
  // file without any), so scanned entries pair up with the new materials by name, in order.
  void match(const std::vector<MtlEntry>& entries, const std::vector<tinyobj::material_t>& materials, size_t first,
             const std::string& file) {
    entries_.resize(materials.size());
    files_.resize(materials.size(), file);
    size_t k = 0;
    for (size_t i = first; i < materials.size(); ++i) {
      size_t j = k;
      while (j < entries.size() && entries[j].name != materials[i].name) ++j;
      if (j == entries.size()) continue;
      entries_[i] = entries[j];
      k = j + 1;
    }
  }

  std::filesystem::path folder_;
  std::set<std::string> missing_;
  std::vector<std::optional<MtlEntry>> entries_;  // per tinyobjloader material
  std::vector<std::string> files_;
};

Rgb to_rgb(const tinyobj::real_t* c) { return Rgb(c[0], c[1], c[2]); }

// Our materials for tinyobjloader's, in the same order; Kd / Ke as scanned where known (the
// scan reads "Kd 0.5" as grey, tinyobjloader as (0.5, 0, 0)).
void add_mtl_materials(RawScene& raw, const std::vector<tinyobj::material_t>& materials, const MtlReader& reader,
                       std::vector<int>& index) {
  for (size_t i = 0; i < materials.size(); ++i) {
    Material m{materials[i].name, to_rgb(materials[i].diffuse), to_rgb(materials[i].emission)};
    std::string origin = reader.file(i);
    if (const MtlEntry* e = reader.entry(i)) {
      if (e->kd) m.reflectance = *e->kd;
      if (e->ke) m.emission = *e->ke;
      origin = at(origin, e->line);
    }
    index.push_back(add_material(raw, m, origin));
  }
}

// A face without a known material: "default" without usemtl, else the usemtl name (so that a
// JSON override by that name still finds it), both with the default values.
int fallback_material(RawScene& raw, const std::string& usemtl, const LoadOptions& options, const std::string& path) {
  const Material m{usemtl.empty() ? "default" : usemtl, options.default_reflectance, options.default_emission};
  return add_material(raw, m, path);
}

std::string trimmed(const std::string& s) {
  const size_t a = s.find_first_not_of(" \t\r\n");
  return a == std::string::npos ? std::string() : s.substr(a, s.find_last_not_of(" \t\r\n") + 1 - a);
}

void add_faces(RawScene& raw, const std::vector<tinyobj::shape_t>& shapes, const ObjScan& scan,
               const std::vector<int>& mtl_index, const LoadOptions& options, const std::string& path) {
  int face_no = 0;
  // tinyobjloader gives 0 both for `s off` and where the file has no `s` line: the groups count
  // only in a file that names some nonzero one.
  bool with_smoothing_groups = false;
  for (const tinyobj::shape_t& shape : shapes)
    for (unsigned id : shape.mesh.smoothing_group_ids) with_smoothing_groups = with_smoothing_groups || id != 0;
  for (const tinyobj::shape_t& shape : shapes) {
    const std::string name = trimmed(shape.name);
    const int group = add_group(raw, name.empty() ? file_stem(path) : name);
    size_t offset = 0;
    for (size_t f = 0; f < shape.mesh.num_face_vertices.size(); ++f, ++face_no) {
      Face face;
      bool has_normal = false;
      for (size_t k = 0; k < shape.mesh.num_face_vertices[f]; ++k) {
        const tinyobj::index_t& corner = shape.mesh.indices[offset + k];
        face.vertices.push_back(corner.vertex_index);
        // tinyobjloader has resolved negative (relative) indices; -1: no vn at this corner. The
        // values are the scan's (doubles, normalised), not tinyobjloader's floats.
        const int vn = corner.normal_index;
        const bool given = vn >= 0 && size_t(vn) < scan.normals.size();
        face.corner_normals.push_back(given ? scan.normals[size_t(vn)] : Vec3(Vec3::Zero()));
        has_normal = has_normal || given;
      }
      if (!has_normal) face.corner_normals.clear();
      offset += shape.mesh.num_face_vertices[f];
      const int id = shape.mesh.material_ids[f];
      face.material = id >= 0
                          ? mtl_index[static_cast<size_t>(id)]
                          : fallback_material(raw, scan.face_material.at(static_cast<size_t>(face_no)), options, path);
      face.group = group;
      face.source_face = face_no;
      if (with_smoothing_groups) face.smoothing_group = long(shape.mesh.smoothing_group_ids.at(f));
      raw.scene.faces.push_back(std::move(face));
    }
  }
}

std::string first_line(const std::string& s) { return s.substr(0, s.find('\n')); }

}  // namespace

RawScene read_obj(const std::string& path, const LoadOptions& options) {
  const std::string text = read_file_text(path);
  ObjScan scan = scan_obj(path, text);
  if (scan.face_material.empty()) throw_bad_input(at(path) + ": no faces");

  tinyobj::attrib_t attrib;
  std::vector<tinyobj::shape_t> shapes;
  std::vector<tinyobj::material_t> materials;
  std::string warn, err;
  MtlReader reader(std::filesystem::path(path).parent_path());
  std::istringstream in(text);
  if (!tinyobj::LoadObj(&attrib, &shapes, &materials, &warn, &err, &in, &reader, /*triangulate=*/false,
                        /*default_vcols_fallback=*/false))
    throw_bad_input(at(path) + ": " + first_line(err));

  RawScene raw;
  std::vector<int> mtl_index;
  add_mtl_materials(raw, materials, reader, mtl_index);
  add_faces(raw, shapes, scan, mtl_index, options, path);
  if (attrib.normals.size() != 3 * scan.normals.size())
    throw_bad_input(at(path) + ": tinyobjloader read " + std::to_string(attrib.normals.size() / 3) +
                    " normals, expected " + std::to_string(scan.normals.size()));
  if (raw.scene.faces.size() != scan.face_material.size() || attrib.vertices.size() != 3 * scan.vertices.size())
    throw_bad_input(at(path) + ": tinyobjloader read " + std::to_string(raw.scene.faces.size()) + " faces and " +
                    std::to_string(attrib.vertices.size() / 3) + " vertices, expected " +
                    std::to_string(scan.face_material.size()) + " and " + std::to_string(scan.vertices.size()));
  raw.scene.vertices = std::move(scan.vertices);
  raw.scene.stats.input_vertices = static_cast<int>(raw.scene.vertices.size());
  raw.scene.stats.input_faces = static_cast<int>(raw.scene.faces.size());
  raw.scene.stats.missing_material_files = reader.missing();
  return raw;
}

}  // namespace photometria::scene_detail
