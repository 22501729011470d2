// Exact form factors between axis-aligned rectangles: Howell's catalog C-11 / C-14 superposed
// as in Ehlert & Smith, J. Thermophysics Heat Transfer 7(1), 1993, eqs. 3–6 (see the header).
#include "formfactors/aligned_rectangles.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <tuple>
#include <unordered_map>

namespace photometria {
namespace {

using ld = long double;
constexpr double kEps = std::numeric_limits<double>::epsilon();

// Corner function of parallel rectangles a distance z > 0 apart (x, y >= 0: Gp is even in both).
ld gp(ld x, ld y, ld z) {
  const ld a = std::sqrt(y * y + z * z), b = std::sqrt(x * x + z * z);
  return x * a * std::atan(x / a) + y * b * std::atan(y / b) - z * z / 2 * std::log(x * x + y * y + z * z);
}

// Corner function of perpendicular rectangles; x along the common axis (>= 0: Gq is even in
// x), y and e the distances from the common line.
ld gq(ld x, ld y, ld e) {
  const ld c = y * y + e * e, r = x * x + c;
  ld t = 0;
  if (c > 0) {
    const ld sc = std::sqrt(c);
    t += x * sc * std::atan(x / sc);
  }
  if (r > 0) t -= 0.25L * (c - x * x) * std::log(r);
  return t;
}

// A long double as an unevaluated sum hi + lo of two doubles (exact: 64 bits fit in 53 + 53).
inline void split(ld x, double* out) {
  out[0] = static_cast<double>(x);
  out[1] = static_cast<double>(x - out[0]);
}

// The superposed sums of Ehlert & Smith 1993 eqs. 3–6 (header), per (i, k) the inner sum over
// (j, l) split into hi + lo doubles for combine(): parallel planes a distance z apart, P's extents
// px, py and Q's qx, qy along the two in-plane axes (low, high)...
void parallel_inner(const ld px[2], const ld py[2], const ld qx[2], const ld qy[2], ld z, double inner[2][2][2]) {
  ld y[2][2];
  for (int j = 0; j < 2; ++j)
    for (int l = 0; l < 2; ++l) y[j][l] = std::fabs(py[j] - qy[l]);
  for (int i = 0; i < 2; ++i)
    for (int k = 0; k < 2; ++k) {
      const ld x = std::fabs(px[i] - qx[k]);
      split((gp(x, y[0][0], z) - gp(x, y[0][1], z)) - (gp(x, y[1][0], z) - gp(x, y[1][1], z)), inner[i][k]);
    }
}
// ... and perpendicular planes: extents px, qx along the common axis, distances y (on P) and e (on
// Q) from the common line, increasing.
void perpendicular_inner(const ld px[2], const ld qx[2], const ld y[2], const ld e[2], double inner[2][2][2]) {
  for (int i = 0; i < 2; ++i)
    for (int k = 0; k < 2; ++k) {
      const ld x = std::fabs(px[i] - qx[k]);
      split((gq(x, y[0], e[0]) - gq(x, y[0], e[1])) - (gq(x, y[1], e[0]) - gq(x, y[1], e[1])), inner[i][k]);
    }
}

// Distinct values of `v` (increasing) and, for each element, the index of its value.
std::vector<ld> distinct(const std::vector<ld>& v, std::vector<int32_t>& id) {
  std::vector<ld> u = v;
  std::sort(u.begin(), u.end());
  u.erase(std::unique(u.begin(), u.end()), u.end());
  id.resize(v.size());
  for (size_t k = 0; k < v.size(); ++k)
    id[k] = static_cast<int32_t>(std::lower_bound(u.begin(), u.end(), v[k]) - u.begin());
  return u;
}

using aligned_rectangles_detail::combine;

int slot_of(int normal_axis, int axis) { return (axis - normal_axis + 3) % 3 - 1; }

}  // namespace

// Per-patch result of the classification, before coordinates are merged.
struct AlignedRectangles::Raw {
  int frame = -1, axis = 0, sign = 1;
  double offset = 0.0;
  double lo[2] = {0, 0}, hi[2] = {0, 0};  // per slot
  int32_t ioff = 0, ilo[2] = {0, 0}, ihi[2] = {0, 0};
};

// Everything a table's build needs beyond the Table itself (freed after the build).
struct AlignedRectangles::Build {
  int table = 0, group = 0;
  std::vector<ld> dx;               // distinct |x − ξ| (outer)
  std::vector<ld> dy;               // parallel: distinct |y − η|
  std::vector<ld> y, e;             // perpendicular: distinct distances of P's and Q's inner coords
  std::vector<int32_t> dy_id;       // parallel: [P coord × Q coord] → dy index
  std::vector<int32_t> y_id, e_id;  // perpendicular: per P / Q inner coord
  ld z = 0;                         // parallel: plane distance
  int32_t nq_inner = 0;
  const std::vector<std::pair<int32_t, int32_t>>* p_intervals = nullptr;
  const std::vector<std::pair<int32_t, int32_t>>* q_intervals = nullptr;
  size_t row = 0;  // stored values per outer index

  // True when two builds have the same argument lists (then they share corner functions).
  static bool same_arguments(const Build& a, const Build& b, bool parallel_a, bool parallel_b) {
    return parallel_a == parallel_b && a.z == b.z && a.dx == b.dx && a.dy == b.dy && a.y == b.y && a.e == b.e;
  }

