// Hierarchical radiosity: link refinement over element quadtrees, solved by gathering with
// push–pull, so that memory and time follow the links the requested error needs instead of N².
//
// Hanrahan, Salzman & Aupperle, "A Rapid Hierarchical Radiosity Algorithm", SIGGRAPH 1991:
//  - Every root patch (an input face) is the root of a quadtree of elements: a quad splits into
//    four at its edge midpoints and centre, a triangle into four at its edge midpoints.
//  - A link p <- q carries the form factor F_pq of receiver element p from source element q:
//      F_pq = F_unoccluded(p -> q) · Σ_k w_k F_vis(dA_{x_k} -> q) / Σ_k w_k F(dA_{x_k} -> q)
//    the unoccluded factor exact for two rectangles along one frame (formfactors/aligned_rectangles.h:
//    Howell's C-11 / C-14 superposed), else from the per-pair rule (formfactors/pair_integration.h:
//    Lambert's exact point-to-polygon kernel, the receiver integral adaptive near shared edges),
//    the visible share from p's 2 × 2 Gauss points x_k (visibility/: exact clipping or rays).
//  - Refinement with the radiosity it carries ("BF refinement": Hanrahan et al. 1991; Cohen &
//    Wallace, "Radiosity and Realistic Image Synthesis", 1993, ch. 7), for an output gathered at
//    every point (Baum et al. 1989, below), with ΔF_pq the range of F_vis(dA_x -> q) over p's
//    Gauss points and centroid:
//      e_source   = ρ_p F_pq S_q   (S_q: how much q's radiosity varies over q; the range of its
//                                   children's, or on a leaf ρ_q Σ ΔF B over the links it gathers)
//      e_receiver = ρ_p B_q ½ ΔF_pq, on links with an occluder in their shaft only (elsewhere the
//                                   gather's exact kernel makes it no error of the output)
//    A link is refined while max(e_receiver, e_source) > ε B̄ max(F_pq, 0.1) (B̄ the scene's
//    area-weighted mean radiosity; each link's share of the receiver's error budget grows with
//    what it carries, so a leaf's many links do not add up past ε), the larger term choosing the
//    element to split, down to the smallest element allowed (docs/theory.md "Hierarchical
//    radiosity").
//  - Solve by gathering: H_p = Σ_{links p<-q} F_pq B_q at every level; push (a child inherits
//    its ancestors' gathered irradiance), at the leaves B = E + ρ (H + H_direct), pull (an
//    element's B is the area-weighted mean of its children's). Sweeps over the roots in order
//    (Gauss–Seidel across roots: later roots see the updated radiosity), to the solver's
//    relative tolerance.
//  - Refine with the solution, solve again, until no link needs refinement (rounds).
//  - Above HierarchicalOptions::cluster_above roots, the first links are made down a cluster tree
//    over the roots (clusters.h; Smits, Arvo & Greenberg, SIGGRAPH 1994) instead of between every
//    facing pair of roots: a link joins two clusters (or a cluster and a root) where both are
//    convex, nothing else lies in the shaft of their boxes, every source face turns toward the
//    receiver, they lie more than twice their radii apart, and the transfer's error estimate
//    times the radiosity it carries is within the threshold above held to the link's own factor
//    (without the 0.1 floor: a cluster link's error reaches the output directly); else the
//    larger side is split, down to pairs of roots, which are linked as above. Cluster links are
//    refined the same way after each solve. A leaf gathers them through its root's enclosing
//    clusters, each evaluated at the receiving point (clusters.h cluster_factor_at).
#pragma once

#include <functional>
#include <memory>
#include <string>

#include "patching/patching.h"
#include "pipeline/direct_light.h"
#include "scene/scene.h"
#include "solver/solver.h"
#include "visibility/visibility.h"

