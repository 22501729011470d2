#include "formfactors/occluded_pair.h"

#include <algorithm>
#include <cmath>

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

OccludedPairIntegrator::OccludedPairIntegrator(const Visibility& vis) : vis_(vis) {}

double OccludedPairIntegrator::blocked_at(const OccludedPair& pair, const Vec3& x, const std::vector<int>& occluders,
                                          double& unoccluded) {
  ++evaluations_;
  const Receiver at{x, pair.receiver_normal};
  unoccluded = lambert_form_factor(at, pair.source, pair.source_count);
  if (!(unoccluded > 0.0)) return 0.0;
  RayTally rays;  // exact visibility: unused
  const double visible =
      vis_.point_to_patch(at, pair.source, pair.source_count, pair.source_normal, unoccluded, occluders, 0, 0, rays);
  return std::max(0.0, unoccluded - visible);
}

bool OccludedPairIntegrator::evaluate(const OccludedPair& pair, Box& b) {
  static const GenzMalikRule points;
  const ReceiverCell& cell = cells_[size_t(b.cell)];
  cell_scale_s_ = (cell.c[1] - cell.c[0]).norm();
  cell_scale_t_ = (cell.n == 4 ? cell.c[3] - cell.c[0] : cell.c[2] - cell.c[1]).norm();
  Vec3 corners[4];
  const int k = cell.box_corners(b.s0, b.s1, b.t0, b.t1, corners);
  if (k < 3) return false;
  std::vector<int>& list = lists_[size_t(b.list)];
  const std::vector<int>& among = b.parent_list >= 0 ? lists_[size_t(b.parent_list)] : *pair.occluders;
  vis_.culler().occluders_among(corners, k, pair.source_part->data(), int(pair.source_part->size()), among, list);
  if (list.empty()) return false;
  const double hs = 0.5 * (b.s1 - b.s0), ht = 0.5 * (b.t1 - b.t0);
  const double sm = b.s0 + hs, tm = b.t0 + ht;
  double g[GenzMalikRule::kPoints], f[GenzMalikRule::kPoints];  // h and F(dA_x → P_j), times the Jacobian
  bool some_shadowed = false, some_lit = false;
  for (int q = 0; q < GenzMalikRule::kPoints; ++q) {
    double jac;
    const Vec3 x = cell.at(sm + hs * points.u[q], tm + ht * points.v[q], &jac);
    double unoccluded;
    g[q] = jac * blocked_at(pair, x, list, unoccluded);
    f[q] = jac * unoccluded;
    some_shadowed = some_shadowed || g[q] > 0.0;
    some_lit = some_lit || g[q] < f[q];
  }
  const double measure = (b.s1 - b.s0) * (b.t1 - b.t0);
  double mean7, mean5;
  points.means(g, mean7, mean5);
  b.integral = measure * mean7;
  b.error = measure * std::abs(mean7 - mean5);
  if ((!some_shadowed || !some_lit) && occluder_within(list, corners, k)) {
    // Every point of the rule is lit, or every point is in full shadow, yet an occluder meets the
    // cell's shaft closer to the cell than the cell's size: a shadow (or a gap of light) thinner
    // than the rule's spacing could go unseen, as where an occluder touches the receiver and its
    // penumbra narrows to nothing at the contact. Both the blocked and the visible part of the
    // cell are at most its unoccluded integral (0 <= h <= F): that bound is the cell's error, so
    // the cell is halved (longer side first) until its shaft is empty, no occluder is nearer
    // than the cell is wide, the samples differ, or the bound is negligible. (An occluder farther
    // away casts penumbrae about as wide as its distance, which the rule's points do sample.)
    double bound7, bound5;
    points.means(f, bound7, bound5);
    b.error = measure * std::max(0.0, bound7);
    b.split_s = hs * cell_scale_s_ >= ht * cell_scale_t_;
    return true;
  }
  const double diff_s = std::abs(g[1] + g[2] - 2 * g[0] - kDifferenceRatio * (g[5] + g[6] - 2 * g[0]));
  const double diff_t = std::abs(g[3] + g[4] - 2 * g[0] - kDifferenceRatio * (g[7] + g[8] - 2 * g[0]));
  // Halve the longer side (in the cell's metric) where the differences cannot tell.
  b.split_s = diff_s > diff_t || (diff_s == diff_t && hs * cell_scale_s_ >= ht * cell_scale_t_);
  return true;
}

