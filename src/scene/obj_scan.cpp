// The validation pass over OBJ and MTL text. tinyobjloader reads unparsable numbers as 0, turns
// out-of-range face indices into a warning and truncates faces of more than 255 vertices, so the
// text is checked here first and every error names the file, the line and the value.
#include <cmath>

#include "scene/loaders.h"
#include "util/error.h"

namespace photometria::scene_detail {
namespace {

using Tokens = std::vector<std::string_view>;

// tinyobjloader stores a face's vertex count in an unsigned char.
constexpr size_t kMaxFaceVertices = 255;

[[noreturn]] void fail(const std::string& path, long line, const std::string& what) {
  throw_bad_input(at(path, line) + ": " + what);
}

double finite_number(const std::string& path, long line, std::string_view token, const char* what) {
  double x = 0;
  if (!parse_number(token, x)) fail(path, line, std::string("bad ") + what + " " + in_quotes(token));
  if (!std::isfinite(x)) fail(path, line, std::string(what) + " " + in_quotes(token) + " is not a finite number");
  return x;
}

class ObjScanner {
 public:
  explicit ObjScanner(const std::string& path) : path_(path) {}

  void line(long n, std::string_view text) {
    const Tokens t = split_tokens(text);
    if (t.empty()) return;
    if (t[0] == "v") {
      vertex(n, t);
    } else if (t[0] == "vn") {
      normal(n, t);
    } else if (t[0] == "vt") {
      numbers(n, t, 1, 3, "texture coordinate");
      ++texcoords_;
    } else if (t[0] == "f") {
      face(n, t);
    } else if (t[0] == "usemtl") {
      material_ = t.size() > 1 ? std::string(t[1]) : std::string();
    }
  }

  ObjScan result() && { return std::move(out_); }

 private:
  void vertex(long n, const Tokens& t) {
    // x y z, x y z w, x y z r g b or x y z w r g b (colour extensions).
    const size_t count = t.size() - 1;
    if (count != 3 && count != 4 && count != 6 && count != 7)
      fail(path_, n, "vertex needs 3 coordinates, got " + std::to_string(count) + " numbers");
    Vec3 p;
    for (int k = 0; k < 3; ++k) p[k] = finite_number(path_, n, t[k + 1], "vertex coordinate");
    for (size_t k = 4; k < t.size(); ++k) finite_number(path_, n, t[k], "vertex value");
    out_.vertices.push_back(p);
  }

  // A vn becomes a shading normal (Face::corner_normals), so it must have a direction: its
  // length must be positive and finite (a vn of 1e300 components overflows when squared).
  void normal(long n, const Tokens& t) {
    numbers(n, t, 3, 3, "normal value");
    Vec3 v;
    for (int k = 0; k < 3; ++k) v[k] = finite_number(path_, n, t[size_t(k) + 1], "normal value");
    const double length = v.norm();
    if (!(length > 0.0) || !std::isfinite(length)) {
      std::string text = "vn";
      for (size_t k = 1; k < 4; ++k) text.append(" ").append(t[k]);
      fail(path_, n, text + " has no direction (zero or overflowing length)");
    }
    out_.normals.push_back(v / length);
    ++normals_;
  }

  void numbers(long n, const Tokens& t, size_t min, size_t max, const char* what) {
    const size_t count = t.size() - 1;
    if (count < min || count > max)
      fail(path_, n,
           std::string(t[0]) + " needs " + std::to_string(min) + (min == max ? "" : " to " + std::to_string(max)) +
               " numbers, got " + std::to_string(count));
    for (size_t k = 1; k < t.size(); ++k) finite_number(path_, n, t[k], what);
  }

  void face(long n, const Tokens& t) {
    const size_t count = t.size() - 1;
    if (count < 3) fail(path_, n, "f with " + std::to_string(count) + " vertices (a face needs at least 3)");
    if (count > kMaxFaceVertices)
      fail(path_, n, "f with " + std::to_string(count) + " vertices (at most 255 are supported)");
    for (size_t k = 1; k < t.size(); ++k) face_ref(n, t[k]);
    out_.face_material.push_back(material_);
  }

  // "v", "v/vt", "v//vn" or "v/vt/vn"; each index 1-based, or negative = counted from the end.
  void face_ref(long n, std::string_view ref) {
    const size_t s1 = ref.find('/');
    const size_t s2 = s1 == std::string_view::npos ? s1 : ref.find('/', s1 + 1);
    if (s2 != std::string_view::npos && ref.find('/', s2 + 1) != std::string_view::npos)
      fail(path_, n, "bad face vertex " + in_quotes(ref));
    check_index(n, ref, ref.substr(0, s1), static_cast<long>(out_.vertices.size()), "face index", "vertices");
    if (s1 == std::string_view::npos) return;
    const std::string_view vt = ref.substr(s1 + 1, s2 == std::string_view::npos ? s2 : s2 - s1 - 1);
    if (!vt.empty()) check_index(n, ref, vt, texcoords_, "texture coordinate index", "texture coordinates");
    if (s2 != std::string_view::npos) check_index(n, ref, ref.substr(s2 + 1), normals_, "normal index", "normals");
  }

  void check_index(long n, std::string_view ref, std::string_view token, long available, const char* what,
                   const char* things) {
    long i = 0;
    if (!parse_integer(token, i)) fail(path_, n, "bad face vertex " + in_quotes(ref));
    if (i == 0) fail(path_, n, std::string(what) + " 0 is invalid (OBJ indices start at 1)");
    if (i > available || -i > available)
      fail(path_, n,
           std::string(what) + " " + std::to_string(i) + " out of range (" + std::to_string(available) + " " + things +
               " so far)");
  }

  const std::string& path_;
  ObjScan out_;
  long normals_ = 0, texcoords_ = 0;
  std::string material_;
};

std::optional<Rgb> mtl_colour(const std::string& path, long n, const Tokens& t) {
  const std::string key(t[0]);
  if (t.size() != 2 && t.size() != 4) fail(path, n, key + " needs 1 or 3 numbers, got " + std::to_string(t.size() - 1));
  const std::string what = key + " value";
  Rgb c;
  for (int k = 0; k < 3; ++k) c[k] = finite_number(path, n, t[t.size() == 2 ? 1 : k + 1], what.c_str());
  return c;  // one number means grey (MTL specification)
}

}  // namespace

ObjScan scan_obj(const std::string& path, std::string_view text) {
  ObjScanner scanner(path);
  for_each_line(text, [&](long n, std::string_view line) { scanner.line(n, line); });
  return std::move(scanner).result();
}

std::vector<MtlEntry> scan_mtl(const std::string& path, std::string_view text) {
  std::vector<MtlEntry> entries;
  for_each_line(text, [&](long n, std::string_view line) {
    const Tokens t = split_tokens(line);
    if (t.empty()) return;
    if (t[0] == "newmtl") {
      // tinyobjloader takes the rest of the line as the name.
      const size_t from = line.find("newmtl") + 6;
      const size_t first = line.find_first_not_of(" \t", from);
      const size_t last = line.find_last_not_of(" \t");
      entries.push_back({first == std::string_view::npos ? "" : std::string(line.substr(first, last + 1 - first)), n,
                         std::nullopt, std::nullopt});
    } else if ((t[0] == "Kd" || t[0] == "Ke") && !entries.empty()) {
      (t[0] == "Kd" ? entries.back().kd : entries.back().ke) = mtl_colour(path, n, t);
    }
  });
  return entries;
}

}  // namespace photometria::scene_detail
