// libFuzzer target: the .json scene loader (parsing, keys, material overrides by material and
// group name, settings, lights) over two fixed meshes in a scratch folder: room.obj (with
// room.mtl: materials "white" and "lamp", groups "walls" and "light") and tri.off.
//
// Input: the scene file's text. photometria::Error is the expected answer to bad input; any
// other exception, a crash, a sanitizer report or a hang is a finding.
#include <cstddef>
#include <cstdint>

#include "fuzz_common.h"
#include "scene/scene.h"
#include "util/error.h"

namespace {

void write_meshes() {
  using photometria::fuzz::write;
  write("room.mtl", "newmtl white\nKd 0.5\nnewmtl lamp\nKd 0.1\nKe 10\n");
  write("room.obj",
        "mtllib room.mtl\n"
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
        "g walls\nusemtl white\nf 1 2 3 4\nf 1 5 6 2\nf 2 6 7 3\nf 3 7 8 4\nf 4 8 5 1\n"
        "g light\nusemtl lamp\nf 5 8 7 6\n");
  write("tri.off", "OFF\n3 1 0\n0 0 0.5\n1 0 0.5\n0 1 0.5\n3 0 1 2\n");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace photometria;
  static const bool once = (write_meshes(), true);
  (void)once;
  const std::string path = fuzz::write("scene.json", std::string_view(reinterpret_cast<const char*>(data), size));
  try {
    const Scene scene = load_scene(path);
    (void)load_warnings(scene.stats);
  } catch (const Error&) {}
  return 0;
}
