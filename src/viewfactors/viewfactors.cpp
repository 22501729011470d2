// View factors: fill, aggregation, checks, enforcement, point factors (viewfactors.h).
#include "viewfactors/viewfactors.h"

#include <omp.h>

#include <Eigen/LU>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <limits>
#include <sstream>

#include "formfactors/facing.h"
#include "formfactors/point_factors.h"
#include "kernels/lambert.h"
#include "pipeline/memory.h"
#include "util/error.h"
#include "util/huge_pages.h"
#include "util/per_thread.h"
#include "visibility/visibility.h"

namespace photometria {

namespace {

// The memory estimate of viewfactors.h (ViewFactorMemory) for `patches` patches and `surfaces`
// output surfaces (the output matrices' bytes on top of the solve's), checked as the solve's is
// (pipeline/memory.h check_storage). Called before patching, from the counts (surfaces: a lower
// bound, 0 unless --by patch), and after, from the mesh.
double stored_output_bytes(double surfaces, const ViewFactorOptions& opt) {
  const double g = surfaces;
  return 8.0 * g * g * (1.0 + (opt.enforcement ? 4.0 : 0.0) + (opt.exchange_factors ? 3.0 : 0.0)) +
         8.0 * double(std::max(opt.points, 0)) * g;
}

void check_stored(const MemoryEstimate& estimate, double patches, double surfaces, const ViewFactorOptions& opt,
                  ViewFactorMemory& m) {
  const double output_bytes = stored_output_bytes(surfaces, opt);
  const StorageChoice c =
      check_storage(estimate, patches, output_bytes, opt.matrix_layout, opt.matrix_precision, opt.max_memory_bytes,
                    "view factors need an estimated", ", " + format_patch_count(surfaces) + " output surfaces",
                    opt.level != AggregateLevel::Group ? "use --by group" : "");
  m.patches = estimate;
  m.surfaces = static_cast<int>(std::min(surfaces, double(std::numeric_limits<int>::max())));
  m.output_bytes = output_bytes;
  m.storage = c.storage;
  m.storage_reason = c.reason;
  m.matrix_bytes = c.matrix_bytes;
  m.estimated_bytes = c.estimated_bytes;
  m.limit_bytes = c.limit_bytes;
  m.limit_source = c.limit_source;
}

// The stored matrix's storage and estimate, with the output copy (`fits`: check_stored would not
// throw).
StorageChoice stored_choice(const MemoryEstimate& estimate, double patches, double surfaces,
                            const ViewFactorOptions& opt) {
  return choose_storage(opt.matrix_layout, opt.matrix_precision, patches, double(estimate.nonzero_pairs),
                        estimate.per_patch_bytes * patches + stored_output_bytes(surfaces, opt), opt.max_memory_bytes);
}

// The streamed run's estimate: the per-patch arrays, the rows in flight and the point rows, and
// with `mirror_bytes` the blocks of a fill mirrored in bands (formfactors.h); the limit it is
// checked against. Throws nothing (check_streamed does).
ViewFactorMemory streamed_memory(const MemoryEstimate& estimate, double patches, double surfaces,
                                 const ViewFactorOptions& opt, double mirror_bytes = 0.0) {
  ViewFactorMemory m;
  const double threads = opt.threads > 0 ? opt.threads : omp_get_max_threads();
  m.patches = estimate;
  m.surfaces = static_cast<int>(std::min(surfaces, double(std::numeric_limits<int>::max())));
  m.output_bytes = 8.0 * double(std::max(opt.points, 0)) * surfaces;
  m.storage = "streamed";
  m.matrix_bytes = 0.0;
  m.estimated_bytes = estimate.per_patch_bytes * patches + threads * kStreamedRowBytes * patches + m.output_bytes +
                      opt.held_bytes_per_entry * opt.held_row_share * patches * patches + mirror_bytes;
  // The ranks of an MPI run on one machine share its available memory; --max-memory is per rank.
  const int sharing = std::max(opt.ranks_per_machine, 1);
  m.limit_bytes = opt.max_memory_bytes > 0 ? opt.max_memory_bytes : available_memory_bytes() / sharing;
  m.limit_source = opt.max_memory_bytes > 0 ? "--max-memory"
                   : sharing > 1            ? "MemAvailable shared by " + std::to_string(sharing) + " ranks"
                                            : "MemAvailable";
  return m;
}

// The streamed run's estimate (streamed_memory) into m; BadInput when it exceeds the limit.
void check_streamed(const MemoryEstimate& estimate, double patches, double surfaces, const ViewFactorOptions& opt,
                    ViewFactorMemory& m, double mirror_bytes = 0.0) {
  m = streamed_memory(estimate, patches, surfaces, opt, mirror_bytes);
  if (m.limit_bytes > 0 && m.estimated_bytes > m.limit_bytes)
    throw_bad_input("view factors need an estimated " + format_bytes(m.estimated_bytes) + " for " +
                    format_patch_count(patches) + " patches (rows streamed, " + format_patch_count(surfaces) +
                    " output surfaces) but " + memory_limit_description(m.limit_bytes, m.limit_source) +
                    "; raise --max-edge or raise --max-memory");
}

// The refusal of a run on several MPI ranks whose rows cannot be streamed.
const std::string kRanksStream =
    "on several MPI ranks the rows are written as they are filled, which is not possible here: ";

// Why the fill cannot stream its rows ("" when it can, before patching: `mesh` null).
std::string why_not_streamed(const ViewFactorOptions& opt, const Aggregation* agg, int patches) {
  if (!opt.row_sink_for) return "the caller needs the whole matrix (no row sink)";
  if (opt.level == AggregateLevel::Group) return "--by group sums rows of several patches";
  if (opt.enforcement) return "--enforce needs the whole matrix";
  if (opt.exchange_factors) return "C emit=1 (exchange factors) needs the whole matrix";
  if (agg && !agg->minus_of_patch.empty())
    return "subsurfaces are taken out of their base surfaces (their rows are subtracted)";
  if (agg && agg->size() != patches) return "a face is split into several patches (--by face sums their rows)";
  return "";
}

}  // namespace

std::string row_streaming_name(RowStreaming mode) {
  switch (mode) {
    case RowStreaming::Auto: return "auto";
    case RowStreaming::Yes: return "yes";
    case RowStreaming::No: return "no";
  }
  return "?";
}

bool row_streaming_from_name(const std::string& name, RowStreaming& out) {
  for (RowStreaming mode : {RowStreaming::Auto, RowStreaming::Yes, RowStreaming::No})
    if (name == row_streaming_name(mode)) {
      out = mode;
      return true;
    }
  return false;
}

PatchViewFactors compute_view_factors(const Scene& scene, const ViewFactorOptions& opt) {
  if (opt.threads > 0) omp_set_num_threads(opt.threads);
  PatchViewFactors r;
  // Stream or store: decided from the counts before patching (so that a matrix too large to
  // store is not refused there), confirmed from the mesh after.
  bool stream = false;
  {
    const PatchGrid grid = count_patches(scene, opt.patching);
    if (grid.patches == 0) throw_bad_input(scene.source + ": no surface to compute view factors for");
    const MemoryEstimate e = estimate_memory(scene, grid, opt.seed);
    const double surfaces = opt.level == AggregateLevel::Patch ? grid.patches : 0.0;
    const std::string why_not = why_not_streamed(opt, nullptr, 0);
    if (opt.rows_for && !why_not.empty()) throw_bad_input(kRanksStream + why_not);
    if (opt.stream == RowStreaming::Yes && !why_not.empty()) throw_bad_input("--stream yes: " + why_not);
    stream = opt.stream != RowStreaming::No && why_not.empty() &&
             (opt.stream == RowStreaming::Yes || opt.rows_for || !stored_choice(e, grid.patches, surfaces, opt).fits);
    if (stream) check_streamed(e, grid.patches, surfaces, opt, r.memory);
    else check_stored(e, grid.patches, surfaces, opt, r.memory);
  }
  r.mesh = subdivide(scene, opt.patching);
  const MemoryEstimate estimate = estimate_memory(r.mesh, opt.seed);
  const Aggregation agg = make_aggregation(scene, r.mesh, opt.level);
  const std::string why_not = why_not_streamed(opt, &agg, r.mesh.size());
  if (opt.rows_for && !why_not.empty()) throw_bad_input(kRanksStream + why_not);
  if (opt.stream == RowStreaming::Yes && !why_not.empty()) throw_bad_input("--stream yes: " + why_not);
  const StorageChoice storage = stored_choice(estimate, r.mesh.size(), agg.size(), opt);
  // Visibility: the same decision as the solve's (visibility/choice.h).
  const VisibilityChoice visibility = choose_visibility(scene, opt.visibility, opt.rays);
  // Where nothing can block and pairs of rectangles have closed forms, streamed rows can mirror
  // them in bands (each computed once per pair, as in a stored fill) if those bands' blocks fit:
  // then streaming does less work than storing (no pass over a stored matrix, the file written
  // while the rows are filled) in less memory, so auto streams.
  const double mirror_bytes = streamed_mirror_peak_bytes(r.mesh.size());
  const bool mirror_fits = [&] {
    if (visibility.mode != VisibilityMode::None || opt.rows_for || !(opt.accuracy > 0.0)) return false;
    const ViewFactorMemory m = streamed_memory(estimate, r.mesh.size(), agg.size(), opt, mirror_bytes);
    return m.limit_bytes > 0.0 && m.estimated_bytes <= m.limit_bytes;
  }();
  stream = stream && why_not.empty();
  if (opt.stream == RowStreaming::Auto && why_not.empty()) stream = !storage.fits || mirror_fits;
  if (opt.rows_for) stream = true;
  if (stream) {
    check_streamed(estimate, r.mesh.size(), agg.size(), opt, r.memory, mirror_fits ? mirror_bytes : 0.0);
    r.stream_reason = opt.rows_for                      ? "the rows are filled on several MPI ranks"
                      : opt.stream == RowStreaming::Yes ? "requested (--stream yes)"
                      : !storage.fits ? "auto: the stored matrix and its output copy need an estimated " +
                                            format_bytes(storage.estimated_bytes) + ", over the limit"
                                      : "auto: nothing blocks and the closed forms mirror in bands, so rows written "
                                        "as they are filled take less time and memory than a stored matrix";
    r.memory.storage_reason = r.stream_reason;
  } else {
    check_stored(estimate, r.mesh.size(), agg.size(), opt, r.memory);
    r.stream_reason = opt.stream == RowStreaming::No ? "requested (--stream no)"
                      : !why_not.empty()             ? why_not
                                                     : "auto: the matrix fits the memory limit, stored";
  }
  r.streamed = stream;
  r.visibility_mode = visibility.name();
  r.visibility_reason = visibility.reason;
  r.visibility = make_visibility(scene, visibility, ray_sampling_for(opt.accuracy));
  FillOptions fill;
  fill.quadrature = opt.quadrature;
  fill.tolerance = opt.accuracy;
  fill.occluded_tolerance = opt.occluded_accuracy;
  fill.visibility = r.visibility.get();
  if (opt.progress) fill.progress = [&opt](double f) { opt.progress("form factors", f); };
  fill.rays = opt.rays;
  fill.seed = opt.seed;
  fill.layout = storage.layout;
  fill.precision = storage.precision;
  if (stream) fill.row_sink = opt.row_sink_for(r.mesh, agg);
  if (stream && mirror_fits) fill.streamed_mirror_bytes = mirror_bytes;
  std::vector<int> rows;
  if (opt.rows_for) {
    rows = opt.rows_for(r.mesh);
    fill.rows = &rows;
  }
  r.F = fill_form_factors(r.mesh, fill, r.fill);
  return r;
}

std::string aggregate_level_name(AggregateLevel level) {
  switch (level) {
    case AggregateLevel::Group: return "group";
    case AggregateLevel::Face: return "face";
    case AggregateLevel::Patch: return "patch";
  }
  return "?";
}

bool aggregate_level_from_name(const std::string& name, AggregateLevel& out) {
  for (AggregateLevel level : {AggregateLevel::Group, AggregateLevel::Face, AggregateLevel::Patch})
    if (name == aggregate_level_name(level)) {
      out = level;
      return true;
    }
  return false;
}

namespace {

// Per face: at the face level, the source face a subsurface (null, mask) face is taken out of:
// the face of its base group that holds it (a combined base surface has several faces: the one
// in whose plane and inside whose convex polygon the subsurface's centroid lies; the group's
// first face if none does); -1 for faces that are no subsurface.
std::vector<int> base_source_faces(const Scene& scene) {
  std::vector<int> out(scene.faces.size(), -1);
  std::vector<std::vector<int>> faces_of_group(scene.groups.size());
  bool any = false;
  for (size_t f = 0; f < scene.faces.size(); ++f) {
    const Face& face = scene.faces[f];
    any = any || face.base_group >= 0;
    if (face.base_group < 0 && face.group >= 0 && face.group < int(scene.groups.size()))
      faces_of_group[size_t(face.group)].push_back(int(f));
  }
  if (!any) return out;
  const auto holds = [&](int base, const Vec3& c) {
    const Polygon poly = scene.face_polygon(base);
    const Vec3 n = polygon_normal(poly);
    double size = 0.0;
    for (size_t k = 0; k < poly.size(); ++k) size = std::max(size, (poly[(k + 1) % poly.size()] - poly[k]).norm());
    const double tol = 1e-9 * std::max(size, 1.0);
    if (std::abs(n.dot(c - poly[0])) > tol) return false;
    for (size_t k = 0; k < poly.size(); ++k)  // convex, counter-clockwise about n
      if ((poly[(k + 1) % poly.size()] - poly[k]).cross(c - poly[k]).dot(n) < -tol * size) return false;
    return true;
  };
  for (size_t f = 0; f < scene.faces.size(); ++f) {
    const Face& face = scene.faces[f];
    if (face.base_group < 0) continue;
    const std::vector<int>& candidates = faces_of_group[size_t(face.base_group)];
    if (candidates.empty()) continue;
    int base = candidates.front();
    if (candidates.size() > 1) {
      const Vec3 c = polygon_centroid(scene.face_polygon(int(f)));
      for (int b : candidates)
        if (holds(b, c)) {
          base = b;
          break;
        }
    }
    out[f] = scene.faces[size_t(base)].source_face;
  }
  return out;
}

}  // namespace

Aggregation make_aggregation(const Scene& scene, const PatchMesh& mesh, AggregateLevel level) {
  Aggregation a;
  const int n = mesh.size();
  a.of_patch.assign(static_cast<size_t>(n), -1);
  if (level == AggregateLevel::Patch) {
    for (int i = 0; i < n; ++i) {
      a.names.push_back("patch " + std::to_string(i));
      a.areas.push_back(mesh.patches[i].area);
      a.of_patch[i] = i;
    }
    return a;
  }
  // Surfaces in order of first appearance of their key (group index or source face).
  std::vector<int> index_of_key;
  const auto surface_of_key = [&](int key) {
    if (key >= static_cast<int>(index_of_key.size())) index_of_key.resize(static_cast<size_t>(key) + 1, -1);
    if (index_of_key[key] < 0) {
      index_of_key[key] = a.size();
      a.names.push_back(level == AggregateLevel::Group ? scene.groups[static_cast<size_t>(key)]
                                                       : "face " + std::to_string(key));
      a.areas.push_back(0.0);
    }
    return index_of_key[key];
  };
  const std::vector<int> base_face = level == AggregateLevel::Face ? base_source_faces(scene) : std::vector<int>();
  for (int i = 0; i < n; ++i) {
    const Face& f = scene.faces[static_cast<size_t>(mesh.patches[i].face)];
    const double area = mesh.patches[i].area;
    // View3D subsurfaces and null surfaces: the base surface (group, or the face holding them)
    // is the base minus them.
    const int base_key =
        level == AggregateLevel::Group ? f.base_group : base_face[static_cast<size_t>(mesh.patches[i].face)];
    if (base_key >= 0) {
      if (a.minus_of_patch.empty()) a.minus_of_patch.assign(static_cast<size_t>(n), -1);
      const int base = surface_of_key(base_key);
      a.minus_of_patch[i] = base;
      a.areas[static_cast<size_t>(base)] -= area;
      if (f.null_surface) continue;
      if (f.mask_surface) {
        // The masked part of the base only sees the mask: its area stays in the base's.
        if (a.mask_of_patch.empty()) a.mask_of_patch.assign(static_cast<size_t>(n), -1);
        a.areas[static_cast<size_t>(base)] += area;
        const int mask = surface_of_key(level == AggregateLevel::Group ? f.group : f.source_face);
        a.mask_of_patch[i] = mask;
        a.areas[static_cast<size_t>(mask)] += area;
        continue;
      }
    }
    const int own = surface_of_key(level == AggregateLevel::Group ? f.group : f.source_face);
    a.of_patch[i] = own;
    a.areas[static_cast<size_t>(own)] += area;
  }
  return a;
}

ViewFactorMatrix aggregate(const FormFactors& F, const PatchMesh& mesh, const Aggregation& agg) {
  // F_IJ = (1/A_I) Σ_{i∈I} A_i Σ_{j∈J} F_ij (Modest 2013, eq. 4.19). A patch of a subsurface
  // (minus_of_patch) also counts with the sign −1 in its base surface: A_B' F_B'J = A_B F_BJ −
  // A_s F_sJ and A_I F_IB' = A_I F_IB − A_I F_Is for the base net of its subsurface s (the same
  // algebra, View3D's post-processing). A mask patch (mask_of_patch) is taken out of its base
  // likewise and adds A_M to A_M F_MB and A_B F_BM instead.
  const int g = agg.size();
  if (g == mesh.size() && agg.minus_of_patch.empty()) {
    // One patch per surface (faces not split): F_IJ = F_ij itself, rows independent, on every
    // core. The output is not zeroed first where a dense F sets every entry: each row's memory
    // is first touched by the thread that copies it, in huge pages.
    ViewFactorMatrix out(g, g);
    advise_huge_pages(out.data(), sizeof(double) * size_t(g) * size_t(g));
    const bool every_entry = F.layout() == MatrixLayout::Dense;
#pragma omp parallel for schedule(dynamic, 16)
    for (int i = 0; i < mesh.size(); ++i) {
      double* row = out.row(agg.of_patch[i]).data();
      if (!every_entry) std::fill(row, row + g, 0.0);
      F.for_each_in_row(i, [&](int j, double f) { row[agg.of_patch[j]] = f; });
    }
    return out;
  }
  ViewFactorMatrix out = ViewFactorMatrix::Zero(g, g);
  const bool minus = !agg.minus_of_patch.empty();
  const auto minus_of = [&](int i) { return minus ? agg.minus_of_patch[size_t(i)] : -1; };
  for (int i = 0; i < mesh.size(); ++i) {
    const int I = agg.of_patch[i], Im = minus_of(i);
    const double ai = mesh.patches[i].area;
    F.for_each_in_row(i, [&](int j, double f) {
      const int J = agg.of_patch[j], Jm = minus_of(j);
      const double af = ai * f;
      if (I >= 0 && J >= 0) out(I, J) += af;
      if (I >= 0 && Jm >= 0) out(I, Jm) -= af;
      if (Im >= 0 && J >= 0) out(Im, J) -= af;
      if (Im >= 0 && Jm >= 0) out(Im, Jm) += af;
    });
    // A mask's patch: the part of the base it covers sees the mask alone (View3D's M surface).
    if (!agg.mask_of_patch.empty() && agg.mask_of_patch[size_t(i)] >= 0) {
      out(agg.mask_of_patch[size_t(i)], Im) += ai;
      out(Im, agg.mask_of_patch[size_t(i)]) += ai;
    }
  }
  for (int I = 0; I < g; ++I) out.row(I) /= agg.areas[static_cast<size_t>(I)];
  return out;
}

ViewFactorMatrix aggregate(FormFactors&& F, const PatchMesh& mesh, const Aggregation& agg) {
  const auto in_patch_order = [&] {
    for (int i = 0; i < mesh.size(); ++i)
      if (agg.of_patch[size_t(i)] != i) return false;
    return true;
  };
  if (agg.size() == mesh.size() && agg.minus_of_patch.empty() && agg.mask_of_patch.empty() &&
      F.layout() == MatrixLayout::Dense && F.precision() == MatrixPrecision::Double && in_patch_order())
    return F.release_dense_double();
  return aggregate(static_cast<const FormFactors&>(F), mesh, agg);
}

MatrixChecks check_matrix(const ViewFactorMatrix& F, const std::vector<double>& areas) {
  MatrixChecks c;
  const int n = static_cast<int>(F.rows());
  if (n == 0) return c;
  // Row sums on every core, then their extremes in row order (check_rows).
  std::vector<double> sums(size_t(n), 0.0);
#pragma omp parallel for schedule(static)
  for (int i = 0; i < n; ++i) sums[size_t(i)] = F.row(i).sum();
  c = check_rows(sums, F.minCoeff(), F.maxCoeff());
  c.reciprocity_checked = true;
  // Reciprocity over the upper triangle in square tiles, so that F(j, i) (a column walk in the
  // row-major matrix) stays in cache; a maximum does not depend on the order.
  constexpr int kTile = 64;
  const int tiles = (n + kTile - 1) / kTile;
  double reciprocity = 0.0;
#pragma omp parallel for schedule(dynamic, 1) reduction(max : reciprocity)
  for (int ti = 0; ti < tiles; ++ti)
    for (int tj = ti; tj < tiles; ++tj)
      for (int i = ti * kTile; i < std::min(n, (ti + 1) * kTile); ++i)
        for (int j = std::max(i + 1, tj * kTile); j < std::min(n, (tj + 1) * kTile); ++j)
          reciprocity = std::max(reciprocity, std::abs(areas[size_t(i)] * F(i, j) - areas[size_t(j)] * F(j, i)) /
                                                  std::min(areas[size_t(i)], areas[size_t(j)]));
  c.reciprocity_error = reciprocity;
  return c;
}

MatrixChecks check_rows(const std::vector<double>& row_sums, double min_entry, double max_entry) {
  MatrixChecks c;
  c.reciprocity_checked = false;
  const int n = static_cast<int>(row_sums.size());
  if (n == 0) return c;
  c.min_row_sum = 1e300;
  c.max_row_sum = -1e300;
  c.min_entry = min_entry;
  c.max_entry = max_entry;
  // In row order: the worst row is the first found.
  double worst = -1.0, total = 0.0;
  for (int i = 0; i < n; ++i) {
    const double s = row_sums[size_t(i)];
    total += s;
    c.min_row_sum = std::min(c.min_row_sum, s);
    c.max_row_sum = std::max(c.max_row_sum, s);
    if (std::abs(s - 1.0) > worst) {
      worst = std::abs(s - 1.0);
      c.worst_row = i;
    }
  }
  c.mean_row_sum = total / n;
  return c;
}

std::string enforcement_name(Enforcement mode) {
  switch (mode) {
    case Enforcement::None: return "none";
    case Enforcement::Reciprocity: return "reciprocity";
    case Enforcement::Closure: return "closure";
    case Enforcement::Both: return "both";
  }
  return "?";
}

bool enforcement_from_name(const std::string& name, Enforcement& out) {
  for (Enforcement mode : {Enforcement::None, Enforcement::Reciprocity, Enforcement::Closure, Enforcement::Both})
    if (name == enforcement_name(mode)) {
      out = mode;
      return true;
    }
  return false;
}

EnforcementReport enforce(ViewFactorMatrix& F, const std::vector<double>& areas, Enforcement mode, double tolerance,
                          int max_iterations) {
  EnforcementReport rep;
  rep.before = check_matrix(F, areas);
  const ViewFactorMatrix original = F;
  const int n = static_cast<int>(F.rows());
  const Eigen::Map<const Eigen::VectorXd> A(areas.data(), n);
  if (mode == Enforcement::Reciprocity || mode == Enforcement::Both) {
    // G = A·F; its symmetric part (G + Gᵀ)/2 is the nearest symmetric matrix in the Frobenius
    // norm (orthogonal projection onto the symmetric matrices; Higham, "Computing a nearest
    // symmetric positive semidefinite matrix", Linear Algebra Appl. 103, 1988, sec. 2).
    Eigen::MatrixXd G = A.asDiagonal() * F;
    G = 0.5 * (G + G.transpose()).eval();
    F = A.cwiseInverse().asDiagonal() * G;
  }
  if (mode == Enforcement::Closure) {
    for (int i = 0; i < n; ++i) {
      const double s = F.row(i).sum();
      if (s > 0.0) F.row(i) /= s;
    }
    rep.iterations = 1;
  }
  if (mode == Enforcement::Both) {
    // Symmetric diagonal scaling: find d > 0 with Σ_j d_i G_ij d_j = A_i for every row i, so that
    // F' = A⁻¹ D G D keeps A·F' = D G D symmetric and has unit row sums. Symmetric Sinkhorn–Knopp
    // iteration d_i <- sqrt(d_i A_i / (G d)_i) (Knight, "The Sinkhorn–Knopp algorithm:
    // convergence and applications", SIAM J. Matrix Anal. Appl. 30(1), 2008, sec. 5; the
    // geometric-mean step converges for symmetric non-negative G with total support).
    // Rows with no exchange (sum 0) are left alone (d_i = 1).
    const Eigen::MatrixXd G = A.asDiagonal() * F;
    Eigen::VectorXd d = Eigen::VectorXd::Ones(n);
    std::vector<bool> active(static_cast<size_t>(n));
    for (int i = 0; i < n; ++i) active[i] = G.row(i).sum() > 0.0;
    for (rep.iterations = 0; rep.iterations < max_iterations; ++rep.iterations) {
      const Eigen::VectorXd Gd = G * d;
      double err = 0.0;
      for (int i = 0; i < n; ++i)
        if (active[i]) err = std::max(err, std::abs(d[i] * Gd[i] / A[i] - 1.0));
      if (err <= tolerance) break;
      for (int i = 0; i < n; ++i)
        if (active[i]) d[i] = std::sqrt(d[i] * A[i] / Gd[i]);
    }
    Eigen::MatrixXd S = d.asDiagonal() * G * d.asDiagonal();
    S = 0.5 * (S + S.transpose()).eval();  // exact symmetry after rounding
    F = A.cwiseInverse().asDiagonal() * S;
  }
  rep.max_change = n ? (F - original).cwiseAbs().maxCoeff() : 0.0;
  rep.after = check_matrix(F, areas);
  return rep;
}

ViewFactorMatrix exchange_factors(const ViewFactorMatrix& F, const std::vector<double>& emissivities) {
  const int n = static_cast<int>(F.rows());
  if (F.cols() != n || emissivities.size() != static_cast<size_t>(n))
    throw_bad_input("exchange factors: " + std::to_string(emissivities.size()) + " emissivities for " +
                    std::to_string(F.rows()) + " x " + std::to_string(F.cols()) + " view factors");
  Eigen::VectorXd eps(n);
  for (int i = 0; i < n; ++i) {
    const double e = emissivities[size_t(i)];
    if (!(e >= 0.0 && e <= 1.0)) {
      std::ostringstream m;
      m << "exchange factors: emissivity " << e << " of surface " << i + 1 << " is outside [0, 1]";
      throw_bad_input(m.str());
    }
    eps[i] = e;
  }
  if (n == 0) return F;
  const Eigen::VectorXd rho = Eigen::VectorXd::Ones(n) - eps;
  // (I − F diag(ρ)) X = F diag(ε): radiation leaving i reaches k with F_ik and is absorbed
  // there (ε_k) or reflected on (ρ_k), so X_ij = F_ij ε_j + Σ_k F_ik ρ_k X_kj.
  const Eigen::MatrixXd M = Eigen::MatrixXd::Identity(n, n) - F * rho.asDiagonal();
  const Eigen::PartialPivLU<Eigen::MatrixXd> lu(M);
  const double rcond = lu.rcond();
  if (!(rcond >= 1e-12)) {
    std::ostringstream m;
    m << "exchange factors: the system is singular (reciprocal condition number " << rcond
      << "): surfaces of emissivity 0 close an enclosure, so nothing ever absorbs what they reflect";
    throw_bad_input(m.str());
  }
  const Eigen::MatrixXd X = lu.solve(Eigen::MatrixXd(F * eps.asDiagonal()));
  ViewFactorMatrix out = eps.asDiagonal() * X;
  if (!out.allFinite()) throw_bad_input("exchange factors: the solve gave a non-finite factor");
  return out;
}

namespace {

Vec3 vec3_of(const nlohmann::json& v, const std::string& where) {
  if (!v.is_array() || v.size() != 3) throw_bad_input(where + ": expected [x, y, z]");
  Vec3 out;
  for (int k = 0; k < 3; ++k) {
    if (!v[static_cast<size_t>(k)].is_number()) throw_bad_input(where + ": expected numbers");
    out[k] = v[static_cast<size_t>(k)].get<double>();
    if (!std::isfinite(out[k])) throw_bad_input(where + ": not finite");
  }
  return out;
}

void finish_point(SurfacePoint& p, const std::string& where) {
  const double len = p.normal.norm();
  if (!(len > 0.0) || !std::isfinite(len)) throw_bad_input(where + ": normal must be non-zero");
  p.normal /= len;
}

}  // namespace

std::vector<SurfacePoint> load_points(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw_io("cannot open '" + path + "'");
  std::stringstream buf;
  buf << in.rdbuf();
  const std::string text = buf.str();
  std::vector<SurfacePoint> points;
  std::string ext = path.size() >= 5 ? path.substr(path.size() - 5) : path;
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext == ".json") {
    nlohmann::json j;
    try {
      j = nlohmann::json::parse(text);
    } catch (const nlohmann::json::parse_error& e) {
      throw_bad_input(path + ": invalid JSON at byte " + std::to_string(e.byte));
    }
    const nlohmann::json& list = j.is_object() && j.contains("points") ? j["points"] : j;
    if (!list.is_array()) throw_bad_input(path + ": expected an array of points or {\"points\": [...]}");
    for (size_t k = 0; k < list.size(); ++k) {
      const std::string where = path + ": points[" + std::to_string(k) + "]";
      const nlohmann::json& e = list[k];
      if (!e.is_object() || !e.contains("position") || !e.contains("normal"))
        throw_bad_input(where + ": needs \"position\" and \"normal\"");
      SurfacePoint p;
      p.id = e.contains("id") ? (e["id"].is_string() ? e["id"].get<std::string>() : e["id"].dump()) : std::to_string(k);
      p.position = vec3_of(e["position"], where + ".position");
      p.normal = vec3_of(e["normal"], where + ".normal");
      finish_point(p, where);
      points.push_back(p);
    }
  } else {
    // CSV: x,y,z,nx,ny,nz[,id]
    std::istringstream lines(text);
    std::string line;
    long number = 0;
    while (std::getline(lines, line)) {
      ++number;
      if (!line.empty() && line.back() == '\r') line.pop_back();
      const size_t first = line.find_first_not_of(" \t");
      if (first == std::string::npos || line[first] == '#') continue;
      if (number == 1 && std::isalpha(static_cast<unsigned char>(line[first]))) continue;  // header
      std::vector<std::string> cells;
      std::stringstream ls(line);
      std::string cell;
      while (std::getline(ls, cell, ',')) cells.push_back(cell);
      const std::string where = at(path, number);
      if (cells.size() < 6) throw_bad_input(where + ": expected x,y,z,nx,ny,nz[,id]");
      double v[6];
      for (int k = 0; k < 6; ++k) {
        char* end = nullptr;
        v[k] = std::strtod(cells[k].c_str(), &end);
        while (end && (*end == ' ' || *end == '\t')) ++end;
        if (end == cells[k].c_str() || (end && *end) || !std::isfinite(v[k]))
          throw_bad_input(where + ": column " + std::to_string(k + 1) + " value '" + cells[k] +
                          "' is not a finite number");
      }
      SurfacePoint p;
      p.id = cells.size() > 6 ? cells[6] : std::to_string(points.size());
      p.position = Vec3(v[0], v[1], v[2]);
      p.normal = Vec3(v[3], v[4], v[5]);
      finish_point(p, where);
      points.push_back(p);
    }
  }
  if (points.empty()) throw_bad_input(path + ": no points");
  return points;
}