  // A hash of the argument lists, equal for builds with the same_arguments.
  static size_t hash_arguments(const Build& b, bool parallel) {
    size_t h = parallel ? 0x9e3779b97f4a7c15ull : 0;
    auto mix = [&](const std::vector<ld>& v) {
      h ^= v.size() + 0x9e3779b97f4a7c15ull + (h << 6) + (h >> 2);
      for (ld x : v) h ^= std::hash<double>()(static_cast<double>(x)) + 0x9e3779b97f4a7c15ull + (h << 6) + (h >> 2);
    };
    mix(b.dx);
    mix(b.dy);
    mix(b.y);
    mix(b.e);
    return h ^ std::hash<double>()(static_cast<double>(b.z));
  }
};

// Corner-function values shared by the plane pairs with the same argument lists (in a cube the
// 12 perpendicular pairs, say): rows over dx, each dy (parallel) or y × e (perpendicular).
struct AlignedRectangles::Group {
  int first = 0;  // a member build, for the argument lists
  size_t row = 0;
  std::shared_ptr<std::vector<ld>> values;
};

// A plane pair that exchanges light, of P.patches × Q.patches pairs (>= 16: worth a table).
struct AlignedRectangles::Candidate {
  int p, q;
  long long pairs;
};

// The constructor runs the steps in order; each leaves its results in the members (or returns
// what only the next steps need).
AlignedRectangles::AlignedRectangles(const PatchMesh& mesh, std::size_t max_table_bytes) {
  const int n = mesh.size();
  rects_.resize(n);
  double scale = 0.0;
  for (const Vec3& p : mesh.points) scale = std::max(scale, p.lpNorm<Eigen::Infinity>());
  scale = std::max(scale, 1e-300);
  const double merge_tol = 1e-12 * scale;

  std::vector<Raw> raw(n);
  classify(mesh, scale, raw);
  merge_coordinates(raw, merge_tol);
  make_planes(raw);
  summary_.frames = static_cast<int>(frames_.size());
  summary_.planes = static_cast<int>(planes_.size());

  std::size_t budget = max_table_bytes;
  const std::vector<Candidate> candidates = exchanging_pairs(max_table_bytes, budget);
  std::vector<Build> builds = plan_tables(candidates, budget);

  const std::vector<Group> groups = share_corner_functions(builds);
  compute_corner_functions(builds, groups);
  compute_interval_sums(builds, groups);
  count_kept(groups);
}

// Charges `bytes` to the table budget (what is left of max_table_bytes) and to table_bytes_, if
// they fit; false (and nothing charged) otherwise.
bool AlignedRectangles::take(std::size_t& budget, std::size_t bytes) {
  if (bytes > budget) return false;
  budget -= bytes;
  table_bytes_ += bytes;
  return true;
}

// 1. Rectangles, grouped by frame: which patches are aligned rectangles, and their frames
// (frames_), found or made as the patches come; raw[i] gets patch i's frame, normal axis, side,
// offset and in-plane extents.
void AlignedRectangles::classify(const PatchMesh& mesh, double scale, std::vector<Raw>& raw) {
  int last = -1;
  for (int i = 0; i < mesh.size(); ++i) {
    const Patch& pa = mesh.patches[i];
    if (pa.corner_count != 4) continue;
    Vec3 c[4];
    for (int k = 0; k < 4; ++k) c[k] = mesh.points[pa.corners[k]];
    const Vec3 e0 = c[1] - c[0], e1 = c[2] - c[1], e2 = c[3] - c[2], e3 = c[0] - c[3];
    const double l0 = e0.norm(), l1 = e1.norm();
    if (!(std::min(l0, l1) > 1e-9 * scale)) continue;
    const double rel = 1e-12 + 16 * kEps * scale / std::min(l0, l1);  // allowed relative deviation
    if (!((e0 + e2).norm() <= rel * l0) || !((e1 + e3).norm() <= rel * l1)) continue;
    const Vec3 u = e0 / l0, v = e1 / l1;
    if (!(std::abs(u.dot(v)) <= rel)) continue;
    const Vec3 w = u.cross(v).normalized();
    if (!((w - pa.normal).norm() <= 4 * rel)) continue;  // counter-clockwise around the normal

    auto match = [&](const Frame& f, int& ku, int& kv) {
      double du[3], dv[3];
      for (int m = 0; m < 3; ++m) {
        du[m] = u.dot(f.axis[m]);
        dv[m] = v.dot(f.axis[m]);
      }
      ku = kv = 0;
      for (int m = 1; m < 3; ++m) {
        if (std::abs(du[m]) > std::abs(du[ku])) ku = m;
        if (std::abs(dv[m]) > std::abs(dv[kv])) kv = m;
      }
      if (ku == kv) return false;
      for (int m = 0; m < 3; ++m)
        if ((m != ku && !(std::abs(du[m]) <= 4 * rel)) || (m != kv && !(std::abs(dv[m]) <= 4 * rel))) return false;
      return true;
    };
    int ku = 0, kv = 0, f = -1;
    if (last >= 0 && match(frames_[last], ku, kv)) f = last;
    for (int g = 0; f < 0 && g < static_cast<int>(frames_.size()); ++g)
      if (g != last && match(frames_[g], ku, kv)) f = g;
    if (f < 0) {
      // New frame from this rectangle's sides: tiny components snapped to zero (so that a
      // world-aligned frame is exact), axes ordered and signed to follow the world axes.
      Vec3 a[3];
      a[0] = u;
      a[1] = (v - v.dot(u) * u).normalized();
      a[2] = a[0].cross(a[1]);
      for (Vec3& x : a) {
        for (int k = 0; k < 3; ++k)
          if (std::abs(x[k]) < 1e-15) x[k] = 0.0;
        x.normalize();
      }
      Frame fr;
      bool used[3] = {false, false, false};
      for (int wax = 0; wax < 3; ++wax) {
        int best = -1;
        for (int k = 0; k < 3; ++k)
          if (!used[k] && (best < 0 || std::abs(a[k][wax]) > std::abs(a[best][wax]))) best = k;
        used[best] = true;
        fr.axis[wax] = a[best][wax] < 0 ? Vec3(-a[best]) : a[best];
      }
      frames_.push_back(std::move(fr));
      f = static_cast<int>(frames_.size()) - 1;
      if (!match(frames_[f], ku, kv)) {
        frames_.pop_back();
        continue;
      }
    }
    last = f;
    Raw& r = raw[i];
    r.frame = f;
    r.axis = 3 - ku - kv;
    const Frame& fr = frames_[f];
    r.sign = pa.normal.dot(fr.axis[r.axis]) > 0 ? 1 : -1;
    double off = 0.0;
    for (int k = 0; k < 4; ++k) off += c[k].dot(fr.axis[r.axis]);
    r.offset = off / 4;
    for (int s = 0; s < 2; ++s) {
      const Vec3& ax = fr.axis[(r.axis + 1 + s) % 3];
      r.lo[s] = r.hi[s] = c[0].dot(ax);
      for (int k = 1; k < 4; ++k) {
        const double x = c[k].dot(ax);
        r.lo[s] = std::min(r.lo[s], x);
        r.hi[s] = std::max(r.hi[s], x);
      }
    }
  }
}

// 2. Coordinates per frame axis (frames_[f].coord), merged when closer than merge_tol; raw's
// coordinates become indices into them (a rectangle collapsed by the merge is dropped).
void AlignedRectangles::merge_coordinates(std::vector<Raw>& raw, double merge_tol) {
  const int nf = static_cast<int>(frames_.size());
  std::vector<std::vector<double>> vals(3 * nf);
  for (const Raw& r : raw) {
    if (r.frame < 0) continue;
    vals[3 * r.frame + r.axis].push_back(r.offset);
    for (int s = 0; s < 2; ++s) {
      auto& v = vals[3 * r.frame + (r.axis + 1 + s) % 3];
      v.push_back(r.lo[s]);
      v.push_back(r.hi[s]);
    }
  }
  std::vector<std::vector<int32_t>> cluster(3 * nf);
  for (int k = 0; k < 3 * nf; ++k) {
    auto& v = vals[k];
    std::sort(v.begin(), v.end());
    auto& out = frames_[k / 3].coord[k % 3];
    cluster[k].resize(v.size());
    for (size_t m = 0; m < v.size(); ++m) {
      if (m == 0 || v[m] - v[m - 1] > merge_tol) out.push_back(v[m]);
      cluster[k][m] = static_cast<int32_t>(out.size()) - 1;
    }
  }
  auto index = [&](int f, int axis, double x) {
    const auto& v = vals[3 * f + axis];
    return cluster[3 * f + axis][std::lower_bound(v.begin(), v.end(), x) - v.begin()];
  };
  for (Raw& r : raw) {
    if (r.frame < 0) continue;
    r.ioff = index(r.frame, r.axis, r.offset);
    for (int s = 0; s < 2; ++s) {
      r.ilo[s] = index(r.frame, (r.axis + 1 + s) % 3, r.lo[s]);
      r.ihi[s] = index(r.frame, (r.axis + 1 + s) % 3, r.hi[s]);
      if (r.ilo[s] == r.ihi[s]) r.frame = -1;  // collapsed by the merge: not a rectangle here
    }
  }
}

// 3. Planes: (frame, normal axis, side, offset), consecutive per frame (planes_); per rectangle
// (rects_) its plane, local coordinate indices and interval ids.
void AlignedRectangles::make_planes(const std::vector<Raw>& raw) {
  const int n = static_cast<int>(raw.size());
  const int nf = static_cast<int>(frames_.size());
  std::map<std::tuple<int, int, int, int32_t>, int> key_to_plane;
  for (const Raw& r : raw)
    if (r.frame >= 0) key_to_plane.emplace(std::make_tuple(r.frame, r.axis, r.sign, r.ioff), 0);
  for (auto& [key, id] : key_to_plane) {
    id = static_cast<int>(planes_.size());
    Plane p;
    std::tie(p.frame, p.axis, p.sign, p.offset) = key;
    planes_.push_back(std::move(p));
  }
  for (int f = 0; f < nf; ++f) frames_[f].first_plane = -1;
  for (int id = 0; id < static_cast<int>(planes_.size()); ++id) {
    Frame& fr = frames_[planes_[id].frame];
    if (fr.first_plane < 0) fr.first_plane = id;
    ++fr.planes;
  }
  for (int i = 0; i < n; ++i) {
    const Raw& r = raw[i];
    if (r.frame < 0) continue;
    const int id = key_to_plane.at(std::make_tuple(r.frame, r.axis, r.sign, r.ioff));
    Plane& p = planes_[id];
    ++p.patches;
    for (int s = 0; s < 2; ++s) {
      p.coords[s].push_back(r.ilo[s]);
      p.coords[s].push_back(r.ihi[s]);
    }
    rects_[i].plane = id;
  }
  for (Plane& p : planes_)
    for (auto& c : p.coords) {
      std::sort(c.begin(), c.end());
      c.erase(std::unique(c.begin(), c.end()), c.end());
    }
  for (int i = 0; i < n; ++i) {
    const Raw& r = raw[i];
    if (r.frame < 0) continue;
    Rect& q = rects_[i];
    Plane& p = planes_[q.plane];
    q.frame = r.frame;
    q.lplane = q.plane - frames_[r.frame].first_plane;
    for (int s = 0; s < 2; ++s) {
      const auto& c = p.coords[s];
      q.l[s][0] = static_cast<int32_t>(std::lower_bound(c.begin(), c.end(), r.ilo[s]) - c.begin());
      q.l[s][1] = static_cast<int32_t>(std::lower_bound(c.begin(), c.end(), r.ihi[s]) - c.begin());
      p.intervals[s].emplace_back(q.l[s][0], q.l[s][1]);
    }
  }
  for (Plane& p : planes_)
    for (auto& iv : p.intervals) {
      std::sort(iv.begin(), iv.end());
      iv.erase(std::unique(iv.begin(), iv.end()), iv.end());
    }
  for (Rect& q : rects_) {
    if (q.frame < 0) continue;
    const Plane& p = planes_[q.plane];
    for (int s = 0; s < 2; ++s) {
      const auto& iv = p.intervals[s];
      q.r[s] = static_cast<int32_t>(std::lower_bound(iv.begin(), iv.end(), std::make_pair(q.l[s][0], q.l[s][1])) -
                                    iv.begin());
    }
    ++summary_.rectangles;
  }
}

// 4. Plane pairs that exchange light; tables for the most used ones, within the budget.
// 4a. Each frame's pair index (dense if it fits), the exchanging pairs marked kDirect in it;
// returns those of at least 16 patch pairs, most pairs first: the candidates for tables.
std::vector<AlignedRectangles::Candidate> AlignedRectangles::exchanging_pairs(std::size_t max_table_bytes,
                                                                              std::size_t& budget) {
  std::vector<Candidate> candidates;
  for (Frame& fr : frames_) {
    const std::size_t np = static_cast<std::size_t>(fr.planes);
    fr.dense = np * np * sizeof(int32_t) <= max_table_bytes / 4 && take(budget, np * np * sizeof(int32_t));
    if (fr.dense) fr.pair_ids.assign(np * np, kNone);
    for (int p = fr.first_plane; p < fr.first_plane + fr.planes; ++p)
      for (int q = p + 1; q < fr.first_plane + fr.planes; ++q) {
        const Plane& P = planes_[p];
        const Plane& Q = planes_[q];
        bool exchange;
        if (P.axis == Q.axis) {
          exchange = P.sign != Q.sign && P.sign * (ld(fr.coord[P.axis][Q.offset]) - ld(fr.coord[P.axis][P.offset])) > 0;
        } else {
          // Some part of P in front of Q's plane and of Q in front of P's.
          const auto& pc = P.coords[slot_of(P.axis, Q.axis)];
          const auto& qc = Q.coords[slot_of(Q.axis, P.axis)];
          const auto& gb = fr.coord[Q.axis];
          const auto& ga = fr.coord[P.axis];
          exchange = (Q.sign > 0 ? gb[pc.back()] > gb[Q.offset] : gb[pc.front()] < gb[Q.offset]) &&
                     (P.sign > 0 ? ga[qc.back()] > ga[P.offset] : ga[qc.front()] < ga[P.offset]);
        }
        if (!exchange) continue;
        ++summary_.plane_pairs_exchanging;
        const std::size_t lp = p - fr.first_plane, lq = q - fr.first_plane;
        if (fr.dense) fr.pair_ids[lp * np + lq] = fr.pair_ids[lq * np + lp] = kDirect;
        const long long pairs = P.patches * Q.patches;
        if (pairs >= 16) candidates.push_back({p, q, pairs});
      }
  }
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const Candidate& a, const Candidate& b) { return a.pairs > b.pairs; });
  return candidates;
}

