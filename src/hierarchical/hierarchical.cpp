#include "hierarchical/hierarchical.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>

#include "formfactors/aligned_rectangles.h"
#include "formfactors/pair_integration.h"
#include "formfactors/quadrature.h"
#include "hierarchical/clusters.h"
#include "kernels/lambert.h"
#include "util/error.h"

namespace photometria {

namespace {

// One node of an element quadtree. Children are four consecutive elements.
struct Element {
  Vec3 corners[4];
  int corner_count = 0;
  int patch = 0;  // the root patch (index into the roots mesh) it descends from
  int parent = -1, first_child = -1;
  double area = 0.0, longest_edge = 0.0;
  Vec3 centroid = Vec3::Zero();
  Rgb emission = Rgb::Zero(), reflectance = Rgb::Zero(), direct = Rgb::Zero();
  Rgb radiosity = Rgb::Zero();
  // How much the radiosity varies over the element (largest channel): max − min of the
  // children's radiosity, or on a leaf the estimate from the links it gathers (sweep()).
  double spread = 0.0;
  bool leaf() const { return first_child < 0; }
};

// A link's source is an element (>= 0) or a cluster (clusters.h cluster_node: < 0). A link with a
// cluster at either end (kept at the receiving cluster, or at a root element when only the
// source is a cluster) carries the transfer at the receiver's centre (clusters.h
// cluster_transfer: `factor` with the receiver turned toward the source, `error` its estimate),
// for refinement; the gather evaluates it at each receiver point (transfer_at).
struct Link {
  int source : 31;
  // Whether an occluder lay in the shaft from the receiver to the source: a point of the
  // receiver needs visibility to the source only then (its shaft lies inside that one).
  unsigned occluded : 1;
  float factor;   // F_pq, the receiver's mean over its Gauss points
  float error;    // estimated error of `factor` (Link evaluation: the rule's, and shadows')
  float visible;  // the visible share of the unoccluded factor, over p's Gauss points
};
static_assert(sizeof(Link) == 16, "links are most of the hierarchy's memory");

double largest(const Rgb& v) { return v.maxCoeff(); }

// Relative tolerance of a link's unoccluded factor (pair_form_factor).
constexpr double kLinkTolerance = 1e-4;
// A link may carry error up to its share of the receiver's irradiance, ε B̄ max(F_pq, this).
constexpr double kLinkShareFloor = 0.1;
// The vertex gather clips a link's source against the occluders in its shaft from the point
// when there are at most this many; beyond, clipping costs more than the link's error allows
// for, and the link's visible share is used.
constexpr size_t kExactGatherOccluders = 32;

}  // namespace

struct HierarchicalRadiosity::Impl {
  Impl(const Scene& scene, const PatchMesh& roots, const Visibility* vis, const DirectLighting& lights,
       const HierarchicalOptions& opt)
      : scene_(scene), roots_(roots), vis_(vis), lights_(lights), opt_(opt) {
    Eigen::AlignedBox3d box;
    for (const Vec3& v : roots.points) box.extend(v);
    const double diagonal = box.isEmpty() ? 0.0 : box.diagonal().norm();
    if (opt_.min_edge <= 0.0) opt_.min_edge = diagonal / 256.0;
    elements_.reserve(size_t(roots.size()) * 4);
    for (int i = 0; i < roots.size(); ++i) {
      Element e;
      const Patch& p = roots.patches[size_t(i)];
      e.corner_count = p.corner_count;
      roots.polygon(i, e.corners);
      e.patch = i;
      add(e);
    }
    links_.resize(elements_.size());
    light_new_elements(0);
    clustered_ = opt_.cluster_above >= 0 && roots.size() > std::max(opt_.cluster_above, 1);
    if (clustered_) build_clusters(1e-9 * diagonal);
  }

  HierarchicalSolution run() {
    HierarchicalStats& st = stats_;
    st.roots = roots_.size();
    st.error = opt_.error;
    st.min_edge = opt_.min_edge;
    // Initial links: down the cluster tree from the top cluster with itself (link_from_top), or
    // every facing pair of roots.
    std::vector<std::pair<int, int>> pending;
    if (clustered_) {
      link_from_top(opt_.error * mean_radiosity(), pending);
    } else {
      for (int p = 0; p < roots_.size(); ++p)
        for (int q = 0; q < roots_.size(); ++q)
          if (p != q && facing(p, q)) pending.emplace_back(p, q);
    }
    evaluate(pending);
    solve();
    for (int round = 0; round < opt_.max_rounds; ++round) {
      if (opt_.progress) opt_.progress("links", double(round) / opt_.max_rounds);
      ++st.rounds;
      const long long split = refine();
      solve();
      if (split == 0 || st.stopped_by_memory) break;
      if (round + 1 == opt_.max_rounds) st.stopped_by_rounds = links_above_error() > 0;
    }
    if (opt_.progress) opt_.progress("links", 1.0);
    return result();
  }

