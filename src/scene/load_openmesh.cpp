// .off .ply .stl .om through OpenMesh, read into a PolyMesh with double points. These formats
// carry no materials: every face gets the default material and one group named after the file.
//
// Worth knowing about OpenMesh's readers (9.0): the text readers parse numbers as float (so
// coordinates carry float precision, ~1e-7 relative), print problems to omerr instead of
// failing, drop faces that repeat a vertex, and re-add faces that would make the mesh
// non-manifold on duplicated vertices (welding merges those again).
#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/PolyMesh_ArrayKernelT.hh>

#include <cmath>
#include <iostream>
#include <sstream>

#include "scene/loaders.h"
#include "util/error.h"

namespace photometria::scene_detail {
namespace {

struct DoubleTraits : OpenMesh::DefaultTraits {
  using Point = OpenMesh::Vec3d;
  using Normal = OpenMesh::Vec3d;
};
using PolyMesh = OpenMesh::PolyMesh_ArrayKernelT<DoubleTraits>;

// Collects what OpenMesh writes to omerr (which goes to std::cerr) into a string for the error
// message, instead of the terminal, while it lives. std::cerr's buffer is swapped rather than
// omerr re-connected because OpenMesh's mostream::disconnect leaks its target. (Not meant for
// several threads loading at once: std::cerr is global.)
class OmerrCapture {
 public:
  OmerrCapture() : saved_(std::cerr.rdbuf(text_.rdbuf())) {}
  ~OmerrCapture() {
    omerr().flush();
    std::cerr.rdbuf(saved_);
  }
  OmerrCapture(const OmerrCapture&) = delete;
  OmerrCapture& operator=(const OmerrCapture&) = delete;
  std::string text() {
    omerr().flush();
    return text_.str();
  }

 private:
  std::ostringstream text_;  // before saved_: the constructor points std::cerr at it
  std::streambuf* saved_;
};

int count_of(const std::string& text, const std::string& what) {
  int n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

std::string first_line(const std::string& s) { return s.substr(0, s.find('\n')); }

// Reads the mesh; returns the number of faces OpenMesh dropped for repeating a vertex.
int read_into(PolyMesh& mesh, const std::string& path) {
  OmerrCapture capture;
  OpenMesh::IO::Options opts;
  const bool ok = OpenMesh::IO::read_mesh(mesh, path, opts);
  const std::string log = capture.text();
  const std::string detail = log.empty() ? "" : " (OpenMesh: " + first_line(log) + ")";
  if (!ok) throw_bad_input(at(path) + ": cannot read the mesh" + detail);
  if (count_of(log, "invalid vertex index") + count_of(log, "invalid faces") > 0)
    throw_bad_input(at(path) + ": a face refers to a vertex that does not exist" + detail);
  return count_of(log, "Face has equal vertices");
}

void check_finite(const PolyMesh& mesh, const std::string& path) {
  for (const auto vh : mesh.vertices()) {
    const auto& p = mesh.point(vh);
    for (int k = 0; k < 3; ++k)
      if (!std::isfinite(p[k]))
        throw_bad_input(at(path) + ": vertex " + std::to_string(vh.idx()) + " has a non-finite coordinate " +
                        format_number(p[k]));
  }
}

}  // namespace

RawScene read_openmesh(const std::string& path, const LoadOptions& options) {
  if (!is_readable_file(path)) throw_io("cannot open '" + path + "'");
  check_mesh_text(path, lower_extension(path));
  PolyMesh mesh;
  const int repeated = read_into(mesh, path);
  check_finite(mesh, path);

  RawScene raw;
  Scene& s = raw.scene;
  for (const auto vh : mesh.vertices()) {
    const auto& p = mesh.point(vh);
    s.vertices.emplace_back(p[0], p[1], p[2]);
  }
  const int material = add_material(raw, {"default", options.default_reflectance, options.default_emission}, path);
  const int group = add_group(raw, file_stem(path));
  for (const auto fh : mesh.faces()) {
    Face face;
    for (const auto vh : mesh.fv_range(fh)) face.vertices.push_back(vh.idx());
    face.material = material;
    face.group = group;
    face.source_face = fh.idx();
    s.faces.push_back(std::move(face));
  }
  s.stats.input_vertices = static_cast<int>(mesh.n_vertices());
  s.stats.input_faces = static_cast<int>(mesh.n_faces()) + repeated;
  s.stats.dropped_degenerate = repeated;
  return raw;
}

}  // namespace photometria::scene_detail
