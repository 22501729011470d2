// The material list after loading: only materials that faces use, each physically possible.
#include <cmath>

#include "scene/loaders.h"
#include "util/error.h"

namespace photometria::scene_detail {

void drop_unused_materials(RawScene& raw) {
  Scene& s = raw.scene;
  std::vector<int> index(s.materials.size(), -1);
  for (const Face& f : s.faces) index[static_cast<size_t>(f.material)] = 0;
  std::vector<Material> kept;
  std::vector<std::string> origin;
  for (size_t i = 0; i < s.materials.size(); ++i)
    if (index[i] == 0) {
      index[i] = static_cast<int>(kept.size());
      kept.push_back(s.materials[i]);
      origin.push_back(raw.material_origin[i]);
    }
  for (Face& f : s.faces) f.material = index[static_cast<size_t>(f.material)];
  s.materials = std::move(kept);
  raw.material_origin = std::move(origin);
}

void check_materials(const RawScene& raw) {
  const auto& materials = raw.scene.materials;
  for (size_t i = 0; i < materials.size(); ++i) {
    const Material& m = materials[i];
    const std::string where = raw.material_origin[i] + ": material " + in_quotes(m.name) + ": ";
    for (int c = 0; c < 3; ++c) {
      const double rho = m.reflectance[c], e = m.emission[c];
      // Written so that NaN fails too. ρ >= 1 would make the radiosity system diverge.
      if (!(rho >= 0 && rho < 1))
        throw_bad_input(where + "reflectance " + format_number(rho) + " (channel " + std::to_string(c) +
                        ") must be in [0, 1)");
      if (!(std::isfinite(e) && e >= 0))
        throw_bad_input(where + "emission " + format_number(e) + " (channel " + std::to_string(c) +
                        ") must be finite and >= 0");
    }
  }
}

}  // namespace photometria::scene_detail