  Rgb irradiance_at(const Receiver& x, int leaf, RayTally& tally, long long& gathered) const {
    Rgb h = Rgb::Zero();
    std::vector<int> occluders;
    for (int e = leaf_element_[size_t(leaf)]; e >= 0; e = elements_[size_t(e)].parent)
      for (const Link& l : links_[size_t(e)]) {
        ++gathered;
        if (l.source < 0) {  // from a cluster: its transfer, unoccluded (link_nodes)
          h += transfer_at(l, x.point, x.normal) * node_radiosity(l.source);
          continue;
        }
        const Element& q = elements_[size_t(l.source)];
        const Vec3& nq = normal(l.source);
        // x on q's boundary (a crease): Lambert's limit from x.approach, as the dense gather.
        double f = lambert_form_factor(x, q.corners, q.corner_count);
        if (vis_ && f > 0.0 && l.occluded) {
          occluders.clear();
          vis_->culler().occluders(&x.point, 1, q.corners, q.corner_count, occluders, true);
          if (occluders.size() > kExactGatherOccluders) {
            // Shadows as the link has them: refinement kept the link only where its visible
            // share varies over the receiver by no more than the error allows.
            f *= double(l.visible);
          } else if (!occluders.empty()) {
            const uint64_t stream = pair_stream(opt_.seed ^ 0x5eedULL, uint64_t(leaf), uint64_t(l.source));
            f = vis_->point_to_patch(x, q.corners, q.corner_count, nq, f, occluders, opt_.rays, stream, tally, true);
          }
        }
        h += f * q.radiosity;
      }
    gather_clusters(elements_[size_t(leaf_element_[size_t(leaf)])].patch, x.point, x.normal, h, nullptr, nullptr,
                    &gathered);
    return h;
  }

  void add(Element e) {
    const int n = e.corner_count;
    Polygon poly(e.corners, e.corners + n);
    e.area = polygon_area(poly);
    e.centroid = polygon_centroid(poly);
    for (int k = 0; k < n; ++k)
      e.longest_edge = std::max(e.longest_edge, (e.corners[(k + 1) % n] - e.corners[k]).norm());
    const Material& m = scene_.materials[size_t(scene_.faces[size_t(roots_.patches[size_t(e.patch)].face)].material)];
    e.emission = m.emission;
    e.reflectance = m.reflectance;
    e.radiosity = m.emission;
    elements_.push_back(e);
  }
  const Vec3& normal(int e) const { return roots_.patches[size_t(elements_[size_t(e)].patch)].normal; }

  // --- Clusters (clusters.h): a tree over the roots, linked from the top down (link_nodes). ---

  void build_clusters(double tolerance) {
    cluster_faces_.resize(size_t(roots_.size()));
    for (int r = 0; r < roots_.size(); ++r) {
      const Element& e = elements_[size_t(r)];
      ClusterFace& f = cluster_faces_[size_t(r)];
      std::copy(e.corners, e.corners + 4, f.corners);
      f.corner_count = e.corner_count;
      f.normal = normal(r);
      f.centroid = e.centroid;
      f.area = e.area;
      f.reflectance = largest(e.reflectance);
    }
    tree_ = build_cluster_tree(cluster_faces_, tolerance);
    cluster_links_.resize(tree_.clusters.size());
    cluster_radiosity_.assign(tree_.clusters.size(), Rgb::Zero());
    cluster_spread_.assign(tree_.clusters.size(), 0.0);
    cluster_low_.assign(tree_.clusters.size(), 0.0);
    roots_of_face_.resize(scene_.faces.size());
    for (int r = 0; r < roots_.size(); ++r) roots_of_face_[size_t(roots_.patches[size_t(r)].face)].push_back(r);
    pull_clusters();
  }

  const Cluster& cluster(int node) const { return tree_.clusters[size_t(cluster_of_node(node))]; }
  const Rgb& node_radiosity(int node) const {
    return node >= 0 ? elements_[size_t(node)].radiosity : cluster_radiosity_[size_t(cluster_of_node(node))];
  }
  double node_spread(int node) const {
    return node >= 0 ? elements_[size_t(node)].spread : cluster_spread_[size_t(cluster_of_node(node))];
  }
  double node_area(int node) const { return node >= 0 ? elements_[size_t(node)].area : cluster(node).area; }
  // The node's corners (a root's) or its box's 8, in a loop along the box's edges (the shaft's
  // hull candidates take consecutive points as edges).
  int node_points(int node, Vec3* out) const {
    if (node >= 0) {
      const Element& e = elements_[size_t(node)];
      std::copy(e.corners, e.corners + e.corner_count, out);
      return e.corner_count;
    }
    box_corners(cluster(node).box, out);  // recognised by the shaft as a box (visibility.h)
    return 8;
  }
  // The points of a node's side of a cluster link's shaft: its box's corners (box_corners), also
  // for a root in a plane of the axes, whose box is a rectangle of that plane around it, so that
  // the shaft is one of two boxes (visibility.h: Haines & Wallace's planes, a dozen at most);
  // other roots give their corners.
  int shaft_points(int node, Vec3* out) const {
    if (node >= 0) {
      const Vec3& n = normal(node);
      if (n.cwiseAbs().maxCoeff() < 1.0 - 1e-12) return node_points(node, out);
      const Element& e = elements_[size_t(node)];
      Eigen::AlignedBox3d box;
      for (int k = 0; k < e.corner_count; ++k) box.extend(e.corners[k]);
      box_corners(box, out);
      return 8;
    }
    return node_points(node, out);
  }
  bool node_holds(int node, int root) const {
    if (node >= 0) return node == root;
    const Cluster& c = cluster(node);
    const int k = tree_.position[size_t(root)];
    return k >= c.first && k < c.first + c.count;
  }