// 4b. A table (tables_, in the pair index) for each candidate that fits in the budget,
// interval form where it pays, else corner form; returns what their values need (step 5).
std::vector<AlignedRectangles::Build> AlignedRectangles::plan_tables(const std::vector<Candidate>& candidates,
                                                                     std::size_t& budget) {
  std::vector<Build> builds;
  for (const Candidate& c : candidates) {
    const Plane& P = planes_[c.p];
    const Plane& Q = planes_[c.q];
    Frame& fr = frames_[P.frame];
    Table t;
    t.parallel = P.axis == Q.axis;
    if (t.parallel) {
      t.p_outer = t.q_outer = 0;
      t.p_inner = t.q_inner = 1;
    } else {
      const int common = 3 - P.axis - Q.axis;
      t.p_outer = slot_of(P.axis, common);
      t.q_outer = slot_of(Q.axis, common);
      t.p_inner = 1 - t.p_outer;
      t.q_inner = 1 - t.q_outer;
    }
    const auto& po = P.coords[t.p_outer];
    const auto& qo = Q.coords[t.q_outer];
    const auto& pi = P.coords[t.p_inner];
    const auto& qi = Q.coords[t.q_inner];
    const std::size_t outer_bytes = po.size() * qo.size() * sizeof(int32_t);
    if (outer_bytes > budget) continue;
    Build b;
    // Distinct |x − ξ| along the outer axis, from the coordinates in long double.
    {
      const auto& g = fr.coord[t.parallel ? (P.axis + 1) % 3 : 3 - P.axis - Q.axis];
      std::vector<ld> d(po.size() * qo.size());
      for (size_t i = 0; i < po.size(); ++i)
        for (size_t k = 0; k < qo.size(); ++k) d[i * qo.size() + k] = std::fabs(ld(g[po[i]]) - ld(g[qo[k]]));
      b.dx = distinct(d, t.outer);
    }
    t.nq_outer = static_cast<int32_t>(qo.size());
    std::size_t corner_entries, inner_bytes;
    if (t.parallel) {
      const auto& g = fr.coord[(P.axis + 2) % 3];
      std::vector<ld> d(pi.size() * qi.size());
      for (size_t j = 0; j < pi.size(); ++j)
        for (size_t l = 0; l < qi.size(); ++l) d[j * qi.size() + l] = std::fabs(ld(g[pi[j]]) - ld(g[qi[l]]));
      b.dy = distinct(d, b.dy_id);
      b.z = P.sign * (ld(fr.coord[P.axis][Q.offset]) - ld(fr.coord[P.axis][P.offset]));
      b.nq_inner = static_cast<int32_t>(qi.size());
      corner_entries = b.dx.size() * b.dy.size();
      inner_bytes = b.dy_id.size() * sizeof(int32_t);
    } else {
      // Distances from the common line of the coordinates in front of the other plane; the part
      // behind is clipped off, so those map to distance 0 (always present).
      std::vector<ld> d(pi.size() + 1);
      const auto& gb = fr.coord[Q.axis];
      for (size_t j = 0; j < pi.size(); ++j) d[j] = std::max(ld(0), Q.sign * (ld(gb[pi[j]]) - ld(gb[Q.offset])));
      d.back() = 0;
      b.y = distinct(d, b.y_id);
      d.assign(qi.size() + 1, 0);
      const auto& ga = fr.coord[P.axis];
      for (size_t l = 0; l < qi.size(); ++l) d[l] = std::max(ld(0), P.sign * (ld(ga[qi[l]]) - ld(ga[P.offset])));
      d.back() = 0;
      b.e = distinct(d, b.e_id);
      t.flip_p = Q.sign < 0;
      t.flip_q = P.sign < 0;
      corner_entries = b.dx.size() * b.y.size() * b.e.size();
      inner_bytes = (pi.size() + qi.size()) * sizeof(int32_t);
    }
    const std::size_t nrp = P.intervals[t.p_inner].size(), nrq = Q.intervals[t.q_inner].size();
    const std::size_t interval_entries = b.dx.size() * nrp * nrq;
    const std::size_t pairs = static_cast<std::size_t>(c.pairs);
    const std::size_t max_entries = std::numeric_limits<int32_t>::max();  // offsets are int32
    const std::size_t index_bytes = fr.dense ? 0 : 48;                    // a hash-map node otherwise
    if (interval_entries <= std::min(pairs, max_entries) &&
        take(budget, index_bytes + outer_bytes + interval_entries * sizeof(ld))) {
      t.intervals = true;
      t.nr_q = static_cast<int32_t>(nrq);
      b.row = nrp * nrq;
      b.p_intervals = &P.intervals[t.p_inner];
      b.q_intervals = &Q.intervals[t.q_inner];
      ++summary_.tables_interval;
    } else if (corner_entries <= std::min(4 * pairs, max_entries) &&
               take(budget, index_bytes + outer_bytes + inner_bytes + corner_entries * sizeof(ld))) {
      b.row = t.parallel ? b.dy.size() : b.y.size() * b.e.size();
      if (t.parallel) {
        t.inner = b.dy_id;
        t.nq_inner = b.nq_inner;
      } else {
        const int32_t ne = static_cast<int32_t>(b.e.size());
        t.inner.resize(pi.size() + qi.size());
        for (size_t j = 0; j < pi.size(); ++j) t.inner[j] = b.y_id[j] * ne;
        for (size_t l = 0; l < qi.size(); ++l) t.inner[pi.size() + l] = b.e_id[l];
        t.q_base = static_cast<int32_t>(pi.size());
        t.zero_p = b.y_id.back() * ne;  // the appended 0
        t.zero_q = b.e_id.back();
      }
      ++summary_.tables_corner;
    } else {
      continue;
    }
    for (int32_t& o : t.outer) o *= static_cast<int32_t>(b.row);
    if (t.intervals) t.interval_values.resize(2 * b.dx.size() * b.row);
    b.table = static_cast<int>(tables_.size());
    const int32_t id = static_cast<int32_t>(tables_.size());
    const std::size_t lp = c.p - fr.first_plane, lq = c.q - fr.first_plane, np = fr.planes;
    if (fr.dense) fr.pair_ids[lp * np + lq] = fr.pair_ids[lq * np + lp] = id;
    else fr.pair_map.emplace((uint64_t(lp) << 32) | uint64_t(lq), id);
    tables_.push_back(std::move(t));
    builds.push_back(std::move(b));
  }
  return builds;
}

