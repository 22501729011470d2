// View3D input (.vs3), the 3-D text format of NIST's View3D (G. N. Walton, "Calculation of
// Obstructed View Factors by Adaptive Integration", NISTIR 6925, 2002, section "Input file"):
//
//   T title                      title (kept as the scene's "title" setting)
//   ! text                       comment
//   C key=value ...              control line: eps, maxU, maxO, minO, row, col, encl, emit, out,
//                                list, maxV, prjD are accepted and kept in Scene::settings["view3d"]
//                                (docs/viewfactors.md says which ones map onto our options)
//   F 3                          geometry format: only 3 (general 3-D) is supported
//   V n x y z                    vertex n (numbered 1, 2, ... in order)
//   S n v1 v2 v3 v4 base cmbn emit name   surface n radiating and obstructing; v4 = 0 for a
//                                triangle; vertices counter-clockwise seen from the front
//   O n v1 v2 v3 v4 base cmbn emit name   obstruction-only surface (Face::obstruction_only)
//   E / End                      end of data (anything after it is ignored)
//
// Refused, with the line named: F other than 3, M (mask) and N (null) surfaces, base or cmbn
// other than 0 (subsurfaces, combined surfaces), unknown control keys, unknown record letters.
// Every S/O surface becomes one group named by its `name` field (or "S<n>" when absent), so
// `viewfactors --by group` reproduces View3D's surface-to-surface matrix.
#include <cctype>
#include <cmath>
#include <set>

#include "scene/loaders.h"
#include "util/error.h"