  // Area-weighted mean radiosity of each cluster, and how much it varies over the cluster: the
  // range of its roots' radiosity (largest channel). The error of sending one mean is at most
  // the factor times that range (cluster_link_above).
  void pull_clusters() {
    for (size_t c = 0; c < tree_.clusters.size(); ++c) {
      const Cluster& cl = tree_.clusters[c];
      Rgb b = Rgb::Zero();
      double lo = 1e300, hi = -1e300;
      for (int child : cl.children) {
        const Rgb& bc = node_radiosity(child);
        b += node_area(child) * bc;
        lo = std::min(lo, child >= 0 ? largest(bc) : cluster_low_[size_t(cluster_of_node(child))]);
        hi = std::max(hi, child >= 0 ? largest(bc)
                                     : cluster_low_[size_t(cluster_of_node(child))] +
                                           cluster_spread_[size_t(cluster_of_node(child))]);
      }
      cluster_radiosity_[c] = b / cl.area;
      cluster_low_[c] = lo;
      cluster_spread_[c] = hi - lo;
    }
  }

  // F(dA_x <- source) of a link with a cluster at either end, at point x of normal n: Lambert's
  // exact factor when the source is a root (its polygon), the cluster transfer when it is a
  // cluster (clusters.h); nothing blocks it (link_nodes).
  double transfer_at(const Link& l, const Vec3& x, const Vec3& n) const {
    if (l.source >= 0) {
      const Element& q = elements_[size_t(l.source)];
      return lambert_form_factor(Receiver{x, n}, q.corners, q.corner_count);
    }
    const Cluster& c = cluster(l.source);
    return cluster_factor_at(x, n, c);
  }

  // The factor of link l at receiver element e (normal n): an element link's own, or a
  // cluster source's transfer at e's centroid.
  double factor_at(int e, const Link& l, const Vec3& n) const {
    return l.source >= 0 ? double(l.factor) : transfer_at(l, elements_[size_t(e)].centroid, n);
  }

  // How much what a cluster link sends (factor f at x, from a source at distance d) varies over
  // root r: the cosine and 1/d² change by about r/d and 2r/d across it.
  double cluster_range_over_root(int root, double f, double d) const {
    return 2.0 * f * 3.0 * node_radius(tree_, cluster_faces_, root) / d;
  }

  // What the links of root's enclosing clusters bring to point x (normal n) on the root:
  // irradiance into h, and (when asked) the range of what they send over the root, their
  // factors' sum, and how many links were gathered.
  void gather_clusters(int root, const Vec3& x, const Vec3& n, Rgb& h, double* range, double* row,
                       long long* count) const {
    if (!clustered_) return;
    for (int c = tree_.parent[size_t(root)]; c >= 0; c = tree_.clusters[size_t(c)].parent)
      for (const Link& l : cluster_links_[size_t(c)]) {
        const double f = transfer_at(l, x, n);
        const Rgb& b = node_radiosity(l.source);
        h += f * b;
        if (range)
          *range +=
              cluster_range_over_root(root, f, (node_centre(tree_, cluster_faces_, l.source) - x).norm()) * largest(b);
        if (row) *row += f;
        if (count) ++*count;
      }
  }

  // Whether a root can exchange light with a node: some corner of the node (its box's, for a
  // cluster) clearly in front of the root's plane.
  bool in_front_of_root(int root, int node) const {
    Vec3 points[8];
    const int n = node_points(node, points);
    const Element& e = elements_[size_t(root)];
    const double tol = 1e-9 * e.longest_edge;
    for (int k = 0; k < n; ++k)
      if (normal(root).dot(points[k] - e.corners[0]) > tol) return true;
    return false;
  }

  // Which side of a cluster link to split: the one that is a cluster, the larger when both are.
  int split_side(int a, int b) const {
    if (b >= 0) return 1;
    if (a >= 0) return 2;
    return node_radius(tree_, cluster_faces_, a) >= node_radius(tree_, cluster_faces_, b) ? 1 : 2;
  }