// 5. Values. Builds with identical argument lists share their corner functions: first the
// corner functions of every group, one task per outer row, then the interval sums.
// 5a. The groups of builds with identical argument lists; corner-form tables point to their
// group's values.
std::vector<AlignedRectangles::Group> AlignedRectangles::share_corner_functions(std::vector<Build>& builds) {
  std::vector<Group> groups;
  std::unordered_multimap<size_t, int> by_hash;
  for (size_t k = 0; k < builds.size(); ++k) {
    Build& b = builds[k];
    const bool par = tables_[b.table].parallel;
    const size_t h = Build::hash_arguments(b, par);
    b.group = -1;
    for (auto [it, end] = by_hash.equal_range(h); it != end; ++it) {
      const Build& o = builds[groups[it->second].first];
      if (Build::same_arguments(b, o, par, tables_[o.table].parallel)) {
        b.group = it->second;
        break;
      }
    }
    if (b.group < 0) {
      b.group = static_cast<int>(groups.size());
      Group g;
      g.first = static_cast<int>(k);
      g.row = par ? b.dy.size() : b.y.size() * b.e.size();
      g.values = std::make_shared<std::vector<ld>>(b.dx.size() * g.row);
      groups.push_back(std::move(g));
      by_hash.emplace(h, b.group);
    }
    Table& t = tables_[b.table];
    if (!t.intervals) {
      t.corner_values = groups[b.group].values;
      t.corner = t.corner_values->data();
    }
  }
  return groups;
}

