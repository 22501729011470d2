// The `photometria viewfactors` job (job.h).
#include "viewfactors/job.h"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <mutex>
#include <optional>
#include <sstream>
#include <thread>

#include <omp.h>

#include "distributed/fill_stats.h"
#include "distributed/ranks.h"
#include "distributed/row_partition.h"
#include "distributed/shared_file.h"
#include "io/atomic_file.h"
#include "pipeline/solve.h"
#include "scene/scene.h"
#include "util/error.h"

namespace photometria {
namespace {

bool is_vs3(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext == ".vs3";
}

// Per output surface, the emissivity of its View3D surface when the input is a .vs3 file (the
// last line of View3D's output, and those of the exchange factors); empty otherwise (the writer
// then puts 1.000).
std::vector<double> view3d_emissivities_of(const std::string& path, const Scene& scene, const PatchMesh& mesh,
                                           const Aggregation& agg) {
  if (!is_vs3(path)) return {};
  const std::vector<double> by_surface = view3d_emissivities(path);
  // A combined output surface keeps the emissivity of its lowest-numbered member (the surface
  // the others are combined into), as View3D intends (it does not renumber its emissivities
  // when it combines, so a kept surface after a combined one gets another's there).
  std::vector<double> out(static_cast<size_t>(agg.size()), 1.0);
  std::vector<int> first(static_cast<size_t>(agg.size()), -1);
  for (int i = 0; i < mesh.size(); ++i) {
    const int source = scene.faces[static_cast<size_t>(mesh.patches[i].face)].source_face;
    // A mask's patches count in no surface's factors but name their mask; null surfaces: none.
    const int I = agg.of_patch[i] >= 0 || agg.mask_of_patch.empty() ? agg.of_patch[i] : agg.mask_of_patch[i];
    if (I < 0) continue;
    int& f = first[static_cast<size_t>(I)];
    if (source < 0 || source >= static_cast<int>(by_surface.size()) || (f >= 0 && f <= source)) continue;
    f = source;
    out[static_cast<size_t>(I)] = by_surface[static_cast<size_t>(source)];
  }
  return out;
}

// Whether the scene is a View3D input (`path`) whose C line sets emit to a non-zero value.
bool view3d_asks_for_exchange_factors(const std::string& path, const Scene& scene) {
  if (!is_vs3(path) || !scene.settings.contains("view3d")) return false;
  const nlohmann::json& control = scene.settings["view3d"];
  const auto it = control.is_object() ? control.find("emit") : control.end();
  return it != control.end() && it->is_number() && it->get<double>() != 0.0;
}

// The rows of a streamed fill (ViewFactorOptions::row_sink_for) into the output: each patch row
// permuted into output order and checked (its sum as check_matrix sums it, the entry extremes).
// One process hands it to a ViewFactorRowStream, which appends it in row order. A rank of an MPI
// run keeps it formatted until every rank has filled its rows; then all write their rows into the
// one file at once (finish_on_ranks). A failure to write is kept, and stops the fill.
class StreamedRows {
 public:
  // `out`: the output, for one process; null on the ranks of an MPI run.
  StreamedRows(AtomicOutput* out, ViewFactorFormat format, const Aggregation& agg, double threshold,
               const View3dOutput& view3d)
      : names_(agg.names),
        areas_(agg.areas),
        form_(format, names_, areas_, threshold, view3d),
        of_patch_(agg.of_patch),
        patch_of_(agg.of_patch.size(), -1),
        row_sums_(agg.of_patch.size(), 0.0) {
    if (out) writer_.emplace(*out, format, names_, areas_, threshold, view3d);
    else {
      kept_.resize(of_patch_.size());
      drops_.resize(of_patch_.size());
    }
    for (size_t i = 0; i < of_patch_.size(); ++i) {
      patch_of_[size_t(of_patch_[i])] = int(i);
      identity_ = identity_ && of_patch_[i] == int(i);
    }
  }