  // The error a cluster link leaves at the receiver: the transfer's error estimate times the
  // radiosity it carries, and the source's spread times its factor (as e_source of element
  // links). Held to the threshold times the link's own factor, without the element links'
  // floor: the output gathers a cluster link as it is, so its error is not one the exact kernel
  // at each point removes, and the links of one receiver must not add up past ε.
  bool cluster_link_above(int a, const Link& l, double threshold) const {
    const double rho = a >= 0 ? largest(elements_[size_t(a)].reflectance) : cluster(a).reflectance;
    const double e = std::max(rho * largest(node_radiosity(l.source)) * double(l.error),
                              rho * double(l.factor) * node_spread(l.source));
    return e > threshold * double(l.factor);
  }

  // Nothing can block a segment between a and b: both convex (clusters.h) and the shaft of
  // their boxes holds no occluder but those made of their own faces (a face without roots, one
  // that only obstructs, is never theirs).
  bool unblocked(int a, int b, std::vector<int>& occluders) const {
    if ((a < 0 && !cluster(a).convex) || (b < 0 && !cluster(b).convex)) return false;
    if (!vis_) return true;
    Vec3 pa[8], pb[8];
    const int na = shaft_points(a, pa), nb = shaft_points(b, pb);
    vis_->culler().occluders(pa, na, pb, nb, occluders);
    for (const int o : occluders)
      for (const int f : vis_->culler().occluder_faces(o)) {
        if (roots_of_face_[size_t(f)].empty()) return false;
        for (const int r : roots_of_face_[size_t(f)])
          if (!node_holds(a, r) && !node_holds(b, r)) return false;
      }
    return true;
  }

  // What linking down the tree makes from one pair of nodes (link_nodes), kept apart per pair
  // so that pairs run in parallel and their results join in the pairs' order.
  struct TreeLinks {
    std::vector<std::pair<int, int>> pending;  // pairs of roots, for evaluate()
    std::vector<std::pair<int, Link>> made;    // cluster links, by receiver node
    long long evaluated = 0;
  };

  // Links receiver node a from source node b (not both roots): a cluster link where the
  // transfer is valid, unblocked and within the error; else down the tree, the larger side
  // first; pairs of roots go to `pending` (element links, evaluate()).
  void link_nodes(int a, int b, double threshold, TreeLinks& out, std::vector<int>& occluders) const {
    if (a >= 0 && b >= 0) {
      if (a != b && facing(a, b)) out.pending.emplace_back(a, b);
      return;
    }
    if (a == b) {  // a cluster with itself: every pair of its children
      const Cluster c = cluster(a);
      for (const int x : c.children)
        for (const int y : c.children) link_nodes(x, y, threshold, out, occluders);
      return;
    }
    if ((a >= 0 && !in_front_of_root(a, b)) || (b >= 0 && !in_front_of_root(b, a))) return;
    ++out.evaluated;
    const ClusterTransfer t = cluster_transfer(tree_, cluster_faces_, a, b);
    if (t.valid) {
      const Link l{b, 0, float(t.factor), float(t.error), 1.0f};
      if (!cluster_link_above(a, l, threshold) && unblocked(a, b, occluders)) {
        out.made.emplace_back(a, l);
        return;
      }
    }
    split_cluster_link(a, b, threshold, out, occluders);
  }
  void split_cluster_link(int a, int b, double threshold, TreeLinks& out, std::vector<int>& occluders) const {
    if (split_side(a, b) == 1) {
      for (const int x : cluster(a).children) link_nodes(x, b, threshold, out, occluders);
    } else {
      for (const int y : cluster(b).children) link_nodes(a, y, threshold, out, occluders);
    }
  }

  // link_nodes (or, with `split`, split_cluster_link) on every pair, in parallel; the cluster
  // links made are added to their receivers' lists and the pairs of roots to `pending`, in the
  // pairs' order (the same hierarchy for any thread count).
  void link_down(const std::vector<std::pair<int, int>>& pairs, bool split, double threshold,
                 std::vector<std::pair<int, int>>& pending) {
    constexpr size_t kChunk = 1 << 14;
    for (size_t begin = 0; begin < pairs.size(); begin += kChunk) {
      const int n = static_cast<int>(std::min(kChunk, pairs.size() - begin));
      std::vector<TreeLinks> out(static_cast<size_t>(n));
#pragma omp parallel
      {
        std::vector<int> occluders;
#pragma omp for schedule(dynamic, 16)
        for (int k = 0; k < n; ++k) {
          const auto [a, b] = pairs[begin + size_t(k)];
          if (split) split_cluster_link(a, b, threshold, out[size_t(k)], occluders);
          else link_nodes(a, b, threshold, out[size_t(k)], occluders);
        }
      }
      for (const TreeLinks& t : out) {
        pending.insert(pending.end(), t.pending.begin(), t.pending.end());
        for (const auto& [receiver, l] : t.made)
          (receiver < 0 ? cluster_links_[size_t(cluster_of_node(receiver))] : links_[size_t(receiver)]).push_back(l);
        stats_.links_evaluated += t.evaluated;
      }
    }
  }

  // The first links: a cluster with itself links its children pairwise, so the pairs of
  // different children of every cluster are where linking down the tree starts.
  void link_from_top(double threshold, std::vector<std::pair<int, int>>& pending) {
    std::vector<std::pair<int, int>> pairs;
    for (const Cluster& c : tree_.clusters) {
      pairs.emplace_back(c.children[0], c.children[1]);
      pairs.emplace_back(c.children[1], c.children[0]);
    }
    link_down(pairs, false, threshold, pending);
  }