// 5b. The corner functions of every group, one task per outer row (OpenMP).
void AlignedRectangles::compute_corner_functions(const std::vector<Build>& builds, const std::vector<Group>& groups) {
  std::vector<std::pair<int, int32_t>> tasks;
  for (size_t g = 0; g < groups.size(); ++g)
    for (size_t d = 0; d < builds[groups[g].first].dx.size(); ++d)
      tasks.emplace_back(static_cast<int>(g), static_cast<int32_t>(d));
  long long ntasks = static_cast<long long>(tasks.size());
#pragma omp parallel for schedule(dynamic, 1)
  for (long long k = 0; k < ntasks; ++k) {
    const Group& g = groups[tasks[k].first];
    const Build& b = builds[g.first];
    const int32_t d = tasks[k].second;
    const ld x = b.dx[d];
    ld* row = g.values->data() + static_cast<size_t>(d) * g.row;
    if (tables_[b.table].parallel) {
      for (size_t m = 0; m < b.dy.size(); ++m) row[m] = gp(x, b.dy[m], b.z);
    } else {
      const size_t ne = b.e.size();
      for (size_t j = 0; j < b.y.size(); ++j)
        for (size_t l = 0; l < ne; ++l) row[j * ne + l] = gq(x, b.y[j], b.e[l]);
    }
  }
}

