#include "formfactors/formfactors.h"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <memory>

#include "formfactors/aligned_rectangles.h"
#include "formfactors/facing.h"
#include "formfactors/occluded_row.h"
#include "formfactors/pair_integration.h"
#include "formfactors/quadrature.h"
#include "kernels/lambert.h"
#include "kernels/lambert_batch.h"
#include "util/per_thread.h"

namespace photometria {

double plane_tolerance(const PatchMesh& mesh) {
  double m = 0.0;
  for (const Vec3& p : mesh.points) m = std::max(m, p.lpNorm<Eigen::Infinity>());
  return 1e-12 * std::max(m, 1e-300);
}

PolygonBatch patch_batch(const PatchMesh& mesh) {
  PolygonBatch batch;
  batch.reserve(mesh.size());
  Vec3 v[4];
  for (int j = 0; j < mesh.size(); ++j) {
    mesh.polygon(j, v);
    batch.push_back(v, mesh.patches[j].corner_count);
  }
  batch.share_edges();  // neighbouring patches share corners: each edge's term once per point
  return batch;
}

namespace {

// The fill's counts (FillStats): pairs by what became of them, rays and kernel evaluations. One
// set per thread, added up after the rows (integers: the order of the sums does not matter).
struct FillCounts {
  long long evaluated = 0, backfacing = 0, tested = 0, culled = 0, occluded = 0, rays = 0, above = 0, rescaled = 0;
  long long fixed_rule = 0, gauss = 0, adaptive = 0, kernels = 0, exact_rectangles = 0;
  long long occluded_adaptive = 0, occluded_evaluations = 0, occluded_budget = 0, blocked_whole = 0;

  void merge(const FillCounts& o) {
    evaluated += o.evaluated;
    backfacing += o.backfacing;
    tested += o.tested;
    culled += o.culled;
    occluded += o.occluded;
    rays += o.rays;
    above += o.above;
    rescaled += o.rescaled;
    fixed_rule += o.fixed_rule;
    gauss += o.gauss;
    adaptive += o.adaptive;
    kernels += o.kernels;
    exact_rectangles += o.exact_rectangles;
    occluded_adaptive += o.occluded_adaptive;
    occluded_evaluations += o.occluded_evaluations;
    occluded_budget += o.occluded_budget;
    blocked_whole += o.blocked_whole;
  }
};

// What every row of one fill reads: set up before the rows, shared by the threads.
struct FillSetup {
  const PatchMesh& mesh;
  const FillOptions& options;
  int n;
  double tol;                       // plane_tolerance(mesh)
  const Visibility* vis;            // null: no occlusion
  bool rays_mode;                   // vis in ray mode
  bool per_pair;                    // accuracy mode: the per-pair rule for pairs nothing can block
  const AlignedRectangles* rects;   // per-pair mode with closed forms for aligned rectangles, else null
  bool mirror;                      // closed forms once per pair, the lower row's entry mirrored later
  bool prefetch;                    // prefetch patch records ahead of the pair loop
  const PolygonBatch& sources;      // every patch, for the batched kernel
  const FacingGroups& facing_runs;  // the facing test per group of coplanar sources
};

// One row F_i,· of the fill: receiver patch i, its quadrature rule and the row's buffers, and
// one function per kind of pair: closed form mirrored, per-pair rule (nothing can block), the
// fixed rule with visibility from one point (PointVisibility) or per receiver point (the pair's
// shaft). Values and the order of every sum are those of the single loop this was cut from.
class RowFill {
 public:
  // grouped, point_visibility: the thread's (null without visibility); row: n entries, zero.
  RowFill(const FillSetup& setup, int i, GroupedShaftCuller* grouped, PointVisibility* point_visibility,
          OccludedRowIntegrator* occluded, double* row, FillCounts& counts)
      : s_(setup), i_(i), pi_(setup.mesh.patches[i]), grouped_(grouped), occluded_(occluded), row_(row), k_(counts) {
    s_.mesh.polygon(i, ri_);
    rule_ = patch_quadrature(ri_, pi_.corner_count, s_.options.quadrature);
    nq_ = static_cast<int>(rule_.size());
    point_sum_.assign(size_t(nq_), 0.0);
    if (s_.rays_mode) ray_part_.assign(size_t(nq_) * s_.n, 0.0);
    unoccluded_.resize(size_t(nq_));
    // With a one-point rule and no per-pair rule, visibility is taken from that point alone
    // (PointVisibility: the point's shafts, narrower than the patch's, and in exact mode one
    // clipping per tile of patches rather than per patch).
    const bool point_shafts = !s_.per_pair && nq_ == 1;
    from_point_ = s_.vis && point_shafts ? point_visibility : nullptr;
    if (from_point_) from_point_->set_receiver(Receiver{rule_[0].point, pi_.normal}, pi_.face);
    else if (grouped_) grouped_->set_receiver(ri_, pi_.corner_count);
  }