std::vector<double> view3d_emissivities(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw_io("cannot open '" + path + "'");
  std::vector<double> emit;
  std::string line;
  bool blast = false;  // F 3a
  while (std::getline(in, line)) {
    // As the loader: '!' starts a comment anywhere, a token starting with '#' ends the line;
    // records are case-insensitive.
    const size_t cut = line.find('!');
    if (cut != std::string::npos) line.resize(cut);
    std::istringstream tokens(line);
    std::vector<std::string> t;
    for (std::string w; tokens >> w && w[0] != '#';) t.push_back(w);
    if (t.empty()) continue;
    std::string rec = t[0];
    for (char& c : rec) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    if (rec == "E" || rec == "END" || rec == "*") break;
    if (rec == "F" && t.size() > 1) blast = t[1] == "3a" || t[1] == "3A";
    // F 3: "S n v1 v2 v3 v4 base cmbn emit name"; F 3a: "S n shape base cmbn emit name" (an O
    // line may stop after its shape: emissivity 0).
    const size_t field = blast ? 5 : 8;
    if (rec != "S" && rec != "O" && rec != "N" && rec != "M") continue;
    if (t.size() <= field) {
      if (blast && rec == "O") emit.push_back(0.0);
      continue;
    }
    char* end = nullptr;
    const double e = std::strtod(t[field].c_str(), &end);
    emit.push_back(end && *end == '\0' && std::isfinite(e) ? e : 0.0);
  }
  return emit;
}

