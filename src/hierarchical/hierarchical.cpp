#include "hierarchical/hierarchical.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>

#include "formfactors/aligned_rectangles.h"
#include "formfactors/pair_integration.h"
#include "formfactors/quadrature.h"
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
    if (opt_.min_edge <= 0.0) {
      Eigen::AlignedBox3d box;
      for (const Vec3& v : roots.points) box.extend(v);
      opt_.min_edge = box.isEmpty() ? 0.0 : box.diagonal().norm() / 256.0;
    }
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
  }

  HierarchicalSolution run() {
    HierarchicalStats& st = stats_;
    st.roots = roots_.size();
    st.error = opt_.error;
    st.min_edge = opt_.min_edge;
    // Initial links: every facing pair of roots (no clustering yet).
    std::vector<std::pair<int, int>> pending;
    for (int p = 0; p < roots_.size(); ++p)
      for (int q = 0; q < roots_.size(); ++q)
        if (p != q && facing(p, q)) pending.emplace_back(p, q);
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
        ++gathered;
        h += f * q.radiosity;
      }
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
      for (const Link& l : links_[p]) n += refinement(int(p), l, threshold) != 0;
    return n;
  }

  double bytes() const {
    long long links = 0;
    for (const auto& v : links_) links += static_cast<long long>(v.capacity());
    return double(elements_.capacity()) * sizeof(Element) + double(links_.capacity()) * sizeof(std::vector<Link>) +
           double(links) * sizeof(Link);
  }

  // Refines every link above the error with the present radiosity, the new links in turn,
  // until none is above it. Returns the links split.
  long long refine() {
    const double threshold = opt_.error * mean_radiosity();
    long long split_count = 0;
    std::vector<int> receivers(elements_.size());
    for (size_t e = 0; e < receivers.size(); ++e) receivers[e] = int(e);
    while (!receivers.empty()) {
      std::vector<std::pair<int, int>> pending;
      const int before = static_cast<int>(elements_.size());
      for (const int p : receivers) {
        // Taken out while its links are split: split() grows links_, which moves the lists.
        std::vector<Link> ls = std::move(links_[size_t(p)]);
        size_t kept = 0;
        for (size_t k = 0; k < ls.size(); ++k) {
          const Link l = ls[k];
          const int side = stats_.stopped_by_memory ? 0 : refinement(p, l, threshold);
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
      const Rgb& bq = elements_[size_t(l.source)].radiosity;
      h += double(l.factor) * bq;
      range += 2.0 * double(l.error) * largest(bq);  // the link's kernel range over e (link())
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
      for (int r = 0; r < roots_.size(); ++r) sweep(r, Rgb::Zero(), 0.0, change);
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
    long long links = 0;
    for (const auto& v : links_) links += static_cast<long long>(v.size());
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
          h += double(l.factor) * elements_[size_t(l.source)].radiosity;
          row += l.factor;
        }
      s.irradiance.row(i) = h.matrix().transpose();
      s.radiosity.row(i) = el.radiosity.matrix().transpose();
      s.direct.row(i) = el.direct.matrix().transpose();
      s.row_sums[i] = row;
    }
    stats_.elements = static_cast<int>(elements_.size());
    stats_.leaves = n;
    stats_.links = links;
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