  // Every pair (i, j), j != i, into row[j].
  void fill_pairs() {
    for (int j = 0; j < s_.n; ++j) {
      if (s_.prefetch) s_.mesh.prefetch(j + 16);
      if (j == i_) continue;
      pair(j);
    }
    if (occluded_) occluded_row();
  }

  // A receiver point sees at most its hemisphere: Σ_j F_vis(x_q -> P_j) <= 1. Scale the
  // ray-estimated terms of a point whose sum exceeds that (see the header). Raises
  // max_point_sum to the row's largest point sum.
  double row_error() const { return row_error_; }
  // Ray mode: the estimated standard error of the row's sum, √(Σ_j Σ_q w_q² F_q² var V_q)
  // (independent estimates; RayTally).
  double row_ray_error() const { return std::sqrt(row_ray_variance_); }

  void rescale_rays(double& max_point_sum) {
    for (int q = 0; q < nq_; ++q) {
      max_point_sum = std::max(max_point_sum, point_sum_[q]);
      if (!s_.rays_mode || point_sum_[q] <= 1.0) continue;
      double ray_sum = 0.0;
      for (int j = 0; j < s_.n; ++j) ray_sum += ray_part_[size_t(q) * s_.n + j];
      if (ray_sum <= 0.0) continue;
      // Keep the unoccluded (culled) terms, shrink the ray terms so the point's sum becomes 1.
      const double keep = std::max(0.0, 1.0 - (point_sum_[q] - ray_sum)) / ray_sum;
      if (keep >= 1.0) continue;
      ++k_.rescaled;
      for (int j = 0; j < s_.n; ++j) {
        const double v = ray_part_[size_t(q) * s_.n + j];
        if (v > 0.0) row_[j] = std::max(0.0, row_[j] - rule_[q].weight * v * (1.0 - keep));
      }
    }
  }

 private:
  // F_ij: a pair facing away is skipped; aligned rectangles take their closed form (mirrored,
  // or as a pair nothing can block); per-pair mode tests the shaft first; the rest take the
  // fixed rule.
  void pair(int j) {
    const bool analytic = s_.rects && s_.rects->eligible(i_, j);
    double area_factor = 0.0;
    if (analytic) {
      if (s_.mirror && j < i_) return;             // from row j's entry after the loop (reciprocity)
      area_factor = s_.rects->area_factor(i_, j);  // 0 exactly when the pair cannot exchange light
      const int count = s_.mirror ? 2 : 1;         // with mirroring this stands for (i, j) and (j, i)
      if (!(area_factor > 0.0)) {
        k_.backfacing += count;
        return;
      }
      if (s_.mirror) {
        row_[j] = area_factor / pi_.area;
        k_.evaluated += 2;
        k_.exact_rectangles += 2;
        return;
      }
    } else if (classify_row(); facing_[size_t(j)] == Facing::Away ||
                               (facing_[size_t(j)] == Facing::Test && facing_away(s_.mesh, i_, j, s_.tol))) {
      ++k_.backfacing;
      return;
    }
    have_sj_ = false;  // P_j's corners, fetched only where needed (not for closed forms)
    bool shaft_known = false;
    if (s_.per_pair) {
      if (s_.vis) {
        source(j);
        ++k_.tested;
        grouped_->occluders(j, sj_, s_.mesh.patches[j].corner_count, occluders_);
        if (!occluders_.empty()) narrow_to_exchanging_parts(j);
        shaft_known = true;
      }
      if (!s_.vis || occluders_.empty()) {
        k_.culled += s_.vis != nullptr;
        store_for_every_point(j, unoccluded_pair(j, analytic, area_factor));
        return;
      }
      if (blocked_by_one_occluder()) {
        ++k_.occluded;
        ++k_.blocked_whole;
        store_for_every_point(j, 0.0);
        return;
      }
      if (occluded_) {
        defer_occluded_pair(j, analytic, area_factor);
        return;
      }
    }
    fixed_rule(j, shaft_known);
  }