ViewFactorMatrix point_view_factors(const std::vector<SurfacePoint>& points, const PatchMesh& mesh,
                                    const Aggregation& agg, const Visibility* vis, const ViewFactorOptions& opt) {
  const int np = static_cast<int>(points.size());
  ViewFactorMatrix out = ViewFactorMatrix::Zero(np, agg.size());
  const double tol = plane_tolerance(mesh);
  // The factors from each point as the vertex gather takes them (formfactors/point_factors.h):
  // one per thread.
  const PolygonBatch sources = patch_batch(mesh);
  const FacingGroups facing(mesh, tol);
  PerThread<PointFactors> point_factors(
      [&] { return std::make_unique<PointFactors>(mesh, sources, facing, vis, tol, opt.rays); });
#pragma omp parallel for schedule(dynamic, 4)
  for (int o = 0; o < np; ++o) {
    const SurfacePoint& x = points[static_cast<size_t>(o)];
    PointFactors::Counts counts;
    auto stream_of = [&](int j) { return pair_stream(opt.seed ^ 0x9017ULL, uint64_t(o), uint64_t(j)); };
    point_factors.local().for_each_visible(Receiver{x.position, x.normal}, stream_of, counts, [&](int j, double f) {
      if (agg.of_patch[j] >= 0) out(o, agg.of_patch[j]) += f;
      if (!agg.minus_of_patch.empty() && agg.minus_of_patch[j] >= 0) out(o, agg.minus_of_patch[j]) -= f;
    });
  }
  return out;
}

}  // namespace photometria
