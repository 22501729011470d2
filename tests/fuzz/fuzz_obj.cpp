// libFuzzer target: the OBJ + MTL loader (scan_obj / scan_mtl, tinyobjloader, cleaning).
//
// Input: OBJ text, optionally followed by a line "#---mtl---" and MTL text. They are written to
// fuzz.obj and fuzz.mtl in a scratch folder and loaded with load_scene; an `mtllib fuzz.mtl`
// line in the OBJ part (the seeds have one) brings the MTL in. photometria::Error is the
// expected answer to bad input; any other exception, a crash, a sanitizer report or a hang is
// a finding.
#include <cstddef>
#include <cstdint>

#include "fuzz_common.h"
#include "scene/scene.h"
#include "util/error.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace photometria;
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  constexpr std::string_view kMarker = "#---mtl---";
  const size_t split = input.find(kMarker);
  fuzz::write("fuzz.mtl", split == std::string_view::npos ? std::string_view() : input.substr(split + kMarker.size()));
  const std::string obj = fuzz::write("fuzz.obj", input.substr(0, split));
  try {
    LoadOptions options;
    options.default_emission = Rgb::Constant(1.0);
    const Scene scene = load_scene(obj, options);
    (void)load_warnings(scene.stats);
  } catch (const Error&) {}
  return 0;
}