namespace photometria::scene_detail {

RawScene read_view3d(const std::string& path, const LoadOptions& options) {
  const std::string text = read_file_text(path);
  RawScene raw;
  Scene& s = raw.scene;
  Material m;
  m.name = "view3d";
  m.reflectance = options.default_reflectance;
  m.emission = options.default_emission;
  const int material = add_material(raw, m, at(path));
  nlohmann::json control = nlohmann::json::object();
  bool have_format = false, ended = false;
  std::set<std::string> names;
  static const std::set<std::string> known_keys = {"eps",  "maxu", "maxo", "mino", "row",  "col", "encl",
                                                   "emit", "out",  "list", "maxv", "prjd", "maxd"};
  for_each_line(text, [&](long line, std::string_view l) {
    if (ended) return;
    const auto where = [&] { return at(path, line); };
    // '!' starts a comment anywhere; split_tokens already stops at '#'.
    const size_t bang = l.find('!');
    if (bang != std::string_view::npos) l = l.substr(0, bang);
    const std::vector<std::string_view> t = split_tokens(l);
    if (t.empty()) return;
    std::string rec(t[0]);
    for (char& c : rec) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    if (rec == "T") {
      const size_t p = l.find_first_not_of(" \t", l.find_first_of("Tt") + 1);
      s.settings["title"] = p == std::string_view::npos ? "" : std::string(l.substr(p));
    } else if (rec == "C") {
      for (size_t k = 1; k < t.size(); ++k) {
        // "key=value" or "key= value" (View3D's own examples use both).
        std::string key(t[k]), value;
        const size_t eq = key.find('=');
        if (eq == std::string::npos)
          throw_bad_input(where() + ": control entry " + in_quotes(t[k]) + " is not key=value");
        value = key.substr(eq + 1);
        key = key.substr(0, eq);
        if (value.empty() && k + 1 < t.size()) value = std::string(t[++k]);
        std::string lower = key;
        for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
        if (!known_keys.count(lower)) throw_bad_input(where() + ": unsupported control key " + in_quotes(key));
        double v = 0.0;
        if (!parse_number(value, v))
          throw_bad_input(where() + ": control " + key + " value " + in_quotes(value) + " is not a number");
        control[lower] = v;
      }
    } else if (rec == "F") {
      long f = 0;
      if (t.size() < 2 || !parse_integer(t[1], f) || f != 3)
        throw_bad_input(where() + ": unsupported geometry format " + in_quotes(t.size() < 2 ? "" : t[1]) +
                        " (only F 3, general 3-D geometry, is supported)");
      have_format = true;
    } else if (rec == "V") {
      long n = 0;
      double x[3];
      if (t.size() < 5 || !parse_integer(t[1], n) || !parse_number(t[2], x[0]) || !parse_number(t[3], x[1]) ||
          !parse_number(t[4], x[2]))
        throw_bad_input(where() + ": vertex line needs 'V n x y z'");
      if (n != static_cast<long>(s.vertices.size()) + 1)
        throw_bad_input(where() + ": vertex number " + std::to_string(n) + " out of sequence (expected " +
                        std::to_string(s.vertices.size() + 1) + ")");
      for (double c : x)
        if (!std::isfinite(c)) throw_bad_input(where() + ": vertex " + std::to_string(n) + " is not finite");
      s.vertices.emplace_back(x[0], x[1], x[2]);
    } else if (rec == "S" || rec == "O") {
      long n = 0, v[4], base = 0, cmbn = 0;
      double emit = 0.0;
      if (t.size() < 9 || !parse_integer(t[1], n) || !parse_integer(t[2], v[0]) || !parse_integer(t[3], v[1]) ||
          !parse_integer(t[4], v[2]) || !parse_integer(t[5], v[3]) || !parse_integer(t[6], base) ||
          !parse_integer(t[7], cmbn) || !parse_number(t[8], emit))
        throw_bad_input(where() + ": surface line needs '" + rec + " n v1 v2 v3 v4 base cmbn emit name'");
      if (n != s.stats.input_faces + 1)
        throw_bad_input(where() + ": surface number " + std::to_string(n) + " out of sequence (expected " +
                        std::to_string(s.stats.input_faces + 1) + ")");
      if (base != 0) throw_bad_input(where() + ": subsurfaces (base = " + std::to_string(base) + ") are not supported");
      if (cmbn != 0)
        throw_bad_input(where() + ": combined surfaces (cmbn = " + std::to_string(cmbn) + ") are not supported");
      if (!(emit >= 0.0 && emit <= 1.0))
        throw_bad_input(where() + ": emissivity " + in_quotes(t[8]) + " outside [0, 1]");
      const int count = v[3] == 0 ? 3 : 4;
      Face face;
      for (int k = 0; k < count; ++k) {
        if (v[k] < 1 || v[k] > static_cast<long>(s.vertices.size()))
          throw_bad_input(where() + ": vertex " + std::to_string(v[k]) + " not defined before this line");
        face.vertices.push_back(static_cast<int>(v[k] - 1));
      }
      std::string name = t.size() > 9 ? std::string(t[9]) : rec + std::to_string(n);
      if (!names.insert(name).second) name.append(1, '#').append(std::to_string(n));  // keep group names unique
      face.material = material;
      face.group = add_group(s, name);
      face.source_face = s.stats.input_faces++;
      face.obstruction_only = rec == "O";
      s.faces.push_back(face);
    } else if (rec == "E" || rec == "END") {
      ended = true;
    } else if (rec == "M" || rec == "N") {
      throw_bad_input(where() + ": " + (rec == "M" ? std::string("mask (M)") : std::string("null (N)")) +
                      " surfaces are not supported");
    } else {
      throw_bad_input(where() + ": unknown View3D record " + in_quotes(t[0]) + " (expected T, C, F, V, S, O, E or !)");
    }
  });
  if (!have_format) throw_bad_input(at(path) + ": no 'F 3' format line");
  s.stats.input_vertices = static_cast<int>(s.vertices.size());
  if (!control.empty()) s.settings["view3d"] = control;
  bool radiating = false;
  for (const Face& f : s.faces) radiating = radiating || !f.obstruction_only;
  if (!s.faces.empty() && !radiating) throw_bad_input(at(path) + ": no S surface (only obstructions)");
  return raw;
}

}  // namespace photometria::scene_detail
