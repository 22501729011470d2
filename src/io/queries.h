// Point queries for `photometria formfactor` (docs/usage.md `photometria formfactor`):
//   {"queries": [
//     {"id": "q1", "point": [0,0,0], "normal": [0,0,1], "polygon": [[-1,-1,1], [1,-1,1], ...]},
//     {"id": "q2", "point": [0,0,0], "normal": [0,0,1], "sphere": {"center": [0,0,3], "radius": 1}},
//     {"id": "q3", "point": [0,0,0], "normal": [0,0,1],
//      "distant": {"direction": [0,0,1], "angle_deg": 0.53}}]}
// Coordinates in metres. Each query has exactly one of polygon / sphere / distant. Optional:
// "intensity" (number) in a sphere or distant object and "normalize" (bool, default false) in a
// distant object, to get the irradiance as well (units in kernels/lights.h). The normal and the
// direction need not be unit length (they are normalized); ids must be unique strings.
// Polygon side: with an optional "front_normal" the polygon emits on that side only (0 from its
// back) in either vertex order; without it, it emits towards the receiver, so either vertex
// order gives the same F (the convention of the analytic references, tests/data/refs_public.json).
// The stored polygon is reordered to be
// counter-clockwise seen from its emitting side. Scene faces, unlike queries, take their front
// from the winding (docs/theory.md "Units and conventions").
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "geometry/polygon.h"

namespace photometria {

struct PointQuery {
  enum class Kind { Polygon, Sphere, Distant };
  std::string id;
  Kind kind = Kind::Polygon;
  Vec3 point = Vec3::Zero();        // receiver point, metres
  Vec3 normal = Vec3::UnitZ();      // receiver normal, unit
  Polygon polygon;                  // Kind::Polygon: >= 3 vertices, counter-clockwise from the emitting side
  Vec3 center = Vec3::Zero();       // Kind::Sphere: centre, metres
  double radius = 0.0;              // Kind::Sphere: radius > 0, metres; the point is not inside
  Vec3 direction = Vec3::UnitZ();   // Kind::Distant: unit, toward the light
  double angle_deg = 0.0;           // Kind::Distant: angular diameter in [0, 360] degrees
  std::optional<double> intensity;  // sphere: exitance (W/m²); distant: radiance or normalized
  bool normalize = false;           // Kind::Distant: UsdLux normalization (kernels/distant.h)
};

// Validates the document. Errors (photometria::Error, BadInput) name `file`, the query index and
// its id and the value at fault, e.g. "q.json: query 2 (id \"q2\"): 'radius' must be > 0, got -1".
std::vector<PointQuery> parse_queries(const nlohmann::json& doc, const std::string& file);

// Reads and parses `path`: Io error if it cannot be read, BadInput with the line for bad JSON.
std::vector<PointQuery> load_queries(const std::string& path);

// A double with exactly 17 significant digits (round-trips exactly; trailing zeros kept), as a
// JSON number: "0.13853160599489300", "0.25000000000000000", "1.5000000000000000e-05".
std::string format_double(double value);

// JSON string literal (quoted and escaped) for an id.
std::string json_string(const std::string& text);

}  // namespace photometria
