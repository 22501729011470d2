// View3D input (.vs3), the 3-D text format of NIST's View3D (G. N. Walton, "Calculation of
// Obstructed View Factors by Adaptive Integration", NISTIR 6925, 2002, section "Input file";
// View3D 4.0 manual, sections "Input Data Elements", "View3D Format (F=3)" and "Blast Surface
// Format (F=3a)"):
//
//   T title                      title (kept as the scene's "title" setting)
//   ! text  or  / text           comment
//   C key=value ...              control line: eps, maxU, maxO, minO, row, col, encl, emit, out,
//                                list, maxV, prjD are accepted and kept in Scene::settings["view3d"]
//                                (docs/viewfactors.md says which ones map onto our options)
//   F 3  or  F 3a                geometry format: general 3-D (vertices, then surfaces) or BLAST
//                                (each surface gives its own plane and shape)
//   V n x y z                    (F 3) vertex n (numbered 1, 2, ... in order)
//   S n v1 v2 v3 v4 base cmbn emit name   (F 3) surface n radiating and obstructing; v4 = 0 for
//                                a triangle; vertices counter-clockwise seen from the front
//   O n v1 v2 v3 v4 base cmbn emit name   (F 3) obstruction-only surface (Face::obstruction_only)
//   S n shape base cmbn emit name          (F 3a) shape R, Q or T, then on the next line(s):
//     x y z azimuth tilt w h               R: origin = lower left corner seen from the front
//     x y z azimuth tilt x1 y1 .. x4 y4    Q (T: three points), in the plane's own axes
//   O n shape [...]                        (F 3a) obstruction-only surface, same geometry lines
//   N ... / M ...                null / mask surface: as S in either format (base required)
//   E / End / *                  end of data (anything after it is ignored)
//
// F 3a planes: azimuth is the facing direction, degrees clockwise from +y (north); tilt is 0 for
// a surface facing up, 90 vertical, 180 facing down. The plane's own axes are
//   u = (−cos az, sin az, 0)                       (horizontal, to the right seen from the front)
//   v = (−cos tilt sin az, −cos tilt cos az, sin tilt)   (up the slope)
// so that u × v is the front normal (sin tilt sin az, sin tilt cos az, cos tilt) and a point
// (x, y) of the plane is origin + x u + y v: the manual's example "3 0 0  0 90  3 3" is the
// 3 m × 3 m wall 0 ≤ x ≤ 3, 0 ≤ z ≤ 3 of y = 0 facing +y.
//
// Combined surfaces (cmbn = k ≠ 0, S only, k an earlier S surface that is itself not combined)
// join the group of surface k: `viewfactors --by group` then applies the view-factor algebra of
// View3D's post-processing (docs/viewfactors.md).
//
// Subsurfaces (base = k ≠ 0 on an S line, k an earlier S surface): a group of their own, and
// Face::base_group = the group of k, so that --by group (and --by face, on the face of k that
// holds it) reports k net of its subsurfaces.
// Null surfaces (N, same fields as S, base required): the part of the base that is not there;
// stored facing as the base does (vertices reversed), Face::null_surface, no group of their own.
// Mask surfaces (M, as N): facing the base, F(mask → base) = 1; the part of the base they cover
// sees only them (Face::mask_surface: a group of their own, taken out of the base's factors).
// All three are checked as View3D does: in the base's plane, facing with (N, M: against) it,
// within it.
//
// Refused, with the line named: F other than 3 or 3a, chained or forward
// combinations, O surfaces with a base, unknown control keys, unknown records.
// Every S/O surface not combined becomes one group named by its `name` field (or "S<n>" when
// absent), so `viewfactors --by group` reproduces View3D's surface-to-surface matrix.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <optional>
#include <set>

#include "geometry/polygon.h"
#include "scene/loaders.h"
#include "util/error.h"

