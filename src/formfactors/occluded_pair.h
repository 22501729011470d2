// Form factors of pairs with occluders in their shaft, to a requested accuracy (exact visibility).
//
//   F_ij = F_ij^unocc − (1/A_i) ∫_{A_i'} h(x) dA_x,   h(x) = F(dA_x → P_j) − F_vis(dA_x → P_j) >= 0
// F_ij^unocc is the pair's factor with nothing in the way (pair_integration.h or the rectangles'
// closed form: accurate to the requested tolerance), A_i' the part of receiver P_i in front of
// P_j's plane (elsewhere h = 0), F(dA_x → P_j) Lambert's closed form (kernels/lambert.h) and
// F_vis its visible part from x, computed exactly (Nishita & Nakamae 1985 shadow clipping,
// visibility.h 3.). Only the blocked part h is integrated numerically, because
//  - h vanishes exactly on every part of the receiver from which no occluder meets the shaft to
//    P_j: each cell of the receiver is shaft-culled first (Haines & Wallace 1994) and a cell with
//    no occluder left contributes exactly 0 without a single evaluation;
//  - h is discontinuous only where an occluder touches or crosses the receiver (a table leg on a
//    floor quad: points under the leg see nothing, points beside it see the leg's face). The
//    receiver is cut along the plane of every such occluder first, so that these lines are cell
//    boundaries and the integrand is continuous inside every cell; elsewhere h has at most kinks
//    along the penumbra's event lines (Heckbert, "Discontinuity meshing for radiosity",
//    Eurographics Workshop on Rendering 1992: D1 and D2 discontinuities), which the adaptive rule
//    isolates in small cells.
// The integral is globally adaptive (Genz & Malik, "An adaptive algorithm for numerical
// integration over an N-dimensional rectangular region", J. Comput. Appl. Math. 6(4), 1980):
// per cell a 17-point rule exact for polynomials of degree 7 and its embedded degree-5 rule, whose
// difference is the cell's error estimate; the cell of largest estimate is halved, across the
// axis of larger fourth difference, until the estimates sum to the tolerance or the evaluation
// budget is spent (then the result says so, with its estimate).
#pragma once

#include <vector>

#include "formfactors/receiver_cells.h"
#include "geometry/polygon.h"
#include "visibility/visibility.h"

namespace photometria {

// Genz & Malik's rule on [−1, 1]² (the integrator's cell rule; exposed for its tests): point q
// (0..16) of the 17 at (u[q], v[q]), and from the values f at those points the mean of f over the
// square by the degree-7 rule and by its embedded degree-5 rule.
struct GenzMalikRule {
  static constexpr int kPoints = 17;
  double u[kPoints], v[kPoints];
  GenzMalikRule();
  void means(const double* f, double& mean7, double& mean5) const;
};

// One occluded pair: receiver P_i, source P_j, and the candidate occluders of their shaft.
struct OccludedPair {
  const Vec3* receiver;  // P_i's corners (3 or 4)
  int receiver_count;
  Vec3 receiver_normal;          // unit
  double receiver_area;          // A_i, m²
  const Polygon* receiver_part;  // the part of P_i in front of P_j's plane (convex)
  const Vec3* source;            // P_j's corners (3 or 4), counter-clockwise from its front
  int source_count;
  Vec3 source_normal;                 // unit
  const Polygon* source_part;         // the part of P_j in front of P_i's plane (convex)
  const std::vector<int>* occluders;  // sorted occluder indices (ShaftCuller) that may meet the shaft
};

struct OccludedPairResult {
  double form_factor = 0.0;       // visible F_ij, in [0, unoccluded]
  double blocked = 0.0;           // (1/A_i) ∫ h dA: what the occluders take away
  double error = 0.0;             // estimated absolute error of form_factor (sum of the cells' estimates)
  long long evaluations = 0;      // receiver points whose visible factor was computed
  int cells = 0;                  // cells the receiver ended in (those with occluders in their shaft)
  bool budget_exhausted = false;  // stopped by max_evaluations with error > the tolerance
};

// One per thread (keeps its buffers between pairs); `vis` must be in exact mode.
class OccludedPairIntegrator {
 public:
  explicit OccludedPairIntegrator(const Visibility& vis);

  // F_ij of `pair` given its unoccluded factor, to absolute accuracy `tolerance` (on F_ij,
  // dimensionless; > 0), spending at most about `max_evaluations` receiver points.
  OccludedPairResult integrate(const OccludedPair& pair, double unoccluded, double tolerance,
                               long long max_evaluations);

 private:
  struct Box {
    int cell;
    double s0, s1, t0, t1;
    double integral, error;
    bool split_s;     // halve across s (else t)
    int list;         // lists_ index: the occluders of this box's shaft
    int parent_list;  // lists_ index of the parent's (-1: the pair's), read while evaluating only
  };
  void cut_along_standing_occluders(const OccludedPair& pair);
  // Shaft-culls box b's image against the pair's occluders, then applies the rule; false when no
  // occluder is left (h = 0 on the box exactly).
  bool evaluate(const OccludedPair& pair, Box& b);
  // True when an occluder of the list may lie within twice the cell's radius of the cell (corners).
  bool occluder_within(const std::vector<int>& occluders, const Vec3* corners, int k) const;
  // h(x), and F(dA_x → P_j) into `unoccluded`.
  double blocked_at(const OccludedPair& pair, const Vec3& x, const std::vector<int>& occluders, double& unoccluded);

  const Visibility& vis_;
  std::vector<Polygon> pieces_, next_pieces_;
  std::vector<ReceiverCell> cells_;
  std::vector<Box> heap_;
  std::vector<std::vector<int>> lists_;  // occluder lists of the boxes in the heap (pooled)
  std::vector<int> free_lists_;
  long long evaluations_ = 0;
  double cell_scale_s_ = 0.0, cell_scale_t_ = 0.0;  // lengths of the current cell's s and t sides
};

}  // namespace photometria