// 5c. The interval form's inner sums, one task per outer row (OpenMP).
void AlignedRectangles::compute_interval_sums(const std::vector<Build>& builds, const std::vector<Group>& groups) {
  std::vector<std::pair<int, int32_t>> tasks;
  for (size_t k = 0; k < builds.size(); ++k)
    if (tables_[builds[k].table].intervals)
      for (size_t d = 0; d < builds[k].dx.size(); ++d) tasks.emplace_back(static_cast<int>(k), static_cast<int32_t>(d));
  const long long ntasks = static_cast<long long>(tasks.size());
#pragma omp parallel for schedule(dynamic, 1)
  for (long long k = 0; k < ntasks; ++k) {
    const Build& b = builds[tasks[k].first];
    Table& t = tables_[b.table];
    const Group& g = groups[b.group];
    const int32_t d = tasks[k].second;
    const ld* row = g.values->data() + static_cast<size_t>(d) * g.row;
    const size_t ne = b.e.size();
    // Inner 2 × 2 alternating sum per (P interval, Q interval), as direct() forms it.
    double* out = t.interval_values.data() + 2 * static_cast<size_t>(d) * b.row;
    const auto& ip = *b.p_intervals;
    const auto& iq = *b.q_intervals;
    for (size_t rp = 0; rp < ip.size(); ++rp)
      for (size_t rq = 0; rq < iq.size(); ++rq) {
        size_t i00, i01, i10, i11;
        if (t.parallel) {
          const size_t nq = static_cast<size_t>(b.nq_inner);
          const auto [j0, j1] = ip[rp];
          const auto [l0, l1] = iq[rq];
          i00 = b.dy_id[j0 * nq + l0];
          i01 = b.dy_id[j0 * nq + l1];
          i10 = b.dy_id[j1 * nq + l0];
          i11 = b.dy_id[j1 * nq + l1];
        } else {
          const int32_t jp[2] = {ip[rp].first, ip[rp].second}, lq[2] = {iq[rq].first, iq[rq].second};
          const size_t y0 = b.y_id[jp[t.flip_p]], y1 = b.y_id[jp[1 - t.flip_p]];
          const size_t e0 = b.e_id[lq[t.flip_q]], e1 = b.e_id[lq[1 - t.flip_q]];
          i00 = y0 * ne + e0;
          i01 = y0 * ne + e1;
          i10 = y1 * ne + e0;
          i11 = y1 * ne + e1;
        }
        split((row[i00] - row[i01]) - (row[i10] - row[i11]), out + 2 * (rp * iq.size() + rq));
      }
  }
}