namespace photometria::scene_detail {
namespace {

// cos and sin of an angle in degrees, exact at multiples of 90° (walls and floors stay exactly
// axis-aligned).
double cos_deg(double d) {
  double r = std::fmod(d, 360.0);
  if (r < 0) r += 360.0;
  if (r == 0.0) return 1.0;
  if (r == 90.0 || r == 270.0) return 0.0;
  if (r == 180.0) return -1.0;
  return std::cos(r * M_PI / 180.0);
}
double sin_deg(double d) { return cos_deg(d - 90.0); }

// A surface record whose F 3a geometry numbers are still to come on the following lines.
struct PendingShape {
  std::string rec;  // "S" or "O"
  long n = 0, base = 0, cmbn = 0;
  char shape = 'R';
  std::string emit, name;
  long line = 0;
  size_t needed = 0;
  std::vector<double> numbers;
};

size_t numbers_of_shape(char shape) { return shape == 'R' ? 7 : shape == 'T' ? 11 : 13; }

// The point (x, y) of the F 3a plane through `origin` (axes in the comment at the top).
Vec3 plane_point(const Vec3& origin, double azimuth, double tilt, double x, double y) {
  const double ca = cos_deg(azimuth), sa = sin_deg(azimuth), ct = cos_deg(tilt), st = sin_deg(tilt);
  const Vec3 u(-ca, sa, 0.0), v(-ct * sa, -ct * ca, st);
  return origin + x * u + y * v;
}

// View3D's conditions on a subsurface (manual, "Surface Types"): in the plane of its base, facing
// the same way (a null surface: the opposite way), entirely within it (the base is convex).
void check_subsurface(const std::string& where, const std::string& kind, bool null, long base, const Polygon& sub,
                      const Polygon& b) {
  const std::string what = kind + " of base surface " + std::to_string(base);
  const Vec3 nb = polygon_normal(b), ns = polygon_normal(sub), c = polygon_centroid(b);
  double size = 0.0;
  for (const Vec3& v : b) size = std::max(size, (v - c).norm());
  const double tol = 1e-5 * size;
  for (const Vec3& v : sub)
    if (std::abs(nb.dot(v - c)) > tol) throw_bad_input(where + ": " + what + " is not in the plane of its base");
  if (null ? ns.dot(nb) > -0.999 : ns.dot(nb) < 0.999)
    throw_bad_input(where + ": " + what +
                    (null ? " must face opposite to its base" : " must face the same way as its base"));
  for (size_t k = 0; k < b.size(); ++k) {
    const Vec3& a = b[k];
    const Vec3 edge = b[(k + 1) % b.size()] - a;
    for (const Vec3& v : sub)
      if (edge.cross(v - a).dot(nb) < -tol * edge.norm())
        throw_bad_input(where + ": " + what + " is not within its base");
  }
}

}  // namespace

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
  int format = 0;  // 3, or 4 for 3a
  bool ended = false;
  std::set<std::string> names;
  struct SurfaceInfo {
    bool radiating;  // an S surface (may be a base or a combination target)
    long cmbn;
    int group;
    int face;
  };
  std::vector<SurfaceInfo> surfaces;  // by surface number − 1
  std::optional<PendingShape> pending;
  static const std::set<std::string> known_keys = {"eps",  "maxu", "maxo", "mino", "row",  "col", "encl",
                                                   "emit", "out",  "list", "maxv", "prjd", "maxd"};

