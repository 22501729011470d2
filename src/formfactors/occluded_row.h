// The occluded pairs of one receiver row, integrated together to a tolerance on the row (exact
// visibility).
//
//   F_ij = F_ij^unocc − (1/A_i) ∫_{A_i} h_j(x) dA_x,   h_j(x) = F(dA_x → P_j) − F_vis(dA_x → P_j) >= 0
// for every source P_j of receiver P_i whose shaft holds an occluder. F_ij^unocc is the pair's
// factor with nothing in the way (pair_integration.h or the rectangles' closed form: accurate to
// the requested tolerance), F(dA_x → P_j) Lambert's closed form (kernels/lambert.h) and F_vis its
// visible part from x, computed exactly (Nishita & Nakamae 1985 shadow clipping, visibility.h 3.).
// Only the blocked parts h_j are integrated numerically.
//
// The sources of a row share their receiver points: at each point the shadow volumes of the
// occluders are built once and serve every source (ShadowVolumes), and the receiver is refined
// where the row's blocked part is uncertain, not once per pair. In a closed room the exact visible
// factors from a point partition its hemisphere, so the row sum's error is the error of
// Σ_j ∫ h_j: the integration stops when the cells' estimates of it, Σ_cells Σ_j |I7_j − I5_j|,
// sum to tolerance × A_i (or the evaluation budget is spent, and the result says so).
//  - h_j vanishes exactly on every part of the receiver from which no occluder meets the shaft to
//    P_j: each cell is shaft-culled per source first (Haines & Wallace 1994), and a source with no
//    occluder left is dropped from the cell without a single evaluation. The occluders left are
//    the only ones clipped at the cell's points (and its halves' points, which lie in the same
//    shaft), so no point culls again.
//  - h_j is discontinuous only where an occluder touches or crosses the receiver (a table leg on a
//    floor quad: points under the leg see nothing, points beside it see the leg's face). The
//    receiver is cut along the plane of every such occluder first, so that these lines are cell
//    boundaries; elsewhere h_j has at most kinks along the penumbra's event lines (Heckbert,
//    "Discontinuity meshing for radiosity", Eurographics Workshop on Rendering 1992: D1 and D2
//    discontinuities), which the adaptive rule isolates in small cells.
//  - A source whose estimate in a cell is below its share of the tolerance is settled there
//    (its value kept, its estimate counted) and not evaluated again in the cell's halves.
// The rule is globally adaptive (Genz & Malik, "An adaptive algorithm for numerical integration
// over an N-dimensional rectangular region", J. Comput. Appl. Math. 6(4), 1980): per cell a
// 17-point rule exact for polynomials of degree 7 and its embedded degree-5 rule, whose
// difference is the cell's error estimate; the cell of largest estimate is halved, across the
// axis of larger fourth difference, until the estimates sum to the tolerance.
#pragma once

#include <utility>
#include <vector>

#include "formfactors/receiver_cells.h"
#include "geometry/polygon.h"
#include "patching/patching.h"
#include "visibility/shadow_clipping.h"
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

// One occluded source of the row.
struct OccludedSource {
  int patch = -1;              // j, a patch of the mesh
  Polygon exchanging_part;     // the part of P_j in front of P_i's plane (convex)
  std::vector<int> occluders;  // sorted occluder indices (ShaftCuller) that may meet the pair's shaft
};

struct OccludedRowResult {
  double error = 0.0;             // estimated absolute error of Σ_j blocked_j (what the row sum may be off)
  long long evaluations = 0;      // (receiver point, source) visible factors computed
  long long points = 0;           // receiver points
  int cells = 0;                  // cells the receiver ended in
  bool budget_exhausted = false;  // stopped by the budget with error > the tolerance
};

// One per thread (keeps its buffers and its PointVisibility between rows); `vis` in exact mode.
class OccludedRowIntegrator {
 public:
  OccludedRowIntegrator(const Visibility& vis, const PatchMesh& mesh);

  // blocked[k] = (1/A_i) ∫ h_j dA for j = sources[k].patch and receiver i, a patch of the mesh,
  // dimensionless, to an absolute accuracy `tolerance` (> 0) on their sum, spending at most about
  // `max_evaluations` (receiver point, source) evaluations.
  OccludedRowResult integrate(int receiver, const std::vector<OccludedSource>& sources, double tolerance,
                              long long max_evaluations, std::vector<double>& blocked);

 private:
  // Occluder indices occluder_pool_[first, first + count).
  struct OccluderSpan {
    int first = 0, count = 0;
  };
  struct Box {
    int cell;
    double s0, s1, t0, t1;
    double error;                         // Σ over `active` of source_error
    bool split_s;                         // halve across s (else t)
    std::vector<int> active;              // sources (indices into the row's) not settled on this box
    std::vector<OccluderSpan> occluders;  // per active source: those that may meet its shaft from the box
    std::vector<double> integral;         // per active source: ∫ h_j over the box (m²)
    std::vector<double> source_error;
  };
  void cut_along_standing_occluders(const std::vector<OccludedSource>& sources);
  // Box b's active sources among `candidates` (sources with the occluders that may meet their shaft
  // from a box containing b) and their integrals; false when none is left (h_j = 0 on the box
  // exactly for every candidate).
  bool evaluate(const std::vector<std::pair<int, OccluderSpan>>& candidates, Box& b);
  // h_j(x) = F(dA_x → P_j) − F_vis(dA_x → P_j) for source k of the row at point `at`, given the
  // occluders that may meet its shaft from x (volumes_ started at x); `lit`: some of the source
  // above x's horizon is visible.
  double blocked_at(const Receiver& at, int k, OccluderSpan occluders, bool& lit);
  // True when the piece of the receiver lies under a convex solid standing on it (a table leg on a
  // floor quad): nothing is visible from it.
  bool under_a_solid(const Polygon& piece) const;
  // A lower bound of the distance from `centre` (the current box's) to occluder o, metres.
  double occluder_distance(int o, const Vec3& centre);

  const Visibility& vis_;
  const PatchMesh& mesh_;
  visibility_detail::ShadowVolumes volumes_;  // seen from the current receiver point
  visibility_detail::PiecePool pieces_clip_, hidden_;
  std::vector<int> casting_;  // scratch of blocked_at
  // Per solid: whether the current receiver point is outside it (ShaftCuller::drop_hidden_occluders),
  // kept across the point's sources.
  std::vector<signed char> outside_state_;
  std::vector<int> touched_solids_;
  std::vector<int> occluder_pool_;  // the row's occluder lists (OccluderSpan), appended as boxes are culled
  // The receiver and the sources of the current row.
  const std::vector<OccludedSource>* sources_ = nullptr;
  Vec3 receiver_[4];
  int receiver_count_ = 0;
  int receiver_face_ = -1;  // its scene face: the receiver points lie inside it
  Vec3 normal_;
  std::vector<Polygon> pieces_, next_pieces_;
  std::vector<ReceiverCell> cells_;
  std::vector<Box> heap_;
  std::vector<std::vector<Vec3>> source_corners_;  // per source of the row
  std::vector<int> shaft_, parent_list_;           // scratch of the per-source culling
  std::vector<int> standing_;                      // the row's occluders touching or crossing the receiver
  std::vector<double> g_;                          // per (active source, point): h_j times the Jacobian
  std::vector<unsigned char> lit_;                 // per (active source, point): blocked_at's `lit`
  std::vector<long long> near_stamp_;              // per occluder: the box its near_ distance is for
  std::vector<double> near_;
  long long box_stamp_ = 0;
  long long evaluations_ = 0, points_evaluated_ = 0;
};

}  // namespace photometria