// 5d. What is kept (<= the budget charged above: shared corner functions count once here).
void AlignedRectangles::count_kept(const std::vector<Group>& groups) {
  table_bytes_ = 0;
  summary_.table_entries = 0;
  for (const Frame& fr : frames_) table_bytes_ += fr.pair_ids.size() * sizeof(int32_t) + fr.pair_map.size() * 48;
  for (const Table& t : tables_) {
    table_bytes_ += (t.outer.size() + t.inner.size()) * sizeof(int32_t) + t.interval_values.size() * sizeof(double);
    summary_.table_entries += static_cast<long long>(t.interval_values.size() / 2);
  }
  for (const Group& g : groups)
    if (g.values.use_count() > 1) {  // held by corner-form tables
      table_bytes_ += g.values->size() * sizeof(ld);
      summary_.table_entries += static_cast<long long>(g.values->size());
    }
}

// The corner form: 16 corner functions from the table, the inner sums in long double as in
// direct(), then the outer sum as in the interval form.
double AlignedRectangles::corner_form(const Table& t, const Rect& p, const Rect& q) const {
  const int32_t* om = t.outer.data();
  const int32_t nq = t.nq_outer;
  const int32_t p0 = p.l[t.p_outer][0] * nq, p1 = p.l[t.p_outer][1] * nq;
  const int32_t q0 = q.l[t.q_outer][0], q1 = q.l[t.q_outer][1];
  const int32_t o00 = om[p0 + q0], o01 = om[p0 + q1], o10 = om[p1 + q0], o11 = om[p1 + q1];
  int32_t i00, i01, i10, i11;
  if (t.parallel) {
    const int32_t* im = t.inner.data();
    const int32_t n = t.nq_inner;
    const int32_t j0 = p.l[t.p_inner][0] * n, j1 = p.l[t.p_inner][1] * n;
    const int32_t l0 = q.l[t.q_inner][0], l1 = q.l[t.q_inner][1];
    i00 = im[j0 + l0];
    i01 = im[j0 + l1];
    i10 = im[j1 + l0];
    i11 = im[j1 + l1];
  } else {
    const int32_t* im = t.inner.data();
    const int32_t y0 = im[p.l[t.p_inner][t.flip_p]], y1 = im[p.l[t.p_inner][1 - t.flip_p]];
    if (y1 == t.zero_p) return 0.0;  // P wholly behind Q's plane
    const int32_t e0 = im[t.q_base + q.l[t.q_inner][t.flip_q]], e1 = im[t.q_base + q.l[t.q_inner][1 - t.flip_q]];
    if (e1 == t.zero_q) return 0.0;  // Q wholly behind P's plane
    i00 = y0 + e0;
    i01 = y0 + e1;
    i10 = y1 + e0;
    i11 = y1 + e1;
  }
  const ld* v = t.corner;
  double h[4][2];
  const int32_t o[4] = {o00, o01, o10, o11};
  for (int k = 0; k < 4; ++k) split((v[o[k] + i00] - v[o[k] + i01]) - (v[o[k] + i10] - v[o[k] + i11]), h[k]);
  return combine(h[0], h[1], h[2], h[3]);
}

double AlignedRectangles::direct(const Rect& p, const Rect& q) const {
  const Plane& P = planes_[p.plane];
  const Plane& Q = planes_[q.plane];
  const Frame& fr = frames_[p.frame];
  // Coordinate of edge e (0 low, 1 high) of patch r on plane L along slot s.
  auto coord = [&](const Plane& L, const Rect& r, int s, int e) -> ld {
    return fr.coord[(L.axis + 1 + s) % 3][L.coords[s][r.l[s][e]]];
  };
  double inner[2][2][2];
  if (P.axis == Q.axis) {
    if (P.sign == Q.sign) return 0.0;
    const ld z = P.sign * (ld(fr.coord[P.axis][Q.offset]) - ld(fr.coord[P.axis][P.offset]));
    if (!(z > 0)) return 0.0;
    const ld px[2] = {coord(P, p, 0, 0), coord(P, p, 0, 1)}, py[2] = {coord(P, p, 1, 0), coord(P, p, 1, 1)};
    const ld qx[2] = {coord(Q, q, 0, 0), coord(Q, q, 0, 1)}, qy[2] = {coord(Q, q, 1, 0), coord(Q, q, 1, 1)};
    parallel_inner(px, py, qx, qy, z, inner);
  } else {
    const int common = 3 - P.axis - Q.axis;
    const int po = slot_of(P.axis, common), qo = slot_of(Q.axis, common);
    // Distances from the common line, increasing, the parts behind the other plane clipped off.
    ld y[2], e[2];
    for (int k = 0; k < 2; ++k) {
      y[k] = std::max(ld(0), Q.sign * (coord(P, p, 1 - po, k) - ld(fr.coord[Q.axis][Q.offset])));
      e[k] = std::max(ld(0), P.sign * (coord(Q, q, 1 - qo, k) - ld(fr.coord[P.axis][P.offset])));
    }
    if (Q.sign < 0) std::swap(y[0], y[1]);
    if (P.sign < 0) std::swap(e[0], e[1]);
    if (!(y[1] > 0) || !(e[1] > 0)) return 0.0;
    const ld px[2] = {coord(P, p, po, 0), coord(P, p, po, 1)}, qx[2] = {coord(Q, q, qo, 0), coord(Q, q, qo, 1)};
    perpendicular_inner(px, qx, y, e, inner);
  }
  return combine(inner[0][0], inner[0][1], inner[1][0], inner[1][1]);
}