  bool add(int i, const double* patch_row) {
    try {
      const int n = int(of_patch_.size());
      thread_local std::vector<double> permuted;
      const double* row = patch_row;
      if (!identity_) {
        permuted.resize(size_t(n));
        for (int J = 0; J < n; ++J) permuted[size_t(J)] = patch_row[patch_of_[size_t(J)]];
        row = permuted.data();
      }
      const Eigen::Map<const Eigen::VectorXd> values(row, n);
      const int I = of_patch_[size_t(i)];
      row_sums_[size_t(I)] = values.sum();
      const double lo = values.minCoeff(), hi = values.maxCoeff();
      {
        const std::lock_guard<std::mutex> lock(mutex_);
        min_entry_ = std::min(min_entry_, lo);
        max_entry_ = std::max(max_entry_, hi);
      }
      if (writer_) writer_->add_row(I, row);
      else form_.row(I, row, kept_[size_t(I)], drops_[size_t(I)]);  // distinct rows: distinct slots
      return true;
    } catch (...) {
      const std::lock_guard<std::mutex> lock(mutex_);
      if (!failure_) failure_ = std::current_exception();
      return false;
    }
  }

  const std::exception_ptr& failure() const { return failure_; }

  // One process, after the fill: rethrows a failure, else the drop statistics and the row checks.
  SparseWriteStats finish(MatrixChecks& checks) {
    if (failure_) std::rethrow_exception(failure_);
    checks = check_rows(row_sums_, min_entry_, max_entry_);
    return writer_->finish();
  }

  // Every rank, after the fill and ranks::agree(failure()): the rows of all ranks written into
  // `temp` (rank 0's temporary file of `target`), and the statistics and checks of all rows (the
  // same on every rank, equal to one process's). Collective; throws on every rank.
  SparseWriteStats finish_on_ranks(const std::string& temp, const std::string& target, MatrixChecks& checks) {
    const size_t n = of_patch_.size();
    ranks::sum(row_sums_);  // each row's sum is on one rank, zeros elsewhere: exact
    checks = check_rows(row_sums_, ranks::min(min_entry_), ranks::max(max_entry_));
    std::vector<double> dropped(n);
    std::vector<long long> counts(2 * n);  // dropped, then written
    std::vector<std::pair<int, const std::string*>> mine;
    for (size_t I = 0; I < n; ++I) {
      dropped[I] = drops_[I].dropped;
      counts[I] = drops_[I].dropped_count;
      counts[n + I] = drops_[I].written;
      if (!kept_[I].empty()) mine.emplace_back(int(I), &kept_[I]);
    }
    ranks::sum(dropped);
    ranks::sum(counts);
    SparseWriteStats stats;
    for (size_t I = 0; I < n; ++I) add_row_drops(stats, RowDrops{dropped[I], counts[I], counts[n + I]}, int(I));
    write_pieces(temp, target, form_.header(), mine, int(n), form_.trailer());
    return stats;
  }