  // Cluster links above the error with the present radiosity, split down the tree; the pairs of
  // roots this reaches go to `pending`. Returns the links split.
  long long refine_cluster_links(double threshold, std::vector<std::pair<int, int>>& pending) {
    std::vector<std::pair<int, int>> split;
    auto take_out = [&](int receiver, std::vector<Link>& ls) {
      size_t kept = 0;
      for (const Link& l : ls) {
        const bool cluster_link = receiver < 0 || l.source < 0;
        if (cluster_link && cluster_link_above(receiver, l, threshold)) split.emplace_back(receiver, l.source);
        else ls[kept++] = l;
      }
      ls.resize(kept);
    };
    for (size_t c = 0; c < cluster_links_.size(); ++c) take_out(cluster_node(int(c)), cluster_links_[c]);
    for (int r = 0; r < roots_.size(); ++r) take_out(r, links_[size_t(r)]);
    link_down(split, true, threshold, pending);
    return static_cast<long long>(split.size());
  }

  // H_direct at the centroid of the elements from `first` on (analytic lights).
  void light_new_elements(int first) {
    if (lights_.empty()) return;
    const int n = static_cast<int>(elements_.size());
#pragma omp parallel for schedule(dynamic, 64)
    for (int e = first; e < n; ++e) elements_[size_t(e)].direct = lights_.at(elements_[size_t(e)].centroid, normal(e));
  }

  // Four children, at the edge midpoints (and the centre of a quad).
  void split(int e) {
    if (!elements_[size_t(e)].leaf()) return;
    const Element parent = elements_[size_t(e)];
    const Vec3* c = parent.corners;
    const int first = static_cast<int>(elements_.size());
    auto child = [&](std::initializer_list<Vec3> corners) {
      Element k;
      k.corner_count = static_cast<int>(corners.size());
      std::copy(corners.begin(), corners.end(), k.corners);
      k.patch = parent.patch;
      k.parent = e;
      add(k);
      elements_.back().radiosity = parent.radiosity;
    };
    if (parent.corner_count == 4) {
      const Vec3 m01 = 0.5 * (c[0] + c[1]), m12 = 0.5 * (c[1] + c[2]), m23 = 0.5 * (c[2] + c[3]),
                 m30 = 0.5 * (c[3] + c[0]), mid = 0.25 * (c[0] + c[1] + c[2] + c[3]);
      child({c[0], m01, mid, m30});
      child({m01, c[1], m12, mid});
      child({mid, m12, c[2], m23});
      child({m30, mid, m23, c[3]});
    } else {
      const Vec3 m01 = 0.5 * (c[0] + c[1]), m12 = 0.5 * (c[1] + c[2]), m20 = 0.5 * (c[2] + c[0]);
      child({c[0], m01, m20});
      child({m01, c[1], m12});
      child({m20, m12, c[2]});
      child({m01, m12, m20});
    }
    elements_[size_t(e)].first_child = first;
    links_.resize(elements_.size());
  }
  bool splittable(int e) const { return elements_[size_t(e)].longest_edge > opt_.min_edge; }

  // Whether p and q can exchange light: each has a corner clearly in front of the other's plane
  // (facing.h's test on patches, here on elements).
  bool facing(int p, int q) const {
    auto in_front = [&](int a, int b) {
      const Element& ea = elements_[size_t(a)];
      const Element& eb = elements_[size_t(b)];
      const double tol = 1e-9 * std::max(ea.longest_edge, eb.longest_edge);
      for (int k = 0; k < ea.corner_count; ++k)
        if (normal(b).dot(ea.corners[k] - eb.corners[0]) > tol) return true;
      return false;
    };
    return in_front(p, q) && in_front(q, p);
  }

  // Link form factors of the (receiver, source) pairs, in parallel, appended to the receivers'
  // links.
  void evaluate(const std::vector<std::pair<int, int>>& pairs) {
    std::vector<Link> out(pairs.size());
    const int n = static_cast<int>(pairs.size());
#pragma omp parallel
    {
      std::vector<int> occluders;
      RayTally tally;
#pragma omp for schedule(dynamic, 64)
      for (int k = 0; k < n; ++k)
        out[size_t(k)] = link(pairs[size_t(k)].first, pairs[size_t(k)].second, occluders, tally);
    }
    for (int k = 0; k < n; ++k) links_[size_t(pairs[size_t(k)].first)].push_back(out[size_t(k)]);
    stats_.links_evaluated += n;
  }

