// libFuzzer target: the point-query file parser (io/queries.h, `photometria formfactor`).
//
// Input: the query file's text, loaded with load_queries. photometria::Error is the expected
// answer to bad input; any other exception, a crash, a sanitizer report or a hang is a finding.
// Accepted queries must hold what the header promises (unit normal, >= 3 polygon vertices,
// radius > 0, finite values), else the target aborts.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>

#include "fuzz_common.h"
#include "io/queries.h"
#include "util/error.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace photometria;
  const std::string path = fuzz::write("queries.json", std::string_view(reinterpret_cast<const char*>(data), size));
  try {
    for (const PointQuery& q : load_queries(path)) {
      if (!q.point.allFinite() || std::abs(q.normal.norm() - 1.0) > 1e-9) std::abort();
      if (q.kind == PointQuery::Kind::Polygon && q.polygon.size() < 3) std::abort();
      if (q.kind == PointQuery::Kind::Sphere && !(q.radius > 0 && std::isfinite(q.radius))) std::abort();
      if (q.kind == PointQuery::Kind::Distant && !(q.angle_deg >= 0 && q.angle_deg <= 360)) std::abort();
      (void)json_string(q.id);
    }
  } catch (const Error&) {}
  return 0;
}