 private:
  std::vector<std::string> names_;  // the writers' (they keep references)
  std::vector<double> areas_;
  ViewFactorForm form_;
  std::optional<ViewFactorRowStream> writer_;  // one process
  std::vector<std::string> kept_;              // on ranks: per output row, this rank's formatted rows
  std::vector<RowDrops> drops_;                // on ranks: their drops
  std::vector<int> of_patch_, patch_of_;
  bool identity_ = true;
  std::vector<double> row_sums_;  // per output row
  std::mutex mutex_;
  double min_entry_ = 1e300, max_entry_ = -1e300;
  std::exception_ptr failure_;
};

// Bytes per matrix entry that a rank keeps of its formatted rows (the memory estimate): a CSV
// value is at most 24 characters and its comma (most are about 20), a sparse triplet about 30
// for the share of entries that are not zero, a view3d field 9, a binary one 8.
double held_bytes_per_entry(ViewFactorFormat format) {
  switch (format) {
    case ViewFactorFormat::Csv: return 22.0;
    case ViewFactorFormat::Sparse: return 15.0;
    case ViewFactorFormat::View3d: return 9.0;
    case ViewFactorFormat::Binary: return 8.0;
  }
  return 24.0;
}

// A number as the C line would give it ("1e-05", "2").
std::string control_value(double v) {
  std::ostringstream o;
  o << v;
  return o.str();
}

// The point factors, written to their (not yet committed) output.
void finish_points(const ViewFactorJobResult& res, const std::vector<SurfacePoint>& points, const PatchViewFactors& r,
                   const Aggregation& agg, std::optional<AtomicOutput>& points_out) {
  if (!points_out) return;
  const ViewFactorMatrix P = point_view_factors(points, r.mesh, agg, r.visibility.get(), res.job.fill);
  std::vector<std::string> ids;
  for (const SurfacePoint& p : points) ids.push_back(p.id);
  write_point_factors(*points_out, ids, agg.names, P);
}

// All or nothing: the matrix first, then the point factors; when those fail to commit, the
// committed matrix is removed again.
void commit_all(AtomicOutput& main_out, std::optional<AtomicOutput>& points_out) {
  main_out.commit();
  if (points_out) {
    try {
      points_out->commit();
    } catch (...) {
      std::remove(main_out.target().c_str());
      throw;
    }
  }
}

void fill_result(ViewFactorJobResult& res, const Scene& scene, const PatchViewFactors& r, const Aggregation& agg,
                 std::chrono::steady_clock::time_point t0) {
  res.faces = static_cast<int>(scene.faces.size());
  res.patches = r.mesh.size();
  res.names = agg.names;
  res.areas = agg.areas;
  res.visibility_mode = r.visibility_mode;
  res.visibility_reason = r.visibility_reason;
  res.memory = r.memory;
  res.fill = r.fill;
  res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

double ViewFactorJobResult::load_imbalance() const { return photometria::load_imbalance(fill_seconds_per_rank); }

std::vector<std::string> view3d_control_notes(const nlohmann::json& control, const ViewFactorJob& job) {
  std::vector<std::string> notes;
  if (!control.is_object()) return notes;
  const bool closure = job.enforcement == Enforcement::Closure || job.enforcement == Enforcement::Both;
  // In the order of the manual's list, then View3D's undocumented keys.
  for (const char* key :
       {"eps", "maxu", "maxo", "mino", "row", "col", "encl", "emit", "out", "list", "maxv", "prjd", "maxd"}) {
    const auto it = control.find(key);
    if (it == control.end() || !it->is_number()) continue;
    const double v = it->get<double>();
    const std::string k = std::string(key) + "=" + control_value(v) + ": ";
    const std::string name(key);
    if (name == "eps") {
      std::ostringstream a;
      a << job.fill.accuracy;
      notes.push_back(k + "superseded by --accuracy " + a.str());
    } else if (name == "maxu" || name == "maxo" || name == "mino" || name == "maxv" || name == "prjd" ||
               name == "maxd") {
      notes.push_back(k + "ignored (View3D's own integration limits; the integration here is adaptive to --accuracy)");
    } else if (name == "row" || name == "col") {
      notes.push_back(k + (v == 0.0 ? "all, as here" : "ignored: every row and column is computed"));
    } else if (name == "encl") {
      if (v == 0.0)
        notes.push_back(k + "no enclosure adjustment" +
                        (closure ? " (but --enforce " + enforcement_name(job.enforcement) + " asked for one)" : ""));
      else
        notes.push_back(k + (closure ? "honoured by --enforce " + enforcement_name(job.enforcement)
                                     : "not applied (rows are not normalised; use --enforce both for View3D's "
                                       "enclosure adjustment)"));
    } else if (name == "emit") {
      notes.push_back(k + (v == 0.0 ? "geometric view factors, as here"
                                    : "honoured: Hottel's total exchange factors (script-F) with the surfaces' "
                                      "emissivities are written"));
    } else if (name == "out") {
      notes.push_back(k + "ignored: the output form is --format " + view_factor_format_name(job.format));
    } else if (name == "list") {
      notes.push_back(k + "ignored (no View3D log file; see the summary and --json)");
    }
  }
  return notes;
}

ViewFactorJobResult run_view_factor_job(const ViewFactorJob& job) {
  const auto t0 = std::chrono::steady_clock::now();
  ViewFactorJobResult res;
  res.job = job;
  res.job.on_load_warning = nullptr;  // the result does not keep the caller's callback alive
  ViewFactorOptions& opt = res.job.fill;
  opt.level = job.level;
  opt.enforcement = job.enforcement != Enforcement::None;
  res.job.points_output = job.points.empty()          ? std::string()
                          : job.points_output.empty() ? job.output + ".points.csv"
                                                      : job.points_output;
  const std::string& points_path = res.job.points_output;
  // On several MPI ranks every rank fills its share of the rows; rank 0 alone holds the outputs.
  // Failures are agreed at fixed points (ranks::agree), so that no rank waits for a failed one.
  const bool on_ranks = ranks::distributed();
  const bool root = ranks::is_root();
  res.ranks = ranks::size();
  std::exception_ptr failure;

  // Every output is opened (its temporary file created) before the long work, so that an
  // unwritable path fails in a second, and committed only when all of them were written, so
  // that a failed run leaves none (io/atomic_file.h).
  const auto all_zero = [](const std::vector<double>& e) {
    return std::all_of(e.begin(), e.end(), [](double x) { return x == 0.0; });
  };
  const std::string no_emissivity =
      ": C emit=1 asks for exchange factors, but every surface's emissivity (the emit field of its S line) is 0";
  std::optional<AtomicOutput> main_out, points_out;
  Scene scene;
  std::vector<SurfacePoint> points;
  try {
    if (on_ranks && job.stream == RowStreaming::No)
      throw_bad_input("--stream no: on several MPI ranks the rows are always written as they are filled");
    if (!points_path.empty()) {
      namespace fs = std::filesystem;
      if (fs::absolute(points_path).lexically_normal() == fs::absolute(job.output).lexically_normal())
        throw_bad_input("--points-output: '" + points_path + "' is also the -o output");
    }
    if (root) main_out.emplace(job.output);
    if (root && !points_path.empty()) points_out.emplace(points_path);

    LoadOptions lo;
    lo.flip_normals = job.flip_normals;
    scene = load_scene(job.scene, lo);
    if (job.on_load_warning && root)
      for (const std::string& w : load_warnings(scene.stats)) job.on_load_warning(scene.source, w);
    // Points are read before the (long) fill so that a bad file fails fast.
    if (!job.points.empty()) points = load_points(job.points);

    // A .vs3 input's `C emit=1`: Hottel's exchange factors instead of the geometric ones.
    res.exchange_factors = view3d_asks_for_exchange_factors(job.scene, scene);
    if (res.exchange_factors && all_zero(view3d_emissivities(job.scene)))  // before the fill
      throw_bad_input(job.scene + no_emissivity);
  } catch (...) { failure = std::current_exception(); }
  if (on_ranks) ranks::agree(failure);
  else if (failure) std::rethrow_exception(failure);
  opt.points = static_cast<int>(points.size());
  opt.exchange_factors = res.exchange_factors;

  // Every form can be written while the rows are filled (compute_view_factors decides). A
  // streamed run has neither enforcement nor exchange factors: View3D's header says 0 and 0.
  std::optional<StreamedRows> streamed;
  opt.stream = job.stream;
  opt.row_sink_for = [&](const PatchMesh& mesh, const Aggregation& agg) -> std::function<bool(int, const double*)> {
    View3dOutput v3;
    if (job.format == ViewFactorFormat::View3d) {
      res.emissivities = view3d_emissivities_of(job.scene, scene, mesh, agg);
      v3.emissivities = res.emissivities;
    }
    streamed.emplace(on_ranks ? nullptr : &*main_out, job.format, agg, job.threshold, v3);
    return [&streamed](int i, const double* row) { return streamed->add(i, row); };
  };
  auto fill_start = t0;  // on ranks: when this rank's rows begin (rows_for)
  if (on_ranks) {
    // Threads per rank: the cores shared by the ranks on this machine, unless --threads says.
    if (opt.threads <= 0)
      opt.threads = std::max(1, int(std::thread::hardware_concurrency()) / std::max(1, ranks::local_size()));
    opt.held_bytes_per_entry = held_bytes_per_entry(job.format);
    opt.held_row_share = 1.0 / res.ranks;
    opt.ranks_per_machine = ranks::local_size();
    opt.rows_for = [&](const PatchMesh& mesh) {
      ranks::agree(nullptr);  // every rank is past patching and the memory check
      fill_start = std::chrono::steady_clock::now();
      std::vector<Vec3> centroids;
      for (const Patch& p : mesh.patches) centroids.push_back(p.centroid);
      const std::vector<double> cost = estimate_row_costs(mesh);
      const std::vector<std::vector<int>> parts = partition_rows(centroids, cost, res.ranks);
      for (const std::vector<int>& part : parts) {
        res.rows_per_rank.push_back(int(part.size()));
        double c = 0.0;
        for (int i : part) c += cost[size_t(i)];
        res.estimated_cost_per_rank.push_back(c);
      }
      return parts[size_t(ranks::rank())];
    };
  }
  res.threads_per_rank = opt.threads > 0 ? opt.threads : omp_get_max_threads();
  PatchViewFactors r;
  try {
    r = compute_view_factors(scene, opt);
  } catch (const ranks::SharedError&) {
    throw;  // agreed already (in rows_for)
  } catch (...) {
    // Before the fill this meets the others' agree() in rows_for, during it their agree() below.
    if (on_ranks) ranks::agree(std::current_exception());
    throw;
  }
  const auto filled = std::chrono::steady_clock::now();
  res.matrix_storage = r.streamed ? "streamed" : r.F.description();
  res.matrix_bytes = r.F.bytes();
  opt.row_sink_for = nullptr;  // (they refer to this frame)
  opt.rows_for = nullptr;
  if (scene.settings.contains("view3d")) res.view3d_control = view3d_control_notes(scene.settings["view3d"], res.job);
  const Aggregation agg = make_aggregation(scene, r.mesh, job.level);
  res.streamed = r.streamed;
  res.stream_reason = r.stream_reason;
  if (on_ranks) {
    ranks::agree(streamed->failure());
    res.fill_seconds_per_rank = ranks::all_values(std::chrono::duration<double>(filled - fill_start).count());
    sum_over_ranks(r.fill);
    try {  // the point factors: rank 0 alone (from the whole scene, which every rank has)
      if (root) finish_points(res, points, r, agg, points_out);
    } catch (...) { failure = std::current_exception(); }
    ranks::agree(failure);
    std::string temp = root ? main_out->temp_path() : std::string();
    ranks::broadcast(temp);
    res.sparse = streamed->finish_on_ranks(temp, job.output, res.checks);
    try {
      if (root) commit_all(*main_out, points_out);
    } catch (...) { failure = std::current_exception(); }
    ranks::agree(failure);
    res.peak_memory_per_rank = ranks::all_values(peak_memory_bytes());
    fill_result(res, scene, r, agg, t0);
    return res;
  }
  if (r.streamed) {
    res.sparse = streamed->finish(res.checks);
    // Rows mirrored in bands were checked for reciprocity while both triangles were held.
    if (r.fill.streamed_reciprocity_error >= 0.0 && agg.size() == r.mesh.size()) {
      res.checks.reciprocity_error = r.fill.streamed_reciprocity_error;
      res.checks.reciprocity_checked = true;
    }
    finish_points(res, points, r, agg, points_out);
    commit_all(*main_out, points_out);
    fill_result(res, scene, r, agg, t0);
    return res;
  }
  res.F = aggregate(std::move(r.F), r.mesh, agg);
  // As View3D (its main program): the enclosure adjustment of the geometric factors first, then
  // the emissivities (IntFac).
  if (job.enforcement != Enforcement::None) res.enforcement_report = enforce(res.F, agg.areas, job.enforcement);
  res.checks = check_matrix(res.F, agg.areas);
  if (job.format == ViewFactorFormat::View3d || res.exchange_factors)
    res.emissivities = view3d_emissivities_of(job.scene, scene, r.mesh, agg);
  if (res.exchange_factors) {
    if (all_zero(res.emissivities)) throw_bad_input(job.scene + no_emissivity);  // of the output surfaces
    res.geometric_checks = res.checks;
    try {
      res.F = exchange_factors(res.F, res.emissivities);
    } catch (const Error& e) { throw Error(e.kind(), job.scene + ": C emit=1: " + e.what()); }
    res.checks = check_matrix(res.F, agg.areas);
  }
  View3dOutput v3;
  if (job.format == ViewFactorFormat::View3d) {
    v3.enclosure = job.enforcement == Enforcement::Closure || job.enforcement == Enforcement::Both ? 1 : 0;
    v3.emittances = res.exchange_factors ? 1 : 0;
    v3.emissivities = res.emissivities;
  }
  std::function<void(double)> writing;
  if (opt.progress) writing = [&opt](double f) { opt.progress("writing", f); };
  res.sparse = write_view_factors(*main_out, job.format, agg.names, agg.areas, res.F, job.threshold, v3, writing);
  finish_points(res, points, r, agg, points_out);
  commit_all(*main_out, points_out);
  fill_result(res, scene, r, agg, t0);
  return res;
}

}  // namespace photometria
