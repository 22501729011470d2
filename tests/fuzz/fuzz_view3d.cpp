// libFuzzer target: the View3D input loader (.vs3: T, C, F, V, S, O, E lines; scene/load_view3d).
//
// Input: the text of a .vs3 file, written to fuzz.vs3 in a scratch folder and loaded with
// load_scene. photometria::Error is the expected answer to bad input; any other exception, a
// crash, a sanitizer report or a hang is a finding.
#include <cstddef>
#include <cstdint>

#include "fuzz_common.h"
#include "scene/scene.h"
#include "util/error.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace photometria;
  const std::string path = fuzz::write("fuzz.vs3", std::string_view(reinterpret_cast<const char*>(data), size));
  try {
    const Scene scene = load_scene(path, LoadOptions{});
    (void)load_warnings(scene.stats);
  } catch (const Error&) {}
  return 0;
}