namespace photometria {

struct HierarchicalOptions {
  // ε, dimensionless: a link is refined while its estimated radiosity error exceeds ε times the
  // scene's area-weighted mean radiosity. Default 1e-2.
  double error = 1e-2;
  // Metres: an element whose longest edge is at most this is not split (0: 1/256 of the
  // scene's bounding diagonal).
  double min_edge = 0.0;
  // Roots above which the first links are made down a cluster tree (clusters.h; Smits, Arvo &
  // Greenberg 1994) instead of between every facing pair of roots; 0: always (two roots or
  // more); negative: never. Default 512: below it the pairs are cheap and every link exact.
  int cluster_above = 512;
  int max_rounds = 8;          // refine–solve rounds at most
  double tolerance = 1e-8;     // relative residual of a sweep (max |ΔB| / max B) to stop at
  int max_iterations = 10000;  // sweeps per solve
  // Bytes the elements and links may take; refinement stops (and says so) rather than exceed
  // it. 0 = no limit.
  double max_memory_bytes = 0.0;
  int rays = kAdaptiveRays;  // ray visibility: rays per (point, element), as SolveOptions::rays
  uint64_t seed = 1;
  // Optional: called with ("links", fraction of the rounds done), from one thread at a time.
  std::function<void(const std::string& stage, double fraction)> progress;
};

struct HierarchicalStats {
  int roots = 0, elements = 0, leaves = 0;
  int clusters = 0;               // of the cluster tree (0 without one)
  long long links = 0;            // links of the final hierarchy
  long long cluster_links = 0;    // of them, with a cluster at either end
  long long links_evaluated = 0;  // link form factors computed, refined ones included
  int rounds = 0;                 // refine–solve rounds
  int sweeps = 0;                 // Gauss–Seidel sweeps, all solves
  double residual = 0.0;          // of the last sweep
  bool converged = false;
  bool stopped_by_memory = false;      // refinement stopped at max_memory_bytes
  bool stopped_by_rounds = false;      // links still above ε after max_rounds
  double bytes = 0.0;                  // elements and links, at the end
  double error = 0.0, min_edge = 0.0;  // the ε and minimum element edge used
};

// Per leaf element, as the dense solve gives per patch.
struct HierarchicalSolution {
  PatchMesh leaves;                     // the leaf elements as patches (their faces and normals are the roots')
  ChannelMatrix irradiance, radiosity;  // leaves × 3, W/m²
  Eigen::VectorXd row_sums;             // Σ F over the links of a leaf and its ancestors
  ChannelMatrix direct;                 // H_direct at each leaf's centroid (analytic lights)
  HierarchicalStats stats;
};

// The hierarchy of one scene: refined and solved by solve(), then asked for the irradiance at
// any point of a leaf (the vertex gather).
class HierarchicalRadiosity {
 public:
  // `roots`: patches of the scene's faces (one per face gives the fewest initial links).
  // `visibility` may be null (a convex enclosure: nothing blocks). The arguments must outlive
  // this object.
  HierarchicalRadiosity(const Scene& scene, const PatchMesh& roots, const Visibility* visibility,
                        const DirectLighting& lights, const HierarchicalOptions& options);
  ~HierarchicalRadiosity();
  HierarchicalRadiosity(const HierarchicalRadiosity&) = delete;
  HierarchicalRadiosity& operator=(const HierarchicalRadiosity&) = delete;

  // Refines and solves. Throws Error(NotConverged) when a solve hits max_iterations.
  HierarchicalSolution solve();

  // H(x) without the analytic lights, for a point x on leaf `leaf` (an index into the solution's
  // leaves): Σ over the links of the leaf and its ancestors of F_vis(dA_x -> q) B_q (Baum,
  // Rushmeier & Winget 1989's vertex gather, over the links instead of every patch). Each
  // link's source is seen from x itself: Lambert's factor; where the link's shaft held an
  // occluder, clipped against the occluders in the shaft from x when they are few (32 at most),
  // else times the link's visible share (refinement bounds how much that share varies over the
  // link's receiver). Thread-safe after solve(); `tally` collects ray counts.
  Rgb irradiance_at(const Receiver& x, int leaf, RayTally& tally, long long& links_gathered) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace photometria