  Link link(int p, int q, std::vector<int>& occluders, RayTally& tally) const {
    const Element& ep = elements_[size_t(p)];
    const Element& eq = elements_[size_t(q)];
    const Vec3& np = normal(p);
    const Vec3& nq = normal(q);
    occluders.clear();
    if (vis_) vis_->culler().occluders(ep.corners, ep.corner_count, eq.corners, eq.corner_count, occluders);
    int k = 0;
    // F_vis(dA_x -> q), and F(dA_x -> q) into f0.
    auto visible_factor = [&](const Vec3& x, double& f0) {
      const Receiver r{x, np};
      f0 = lambert_form_factor(r, eq.corners, eq.corner_count);
      double f = f0;
      if (vis_ && !occluders.empty() && f0 > 0.0) {
        const uint64_t stream = pair_stream(pair_stream(opt_.seed, uint64_t(p), uint64_t(q)), uint64_t(k), 0);
        // x lies inside p, so inside its root's scene face.
        f = vis_->point_to_patch(r, eq.corners, eq.corner_count, nq, f0, occluders, opt_.rays, stream, tally, false,
                                 roots_.patches[size_t(ep.patch)].face);
      }
      ++k;
      return f;
    };
    // The unoccluded factor: exact for two rectangles along one frame (aligned_rectangles.h:
    // Howell's C-11 / C-14 superposed; the elements of a rectilinear room), else to a tolerance
    // (pair_integration.h: exact kernel, receiver integral adaptive near shared edges);
    // occluders scale it by the visible share at p's points.
    double unoccluded = 0.0;
    if (ep.corner_count == 4 && eq.corner_count == 4 &&
        aligned_rectangle_pair(ep.corners, np, eq.corners, nq, unoccluded))
      unoccluded /= ep.area;
    else
      unoccluded = pair_form_factor(ep.corners, ep.corner_count, np, eq.corners, eq.corner_count, nq, kLinkTolerance)
                       .form_factor;
    double visible = 0.0, total = 0.0, lo = 1e300, hi = -1e300;
    for (const QuadraturePoint& x : patch_quadrature(ep.corners, ep.corner_count, 2)) {
      double f0 = 0.0;
      const double f = visible_factor(x.point, f0);
      visible += x.weight * f;
      total += x.weight * f0;
      lo = std::min(lo, f);
      hi = std::max(hi, f);
    }
    double f0 = 0.0;
    const double centre = visible_factor(ep.centroid, f0);
    lo = std::min(lo, centre);
    hi = std::max(hi, centre);
    const double share = total > 0.0 && visible < total ? visible / total : 1.0;
    // p's radiosity is one value; what q sends it varies over p by about half the kernel's range
    // (with visibility) between p's points: the piecewise-constant error the link leaves.
    const double error = 0.5 * (hi - lo);
    return Link{q, !occluders.empty(), float(unoccluded * share), float(error), float(share)};
  }

  double mean_radiosity() const {
    double sum = 0.0, area = 0.0;
    for (int r = 0; r < roots_.size(); ++r) {
      sum += elements_[size_t(r)].area * largest(elements_[size_t(r)].radiosity);
      area += elements_[size_t(r)].area;
    }
    return area > 0.0 ? sum / area : 0.0;
  }

  // Which side of link (p <- l) to split: 0 none, 1 the receiver, 2 the source.
  int refinement(int p, const Link& l, double threshold) const {
    const Element& ep = elements_[size_t(p)];
    const Element& eq = elements_[size_t(l.source)];
    const double rho = largest(ep.reflectance);
    // What q sends varies over p; the output gathers it at each point with the exact kernel, so
    // that error reaches the output only through p's radiosity as a source (its spread, counted
    // by e_source of the links from p), and through the link's visible share where the gather
    // falls back on it (more occluders than it clips).
    const double e_receiver = l.occluded ? rho * largest(eq.radiosity) * l.error : 0.0;
    const double e_source = rho * l.factor * eq.spread;
    if (std::max(e_receiver, e_source) <= threshold * std::max(double(l.factor), kLinkShareFloor)) return 0;
    const bool receiver_first = e_receiver >= e_source;
    if (receiver_first ? splittable(p) : splittable(l.source)) return receiver_first ? 1 : 2;
    if (receiver_first ? splittable(l.source) : splittable(p)) return receiver_first ? 2 : 1;
    return 0;
  }

  long long links_above_error() const {
    const double threshold = opt_.error * mean_radiosity();
    long long n = 0;
    for (size_t p = 0; p < links_.size(); ++p)
      for (const Link& l : links_[p])
        n += l.source < 0 ? cluster_link_above(int(p), l, threshold) : refinement(int(p), l, threshold) != 0;
    for (size_t c = 0; c < cluster_links_.size(); ++c)
      for (const Link& l : cluster_links_[c]) n += cluster_link_above(cluster_node(int(c)), l, threshold);
    return n;
  }

  double bytes() const {
    long long links = 0;
    for (const auto& v : links_) links += static_cast<long long>(v.capacity());
    for (const auto& v : cluster_links_) links += static_cast<long long>(v.capacity());
    return double(elements_.capacity()) * sizeof(Element) +
           double(links_.capacity() + cluster_links_.capacity()) * sizeof(std::vector<Link>) +
           double(links) * sizeof(Link) + double(tree_.clusters.capacity()) * (sizeof(Cluster) + sizeof(Rgb) + 8) +
           double(cluster_faces_.capacity()) * (sizeof(ClusterFace) + 3 * sizeof(int));
  }

