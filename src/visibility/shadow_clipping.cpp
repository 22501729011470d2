// Exact visibility: clip the source against shadow volumes in 3-D (Nishita & Nakamae 1985);
// see shadow_clipping.h. The shadow volume of an occluder or a convex solid seen from a point, their
// subtraction from convex pieces, and exact_visible_form_factor (visibility.h).
#include "visibility/shadow_clipping.h"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "kernels/lambert.h"
#include "visibility/visibility.h"
#include "visibility/visibility_internal.h"

namespace photometria {

namespace visibility_detail {
namespace {

// Both parts at once: inside as clip_keep(in, s, inside) (point_visibility.cpp), outside the
// same for −s (the crossing si / (si − sj) is the same number with both signs flipped).
void split_keep(const Polygon& in, const std::vector<double>& s, Polygon& inside, Polygon& outside) {
  inside.clear();
  outside.clear();
  const size_t n = in.size();
  for (size_t i = 0; i < n; ++i) {
    const size_t j = i + 1 == n ? 0 : i + 1;
    const double si = s[i], sj = s[j];
    if (si >= 0) inside.push_back(in[i]);
    if (si <= 0) outside.push_back(in[i]);
    if ((si > 0 && sj < 0) || (si < 0 && sj > 0)) {
      const Vec3 y = in[i] + (si / (si - sj)) * (in[j] - in[i]);
      inside.push_back(y);
      outside.push_back(y);
    }
  }
  if (inside.size() < 3) inside.clear();
  if (outside.size() < 3) outside.clear();
}

}  // namespace

// The shadow volume of a convex solid seen from x (shadow_clipping.h).
bool solid_volume(const ShaftCuller& culler, int solid, const Vec3& x, std::vector<Plane>& volume, double& reach) {
  const std::vector<int>& faces = culler.solid_occluders(solid);
  const double tol = culler.tolerance();
  thread_local std::vector<int> front;
  front.clear();
  Vec3 centre = Vec3::Zero();
  int corners = 0;
  reach = 0.0;
  for (int g : faces) {
    const Polygon& w = culler.occluder_polygons()[size_t(g)];
    if (culler.occluder_normals()[size_t(g)].dot(x - w[0]) > tol) front.push_back(g);
    for (const Vec3& v : w) {
      centre += v - x;
      ++corners;
      reach = std::max(reach, (v - x).norm());
    }
  }
  if (front.empty() || corners == 0) return false;
  centre /= corners;
  auto is_front = [&](int g) { return std::find(front.begin(), front.end(), g) != front.end(); };
  for (int g : front) {
    const Polygon& w = culler.occluder_polygons()[size_t(g)];
    const Vec3& n = culler.occluder_normals()[size_t(g)];
    volume.push_back({-n, -n.dot(w[0] - x)});  // behind the face, away from x
    for (size_t k = 0; k < w.size(); ++k) {
      const int across = culler.neighbour(g, static_cast<int>(k));
      if (across >= 0 && is_front(across)) continue;  // an inner edge of the front surface
      Vec3 m = (w[k] - x).cross(w[(k + 1) % w.size()] - x);
      const double len = m.norm();
      if (!(len > 0.0)) continue;
      m /= len;
      if (m.dot(centre) < 0) m = -m;
      volume.push_back({m, 0.0});
    }
  }
  return true;
}

// Subtracts the shadow volumes of faces[which] seen from x from `pieces` (shadow_clipping.h).
bool subtract_shadows(double scale, const std::vector<Polygon>& faces, const std::vector<int>& which,
                      const std::vector<Vec3>* normals, PiecePool& pieces, PiecePool* shadows,
                      const ShaftCuller* solids, ShadowVolumes& volumes) {
  thread_local PiecePool next;
  thread_local std::vector<double> s;
  thread_local Polygon inside, outside, cur;
  thread_local std::vector<int> done_solids;
  bool cut = false;
  // Nearest occluders first: their shadows are the widest, and what they hide is not cut again
  // by the others.
  thread_local std::vector<std::pair<double, int>> order;
  order.clear();
  for (int f : which) order.emplace_back(volumes.nearest(faces, f), f);
  std::sort(order.begin(), order.end());
  done_solids.clear();
  for (const auto& [distance, f] : order) {
    if (pieces.empty()) break;
    const int solid = solids ? solids->solid_of(f) : -1;
    if (solid >= 0 && std::find(done_solids.begin(), done_solids.end(), solid) != done_solids.end()) continue;
    const ShadowVolumes::Volume* v = solid >= 0 ? &volumes.solid(*solids, solid) : nullptr;
    if (v && v->casts) {
      done_solids.push_back(solid);
    } else {
      v = &volumes.face(faces, normals, f);
      if (!v->casts || v->edge_on <= 1e-12 * std::max(scale, v->reach)) continue;  // seen edge-on: blocks nothing
    }
    // Classification tolerance: 1e-12 × the configuration's size.
    const double eps = 1e-12 * std::max(scale, v->reach);
    const std::vector<Plane>& volume = v->planes;
    // Whether polygon q lies on or outside plane p of the volume (then the volume hides none of it).
    auto outside_of = [&](const Polygon& q, const Plane& p) {
      bool all_out = true;
      for (const Vec3& y : q) all_out = all_out && p.m.dot(y) - p.d <= eps;
      return all_out;
    };
    // Every piece outside one plane of the volume (the usual case for the back faces of a box
    // and for occluders behind the source): it hides none of them.
    bool separated = false;
    for (size_t p = 0; p < volume.size() && !separated; ++p) {
      bool all_out = true;
      for (size_t pi = 0; pi < pieces.size() && all_out; ++pi) all_out = outside_of(pieces[pi], volume[p]);
      separated = all_out;
    }
    if (separated) continue;
    // Subtract the volume from every piece: the part outside plane 1, then the part inside 1
    // but outside 2, ... are visible; what lies inside every plane is in the shadow.
    next.clear();
    for (size_t pi = 0; pi < pieces.size(); ++pi) {
      // Outside one plane of the volume: not in the shadow; kept whole, with no split.
      if (std::any_of(volume.begin(), volume.end(), [&](const Plane& p) { return outside_of(pieces[pi], p); })) {
        next.push().swap(pieces[pi]);
        continue;
      }
      // The piece itself until a plane cuts it, then what is left inside (in `cur`). Pieces are
      // moved, not copied, into `next`: `pieces` is replaced by it.
      Polygon* rest = &pieces[pi];
      bool shadowed = true, split = false;
      const size_t first_part = next.size();
      for (const Plane& p : volume) {
        s.resize(rest->size());
        bool all_out = true, all_in = true;
        for (size_t k = 0; k < rest->size(); ++k) {
          s[k] = p.m.dot((*rest)[k]) - p.d;
          all_out = all_out && s[k] <= eps;
          all_in = all_in && s[k] >= -eps;
        }
        if (all_out) {  // on or outside this plane (a coplanar piece counts as outside): visible
          next.push().swap(*rest);
          shadowed = false;
          break;
        }
        if (all_in) continue;
        split = true;
        split_keep(*rest, s, inside, outside);
        if (!outside.empty()) next.push().swap(outside);
        cur.swap(inside);
        rest = &cur;
        if (cur.empty()) {
          shadowed = false;
          break;
        }
      }
      if (shadowed) {
        cut = true;
        if (shadows) shadows->push().swap(*rest);
      } else if (split) {
        // Nothing of it was in the shadow after all (a later plane had all of the part inside the
        // earlier ones outside it): keep the piece whole rather than the parts the splits made.
        next.truncate(first_part);
        next.push().swap(pieces[pi]);
      }
    }
    swap(pieces, next);
  }
  return cut;
}

}  // namespace visibility_detail

using namespace visibility_detail;

double exact_visible_form_factor(const Receiver& receiver, const Vec3* source, int n,
                                 const std::vector<Polygon>& occluders, const std::vector<int>& which,
                                 const std::vector<Vec3>* normals, const ShaftCuller* solids) {
  const Vec3& x = receiver.point;
  // Work relative to x: every wedge plane then passes through the origin.
  // Per-thread scratch: this runs once per occluded pair, and allocation was a tenth of its cost.
  thread_local PiecePool pieces;
  pieces.clear();
  Polygon& src = pieces.push();
  src.resize(size_t(n));
  double scale = 0.0;
  for (int k = 0; k < n; ++k) {
    src[size_t(k)] = source[k] - x;
    scale = std::max(scale, src[size_t(k)].norm());
  }
  thread_local ShadowVolumes volumes;  // one call per point here
  volumes.start(x);
  if (!subtract_shadows(scale, occluders, which, normals, pieces, nullptr, solids, volumes))
    return lambert_form_factor(receiver, source, n);
  // Lambert's formula is additive over a partition of the source (an integral over directions).
  const Receiver at_origin{Vec3::Zero(), receiver.normal, receiver.approach};
  double f = 0.0;
  for (size_t pi = 0; pi < pieces.size(); ++pi)
    f += lambert_form_factor(at_origin, pieces[pi].data(), static_cast<int>(pieces[pi].size()));
  return std::clamp(f, 0.0, 1.0);
}

}  // namespace photometria