  // Checks of the fields common to both formats, then the face (vertex indices into s.vertices).
  const auto add_surface = [&](const std::string& where, const std::string& rec, long n, std::vector<int> vertices,
                               long base, long cmbn, std::string_view emit_text, std::string name) {
    if (n != s.stats.input_faces + 1)
      throw_bad_input(where + ": surface number " + std::to_string(n) + " out of sequence (expected " +
                      std::to_string(s.stats.input_faces + 1) + ")");
    int group = -1, base_group = -1;
    const bool masking = rec == "N" || rec == "M";
    const std::string kind = rec == "N" ? "null" : "mask";
    if (masking && base == 0)
      throw_bad_input(where + ": " + kind + " surface " + std::to_string(n) + " needs a base surface");
    if (masking && cmbn != 0)
      throw_bad_input(where + ": " + kind + " surfaces cannot be combined (cmbn = " + std::to_string(cmbn) + ")");
    if (rec == "O" && base != 0)
      throw_bad_input(where +
                      ": an obstruction-only (O) surface cannot be a subsurface (base = " + std::to_string(base) + ")");
    if (base != 0) {
      const std::string b = "base surface " + std::to_string(base);
      if (base < 1 || base >= n) throw_bad_input(where + ": " + b + " must be an earlier surface");
      const SurfaceInfo& bs = surfaces[static_cast<size_t>(base - 1)];
      if (!bs.radiating) throw_bad_input(where + ": " + b + " is not a radiating (S) surface");
      Polygon sub;
      for (int v : vertices) sub.push_back(s.vertices[static_cast<size_t>(v)]);
      check_subsurface(where, masking ? kind + " surface" : "subsurface", masking, base, sub, s.face_polygon(bs.face));
      base_group = bs.group;
      if (masking) std::reverse(vertices.begin(), vertices.end());  // faces as the part of the base it covers
      if (rec == "N") group = base_group;
    }
    if (cmbn != 0) {
      const std::string c = "combined surface (cmbn = " + std::to_string(cmbn) + ")";
      if (rec != "S") throw_bad_input(where + ": " + c + " on an obstruction-only (O) surface");
      if (cmbn < 1 || cmbn >= n) throw_bad_input(where + ": " + c + " must name an earlier surface");
      const SurfaceInfo& target = surfaces[static_cast<size_t>(cmbn - 1)];
      if (!target.radiating) throw_bad_input(where + ": " + c + " names a surface that is not an S surface");
      if (target.cmbn != 0)
        throw_bad_input(where + ": " + c + " names a surface itself combined into " + std::to_string(target.cmbn) +
                        " (combine all with the lowest-numbered surface, do not chain)");
      group = target.group;
    }
    double emit = 0.0;
    if (!emit_text.empty() && (!parse_number(emit_text, emit) || !(emit >= 0.0 && emit <= 1.0)))
      throw_bad_input(where + ": emissivity " + in_quotes(emit_text) + " outside [0, 1]");
    Face face;
    face.vertices = std::move(vertices);
    if (group < 0) {  // not combined, not null: a group of its own
      if (name.empty()) name = rec + std::to_string(n);
      // Group names stay unique (a repeated name gets "#<surface number>", then "#" until free),
      // so the group is new: no search of the earlier ones (quadratic in a file of 10⁵ surfaces).
      if (!names.insert(name).second) {
        name.append(1, '#').append(std::to_string(n));
        while (!names.insert(name).second) name.push_back('#');
      }
      s.groups.push_back(name);
      group = static_cast<int>(s.groups.size()) - 1;
    }
    face.material = material;
    face.group = group;
    face.source_face = s.stats.input_faces++;
    face.obstruction_only = rec == "O";
    face.base_group = base_group;
    face.null_surface = rec == "N";
    face.mask_surface = rec == "M";
    surfaces.push_back({rec == "S", cmbn, group, static_cast<int>(s.faces.size())});
    s.faces.push_back(face);
  };

  // The F 3a surface whose geometry numbers are complete: its vertices, then the face.
  const auto finish_shape = [&](const PendingShape& p) {
    const std::string where = at(path, p.line);
    const std::vector<double>& g = p.numbers;
    for (double c : g)
      if (!std::isfinite(c)) throw_bad_input(where + ": surface " + std::to_string(p.n) + " geometry is not finite");
    const Vec3 origin(g[0], g[1], g[2]);
    std::vector<std::pair<double, double>> local;
    if (p.shape == 'R') {
      if (!(g[5] > 0.0 && g[6] > 0.0))
        throw_bad_input(where + ": rectangle " + std::to_string(p.n) + " needs a positive width and height");
      local = {{0.0, 0.0}, {g[5], 0.0}, {g[5], g[6]}, {0.0, g[6]}};  // counter-clockwise from the front
    } else {
      for (size_t k = 5; k + 1 < g.size(); k += 2) local.emplace_back(g[k], g[k + 1]);
    }
    std::vector<int> vertices;
    for (const auto& [x, y] : local) {
      vertices.push_back(static_cast<int>(s.vertices.size()));
      s.vertices.push_back(plane_point(origin, g[3], g[4], x, y));
    }
    add_surface(where, p.rec, p.n, std::move(vertices), p.base, p.cmbn, p.emit, p.name);
  };
  const auto pending_error = [&](const PendingShape& p, const std::string& where) {
    throw_bad_input(at(path, p.line) + ": surface " + std::to_string(p.n) + " (shape " + std::string(1, p.shape) +
                    ") needs " + std::to_string(p.needed) + " geometry numbers (x y z azimuth tilt " +
                    (p.shape == 'R'   ? "width height"
                     : p.shape == 'T' ? "and 3 points x y"
                                      : "and 4 points x y") +
                    ") on the lines after it; found " + std::to_string(p.numbers.size()) + " before " + where);
  };