  // Refines every link above the error with the present radiosity, the new links in turn,
  // until none is above it. Returns the links split.
  long long refine() {
    const double threshold = opt_.error * mean_radiosity();
    long long split_count = 0;
    std::vector<std::pair<int, int>> pending;
    if (clustered_ && !stats_.stopped_by_memory) split_count += refine_cluster_links(threshold, pending);
    std::vector<int> receivers(elements_.size());
    for (size_t e = 0; e < receivers.size(); ++e) receivers[e] = int(e);
    while (!receivers.empty()) {
      const int before = static_cast<int>(elements_.size());
      for (const int p : receivers) {
        // Taken out while its links are split: split() grows links_, which moves the lists.
        std::vector<Link> ls = std::move(links_[size_t(p)]);
        size_t kept = 0;
        for (size_t k = 0; k < ls.size(); ++k) {
          const Link l = ls[k];
          // Cluster links (l.source < 0) were refined above (refine_cluster_links).
          const int side = stats_.stopped_by_memory || l.source < 0 ? 0 : refinement(p, l, threshold);
          if (side == 0) {
            ls[kept++] = l;
            continue;
          }
          ++split_count;
          const int e = side == 1 ? p : l.source;
          split(e);
          const int first = elements_[size_t(e)].first_child;
          for (int c = first; c < first + 4; ++c) {
            const int rp = side == 1 ? c : p, rq = side == 1 ? l.source : c;
            if (facing(rp, rq)) pending.emplace_back(rp, rq);
          }
        }
        ls.resize(kept);
        links_[size_t(p)] = std::move(ls);
      }
      light_new_elements(before);
      // Children inherit their parent's radiosity (split); new elements start without links.
      std::sort(pending.begin(), pending.end());
      pending.erase(std::unique(pending.begin(), pending.end()), pending.end());
      evaluate(pending);
      receivers.clear();
      for (const auto& [p, q] : pending)
        if (receivers.empty() || receivers.back() != p) receivers.push_back(p);
      receivers.erase(std::unique(receivers.begin(), receivers.end()), receivers.end());
      pending.clear();
      if (opt_.max_memory_bytes > 0.0 && bytes() > opt_.max_memory_bytes) stats_.stopped_by_memory = true;
    }
    return split_count;
  }

  // Gathers, pushes and pulls the subtree of e with the irradiance gathered above it (and the
  // range over e of what that irradiance's links send, `above_range`); returns its new
  // radiosity. Records the largest change at a leaf.
  Rgb sweep(int e, const Rgb& above, double above_range, double& change) {
    Element& el = elements_[size_t(e)];
    Rgb h = above;
    double range = above_range;
    for (const Link& l : links_[size_t(e)]) {
      const Rgb& bq = node_radiosity(l.source);
      const double f = factor_at(e, l, normal(e));
      h += f * bq;
      // The link's kernel range over e (link()), or a cluster transfer's over the root.
      range +=
          (l.source >= 0
               ? 2.0 * double(l.error)
               : cluster_range_over_root(
                     e, f, (node_centre(tree_, cluster_faces_, l.source) - elements_[size_t(e)].centroid).norm())) *
          largest(bq);
    }
    if (el.leaf()) {
      const Rgb b = el.emission + el.reflectance * (h + el.direct);
      change = std::max(change, (b - el.radiosity).abs().maxCoeff());
      el.radiosity = b;
      // One value stands for a radiosity that varies by up to ρ times the range of the
      // irradiance; the links leaving this leaf are refined (e_source) where that matters.
      el.spread = largest(el.reflectance) * range;
      return b;
    }
    Rgb b = Rgb::Zero();
    double lo = 1e300, hi = -1e300;
    const int first = el.first_child;
    for (int c = first; c < first + 4; ++c) {
      const Rgb bc = sweep(c, h, range, change);
      b += elements_[size_t(c)].area * bc;
      lo = std::min(lo, largest(bc));
      hi = std::max(hi, largest(bc));
    }
    Element& after = elements_[size_t(e)];
    after.radiosity = b / after.area;
    after.spread = hi - lo;
    return after.radiosity;
  }

  void solve() {
    for (int it = 0; it < opt_.max_iterations; ++it) {
      double change = 0.0, top = 0.0;
      for (int r = 0; r < roots_.size(); ++r) {
        Rgb above = Rgb::Zero();
        double range = 0.0;
        gather_clusters(r, elements_[size_t(r)].centroid, normal(r), above, &range, nullptr, nullptr);
        sweep(r, above, range, change);
      }
      if (clustered_) pull_clusters();
      for (int r = 0; r < roots_.size(); ++r) top = std::max(top, largest(elements_[size_t(r)].radiosity));
      ++stats_.sweeps;
      stats_.residual = top > 0.0 ? change / top : 0.0;
      if (stats_.residual <= opt_.tolerance) {
        stats_.converged = true;
        return;
      }
    }
    stats_.converged = false;
    std::ostringstream m;
    m << scene_.source << ": the hierarchical solve did not converge in " << opt_.max_iterations
      << " sweeps (relative change " << stats_.residual << " > tolerance " << opt_.tolerance
      << "); raise --max-iterations";
    throw Error(ErrorKind::NotConverged, m.str());
  }

