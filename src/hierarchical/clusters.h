// Clusters of root elements for hierarchical radiosity: a binary tree over the input faces, so
// that the first links join groups of faces where the error allows, instead of every facing pair
// of faces (quadratic in the input).
//
// Smits, Arvo & Greenberg, "A Clustering Algorithm for Radiosity in Complex Environments",
// SIGGRAPH 1994: light is exchanged between clusters through links whose error is estimated, and
// refined down the cluster tree, then down the elements, where the estimate is too large.
//
// The transfer from a source cluster B to a receiver point x (normal n_x), cluster_factor_at:
// Σ_q ∫_q K(x, y, n_q) dA_y over B's faces q, with the point-to-point kernel
// K = cos θ_x cos θ_y / (π r²) = (n_x · w)(−n_q · w) / (π |w|⁴), w = y − x (Cohen & Wallace,
// "Radiosity and Realistic Image Synthesis", 1993, ch. 4, the form factor between two
// differential areas), expanded in y about B's area centroid c_B (δ = y − c_B, w = c_B − x,
// d = |w|, a = n_x · w); K is linear in n_q, so the expansion needs only three sums over B:
//   zeroth order:  K(x, c_B, N_B), with N_B = Σ_q A_q n_q its vector area:
//                  F0 = a (−N_B · w) / (π d⁴)            (B as one flat emitter at c_B)
//   first order:   ∇_y K · δ summed over B, with T = Σ_q A_q n_q (c_q − c_B)ᵀ, which vanishes
//                  for a flat B (the offsets of one plane's area cancel about its centroid):
//                  F1 = (−wᵀ T n_x − a tr T) / (π d⁴) + 4 a (wᵀ T w) / (π d⁶)
//   second order:  ½ tr(H M) with M = Σ_q ∫_q δ δᵀ dA (the area's second moment about c_B) and
//                  H the Hessian of K in y for the mean normal m = N_B / A_B (b = −m · w):
//                  π tr(H M) = −2 n_xᵀ M m / d⁴ − 8 wᵀ M (n_x b − m a) / d⁶ − 4 a b tr M / d⁶
//                              + 24 a b (wᵀ M w) / d⁸
// F = max(0, F0 + F1 + F2), and 0 where x's horizon or B's faces turn from the centre (a ≤ 0 or
// −N_B · w ≤ 0). For a disk of radius ρ on the axis at distance d this gives ρ²/d² − ρ⁴/d⁴, the
// first two terms of the exact ρ²/(ρ² + d²); B as a point (F0 alone) overestimates by the
// second. What is left is third order in r_B / d, plus the second-order part of the normals'
// spread over B (H taken for the mean normal).
// When every face of B faces every point of the receiver (checked per face: n_q · (c_A − c_q) > r_A),
// no face turns away within the link, so the expansion holds over the whole receiver. The estimate
// used (cluster_transfer), with R = r_A + r_B and F the factor at A's centre:
//     e = F · ((R / d)² + (r_B / d) φ_B)
// bounds B as a point (F0 alone) and so, more loosely, the expansion; it was checked against
// Lambert's exact factor on 6,080 points of 380 random pairs of clusters
// (tests/test_hierarchical_clusters.cpp), where the expansion's error was at most 0.038 of e (0.40
// of e for B as a point, F0 alone). A root element as the source is not approximated: the
// gather takes Lambert's factor to its polygon.
//
// Visibility: a cluster link is made only when nothing can block a segment between its two sides
// (hierarchical.cpp): no occluder in the shaft of their bounding boxes besides their own faces,
// and each side convex (every corner of its faces on or behind the plane of each of its faces), so
// that a face of A turned toward a point of B looks out of A's hull and never through it. A scene
// of concave parts (a room and its furniture) is then linked at clusters only inside its flat or
// convex parts, and between elements elsewhere.
#pragma once

#include <vector>

#include "geometry/polygon.h"