  // True when one occluder of the pair's shaft blocks every segment between the parts of the
  // patches that exchange light (ShaftCuller::blocks_every_segment): F_ij = 0 exactly, no rule needed.
  bool blocked_by_one_occluder() const {
    if (receiver_part_.size() < 3 || source_part_.size() < 3) return false;
    for (const int o : occluders_)
      if (s_.vis->culler().blocks_every_segment(receiver_part_.data(), int(receiver_part_.size()), source_part_.data(),
                                                int(source_part_.size()), o))
        return true;
    return false;
  }

  // Per-pair mode: the pair's value stands in for each receiver point's.
  void store_for_every_point(int j, double f) {
    ++k_.evaluated;
    row_[j] = f;
    for (int q = 0; q < nq_; ++q) point_sum_[q] += f;
  }

  // Per-pair mode, exact visibility, occluders in the pair's shaft: the unoccluded factor now,
  // less the blocked part once the row's occluded pairs are known (occluded_row).
  void defer_occluded_pair(int j, bool analytic, double area_factor) {
    row_[j] = unoccluded_pair(j, analytic, area_factor);
    occluded_sources_.push_back({j, source_part_, occluders_});
  }

  // The blocked parts of the row's occluded pairs, integrated together to the requested accuracy
  // on the row (occluded_row.h).
  void occluded_row() {
    if (occluded_sources_.empty()) return;
    const OccludedRowResult r = occluded_->integrate(i_, occluded_sources_, s_.options.occluded_tolerance,
                                                     s_.options.occluded_budget, blocked_);
    for (size_t k = 0; k < occluded_sources_.size(); ++k) {
      const int j = occluded_sources_[k].patch;
      const double f0 = row_[j];
      const double f = std::clamp(f0 - blocked_[k], 0.0, f0);
      ++k_.evaluated;
      ++k_.occluded_adaptive;
      if (f == 0.0) ++k_.occluded;
      row_[j] = f;
      for (int q = 0; q < nq_; ++q) point_sum_[q] += f;
    }
    k_.occluded_evaluations += r.evaluations;
    k_.occluded_budget += r.budget_exhausted;
    row_error_ = r.error;
  }

  // Per-pair mode, the factor with nothing in the way: the closed form of aligned rectangles,
  // else the per-pair rule to the requested accuracy.
  double unoccluded_pair(int j, bool analytic, double area_factor) {
    const Patch& pj = s_.mesh.patches[j];
    double f;
    if (analytic) {
      f = area_factor / pi_.area;
      ++k_.exact_rectangles;
    } else {
      const PairResult r = pair_form_factor(ri_, pi_.corner_count, pi_.normal, source(j), pj.corner_count, pj.normal,
                                            s_.options.tolerance);
      f = r.form_factor;
      k_.kernels += r.evaluations;
      k_.gauss += r.rule == PairRule::Gauss;
      k_.adaptive += r.rule == PairRule::Adaptive;
    }
    return f;
  }

  // The fixed rule: Lambert's kernel at each receiver point (unoccluded_), then, with
  // visibility, its visible part: from the one point (visible_from_point: the patch's tile
  // alone where that settles it) or per point in the pair's shaft (visible_per_point).
  void fixed_rule(int j, bool shaft_known) {
    const Patch& pj = s_.mesh.patches[j];
    ++k_.fixed_rule;
    k_.kernels += nq_;
    double f0 = 0.0;
    for (int q = 0; q < nq_; ++q) {
      // A receiver point in P_j's plane sees P_j edge-on. Lambert's kernel returns its limit
      // from P_j's front when the point is on P_j's boundary (right for vertices at creases);
      // an interior quadrature point lands there only where a face of an occluder stands on
      // patch i (a table leg on the floor), and then that limit and the occlusion seen from
      // the point itself would count half a hemisphere twice. With visibility on, take 0.
      unoccluded_[q] = s_.vis && std::abs(pj.normal.dot(rule_[q].point - pj.centroid)) <= s_.vis->culler().tolerance()
                           ? 0.0
                           : kernel_at(q, j);
      f0 += rule_[q].weight * unoccluded_[q];
    }
    ++k_.evaluated;
    double f = f0;
    if (from_point_ && f0 > 0.0) {
      f = visible_from_point(j, f0);
    } else if (s_.vis && f0 > 0.0) {
      f = visible_per_point(j, f0, shaft_known);
    }
    for (int q = 0; q < nq_; ++q) point_sum_[q] += unoccluded_[q];
    row_[j] = f;
  }

