#include "formfactors/occluded_row.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "formfactors/pair_integration.h"
#include "formfactors/receiver_cells.h"
#include "kernels/lambert.h"

namespace photometria {
namespace {

// Genz & Malik (1980) in two dimensions on [−1, 1]²: the centre, ±λ2 and ±λ3 on each axis,
// (±λ4, ±λ4) and (±λ5, ±λ5); weights normalised to sum to 1 (the rule gives the cell's mean),
// solved from the moment equations of the even monomials up to degree 6 (degree 7 by symmetry)
// and, without the λ5 points, up to degree 4 for the embedded degree-5 rule
// (tests/test_formfactors_occluded.cpp checks both on monomials).
const double kLambda2 = std::sqrt(9.0 / 70.0), kLambda3 = std::sqrt(9.0 / 10.0), kLambda4 = std::sqrt(9.0 / 10.0),
             kLambda5 = std::sqrt(9.0 / 19.0);
constexpr double kW7[5] = {-424.0 / 2187.0, 980.0 / 6561.0, 340.0 / 6561.0, 200.0 / 19683.0, 6859.0 / 78732.0};
constexpr double kW5[4] = {-971.0 / 729.0, 245.0 / 486.0, 65.0 / 1458.0, 25.0 / 729.0};
// Fourth-difference ratio λ2² / λ3² (Genz & Malik's choice of the axis to halve).
constexpr double kDifferenceRatio = (9.0 / 70.0) / (9.0 / 10.0);
// Boxes of at least this share of their cell's parameter square (the cell and its first halvings)
// take the bound of a possibly unseen thin shadow near an occluder (OccludedRowIntegrator::evaluate);
// smaller ones take the rule's estimate, so that the cells along a contact line stop halving. On the
// 1,666-face room at 1e-3 (docs/performance.md): 1/4 took 32.6 M evaluations and left rows within
// 3.8e-5, 1/64 took 65.9 M for 3.5e-5, no bound 30.7 M for 2.1e-4. (The bound on every box that
// still has an occluder in its shaft down to 1/16 took 195 M, for 3.5e-5.)
constexpr double kNearBoundMeasure = 1.0 / 4.0;
// Boxes of at least this share of their cell are shaft-culled per source (evaluate).
constexpr double kCullMeasure = 1.0 / 4.0;

}  // namespace

// The 17 points, in the order the rule reads them: centre; +λ2 s, −λ2 s, +λ2 t, −λ2 t; the
// same with λ3; (±λ4, ±λ4); (±λ5, ±λ5).
GenzMalikRule::GenzMalikRule() {
  int k = 0;
  u[k] = v[k] = 0.0;
  ++k;
  for (const double l : {kLambda2, kLambda3}) {
    const double a[4][2] = {{l, 0}, {-l, 0}, {0, l}, {0, -l}};
    for (const auto& p : a) u[k] = p[0], v[k++] = p[1];
  }
  for (const double l : {kLambda4, kLambda5})
    for (const double a : {l, -l})
      for (const double b : {l, -l}) u[k] = a, v[k++] = b;
}

void GenzMalikRule::means(const double* f, double& mean7, double& mean5) const {
  const double axis2 = f[1] + f[2] + f[3] + f[4], axis3 = f[5] + f[6] + f[7] + f[8];
  const double diag4 = f[9] + f[10] + f[11] + f[12], diag5 = f[13] + f[14] + f[15] + f[16];
  mean7 = kW7[0] * f[0] + kW7[1] * axis2 + kW7[2] * axis3 + kW7[3] * diag4 + kW7[4] * diag5;
  mean5 = kW5[0] * f[0] + kW5[1] * axis2 + kW5[2] * axis3 + kW5[3] * diag4;
}

OccludedRowIntegrator::OccludedRowIntegrator(const Visibility& vis, const PatchMesh& mesh) : vis_(vis), mesh_(mesh) {
  near_stamp_.assign(size_t(vis.culler().occluder_count()), -1);
  near_.assign(size_t(vis.culler().occluder_count()), 0);
}

double OccludedRowIntegrator::occluder_distance(int o, const Vec3& centre) {
  if (near_stamp_[size_t(o)] == box_stamp_) return near_[size_t(o)];
  near_stamp_[size_t(o)] = box_stamp_;
  // A lower bound of the distance from the centre to the occluder: the larger of the distances
  // to its plane and to its bounding box.
  const ShaftCuller& culler = vis_.culler();
  const Polygon& w = culler.occluder_polygons()[size_t(o)];
  const double to_plane = std::abs(culler.occluder_normals()[size_t(o)].dot(centre - w[0]));
  Eigen::AlignedBox3d box;
  for (const Vec3& v : w) box.extend(v);
  const double to_box = std::sqrt(box.squaredExteriorDistance(centre));
  near_[size_t(o)] = std::max(to_plane, to_box);
  return near_[size_t(o)];
}

double OccludedRowIntegrator::blocked_at(const Receiver& at, int k, OccluderSpan occluders, bool& lit) {
  using namespace visibility_detail;
  const ShaftCuller& culler = vis_.culler();
  lit = true;
  casting_.assign(occluder_pool_.begin() + occluders.first, occluder_pool_.begin() + occluders.first + occluders.count);
  // Only the occluders of each convex solid that face x cast its shadow (ShaftCuller).
  culler.drop_hidden_occluders(at.point, casting_, receiver_face_, &at.normal, outside_state_, touched_solids_);
  if (casting_.empty()) return 0.0;
  const std::vector<Vec3>& source = source_corners_[size_t(k)];
  pieces_clip_.clear();
  hidden_.clear();
  Polygon& relative = pieces_clip_.push();
  relative.resize(source.size());
  double scale = 0.0;
  for (size_t c = 0; c < source.size(); ++c) {
    relative[c] = source[c] - at.point;
    scale = std::max(scale, relative[c].norm());
  }
  if (!subtract_shadows(scale, culler.occluder_polygons(), casting_, &culler.occluder_normals(), pieces_clip_, &hidden_,
                        &culler, volumes_))
    return 0.0;
  // Lit: some visible piece rises above x's horizon.
  lit = false;
  for (size_t q = 0; q < pieces_clip_.size() && !lit; ++q)
    for (const Vec3& y : pieces_clip_[q]) lit = lit || at.normal.dot(y) > 0.0;
  // Wholly hidden: h_j is the source's whole factor.
  if (pieces_clip_.empty()) return lambert_form_factor(at, source.data(), int(source.size()));
  // Lambert's formula is additive over a partition of the source (an integral over directions;
  // Stark 2000 sec. 1.1, full reference in visibility.h): the hidden pieces' factors sum to h_j.
  const Receiver at_origin{Vec3::Zero(), at.normal, at.approach};
  double h = 0.0;
  for (size_t q = 0; q < hidden_.size(); ++q)
    h += lambert_form_factor(at_origin, hidden_[q].data(), static_cast<int>(hidden_[q].size()));
  return std::max(0.0, h);
}

bool OccludedRowIntegrator::evaluate(const std::vector<std::pair<int, OccluderSpan>>& candidates, Box& b) {
  const std::vector<OccludedSource>& sources = *sources_;
  static const GenzMalikRule rule;
  const ReceiverCell& cell = cells_[size_t(b.cell)];
  const double scale_s = (cell.c[1] - cell.c[0]).norm();
  const double scale_t = (cell.n == 4 ? cell.c[3] - cell.c[0] : cell.c[2] - cell.c[1]).norm();
  Vec3 corners[4];
  const int k = cell.box_corners(b.s0, b.s1, b.t0, b.t1, corners);
  if (k < 3) return false;
  const ShaftCuller& culler = vis_.culler();
  b.active.clear();
  b.occluders.clear();
  // Culling a box's shaft per source costs about what two of its 17 points do; past the first two
  // halvings it rarely frees a source its parent's shaft did not, so smaller boxes keep the
  // parent's list (1,666-face room, one thread: culling down to 1/16 of the cell took 5% longer
  // than down to 1/4, for 2.5% fewer evaluations and the same matrix).
  const bool cull = (b.s1 - b.s0) * (b.t1 - b.t0) >= kCullMeasure;
  for (const auto& [s, span] : candidates) {
    const Polygon& part = sources[size_t(s)].exchanging_part;
    if (part.size() < 3) continue;
    OccluderSpan kept = span;
    if (cull) {
      parent_list_.assign(occluder_pool_.begin() + span.first, occluder_pool_.begin() + span.first + span.count);
      culler.occluders_among(corners, k, part.data(), int(part.size()), parent_list_, shaft_);
      if (shaft_.empty()) continue;
      if (shaft_.size() < size_t(span.count)) {
        kept = {int(occluder_pool_.size()), int(shaft_.size())};
        occluder_pool_.insert(occluder_pool_.end(), shaft_.begin(), shaft_.end());
      }
    }
    b.active.push_back(s);
    b.occluders.push_back(kept);
  }
  if (b.active.empty()) return false;

  const size_t active = b.active.size();
  const double hs = 0.5 * (b.s1 - b.s0), ht = 0.5 * (b.t1 - b.t0);
  const double sm = b.s0 + hs, tm = b.t0 + ht;
  g_.assign(active * GenzMalikRule::kPoints, 0.0);
  lit_.assign(active * GenzMalikRule::kPoints, 0);
  Vec3 points[GenzMalikRule::kPoints];
  double jacobians[GenzMalikRule::kPoints];
  for (int q = 0; q < GenzMalikRule::kPoints; ++q) {
    const Vec3 x = points[q] = cell.at(sm + hs * rule.u[q], tm + ht * rule.v[q], &jacobians[q]);
    const Receiver at{x, normal_};
    volumes_.start(x);
    // A new point: what blocked_at learnt of the solids (x outside them or not) is for the last one.
    for (const int solid : touched_solids_) outside_state_[size_t(solid)] = 0;
    touched_solids_.clear();
    ++points_evaluated_;
    for (size_t a = 0; a < active; ++a) {
      // A source wholly at or below x's horizon sends nothing to x: h_j = 0, neither lit nor shadowed.
      bool above = false;
      for (const Vec3& c : source_corners_[size_t(b.active[a])]) above = above || normal_.dot(c - x) > 0.0;
      if (!above) continue;
      ++evaluations_;
      const size_t at_q = a * GenzMalikRule::kPoints + size_t(q);
      bool lit = true;
      g_[at_q] = jacobians[q] * blocked_at(at, b.active[a], b.occluders[a], lit);
      lit_[at_q] = lit;
    }
  }

  ++box_stamp_;
  Vec3 centre = Vec3::Zero();
  for (int i = 0; i < k; ++i) centre += corners[i];
  centre /= k;
  double radius = 0.0;
  for (int i = 0; i < k; ++i) radius = std::max(radius, (corners[i] - centre).norm());
  const bool longer_is_s = hs * scale_s >= ht * scale_t;
  const double measure = (b.s1 - b.s0) * (b.t1 - b.t0);
  b.integral.resize(active);
  b.source_error.resize(active);
  b.error = 0.0;
  double vote_s = 0.0, vote_t = 0.0;  // Σ of the sources' fourth differences across s and t
  for (size_t a = 0; a < active; ++a) {
    const double* g = g_.data() + a * GenzMalikRule::kPoints;
    const unsigned char* lit_at = lit_.data() + a * GenzMalikRule::kPoints;
    double mean7, mean5;
    rule.means(g, mean7, mean5);
    b.integral[a] = measure * mean7;
    double error = measure * std::abs(mean7 - mean5);
    bool shadowed = false, lit = false;
    for (int q = 0; q < GenzMalikRule::kPoints; ++q) {
      shadowed = shadowed || g[q] > 0.0;
      lit = lit || lit_at[q];
    }
    bool near = false;
    if ((!shadowed || !lit) && measure > kNearBoundMeasure)
      for (int i = 0; i < b.occluders[a].count; ++i)
        if ((near =
                 occluder_distance(occluder_pool_[size_t(b.occluders[a].first + i)], centre) - radius < 2.0 * radius))
          break;
    if (near) {
      // Every point of the rule is lit, or every point is in full shadow, yet an occluder lies
      // closer to the box than the box's size: a shadow (or a gap of light) thinner than the
      // rule's spacing could go unseen, as where an occluder touches the receiver and its
      // penumbra narrows to nothing at the contact. Both the blocked and the visible part of the
      // box are at most its unoccluded integral (0 <= h <= F): that bound is the error, and the
      // longer side is halved. (An occluder farther away casts penumbrae about as wide as its
      // distance, which the rule's points do sample.)
      // The unoccluded factors, needed here only (a few boxes of the row).
      const std::vector<Vec3>& source = source_corners_[size_t(b.active[a])];
      double f[GenzMalikRule::kPoints];
      for (int q = 0; q < GenzMalikRule::kPoints; ++q)
        f[q] = jacobians[q] * lambert_form_factor(Receiver{points[q], normal_}, source.data(), int(source.size()));
      double bound7, bound5;
      rule.means(f, bound7, bound5);
      error = measure * std::max(0.0, bound7);
      (longer_is_s ? vote_s : vote_t) += error;
    } else {
      vote_s += measure * std::abs(g[1] + g[2] - 2 * g[0] - kDifferenceRatio * (g[5] + g[6] - 2 * g[0]));
      vote_t += measure * std::abs(g[3] + g[4] - 2 * g[0] - kDifferenceRatio * (g[7] + g[8] - 2 * g[0]));
    }
    b.source_error[a] = error;
    b.error += error;
  }
  // Halve the longer side (in the cell's metric) where the differences cannot tell.
  b.split_s = vote_s > vote_t || (vote_s == vote_t && longer_is_s);
  return true;
}

void OccludedRowIntegrator::cut_along_standing_occluders(const std::vector<OccludedSource>& sources) {
  pieces_.assign(1, Polygon(receiver_, receiver_ + receiver_count_));
  const ShaftCuller& culler = vis_.culler();
  const double tol = culler.tolerance();
  const Vec3& origin = receiver_[0];
  constexpr size_t kMaxPieces = 64;  // bounds the work for a receiver crossed by many occluders
  // The row's occluders, each once (in occluder order, so the cut does not depend on the sources' order).
  shaft_.clear();
  for (const OccludedSource& s : sources) shaft_.insert(shaft_.end(), s.occluders.begin(), s.occluders.end());
  std::sort(shaft_.begin(), shaft_.end());
  shaft_.erase(std::unique(shaft_.begin(), shaft_.end()), shaft_.end());
  Polygon front, back;
  standing_.clear();
  for (const int o : shaft_) {
    const Polygon& w = culler.occluder_polygons()[size_t(o)];
    double lo = 1e300, hi = -1e300;
    for (const Vec3& v : w) {
      const double d = normal_.dot(v - origin);
      lo = std::min(lo, d);
      hi = std::max(hi, d);
    }
    // Touching (a corner on the receiver's plane) or crossing it, and rising above it.
    if (!(lo <= tol && hi > tol)) continue;
    standing_.push_back(o);
    const Vec3& m = culler.occluder_normals()[size_t(o)];
    next_pieces_.clear();
    for (const Polygon& piece : pieces_) {
      double below = 0.0, above = 0.0;
      for (const Vec3& v : piece) {
        const double e = m.dot(v - w[0]);
        below = std::min(below, e);
        above = std::max(above, e);
      }
      if (below < -tol && above > tol && pieces_.size() + next_pieces_.size() < kMaxPieces) {
        clip_to_halfspace_at(piece.data(), int(piece.size()), w[0], m, front);
        clip_to_halfspace_at(piece.data(), int(piece.size()), w[0], -m, back);
        if (front.size() >= 3) next_pieces_.push_back(front);
        if (back.size() >= 3) next_pieces_.push_back(back);
      } else {
        next_pieces_.push_back(piece);
      }
    }
    pieces_.swap(next_pieces_);
  }
}

bool OccludedRowIntegrator::under_a_solid(const Polygon& piece) const {
  const ShaftCuller& culler = vis_.culler();
  Vec3 centre = Vec3::Zero();
  for (const Vec3& v : piece) centre += v;
  centre /= double(piece.size());
  double radius = 0.0;
  for (const Vec3& v : piece) radius = std::max(radius, (v - centre).norm());
  // Just above the piece's centre: inside a convex solid standing on the receiver when the piece
  // is (part of) its footprint. Cut along the solid's planes, a piece is wholly in or out of it.
  const Vec3 probe = centre + std::max(1e-6 * radius, 8.0 * culler.tolerance()) * normal_;
  for (const int o : standing_) {
    const int solid = culler.solid_of(o);
    if (solid < 0) continue;
    bool inside = true;
    for (const int w : culler.solid_occluders(solid)) {
      const Vec3& m = culler.occluder_normals()[size_t(w)];
      inside = inside && m.dot(probe - culler.occluder_polygons()[size_t(w)][0]) < -culler.tolerance();
    }
    if (inside) return true;
  }
  return false;
}

OccludedRowResult OccludedRowIntegrator::integrate(int receiver, const std::vector<OccludedSource>& sources,
                                                   double tolerance, long long max_evaluations,
                                                   std::vector<double>& blocked) {
  OccludedRowResult result;
  blocked.assign(sources.size(), 0.0);
  heap_.clear();
  evaluations_ = points_evaluated_ = 0;
  if (sources.empty()) return result;
  sources_ = &sources;
  const Patch& p = mesh_.patches[size_t(receiver)];
  receiver_face_ = p.face;
  receiver_count_ = p.corner_count;
  mesh_.polygon(receiver, receiver_);
  normal_ = p.normal;
  if (source_corners_.size() < sources.size()) source_corners_.resize(sources.size());
  for (size_t k = 0; k < sources.size(); ++k) {
    Vec3 c[4];
    mesh_.polygon(sources[k].patch, c);
    source_corners_[k].assign(c, c + mesh_.patches[size_t(sources[k].patch)].corner_count);
  }
  cut_along_standing_occluders(sources);
  cells_.clear();
  for (const Polygon& piece : pieces_) {
    if (under_a_solid(piece)) {
      // Nothing is visible from the piece: every source is blocked by its unoccluded factor,
      // which the per-pair rule gives to far below the tolerance.
      for (const ReceiverCell& c : receiver_cells(piece)) {
        const double area = polygon_area(Polygon(c.c, c.c + c.n));
        for (size_t k = 0; k < sources.size(); ++k) {
          const std::vector<Vec3>& s = source_corners_[k];
          const Patch& q = mesh_.patches[size_t(sources[k].patch)];
          blocked[k] += area * pair_form_factor(c.c, c.n, normal_, s.data(), int(s.size()), q.normal, 1e-9).form_factor;
        }
      }
      continue;
    }
    for (const ReceiverCell& c : receiver_cells(piece)) cells_.push_back(c);
  }

  const auto by_error = [](const Box& a, const Box& b) { return a.error < b.error; };
  double error = 0.0, settled_error = 0.0;
  // Each source starts with the occluders of the pair's shaft.
  occluder_pool_.clear();
  std::vector<std::pair<int, OccluderSpan>> candidates;
  for (size_t k = 0; k < sources.size(); ++k) {
    candidates.push_back({int(k), {int(occluder_pool_.size()), int(sources[k].occluders.size())}});
    occluder_pool_.insert(occluder_pool_.end(), sources[k].occluders.begin(), sources[k].occluders.end());
  }
  for (int c = 0; c < int(cells_.size()); ++c) {
    Box b{c, 0.0, 1.0, 0.0, 1.0, 0.0, true, {}, {}, {}, {}};
    if (!evaluate(candidates, b)) continue;
    error += b.error;
    heap_.push_back(std::move(b));
    std::push_heap(heap_.begin(), heap_.end(), by_error);
  }
  const double target = tolerance * p.area;  // on Σ_j ∫ h_j dA
  // A source is settled on a box once its estimate there is below this times the box's share of
  // the receiver's area: then all its settled estimates together stay below a tenth of the target.
  const double settle_per_area = 0.1 * target / (double(sources.size()) * p.area);
  while (!heap_.empty() && error > target) {
    if (evaluations_ + 2LL * GenzMalikRule::kPoints * (long long)heap_.front().active.size() > max_evaluations) {
      result.budget_exhausted = true;
      break;
    }
    std::pop_heap(heap_.begin(), heap_.end(), by_error);
    Box parent = std::move(heap_.back());
    heap_.pop_back();
    error -= parent.error;
    Vec3 corners[4];
    const int k = cells_[size_t(parent.cell)].box_corners(parent.s0, parent.s1, parent.t0, parent.t1, corners);
    const double area = polygon_area(Polygon(corners, corners + k));
    candidates.clear();
    for (size_t a = 0; a < parent.active.size(); ++a) {
      if (parent.source_error[a] <= settle_per_area * area) {
        blocked[size_t(parent.active[a])] += parent.integral[a];
        settled_error += parent.source_error[a];
        error += parent.source_error[a];
      } else {
        candidates.push_back({parent.active[a], parent.occluders[a]});
      }
    }
    for (int half = 0; half < 2 && !candidates.empty(); ++half) {
      Box b{parent.cell, parent.s0, parent.s1, parent.t0, parent.t1, 0.0, true, {}, {}, {}, {}};
      if (parent.split_s) (half == 0 ? b.s1 : b.s0) = 0.5 * (parent.s0 + parent.s1);
      else (half == 0 ? b.t1 : b.t0) = 0.5 * (parent.t0 + parent.t1);
      if (!evaluate(candidates, b)) continue;
      error += b.error;
      heap_.push_back(std::move(b));
      std::push_heap(heap_.begin(), heap_.end(), by_error);
    }
  }
  // The sums again from the boxes themselves (the running error drifts by rounding).
  result.error = settled_error;
  for (const Box& b : heap_) {
    for (size_t a = 0; a < b.active.size(); ++a) blocked[size_t(b.active[a])] += b.integral[a];
    result.error += b.error;
  }
  for (double& v : blocked) v = std::max(0.0, v / p.area);
  result.error /= p.area;
  result.evaluations = evaluations_;
  result.points = points_evaluated_;
  result.cells = int(heap_.size());
  return result;
}

}  // namespace photometria