namespace photometria {

// One root element as the tree sees it.
struct ClusterFace {
  Vec3 corners[4];
  int corner_count = 0;
  Vec3 normal = Vec3::Zero();  // unit, the front side
  Vec3 centroid = Vec3::Zero();
  double area = 0.0;         // m²
  double reflectance = 0.0;  // the largest channel
};

// Node ids name either a face (>= 0, an index into the faces) or a cluster c (-1 - c).
inline int cluster_node(int c) { return -1 - c; }
inline int cluster_of_node(int node) { return -1 - node; }

struct Cluster {
  Eigen::AlignedBox3d box;          // of its faces' corners
  Vec3 centre = Vec3::Zero();       // its faces' area centroid
  Vec3 vector_area = Vec3::Zero();  // Σ A_q n_q over its faces, m²
  double normal_spread = 0.0;       // radians: the largest angle between a face's normal and vector_area
  double radius = 0.0;              // metres: the farthest corner of its faces from the centre
  Eigen::Matrix3d area_moment = Eigen::Matrix3d::Zero();    // M = Σ_q ∫_q (y − centre)(y − centre)ᵀ dA, m⁴
  Eigen::Matrix3d normal_offset = Eigen::Matrix3d::Zero();  // T = Σ_q A_q n_q (c_q − centre)ᵀ, m³
  double area = 0.0;                                        // m², its faces' total
  double reflectance = 0.0;                                 // the largest of its faces'
  int children[2] = {0, 0};                                 // node ids
  int parent = -1;                                          // a cluster index, -1 at the top
  int first = 0, count = 0;                                 // its faces: ClusterTree::order[first, first + count)
  bool convex = false;  // every corner of its faces on or behind each of its faces' planes
};

struct ClusterTree {
  std::vector<Cluster> clusters;    // children before parents: the top is the last
  std::vector<int> order;           // the faces, each cluster's a contiguous range
  std::vector<int> position;        // per face: its index in `order`
  std::vector<int> parent;          // per face: the cluster holding it, -1 when there is one face
  std::vector<double> face_radius;  // per face: its farthest corner from its centroid, metres
  // The node holding everything: the top cluster, or face 0 alone; -1 without faces.
  int top() const { return clusters.empty() ? (order.empty() ? -1 : 0) : cluster_node(int(clusters.size()) - 1); }
};

// Splits the faces at the median of their keys along the longest axis of the keys' box, down to
// single faces (a bounding volume hierarchy built top-down, as Kay & Kajiya, "Ray Tracing Complex
// Scenes", SIGGRAPH 1986); a face's key is its centroid and its normal times half the centroids'
// bounding diagonal, so that faces turned differently part near the top. `tolerance`, metres:
// how far in front of a plane a corner may lie and still count as on it (convexity). A cluster
// of more than kMaxConvexPlanes distinct face planes is not tested and counts as not convex (the
// test's cost would otherwise grow with each face).
inline constexpr int kMaxConvexPlanes = 32;
ClusterTree build_cluster_tree(const std::vector<ClusterFace>& faces, double tolerance);

// A node's centre and radius: a cluster's, or for a face its centroid and farthest corner.
Vec3 node_centre(const ClusterTree& tree, const std::vector<ClusterFace>& faces, int node);
double node_radius(const ClusterTree& tree, const std::vector<ClusterFace>& faces, int node);

struct ClusterTransfer {
  bool valid = false;     // d > 2 R and every face of the source faces the receiver's ball
  double distance = 0.0;  // d between the centres, metres
  double factor = 0.0;    // F at the receiver's centre, with n_x along u
  double error = 0.0;     // the estimate e above
};

// The transfer to receiver node A from source node B, as above (factor and error left 0 when not
// valid). Visibility is the caller's.
ClusterTransfer cluster_transfer(const ClusterTree& tree, const std::vector<ClusterFace>& faces, int receiver,
                                 int source);

// F(dA_x <- B) at point x of unit normal `normal`, as above: B's expansion to second order.
double cluster_factor_at(const Vec3& x, const Vec3& normal, const Cluster& source);

}  // namespace photometria