  // The one-point rule's visible factor from PointVisibility (f0: the unoccluded one): by the
  // patch's tile where that settles it, else by clipping or rays (visible_factor).
  double visible_from_point(int j, double f0) {
    ++k_.tested;
    // Only rays use the pair's stream.
    const uint64_t stream =
        s_.rays_mode ? pair_stream(pair_stream(s_.options.seed, uint64_t(i_), uint64_t(j)), 0, 0) : 0;
    RayTally tally;
    const PointVisibility::VisibleFactor v =
        from_point_->visible_factor(j, unoccluded_[0], s_.options.rays, stream, tally);
    add_rays(tally, rule_[0].weight);
    if (v.unshadowed) ++k_.culled;
    if (s_.rays_mode && !v.unshadowed) ray_part_[size_t(j)] = v.value;
    unoccluded_[0] = v.value;
    const double f = rule_[0].weight * v.value;
    if (f == 0.0) ++k_.occluded;
    if (f > f0) ++k_.above;
    return f;
  }

  // The visible factor summed over the receiver points, each culled in the pair's shaft (tested
  // already where shaft_known) and then by Visibility::point_to_patch (f0: the unoccluded one).
  double visible_per_point(int j, double f0, bool shaft_known) {
    const Patch& pj = s_.mesh.patches[j];
    if (!shaft_known) {
      ++k_.tested;
      grouped_->occluders(j, source(j), pj.corner_count, occluders_);
    }
    if (occluders_.empty()) {
      ++k_.culled;
      return f0;
    }
    double f = 0.0;
    const uint64_t stream = pair_stream(s_.options.seed, uint64_t(i_), uint64_t(j));
    RayTally tally;
    for (int q = 0; q < nq_; ++q) {
      const double v = s_.vis->point_to_patch(Receiver{rule_[q].point, pi_.normal}, source(j), pj.corner_count,
                                              pj.normal, unoccluded_[q], occluders_, s_.options.rays,
                                              pair_stream(stream, uint64_t(q), 0), tally, false, pi_.face);
      add_rays(tally, rule_[q].weight);
      if (s_.rays_mode) ray_part_[size_t(q) * s_.n + j] = v;
      unoccluded_[q] = v;  // now the visible factor
      f += rule_[q].weight * v;
    }
    if (f == 0.0) ++k_.occluded;
    if (f > f0) ++k_.above;
    return f;
  }

  // Only the part of P_i in front of P_j's plane and the part of P_j in front of P_i's plane
  // exchange light (the cosine factor of the other side is <= 0 elsewhere), so only segments
  // between those parts need to be unblocked. Their shaft lies inside the pair's, so its occluders
  // are found among the pair's (ShaftCuller::occluders_among). This is what frees a pair that
  // touches a convex solid it belongs to (a table leg's face and the floor quad the leg stands
  // on): the solid's other faces lie behind the face's plane, outside the narrower shaft.
  void narrow_to_exchanging_parts(int j) {
    const Patch& pj = s_.mesh.patches[j];
    clip_to_halfspace_at(ri_, pi_.corner_count, sj_[0], pj.normal, receiver_part_);
    clip_to_halfspace_at(sj_, pj.corner_count, ri_[0], pi_.normal, source_part_);
    if (receiver_part_.size() < 3 || source_part_.size() < 3) {
      occluders_.clear();  // no exchange at all: nothing to block
      return;
    }
    if (receiver_part_.size() + source_part_.size() > 24) return;  // (cannot happen for quads)
    candidates_.swap(occluders_);
    s_.vis->culler().occluders_among(receiver_part_.data(), int(receiver_part_.size()), source_part_.data(),
                                     int(source_part_.size()), candidates_, occluders_);
  }

  // A point's ray tally into the row's counts, with the point's rule weight.
  void add_rays(RayTally& tally, double weight) {
    k_.rays += tally.cast;
    row_ray_variance_ += weight * weight * tally.variance;
    tally = {};
  }

  // P_j's corners (sj_), fetched on first need per pair.
  Vec3* source(int j) {
    if (!have_sj_) s_.mesh.polygon(j, sj_);
    have_sj_ = true;
    return sj_;
  }

  // The facing classes of the row, on first need (closed-form pairs do not use them).
  void classify_row() {
    if (facing_.empty()) {
      facing_.resize(static_cast<size_t>(s_.n));
      s_.facing_runs.classify(i_, facing_.data());
    }
  }