bool OccludedPairIntegrator::occluder_within(const std::vector<int>& occluders, const Vec3* corners, int k) const {
  Vec3 centre = Vec3::Zero();
  for (int i = 0; i < k; ++i) centre += corners[i];
  centre /= k;
  double radius = 0.0;
  for (int i = 0; i < k; ++i) radius = std::max(radius, (corners[i] - centre).norm());
  const ShaftCuller& culler = vis_.culler();
  for (const int o : occluders) {
    // A lower bound of the distance from the cell to the occluder: the larger of the distances
    // from the cell's bounding sphere to the occluder's plane and to its bounding box.
    const Polygon& w = culler.occluder_polygons()[size_t(o)];
    const double to_plane = std::abs(culler.occluder_normals()[size_t(o)].dot(centre - w[0]));
    Eigen::AlignedBox3d box;
    for (const Vec3& v : w) box.extend(v);
    const double to_box = std::sqrt(box.squaredExteriorDistance(centre));
    if (std::max(to_plane, to_box) - radius < 2.0 * radius) return true;
  }
  return false;
}

void OccludedPairIntegrator::cut_along_standing_occluders(const OccludedPair& pair) {
  pieces_.assign(1, *pair.receiver_part);
  const ShaftCuller& culler = vis_.culler();
  const double tol = culler.tolerance();
  const Vec3& origin = pair.receiver[0];
  constexpr size_t kMaxPieces = 64;  // bounds the work for a receiver crossed by many occluders
  Polygon front, back;
  for (const int o : *pair.occluders) {
    const Polygon& w = culler.occluder_polygons()[size_t(o)];
    double lo = 1e300, hi = -1e300;
    for (const Vec3& v : w) {
      const double d = pair.receiver_normal.dot(v - origin);
      lo = std::min(lo, d);
      hi = std::max(hi, d);
    }
    // Touching (a corner on the receiver's plane) or crossing it, and rising above it.
    if (!(lo <= tol && hi > tol)) continue;
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

OccludedPairResult OccludedPairIntegrator::integrate(const OccludedPair& pair, double unoccluded, double tolerance,
                                                     long long max_evaluations) {
  OccludedPairResult result;
  const auto by_error = [](const Box& a, const Box& b) { return a.error < b.error; };
  evaluations_ = 0;
  heap_.clear();
  free_lists_.clear();
  for (int l = 0; l < int(lists_.size()); ++l) free_lists_.push_back(l);
  auto take_list = [&]() {
    if (free_lists_.empty()) {
      lists_.emplace_back();
      return int(lists_.size()) - 1;
    }
    const int l = free_lists_.back();
    free_lists_.pop_back();
    return l;
  };

  cut_along_standing_occluders(pair);
  cells_.clear();
  for (const Polygon& piece : pieces_)
    for (const ReceiverCell& c : receiver_cells(piece)) cells_.push_back(c);

  double error = 0.0;
  // Evaluates box b; keeps it when an occluder meets its shaft (else h = 0 on it: dropped).
  const auto add = [&](Box b) {
    if (!evaluate(pair, b)) {
      free_lists_.push_back(b.list);
      return;
    }
    error += b.error;
    heap_.push_back(b);
    std::push_heap(heap_.begin(), heap_.end(), by_error);
  };
  for (int c = 0; c < int(cells_.size()); ++c) add(Box{c, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0, true, take_list(), -1});
  const double target = tolerance * pair.receiver_area;  // on ∫ h dA
  constexpr long long kPointsPerSplit = 34;              // two halves of 17 points
  while (!heap_.empty() && error > target) {
    if (evaluations_ + kPointsPerSplit > max_evaluations) {
      result.budget_exhausted = true;
      break;
    }
    std::pop_heap(heap_.begin(), heap_.end(), by_error);
    const Box parent = heap_.back();
    heap_.pop_back();
    error -= parent.error;
    for (int half = 0; half < 2; ++half) {
      Box b = parent;
      b.list = take_list();
      b.parent_list = parent.list;
      if (parent.split_s) (half == 0 ? b.s1 : b.s0) = 0.5 * (parent.s0 + parent.s1);
      else (half == 0 ? b.t1 : b.t0) = 0.5 * (parent.t0 + parent.t1);
      add(b);
    }
    free_lists_.push_back(parent.list);
  }
  // The sums again from the cells themselves (the running error drifts by rounding).
  double blocked = 0.0;
  error = 0.0;
  for (const Box& b : heap_) {
    blocked += b.integral;
    error += b.error;
  }
  result.blocked = std::max(0.0, blocked / pair.receiver_area);
  result.error = error / pair.receiver_area;
  result.form_factor = std::clamp(unoccluded - result.blocked, 0.0, unoccluded);
  result.evaluations = evaluations_;
  result.cells = int(heap_.size());
  return result;
}

}  // namespace photometria
