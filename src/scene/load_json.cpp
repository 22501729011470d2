// .json scene files: meshes (paths relative to the scene file), material overrides by material
// or group name, settings and analytic lights (kept in settings["lights"] for later stages).
//
//   {"meshes": [{"file": "room.obj", "reflectance": [r, g, b], "emission": [r, g, b]}],
//    "materials": {"<material or group name>": {"reflectance": 0.5, "emission": [1, 1, 1]}},
//    "settings": {...}, "lights": [...]}
#include <algorithm>
#include <filesystem>
#include <map>

#include "scene/loaders.h"
#include "util/error.h"

namespace photometria::scene_detail {
namespace {

using nlohmann::json;

// "[json.exception.parse_error.101] parse error at line 3, column 5: syntax error ..." -> the
// part after the position, which we report as file:line ourselves.
std::string parse_reason(const std::string& what) {
  const size_t column = what.find("column ");
  const size_t colon = what.find(": ", column == std::string::npos ? 0 : column);
  return colon == std::string::npos ? what : what.substr(colon + 2);
}

json parse_scene(const std::string& path, const std::string& text) {
  try {
    return json::parse(text, nullptr, /*allow_exceptions=*/true, /*ignore_comments=*/true);
  } catch (const json::parse_error& e) {
    // e.byte is the 1-based position of the last character read.
    const size_t before = std::min(e.byte == 0 ? 0 : e.byte - 1, text.size());
    const long line = 1 + std::count(text.begin(), text.begin() + static_cast<long>(before), '\n');
    throw_bad_input(at(path, line) + ": " + parse_reason(e.what()));
  } catch (const json::out_of_range& e) {
    // "number overflow parsing '1e999'": a number too large for a double (it would be ±inf).
    const std::string what = e.what();
    const size_t q1 = what.find('\''), q2 = q1 == std::string::npos ? q1 : what.find('\'', q1 + 1);
    const std::string number = q2 == std::string::npos ? std::string() : what.substr(q1 + 1, q2 - q1 - 1);
    const size_t pos = number.empty() ? std::string::npos : text.find(number);
    const long line =
        pos == std::string::npos ? 0 : 1 + std::count(text.begin(), text.begin() + static_cast<long>(pos), '\n');
    throw_bad_input(at(path, line) + ": number " + in_quotes(number) +
                    " is not a finite number (too large for a double)");
  }
}

void check_keys(const std::string& path, const json& object, const std::string& where,
                const std::vector<std::string>& allowed) {
  for (const auto& item : object.items()) {
    if (std::find(allowed.begin(), allowed.end(), item.key()) != allowed.end()) continue;
    std::string list;
    for (const std::string& a : allowed) list += (list.empty() ? "" : ", ") + a;
    throw_bad_input(at(path) + ": unknown key " + in_quotes(item.key()) + (where.empty() ? "" : " in " + where) +
                    " (expected " + list + ")");
  }
}

// The JSON text of a value for a message, shortened.
std::string excerpt(const json& v) {
  std::string text = v.dump();
  return text.size() > 40 ? text.substr(0, 37) + "..." : text;
}

// A number that overflows a double (1e999) parses as ±inf: refused here, naming the key.
Rgb finite(const std::string& path, const Rgb& c, const json& v, const std::string& where) {
  if (!c.isFinite().all()) throw_bad_input(at(path) + ": " + where + " is not a finite number (" + excerpt(v) + ")");
  return c;
}

Rgb colour(const std::string& path, const json& v, const std::string& where) {
  if (v.is_number()) return finite(path, Rgb::Constant(v.get<double>()), v, where);
  if (v.is_array() && v.size() == 3 && std::all_of(v.begin(), v.end(), [](const json& x) { return x.is_number(); }))
    return finite(path, Rgb(v[0].get<double>(), v[1].get<double>(), v[2].get<double>()), v, where);
  std::string text = v.dump();
  if (text.size() > 40) text = text.substr(0, 37) + "...";
  throw_bad_input(at(path) + ": " + where + " must be a number or [r, g, b], got " + text);
}

std::string resolve(const std::string& scene_path, const std::string& file) {
  const std::filesystem::path p(file);
  return p.is_absolute() ? file : (std::filesystem::path(scene_path).parent_path() / p).string();
}

void add_meshes(RawScene& raw, const json& meshes, const std::string& path, const LoadOptions& options) {
  if (!meshes.is_array() || meshes.empty())
    throw_bad_input(at(path) + ": 'meshes' must be a non-empty array of {\"file\": ...}");
  for (size_t i = 0; i < meshes.size(); ++i) {
    const json& m = meshes[i];
    const std::string where = "meshes[" + std::to_string(i) + "]";
    if (!m.is_object()) throw_bad_input(at(path) + ": " + where + " must be an object with a \"file\"");
    check_keys(path, m, where, {"file", "reflectance", "emission"});
    if (!m.contains("file") || !m["file"].is_string())
      throw_bad_input(at(path) + ": " + where + ".file must be the name of a mesh file");
    LoadOptions mesh_options = options;  // the entry's defaults for faces without a material
    if (m.contains("reflectance"))
      mesh_options.default_reflectance = colour(path, m["reflectance"], where + ".reflectance");
    if (m.contains("emission")) mesh_options.default_emission = colour(path, m["emission"], where + ".emission");
    const std::string file = resolve(path, m["file"].get<std::string>());
    if (lower_extension(file) == ".json")
      throw_bad_input(at(path) + ": " + where + ".file " + in_quotes(file) + " is a scene file, not a mesh");
    try {
      append_scene(raw, read_mesh_file(file, mesh_options));
    } catch (const Error& e) {
      if (e.kind() != ErrorKind::Io) throw;
      throw Error(e.kind(), std::string(e.what()) + " (" + where + " of " + path + ")");
    }
  }
}

struct Override {
  std::optional<Rgb> reflectance, emission;
  std::string origin;
  void apply(Material& m) const {
    if (reflectance) m.reflectance = *reflectance;
    if (emission) m.emission = *emission;
  }
};

Override read_override(const std::string& path, const std::string& name, const json& o) {
  const std::string where = "materials." + name;
  if (!o.is_object()) throw_bad_input(at(path) + ": " + where + " must be an object");
  check_keys(path, o, where, {"reflectance", "emission"});
  Override result;
  result.origin = path;
  if (o.contains("reflectance")) result.reflectance = colour(path, o["reflectance"], where + ".reflectance");
  if (o.contains("emission")) result.emission = colour(path, o["emission"], where + ".emission");
  return result;
}

bool override_material(RawScene& raw, const std::string& name, const Override& o) {
  bool found = false;
  for (size_t i = 0; i < raw.scene.materials.size(); ++i) {
    if (raw.scene.materials[i].name != name) continue;
    o.apply(raw.scene.materials[i]);
    raw.material_origin[i] = o.origin;
    found = true;
  }
  return found;
}

// Faces of the group get a material named after the group: a copy of their own material with
// the override applied (one per distinct original material, so other values are kept).
bool override_group(RawScene& raw, const std::string& name, const Override& o) {
  Scene& s = raw.scene;
  const auto g = std::find(s.groups.begin(), s.groups.end(), name);
  if (g == s.groups.end()) return false;
  const int group = static_cast<int>(g - s.groups.begin());
  std::map<int, int> derived;  // original material -> the group's version of it
  for (Face& f : s.faces) {
    // A material of the same name was overridden in the first pass already.
    if (f.group != group || s.materials[static_cast<size_t>(f.material)].name == name) continue;
    auto it = derived.find(f.material);
    if (it == derived.end()) {
      Material m = s.materials[static_cast<size_t>(f.material)];
      m.name = name;
      o.apply(m);
      it = derived.emplace(f.material, add_material(raw, m, o.origin)).first;
    }
    f.material = it->second;
  }
  return true;
}

// Material names first, then group names, so that a group's override wins for its faces.
void apply_overrides(RawScene& raw, const json& materials, const std::string& path) {
  if (!materials.is_object()) throw_bad_input(at(path) + ": 'materials' must be an object of name: {...}");
  std::map<std::string, bool> used;
  for (const auto& item : materials.items())
    used[item.key()] = override_material(raw, item.key(), read_override(path, item.key(), item.value()));
  for (const auto& item : materials.items())
    used[item.key()] |= override_group(raw, item.key(), read_override(path, item.key(), item.value()));
  for (const auto& [name, found] : used)
    if (!found)
      throw_bad_input(at(path) + ": materials: " + in_quotes(name) + " is neither a material nor a group name");
}

void copy_settings(Scene& scene, const json& j, const std::string& path) {
  if (j.contains("settings")) {
    if (!j["settings"].is_object()) throw_bad_input(at(path) + ": 'settings' must be an object");
    scene.settings = j["settings"];
  }
  if (j.contains("lights")) {
    if (!j["lights"].is_array()) throw_bad_input(at(path) + ": 'lights' must be an array");
    if (scene.settings.contains("lights"))
      throw_bad_input(at(path) + ": 'lights' given both at the top and in 'settings'");
    scene.settings["lights"] = j["lights"];
  }
}

}  // namespace

RawScene read_json_scene(const std::string& path, const LoadOptions& options) {
  const std::string text = read_file_text(path);
  const json j = parse_scene(path, text);
  if (!j.is_object()) throw_bad_input(at(path) + ": a scene file must be a JSON object with \"meshes\"");
  check_keys(path, j, "", {"meshes", "materials", "settings", "lights"});
  if (!j.contains("meshes")) throw_bad_input(at(path) + ": no \"meshes\"");
  RawScene raw;
  add_meshes(raw, j["meshes"], path, options);
  if (j.contains("materials")) apply_overrides(raw, j["materials"], path);
  copy_settings(raw.scene, j, path);
  return raw;
}

}  // namespace photometria::scene_detail