  // Lambert's kernel from each receiver point to every patch (nq × n), batched, on first need.
  double kernel_at(int q, int j) {
    if (kernel_.empty()) {
      kernel_.resize(size_t(nq_) * s_.n);
      // Only for the sources that face the receiver: the others are never read, except that
      // closed-form pairs (which skip the facing test) may be read, so then for all.
      if (!s_.rects) classify_row();
      for (int k = 0; k < nq_; ++k) {
        const Receiver at{rule_[k].point, pi_.normal};
        double* out = kernel_.data() + size_t(k) * s_.n;
        if (s_.rects) lambert_form_factors(at, s_.sources, 0, s_.n, out);
        else lambert_form_factors_facing(at, s_.sources, facing_.data(), out);
      }
    }
    return kernel_[size_t(q) * s_.n + j];
  }

  const FillSetup& s_;
  const int i_;
  const Patch& pi_;
  Vec3 ri_[4], sj_[4];
  bool have_sj_ = false;
  std::vector<QuadraturePoint> rule_;
  int nq_ = 0;
  // Per receiver point: its visible factor to each source (for the row-sum check and scaling),
  // and the part of that which rays estimated (the only part that may need scaling).
  std::vector<double> point_sum_, ray_part_;
  std::vector<double> unoccluded_;  // per receiver point, of the current pair
  std::vector<int> occluders_, candidates_;
  Polygon receiver_part_, source_part_;  // narrow_to_exchanging_parts
  // Shaft culling in a hierarchy (face, tile, patch; visibility.h); one per thread, reused across rows.
  GroupedShaftCuller* grouped_;
  OccludedRowIntegrator* occluded_;               // per-pair mode with exact visibility, else null
  std::vector<OccludedSource> occluded_sources_;  // the row's occluded pairs (defer_occluded_pair)
  std::vector<double> blocked_;
  double row_error_ = 0.0;         // estimated error of the occluded pairs' sum
  double row_ray_variance_ = 0.0;  // see row_ray_error()
  PointVisibility* from_point_ = nullptr;
  double* row_;
  std::vector<Facing> facing_;
  std::vector<double> kernel_;
  FillCounts& k_;
};

#pragma omp declare reduction(merge:FillCounts : omp_out.merge(omp_in)) initializer(omp_priv = FillCounts())

// Rows per band of the streamed, mirrored fill: few enough that a band's rows (kMirrorBand × n)
// are small beside the held blocks, enough that the barriers between bands cost nothing.
constexpr int kMirrorBand = 256;

// The streamed fill with mirrored closed forms (FillOptions::streamed_mirror_bytes). Band after
// band of kMirrorBand rows:
//   1. the band's rows are filled as in the stored mirrored fill: a pair with a closed form only
//      from its lower-index patch (j > i), every other pair in its row;
//   2. the band's closed forms with later bands are copied, transposed, into blocks (band, J);
//   3. each row's entries below the diagonal follow by reciprocity, A_i F_ij = A_j F_ji (the
//      bands before from their blocks, the band itself from its rows), as
//      FormFactors::mirror_lower does for a stored matrix, and the row goes to the sink;
//   4. the blocks whose rows are now written are freed.
// So every closed form is computed once, and at most about n²/4 entries are held at a time
// (bands 0..K against bands after K). A sink that returns false stops it after its band. Both
// triangles are at hand in step 3, so the reciprocity error of every pair is measured there.
void fill_streamed_mirrored(const FillSetup& setup, const AlignedRectangles& rects, FillCounts& counts,
                            double& max_point_sum, double& reciprocity_error) {
  const int n = setup.n;
  const FillOptions& options = setup.options;
  const int bands = (n + kMirrorBand - 1) / kMirrorBand;
  auto band_begin = [&](int b) { return b * kMirrorBand; };
  auto band_rows = [&](int b) { return std::min(n, (b + 1) * kMirrorBand) - b * kMirrorBand; };
  std::vector<double> areas(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) areas[size_t(i)] = setup.mesh.patches[i].area;
  // held[K * bands + J], J > K: F_kj for k in band K, j in band J, stored at [(j - J0) rows(K) +
  // (k - K0)], so that a row j of band J reads its column k contiguously.
  std::vector<std::vector<double>> held(size_t(bands) * size_t(bands));
  std::vector<double> band(size_t(kMirrorBand) * size_t(n));
  bool stopped = false;
  for (int b = 0; b < bands && !stopped; ++b) {
    const int b0 = band_begin(b), rows = band_rows(b);
    std::fill(band.begin(), band.begin() + ptrdiff_t(rows) * n, 0.0);
#pragma omp parallel for schedule(dynamic, 1) reduction(merge : counts)
    for (int r = 0; r < rows; ++r) {
      RowFill fill(setup, b0 + r, nullptr, nullptr, nullptr, band.data() + size_t(r) * n, counts);
      fill.fill_pairs();
    }
#pragma omp parallel for schedule(dynamic, 1)
    for (int J = b + 1; J < bands; ++J) {
      const int j0 = band_begin(J), cols = band_rows(J);
      std::vector<double>& block = held[size_t(b) * bands + J];
      block.resize(size_t(cols) * rows);
      for (int r = 0; r < rows; ++r)
        for (int c = 0; c < cols; ++c) block[size_t(c) * rows + r] = band[size_t(r) * n + size_t(j0 + c)];
    }
    std::atomic<bool> stop{false};
#pragma omp parallel for schedule(dynamic, 1) reduction(max : max_point_sum, reciprocity_error)
    for (int r = 0; r < rows; ++r) {
      if (stop) continue;
      const int i = b0 + r;
      const double ai = areas[size_t(i)];
      double* row = band.data() + size_t(r) * n;
      // F_ik, k < i, from F_ki: mirrored where the pair has a closed form, else compared.
      auto lower = [&](int k, double f_ki) {
        const double ak = areas[size_t(k)];
        if (rects.eligible(i, k)) row[k] = f_ki * ak / ai;
        reciprocity_error = std::max(reciprocity_error, std::abs(ai * row[k] - ak * f_ki) / std::min(ai, ak));
      };
      for (int K = 0; K < b; ++K) {
        const int k0 = band_begin(K), krows = band_rows(K);
        const double* column = held[size_t(K) * bands + b].data() + size_t(r) * krows;
        for (int c = 0; c < krows; ++c) lower(k0 + c, column[c]);
      }
      for (int k = b0; k < i; ++k) lower(k, band[size_t(k - b0) * n + size_t(i)]);
      double sum = 0.0;  // without visibility every point's sum is its row's sum
      for (int j = 0; j < n; ++j) sum += row[j];
      max_point_sum = std::max(max_point_sum, sum);
      if (!options.row_sink(i, row)) stop = true;
    }
    stopped = stop;
    for (int K = 0; K < b; ++K) std::vector<double>().swap(held[size_t(K) * bands + b]);
    if (options.progress) options.progress(double(b + 1) / bands);
  }
}

}  // namespace

double streamed_mirror_peak_bytes(int n) {
  const double entries = 0.25 * double(n) * double(n) + 2.0 * kMirrorBand * double(n);
  return 8.0 * entries;
}

FormFactors fill_form_factors(const PatchMesh& mesh, const FillOptions& options, FillStats& stats) {
  const int n = mesh.size();
  const bool sink = static_cast<bool>(options.row_sink);
  // Streamed rows: an empty sparse matrix, whose rows give no storage to fill in place.
  FormFactors F(sink ? 0 : n,
                sink || options.layout == MatrixLayout::Sparse ? MatrixLayout::Sparse : MatrixLayout::Dense,
                options.precision);
  const double tol = plane_tolerance(mesh);
  const Visibility* vis = options.visibility;
  const bool rays_mode = vis && vis->method() == VisibilityMethod::Rays;
  std::atomic<int> rows_done{0};
  FillCounts counts;
  // Accuracy mode: every pair nothing can block (no visibility, or an empty shaft) gets the
  // per-pair rule, and pairs of aligned rectangles their closed form; blocked pairs the fixed rule.
  const bool per_pair = options.tolerance > 0.0;
  std::unique_ptr<AlignedRectangles> rects;
  if (per_pair && options.exact_rectangles) rects = std::make_unique<AlignedRectangles>(mesh);
  // Every patch as one SIMD batch: a receiver point's kernel to all sources in one call.
  const PolygonBatch sources = patch_batch(mesh);
  // Without visibility, a closed-form pair is computed once, from its lower-index patch, and the
  // other entry follows by reciprocity (dense storage: filled in place after the loop).
  // (Not for a subset of the rows: the mirrored entries would come from rows not filled.)
  const bool mirror = rects && !vis && F.layout() == MatrixLayout::Dense && !options.rows;
  // Streamed rows mirrored in bands (fill_streamed_mirrored), where the blocks it holds fit.
  const bool mirror_streamed =
      sink && rects && !vis && !options.rows && streamed_mirror_peak_bytes(n) <= options.streamed_mirror_bytes;
  double max_point_sum = 0.0;
  // The facing test per group of coplanar sources, so most pairs skip facing_away (facing.h).
  const FacingGroups facing_runs(mesh, tol);
  // (Mirrored rows read no patch records.)
  const bool prefetch = mesh.prefetch_pays() && !mirror && !mirror_streamed;
  const FillSetup setup{
      mesh,     options, n,          tol, vis, rays_mode, per_pair, rects.get(), mirror || mirror_streamed,
      prefetch, sources, facing_runs};

  // Per thread, with visibility: the hierarchical shaft culler, visibility from one point (the
  // one-point rules, see RowFill) and, in per-pair mode with exact visibility, the occluded pairs'
  // integrator.
  PerThread<GroupedShaftCuller> grouped_cullers(
      [&] { return std::make_unique<GroupedShaftCuller>(vis->culler(), mesh); });
  PerThread<PointVisibility> point_visibility([&] { return std::make_unique<PointVisibility>(*vis, mesh); });
  PerThread<OccludedRowIntegrator> occluded([&] { return std::make_unique<OccludedRowIntegrator>(*vis, mesh); });
  const bool integrate_occluded = vis && per_pair && !rays_mode && options.occluded_tolerance > 0.0;
  double max_row_error = 0.0, max_ray_error = 0.0;
  std::atomic<bool> stopped{false};
  double streamed_reciprocity = -1.0;
  if (mirror_streamed) {
    streamed_reciprocity = 0.0;
    fill_streamed_mirrored(setup, *rects, counts, max_point_sum, streamed_reciprocity);
  }
  const int row_count = mirror_streamed ? 0 : options.rows ? static_cast<int>(options.rows->size()) : n;

#pragma omp parallel for schedule(dynamic, 4) reduction(merge     \
                                                        : counts) \
    reduction(max                                                 \
              : max_point_sum, max_row_error, max_ray_error)
  for (int k = 0; k < row_count; ++k) {
    const int i = options.rows ? (*options.rows)[size_t(k)] : k;
    if (stopped) continue;  // the row sink asked to stop
    // F_i,·: written in place into a dense double matrix (zero until now), else into a buffer.
    std::vector<double> row_buffer;
    double* row = sink ? nullptr : F.dense_double_row(i);
    if (!row) {
      row_buffer.assign(size_t(n), 0.0);
      row = row_buffer.data();
    }
    RowFill fill(setup, i, vis ? &grouped_cullers.local() : nullptr, vis ? &point_visibility.local() : nullptr,
                 integrate_occluded ? &occluded.local() : nullptr, row, counts);
    fill.fill_pairs();
    fill.rescale_rays(max_point_sum);
    max_row_error = std::max(max_row_error, fill.row_error());
    max_ray_error = std::max(max_ray_error, fill.row_ray_error());
    if (sink) {
      if (!options.row_sink(i, row)) stopped = true;
    } else {
      F.set_row(i, row);
    }
    const int done = ++rows_done;
    if (options.progress && omp_get_thread_num() == 0) options.progress(double(done) / row_count);
  }
  if (options.progress) options.progress(1.0);
  if (mirror) {
    std::vector<double> areas(n);
    for (int i = 0; i < n; ++i) areas[i] = mesh.patches[i].area;
    F.mirror_lower([&](int i, int j) { return rects->eligible(i, j); }, areas.data());
    // The rows are complete only now; without visibility every point's sum is its row's sum.
    max_point_sum = 0.0;
#pragma omp parallel for schedule(static) reduction(max : max_point_sum)
    for (int i = 0; i < n; ++i) max_point_sum = std::max(max_point_sum, F.row_sum(i));
  }
  stats.pairs_evaluated += counts.evaluated;
  stats.pairs_backfacing += counts.backfacing;
  stats.pairs_tested += counts.tested;
  stats.pairs_culled += counts.culled;
  stats.pairs_occluded += counts.occluded;
  stats.rays_cast += counts.rays;
  stats.pairs_fixed_rule += counts.fixed_rule;
  stats.pairs_gauss += counts.gauss;
  stats.pairs_adaptive += counts.adaptive;
  stats.pairs_exact_rectangles += counts.exact_rectangles;
  stats.kernel_evaluations += counts.kernels;
  stats.above_unoccluded += counts.above;
  stats.max_point_row_sum = std::max(stats.max_point_row_sum, max_point_sum);
  stats.points_rescaled += counts.rescaled;
  stats.pairs_occluded_adaptive += counts.occluded_adaptive;
  stats.occluded_evaluations += counts.occluded_evaluations;
  stats.occluded_budget_exhausted += counts.occluded_budget;
  stats.pairs_blocked_whole += counts.blocked_whole;
  stats.max_row_error_estimate = std::max(stats.max_row_error_estimate, max_row_error);
  stats.max_row_ray_error = std::max(stats.max_row_ray_error, max_ray_error);
  stats.mirrored = mirror || mirror_streamed;
  stats.streamed_reciprocity_error = streamed_reciprocity;
  return F;
}

