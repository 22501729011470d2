#include "io/queries.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <set>
#include <sstream>

#include "util/error.h"

namespace photometria {
namespace {

using nlohmann::json;

[[noreturn]] void fail(const std::string& where, const std::string& msg) { throw_bad_input(where + ": " + msg); }

std::string quoted(const std::string& key) { return "'" + key + "'"; }

Vec3 read_vec3(const json& v, const std::string& key, const std::string& where) {
  if (!v.is_array() || v.size() != 3) fail(where, quoted(key) + " must be an array of 3 numbers, got " + v.dump());
  Vec3 out;
  for (int i = 0; i < 3; ++i) {
    if (!v[i].is_number() || !std::isfinite(v[i].get<double>()))
      fail(where, quoted(key) + " must be an array of 3 finite numbers, got " + v.dump());
    out[i] = v[i].get<double>();
  }
  return out;
}

Vec3 read_unit(const json& v, const std::string& key, const std::string& where) {
  const Vec3 d = read_vec3(v, key, where);
  const double len = d.norm();
  if (!(len > 0.0) || !std::isfinite(len)) fail(where, quoted(key) + " must be a non-zero vector, got " + v.dump());
  return d / len;
}

double read_number(const json& obj, const std::string& key, const std::string& where) {
  if (!obj.contains(key)) fail(where, quoted(key) + " is missing");
  const json& v = obj[key];
  if (!v.is_number() || !std::isfinite(v.get<double>()))
    fail(where, quoted(key) + " must be a finite number, got " + v.dump());
  return v.get<double>();
}

const json& require(const json& obj, const std::string& key, const std::string& where) {
  if (!obj.contains(key)) fail(where, quoted(key) + " is missing");
  return obj[key];
}

void check_keys(const json& obj, const std::string& where, std::initializer_list<const char*> allowed) {
  for (const auto& item : obj.items()) {
    bool ok = false;
    for (const char* a : allowed) ok = ok || item.key() == a;
    if (!ok) fail(where, "unknown key " + quoted(item.key()));
  }
}

void read_intensity(const json& obj, const std::string& where, PointQuery& q) {
  if (!obj.contains("intensity")) return;
  const double i = read_number(obj, "intensity", where);
  if (i < 0.0) fail(where, "'intensity' must be >= 0, got " + obj["intensity"].dump());
  q.intensity = i;
}

PointQuery parse_one(const json& j, size_t index, const std::string& file) {
  std::string where = file + ": query " + std::to_string(index + 1);
  if (!j.is_object()) fail(where, "must be an object, got " + j.dump());
  PointQuery q;
  if (!j.contains("id") || !j["id"].is_string() || j["id"].get<std::string>().empty())
    fail(where, "'id' must be a non-empty string");
  q.id = j["id"].get<std::string>();
  where += " (id " + json_string(q.id) + ")";
  check_keys(j, where, {"id", "point", "normal", "polygon", "front_normal", "sphere", "distant"});
  q.point = read_vec3(require(j, "point", where), "point", where);
  q.normal = read_unit(require(j, "normal", where), "normal", where);
  const int kinds = int(j.contains("polygon")) + int(j.contains("sphere")) + int(j.contains("distant"));
  if (kinds != 1) fail(where, "needs exactly one of 'polygon', 'sphere', 'distant'");
  if (j.contains("polygon")) {
    q.kind = PointQuery::Kind::Polygon;
    const json& p = j["polygon"];
    if (!p.is_array() || p.size() < 3)
      fail(where, "'polygon' must be an array of at least 3 vertices, got " + p.dump());
    for (size_t k = 0; k < p.size(); ++k)
      q.polygon.push_back(read_vec3(p[k], "polygon[" + std::to_string(k) + "]", where));
    // Which side emits: the optional front_normal, else the side the receiver is on, so that
    // either vertex order gives the same F (the convention of tests/data/refs_public.json).
    const Vec3 winding = newell_vector(q.polygon);
    const Vec3 front = j.contains("front_normal") ? read_unit(j["front_normal"], "front_normal", where)
                                                  : Vec3(q.point - polygon_centroid(q.polygon));
    if (winding.dot(front) < 0.0) std::reverse(q.polygon.begin(), q.polygon.end());
  } else if (j.contains("front_normal")) {
    fail(where, "'front_normal' belongs to a polygon query");
  } else if (j.contains("sphere")) {
    q.kind = PointQuery::Kind::Sphere;
    const json& s = j["sphere"];
    if (!s.is_object()) fail(where, "'sphere' must be an object {center, radius}");
    check_keys(s, where + ": sphere", {"center", "radius", "intensity"});
    q.center = read_vec3(require(s, "center", where), "center", where);
    q.radius = read_number(s, "radius", where);
    if (!(q.radius > 0.0)) fail(where, "'radius' must be > 0, got " + s["radius"].dump());
    if ((q.center - q.point).norm() < q.radius) fail(where, "the point lies inside the sphere");
    read_intensity(s, where, q);
  } else {
    q.kind = PointQuery::Kind::Distant;
    const json& d = j["distant"];
    if (!d.is_object()) fail(where, "'distant' must be an object {direction, angle_deg}");
    check_keys(d, where + ": distant", {"direction", "angle_deg", "intensity", "normalize"});
    q.direction = read_unit(require(d, "direction", where), "direction", where);
    q.angle_deg = read_number(d, "angle_deg", where);
    if (q.angle_deg < 0.0 || q.angle_deg > 360.0)
      fail(where, "'angle_deg' must be in [0, 360], got " + d["angle_deg"].dump());
    read_intensity(d, where, q);
    if (d.contains("normalize")) {
      if (!d["normalize"].is_boolean()) fail(where, "'normalize' must be true or false, got " + d["normalize"].dump());
      q.normalize = d["normalize"].get<bool>();
    }
  }
  return q;
}

}  // namespace

std::vector<PointQuery> parse_queries(const json& doc, const std::string& file) {
  if (!doc.is_object() || !doc.contains("queries") || !doc["queries"].is_array())
    throw_bad_input(file + ": expected {\"queries\": [...]}");
  std::vector<PointQuery> out;
  std::set<std::string> ids;
  for (size_t i = 0; i < doc["queries"].size(); ++i) {
    out.push_back(parse_one(doc["queries"][i], i, file));
    if (!ids.insert(out.back().id).second)
      throw_bad_input(file + ": query " + std::to_string(i + 1) + " (id " + json_string(out.back().id) +
                      "): duplicate id");
  }
  if (out.empty()) throw_bad_input(file + ": 'queries' is empty");
  return out;
}

std::vector<PointQuery> load_queries(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw_io(path + ": cannot open for reading");
  std::stringstream buffer;
  buffer << in.rdbuf();
  const std::string text = buffer.str();
  json doc;
  try {
    doc = json::parse(text);
  } catch (const json::parse_error& e) {
    // Line of the byte where the parser stopped.
    const size_t stop = std::min(text.size(), e.byte > 0 ? size_t(e.byte - 1) : size_t(0));
    long line = 1;
    for (size_t k = 0; k < stop; ++k) line += text[k] == '\n';
    std::string what = e.what();
    const size_t colon = what.rfind(": ");
    throw_bad_input(at(path, line) + ": invalid JSON: " + (colon == std::string::npos ? what : what.substr(colon + 2)));
  } catch (const json::exception& e) {
    // e.g. out_of_range 406 for a number beyond double (1e999): name the file and the reason.
    std::string what = e.what();
    const size_t colon = what.rfind("] ");
    throw_bad_input(path + ": invalid JSON: " + (colon == std::string::npos ? what : what.substr(colon + 2)));
  }
  return parse_queries(doc, path);
}

std::string format_double(double value) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%#.17g", value);  // exactly 17 significant digits, zeros kept
  return buf;
}

std::string json_string(const std::string& text) { return json(text).dump(); }

}  // namespace photometria
