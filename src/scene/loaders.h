// Internal to the scene stage: the readers behind load_scene and the cleaning steps they share.
//
// Readers return a RawScene: faces as read (any vertex count, possibly degenerate), materials
// with the place their values came from (for error messages after JSON overrides), stats filled
// in as far as reading goes. load_scene then welds, drops, splits and checks.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "scene/scene.h"

namespace photometria::scene_detail {

struct RawScene {
  Scene scene;
  std::vector<std::string> material_origin;  // per material: "file" or "file:line" of its values
  // scene.groups by name (add_group), so that a file of 10⁵ groups (a CAD export with a `g` per
  // face) is not searched once per group; rebuilt when scene.groups changed behind its back.
  std::unordered_map<std::string, int> group_index;
};

// --- text.cpp: file and token helpers ----------------------------------------------------------

// Whole file as text; throws Io "cannot open 'path'" when missing, a directory or unreadable.
std::string read_file_text(const std::string& path);
bool is_readable_file(const std::string& path);
std::string lower_extension(const std::string& path);  // ".obj"; "" when there is none
std::string file_stem(const std::string& path);
// Calls f(line_number, line) for every line ("\n", "\r\n" or "\r" endings), numbered from 1.
template <class F>
void for_each_line(std::string_view text, F&& f);
// Whitespace-separated tokens, stopping at a '#' comment.
std::vector<std::string_view> split_tokens(std::string_view line);
// The whole token as a number (leading '+' allowed; nan/inf parse and are left to the caller).
bool parse_number(std::string_view token, double& out);
bool parse_integer(std::string_view token, long& out);
// Shortest text that reads back as the same double ("1.2", not "1.19999999999999996").
std::string format_number(double x);
std::string in_quotes(std::string_view s);  // 'value' for messages

// Adds a material / group, or returns the index of an equal one already there (same name and,
// for materials, same values: same-named materials with different values stay separate).
int add_material(RawScene& raw, const Material& m, const std::string& origin);
int add_group(RawScene& raw, const std::string& name);

// --- readers -----------------------------------------------------------------------------------

// One mesh file of any supported format, checked to have faces; .json is refused here.
RawScene read_mesh_file(const std::string& path, const LoadOptions& options);
RawScene read_obj(const std::string& path, const LoadOptions& options);         // load_obj.cpp
RawScene read_openmesh(const std::string& path, const LoadOptions& options);    // load_openmesh.cpp
RawScene read_json_scene(const std::string& path, const LoadOptions& options);  // load_json.cpp
RawScene read_view3d(const std::string& path, const LoadOptions& options);      // load_view3d.cpp (.vs3)

// obj_scan.cpp: the validation pass over OBJ text that tinyobjloader does not do (it accepts
// garbage numbers as 0 and out-of-range indices). Also records per face the `usemtl` name in
// force, which tinyobjloader forgets when the name is not in any .mtl.
struct ObjScan {
  std::vector<Vec3> vertices;
  std::vector<Vec3> normals;               // `vn`, normalised (zero-length or overflowing ones are refused)
  std::vector<std::string> face_material;  // one per face, in file order ("" = no usemtl yet)
};
ObjScan scan_obj(const std::string& path, std::string_view text);

// The same for .mtl text: Kd and Ke must be 1 or 3 finite numbers.
struct MtlEntry {
  std::string name;
  long line = 0;  // of `newmtl`
  std::optional<Rgb> kd, ke;
};
std::vector<MtlEntry> scan_mtl(const std::string& path, std::string_view text);

// mesh_text_check.cpp: OpenMesh's text readers turn unreadable or non-finite numbers into
// zeros or garbage without failing, so text OFF / PLY / STL files are checked first.
void check_mesh_text(const std::string& path, const std::string& extension);

// --- cleaning ----------------------------------------------------------------------------------

// weld.cpp: maps each point with used[i] to the first earlier used point within `tolerance`
// (itself if there is none); unused points map to -1. `merged` counts the points mapped away.
std::vector<int> weld_points(const std::vector<Vec3>& points, const std::vector<bool>& used, double tolerance,
                             int& merged);

// clean.cpp: welds, drops degenerate faces, splits non-planar / non-convex / n > 4 polygons,
// drops unused vertices.
void clean_geometry(Scene& scene, const LoadOptions& options);

// clean.cpp: drops faces equal to an earlier one (same vertex cycle, same winding), counting
// them in stats.duplicate_faces. Runs after clean_geometry (on welded, split faces).
void drop_duplicate_faces(Scene& scene);

// orient.cpp: in every closed surface, flips the faces wound against the rest (the winding
// covering the larger area wins) and counts them; flags an enclosure facing outward.
void fix_orientation(Scene& scene, bool flip_inconsistent);

// merge.cpp: appends one mesh file's scene (offsetting vertex and source-face indices).
void append_scene(RawScene& into, RawScene&& part);

// materials.cpp
void drop_unused_materials(RawScene& raw);
// Throws BadInput unless every material has 0 <= ρ < 1 and finite E >= 0.
void check_materials(const RawScene& raw);

// --- template definition -----------------------------------------------------------------------

template <class F>
void for_each_line(std::string_view text, F&& f) {
  long number = 0;
  size_t start = 0;
  while (start < text.size()) {
    size_t end = text.find_first_of("\r\n", start);
    if (end == std::string_view::npos) end = text.size();
    f(++number, text.substr(start, end - start));
    // "\r\n" is one line ending.
    start = end + ((end + 1 < text.size() && text[end] == '\r' && text[end + 1] == '\n') ? 2 : 1);
  }
}

}  // namespace photometria::scene_detail