FormFactorChecks check_form_factors(const PatchMesh& mesh, const FormFactors& F) {
  FormFactorChecks c;
  const int n = mesh.size();
  if (n == 0) return c;
  double min_entry = 1.0, max_entry = 0.0, recip = 0.0;
  std::vector<double> row_sums(size_t(n), 0.0);
  if (F.layout() == MatrixLayout::Dense) {
    // One pass over F in 64 × 64 tiles (I, J >= I), so that F_ji is read from a cached tile, not
    // a far row: each entry is read once, as F_ij or F_ji of a pair i < j or on the diagonal. A
    // dense matrix is read from memory once rather than twice (entries and row sums, then
    // reciprocity); the row sums gather per thread, a row's entries coming from many tiles.
    constexpr int kTile = 64;
    const int tiles = (n + kTile - 1) / kTile;
    std::vector<std::vector<double>> partial(static_cast<size_t>(omp_get_max_threads()));
#pragma omp parallel reduction(max : recip, max_entry) reduction(min : min_entry)
    {
      std::vector<double>& rows = partial[size_t(omp_get_thread_num())];
      rows.assign(size_t(n), 0.0);
#pragma omp for schedule(dynamic, 1)
      for (int bi = 0; bi < tiles; ++bi)
        for (int bj = bi; bj < tiles; ++bj) {
          const int i1 = std::min(n, (bi + 1) * kTile), j1 = std::min(n, (bj + 1) * kTile);
          for (int i = bi * kTile; i < i1; ++i) {
            const double ai = mesh.patches[i].area;
            if (bj == bi) rows[size_t(i)] += F(i, i);
            for (int j = std::max(i + 1, bj * kTile); j < j1; ++j) {
              const double aj = mesh.patches[j].area, fij = F(i, j), fji = F(j, i);
              rows[size_t(i)] += fij;
              rows[size_t(j)] += fji;
              min_entry = std::min(min_entry, std::min(fij, fji));
              max_entry = std::max(max_entry, std::max(fij, fji));
              recip = std::max(recip, std::abs(ai * fij - aj * fji) / std::min(ai, aj));
            }
          }
        }
    }
    for (const std::vector<double>& rows : partial)
      if (!rows.empty())
        for (int i = 0; i < n; ++i) row_sums[size_t(i)] += rows[size_t(i)];
  } else {
    // Sparse: entries and row sums row by row; reciprocity from each stored entry (a pair stored
    // only one way is seen from that side).
#pragma omp parallel for schedule(dynamic, 16) reduction(min : min_entry) reduction(max : max_entry, recip)
    for (int i = 0; i < n; ++i) {
      const double ai = mesh.patches[i].area;
      double row = 0.0;
      int stored = 0;
      F.for_each_in_row(i, [&](int j, double f) {
        row += f;
        if (j == i) return;
        ++stored;
        min_entry = std::min(min_entry, f);
        max_entry = std::max(max_entry, f);
        const double fji = F(j, i);
        if (j < i && fji != 0.0) return;  // counted from row j
        const double aj = mesh.patches[j].area;
        recip = std::max(recip, std::abs(ai * f - aj * fji) / std::min(ai, aj));
      });
      if (stored < n - 1) min_entry = std::min(min_entry, 0.0);  // unstored entries are 0
      row_sums[size_t(i)] = row;
    }
  }
  c.min_entry = n == 1 ? 0.0 : min_entry;
  c.max_entry = max_entry;
  c.min_row_sum = *std::min_element(row_sums.begin(), row_sums.end());
  c.max_row_sum = *std::max_element(row_sums.begin(), row_sums.end());
  c.reciprocity_error = recip;
  return c;
}

}  // namespace photometria