  for_each_line(text, [&](long line, std::string_view l) {
    if (ended) return;
    const auto where = [&] { return at(path, line); };
    // '!' starts a comment anywhere; split_tokens already stops at '#'.
    const size_t bang = l.find('!');
    if (bang != std::string_view::npos) l = l.substr(0, bang);
    const std::vector<std::string_view> t = split_tokens(l);
    if (t.empty() || t[0][0] == '/') return;
    if (pending) {
      // F 3a geometry numbers, possibly over several lines.
      double x = 0.0;
      if (parse_number(t[0], x)) {
        for (std::string_view tok : t) {
          if (!parse_number(tok, x))
            throw_bad_input(where() + ": geometry value " + in_quotes(tok) + " is not a number");
          if (pending->numbers.size() == pending->needed)
            throw_bad_input(where() + ": more geometry numbers than surface " + std::to_string(pending->n) +
                            " (shape " + std::string(1, pending->shape) + ") takes (" +
                            std::to_string(pending->needed) + ")");
          pending->numbers.push_back(x);
        }
        if (pending->numbers.size() == pending->needed) {
          finish_shape(*pending);
          pending.reset();
        }
        return;
      }
      pending_error(*pending, "line " + std::to_string(line));
    }
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
      std::string f = t.size() < 2 ? "" : std::string(t[1]);
      for (char& c : f) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
      if (f != "3" && f != "3a")
        throw_bad_input(where() + ": unsupported geometry format " + in_quotes(t.size() < 2 ? "" : t[1]) +
                        " (F 3, general 3-D, and F 3a, BLAST surfaces, are supported)");
      if (format != 0 && !s.faces.empty()) throw_bad_input(where() + ": second F line after surfaces");
      format = f == "3" ? 3 : 4;
    } else if (rec == "V") {
      if (format == 4) throw_bad_input(where() + ": V records are not part of the F 3a format");
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
    } else if ((rec == "S" || rec == "O" || rec == "N" || rec == "M") && format == 4) {
      // F 3a: "S n shape base cmbn emit [name]"; View3D reads nothing after the shape of an O line.
      PendingShape p;
      p.rec = rec;
      p.line = line;
      std::string shape = t.size() > 2 ? std::string(t[2]) : "";
      for (char& c : shape) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
      const bool fields = rec == "O" ? t.size() == 3 || t.size() >= 6 : t.size() >= 6;
      if (!fields || !parse_integer(t[1], p.n) ||
          (t.size() >= 6 && (!parse_integer(t[3], p.base) || !parse_integer(t[4], p.cmbn))))
        throw_bad_input(where() + ": surface line needs '" + rec + " n shape base cmbn emit name' (F 3a)");
      if (shape != "R" && shape != "Q" && shape != "T")
        throw_bad_input(where() + ": surface shape " + in_quotes(shape) +
                        " is not R (rectangle), Q (quadrilateral) or T (triangle)");
      p.shape = shape[0];
      if (t.size() >= 6) p.emit = std::string(t[5]);
      if (t.size() > 6) p.name = std::string(t[6]);
      p.needed = numbers_of_shape(p.shape);
      pending = std::move(p);
    } else if (rec == "S" || rec == "O" || rec == "N" || rec == "M") {
      long n = 0, v[4], base = 0, cmbn = 0;
      double emit = 0.0;
      if (t.size() < 9 || !parse_integer(t[1], n) || !parse_integer(t[2], v[0]) || !parse_integer(t[3], v[1]) ||
          !parse_integer(t[4], v[2]) || !parse_integer(t[5], v[3]) || !parse_integer(t[6], base) ||
          !parse_integer(t[7], cmbn) || !parse_number(t[8], emit))
        throw_bad_input(where() + ": surface line needs '" + rec + " n v1 v2 v3 v4 base cmbn emit name'");
      const int count = v[3] == 0 ? 3 : 4;
      std::vector<int> vertices;
      for (int k = 0; k < count; ++k) {
        if (v[k] < 1 || v[k] > static_cast<long>(s.vertices.size()))
          throw_bad_input(where() + ": vertex " + std::to_string(v[k]) + " not defined before this line");
        vertices.push_back(static_cast<int>(v[k] - 1));
      }
      add_surface(where(), rec, n, std::move(vertices), base, cmbn, t[8], t.size() > 9 ? std::string(t[9]) : "");
    } else if (rec == "E" || rec == "END" || rec == "*") {
      ended = true;
    } else {
      throw_bad_input(where() + ": unknown View3D record " + in_quotes(t[0]) +
                      " (expected T, C, F, V, S, O, N, M, E or !)");
    }
  });
  if (pending) pending_error(*pending, "the end of the data");
  if (format == 0) throw_bad_input(at(path) + ": no 'F 3' or 'F 3a' format line");
  s.stats.input_vertices = static_cast<int>(s.vertices.size());
  if (!control.empty()) s.settings["view3d"] = control;
  bool radiating = false;
  for (const Face& f : s.faces) radiating = radiating || !f.obstruction_only;
  if (!s.faces.empty() && !radiating) throw_bad_input(at(path) + ": no S surface (only obstructions)");
  return raw;
}

}  // namespace photometria::scene_detail