  // The leaves as a patch mesh, with the irradiance and the row sums gathered down their paths.
  HierarchicalSolution result() {
    HierarchicalSolution s;
    std::vector<int> leaves;
    for (size_t e = 0; e < elements_.size(); ++e)
      if (elements_[e].leaf()) leaves.push_back(int(e));
    leaf_element_ = leaves;
    const int n = static_cast<int>(leaves.size());
    s.irradiance.resize(n, 3);
    s.radiosity.resize(n, 3);
    s.direct.resize(n, 3);
    s.row_sums.resize(n);
    std::map<std::array<double, 3>, int> point_of;
    long long links = 0, cluster_links = 0;  // all, and those with a cluster at either end
    for (const auto& v : links_) {
      links += static_cast<long long>(v.size());
      for (const Link& l : v) cluster_links += l.source < 0;
    }
    for (const auto& v : cluster_links_) {
      links += static_cast<long long>(v.size());
      cluster_links += static_cast<long long>(v.size());
    }
    for (int i = 0; i < n; ++i) {
      const int leaf = leaves[size_t(i)];
      const Element& el = elements_[size_t(leaf)];
      Patch patch;
      patch.corner_count = el.corner_count;
      patch.face = roots_.patches[size_t(el.patch)].face;
      patch.normal = normal(leaf);
      patch.centroid = el.centroid;
      patch.area = el.area;
      for (int k = 0; k < el.corner_count; ++k) {
        const Vec3& c = el.corners[k];
        const auto [it, fresh] = point_of.try_emplace({c.x(), c.y(), c.z()}, int(s.leaves.points.size()));
        if (fresh) s.leaves.points.push_back(c);
        patch.corners[size_t(k)] = it->second;
      }
      s.leaves.patches.push_back(patch);
      Rgb h = el.direct;
      double row = 0.0;
      for (int e = leaf; e >= 0; e = elements_[size_t(e)].parent)
        for (const Link& l : links_[size_t(e)]) {
          const double f = factor_at(e, l, patch.normal);
          h += f * node_radiosity(l.source);
          row += f;
        }
      gather_clusters(el.patch, el.centroid, patch.normal, h, nullptr, &row, nullptr);
      s.irradiance.row(i) = h.matrix().transpose();
      s.radiosity.row(i) = el.radiosity.matrix().transpose();
      s.direct.row(i) = el.direct.matrix().transpose();
      s.row_sums[i] = row;
    }
    stats_.elements = static_cast<int>(elements_.size());
    stats_.leaves = n;
    stats_.links = links;
    stats_.cluster_links = cluster_links;
    stats_.clusters = static_cast<int>(tree_.clusters.size());
    stats_.bytes = bytes();
    s.stats = stats_;
    return s;
  }

  const Scene& scene_;
  const PatchMesh& roots_;
  const Visibility* vis_;
  const DirectLighting& lights_;
  HierarchicalOptions opt_;
  std::vector<Element> elements_;
  std::vector<std::vector<Link>> links_;  // per receiver element
  HierarchicalStats stats_;
  std::vector<int> leaf_element_;  // per leaf of the solution: its element
  // Clusters (clustered_: more roots than HierarchicalOptions::cluster_above).
  bool clustered_ = false;
  std::vector<ClusterFace> cluster_faces_;  // per root
  ClusterTree tree_;
  std::vector<std::vector<Link>> cluster_links_;  // per cluster, as receiver
  std::vector<Rgb> cluster_radiosity_;            // per cluster: its roots' area-weighted mean
  std::vector<double> cluster_spread_;            // per cluster: how much that varies over its roots
  std::vector<double> cluster_low_;               // per cluster: the least of its roots' (largest channel)
  std::vector<std::vector<int>> roots_of_face_;   // per scene face: its roots
};

HierarchicalRadiosity::HierarchicalRadiosity(const Scene& scene, const PatchMesh& roots, const Visibility* visibility,
                                             const DirectLighting& lights, const HierarchicalOptions& options) {
  if (!(options.error > 0.0) || !std::isfinite(options.error))
    throw Error(ErrorKind::BadInput, "hierarchical error must be finite and > 0");
  impl_ = std::make_unique<Impl>(scene, roots, visibility, lights, options);
}
HierarchicalRadiosity::~HierarchicalRadiosity() = default;
HierarchicalSolution HierarchicalRadiosity::solve() { return impl_->run(); }
Rgb HierarchicalRadiosity::irradiance_at(const Receiver& x, int leaf, RayTally& tally, long long& gathered) const {
  return impl_->irradiance_at(x, leaf, tally, gathered);
}

}  // namespace photometria