namespace {

// A rectangle's sides: unit u (corner 0 to 1) and v (1 to 2), when it is one: opposite sides
// equal and adjacent ones at right angles to `rel` of its sides (plus rounding at `scale`, the
// largest |coordinate|), counter-clockwise around `normal`.
bool rectangle_sides(const Vec3 c[4], const Vec3& normal, double scale, Vec3& u, Vec3& v) {
  const Vec3 e0 = c[1] - c[0], e1 = c[2] - c[1], e2 = c[3] - c[2], e3 = c[0] - c[3];
  const double l0 = e0.norm(), l1 = e1.norm();
  if (!(std::min(l0, l1) > 1e-9 * scale)) return false;
  const double rel = 1e-12 + 16 * kEps * scale / std::min(l0, l1);
  if (!((e0 + e2).norm() <= rel * l0) || !((e1 + e3).norm() <= rel * l1)) return false;
  u = e0 / l0;
  v = e1 / l1;
  return std::abs(u.dot(v)) <= rel && (u.cross(v).normalized() - normal).norm() <= 4 * rel;
}

// Which of the frame's axes `d` runs along (to 1e-12), or −1.
int axis_along(const Vec3 axes[3], const Vec3& d) {
  for (int k = 0; k < 3; ++k)
    if (std::abs(std::abs(d.dot(axes[k])) - 1.0) <= 1e-12 && (d - d.dot(axes[k]) * axes[k]).norm() <= 1e-12) return k;
  return -1;
}

}  // namespace

bool aligned_rectangle_pair(const Vec3 p[4], const Vec3& p_normal, const Vec3 q[4], const Vec3& q_normal,
                            double& area_factor) {
  double scale = 0.0;
  for (int k = 0; k < 4; ++k) scale = std::max({scale, p[k].cwiseAbs().maxCoeff(), q[k].cwiseAbs().maxCoeff()});
  Vec3 axes[3], qu, qv;
  if (!rectangle_sides(p, p_normal, scale, axes[0], axes[1]) || !rectangle_sides(q, q_normal, scale, qu, qv))
    return false;
  axes[2] = axes[0].cross(axes[1]).normalized();  // P's normal: P lies in a plane of axis 2, facing +
  const int a_u = axis_along(axes, qu), a_v = axis_along(axes, qv);
  if (a_u < 0 || a_v < 0 || a_u == a_v) return false;
  const int q_axis = 3 - a_u - a_v;  // Q's normal axis
  const int q_sign = q_normal.dot(axes[q_axis]) > 0 ? 1 : -1;
  // A rectangle's extent along frame axis k: its lowest and highest corner coordinates.
  auto range = [&](const Vec3 c[4], int k, ld out[2]) {
    out[0] = out[1] = ld(c[0].dot(axes[k]));
    for (int m = 1; m < 4; ++m) {
      out[0] = std::min(out[0], ld(c[m].dot(axes[k])));
      out[1] = std::max(out[1], ld(c[m].dot(axes[k])));
    }
  };
  auto offset = [&](const Vec3 c[4], int k) {
    ld sum = 0;
    for (int m = 0; m < 4; ++m) sum += ld(c[m].dot(axes[k]));
    return sum / 4;
  };
  double inner[2][2][2];
  if (q_axis == 2) {  // parallel planes (Howell C-11 superposed)
    const ld z = offset(q, 2) - offset(p, 2);
    if (q_sign > 0 || !(z > 0)) {  // facing the same way, or Q not in front of P
      area_factor = 0.0;
      return true;
    }
    ld px[2], py[2], qx[2], qy[2];
    range(p, 0, px), range(p, 1, py), range(q, 0, qx), range(q, 1, qy);
    parallel_inner(px, py, qx, qy, z, inner);
  } else {  // perpendicular planes (Howell C-14 superposed), x along the common axis
    const int common = 3 - 2 - q_axis, p_across = q_axis;
    ld px[2], qx[2], pa[2], qa[2], y[2], e[2];
    range(p, common, px), range(q, common, qx), range(p, p_across, pa), range(q, 2, qa);
    const ld q_offset = offset(q, q_axis), p_offset = offset(p, 2);
    // Distances from the common line, increasing, the parts behind the other's plane clipped off.
    for (int k = 0; k < 2; ++k) {
      y[k] = std::max(ld(0), q_sign * (pa[k] - q_offset));
      e[k] = std::max(ld(0), qa[k] - p_offset);
    }
    if (q_sign < 0) std::swap(y[0], y[1]);
    if (!(y[1] > 0) || !(e[1] > 0)) {
      area_factor = 0.0;
      return true;
    }
    perpendicular_inner(px, qx, y, e, inner);
  }
  area_factor = combine(inner[0][0], inner[0][1], inner[1][0], inner[1][1]);
  return true;
}

}  // namespace photometria
