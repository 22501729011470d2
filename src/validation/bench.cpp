// The speed benchmark (bench.h): scene generators and the runner.
#include "validation/bench.h"

#include <omp.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <limits>
#include <map>
#include <sstream>

#include "formfactors/aligned_rectangles.h"
#include "formfactors/storage.h"
#include "io/atomic_file.h"
#include "pipeline/memory.h"
#include "pipeline/solve.h"
#include "util/error.h"
#include "validation/scenes.h"
#include "viewfactors/viewfactors.h"

namespace photometria::validation {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Appends the closed box [lo, hi] as six quads, facing out of it (or into it when `inward`).
// Face order: z = lo, z = hi, y = lo, x = hi, y = hi, x = lo.
void add_box(Scene& s, const Vec3& lo, const Vec3& hi, bool inward, int material, int group) {
  const int b = static_cast<int>(s.vertices.size());
  for (int k = 0; k < 8; ++k)
    s.vertices.emplace_back(k & 1 ? hi.x() : lo.x(), k & 2 ? hi.y() : lo.y(), k & 4 ? hi.z() : lo.z());
  // Counter-clockwise seen from outside the box: outward normals.
  static const int faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {1, 3, 7, 5}, {2, 6, 7, 3}, {0, 4, 6, 2}};
  for (const auto& f : faces) {
    Face face;
    for (int k = 0; k < 4; ++k) face.vertices.push_back(b + f[inward ? 3 - k : k]);
    face.material = material;
    face.group = group;
    face.source_face = static_cast<int>(s.faces.size());
    s.faces.push_back(face);
  }
}

double seconds_of(const SolveSummary& s, const std::string& stage) {
  for (const auto& [name, seconds] : s.stage_seconds)
    if (name == stage) return seconds;
  return kNaN;
}

// Max relative and absolute error of F against the exact factors of the axis-aligned
// rectangles (every ordered pair with an exact factor > 0; the pairs not eligible are skipped).
void exact_errors(const PatchMesh& mesh, const FormFactors& F, double& max_rel, double& max_abs) {
  const AlignedRectangles exact(mesh);
  const int n = mesh.size();
  double rel = 0.0, abs_err = 0.0;
#pragma omp parallel for schedule(dynamic, 16) reduction(max : rel, abs_err)
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      if (i == j || !exact.eligible(i, j)) continue;
      const double want = exact.area_factor(i, j) / mesh.patches[i].area;
      if (!(want > 0)) continue;
      const double d = std::abs(F(i, j) - want);
      rel = std::max(rel, d / want);
      abs_err = std::max(abs_err, d);
    }
  max_rel = rel;
  max_abs = abs_err;
}

double max_row_sum_error(const FormFactors& F) {
  double worst = 0.0;
  for (int i = 0; i < F.rows(); ++i) worst = std::max(worst, std::abs(F.row_sum(i) - 1.0));
  return worst;
}

// Resets the process's peak-RSS high-water mark (Linux >= 4.0, "5" to /proc/self/clear_refs),
// so that the next peak_memory_bytes() is this case's peak. False when not allowed.
bool reset_peak_memory() {
  std::ofstream f("/proc/self/clear_refs");
  if (!f) return false;
  f << "5";
  f.flush();
  return static_cast<bool>(f);
}

std::string format_edge(double edge) {
  std::ostringstream s;
  s << "edge=" << edge << " m";
  return s.str();
}

struct Case {
  std::string scene, setting, task;
  const Scene* geometry;
  PatchingOptions patching;
};

// The estimate solve_scene and compute_view_factors check (pipeline/memory.h choose_storage),
// with the default options: the matrix in the layout and precision `auto` picks for the memory
// limit, plus the per-patch arrays.
StorageChoice estimate_storage(const PatchMesh& mesh, double max_memory_bytes) {
  const MemoryEstimate e = estimate_memory(mesh, 1);
  const double n = mesh.size();
  return choose_storage(MatrixLayout::Auto, MatrixPrecision::Auto, n, double(e.nonzero_pairs), e.per_patch_bytes * n,
                        max_memory_bytes);
}

void mark_skipped(BenchRow& row, const std::string& why, int threads) {
  row.skipped = why;
  row.pairs_per_second = row.rays_per_second = row.evaluations_per_second = kNaN;
  row.form_factor_seconds = row.solve_seconds = row.gather_seconds = row.total_seconds = kNaN;
  row.peak_memory_bytes = row.matrix_bytes = kNaN;
  row.threads = threads > 0 ? threads : omp_get_max_threads();
}

// Runs case `c` (started at `start`) and fills the measured fields of `row`.
void measure(const Case& c, const BenchOptions& opt, BenchRow& row, std::chrono::steady_clock::time_point start) {
  const bool closed = c.scene == "cube";
  std::function<void(const std::string&, double)> progress;
  if (opt.progress) {
    const std::string label = c.scene + " " + c.setting + " " + c.task + ": ";
    progress = [&opt, label](const std::string& stage, double f) { opt.progress(label + stage, f); };
  }
  if (c.task == "solve") {
    SolveOptions so;
    so.patching = c.patching;
    so.threads = opt.threads;
    so.max_memory_bytes = opt.max_memory_bytes;
    so.progress = progress;
    const SolveResult r = solve_scene(*c.geometry, so);
    row.total_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const SolveSummary& s = r.summary;
    row.visibility = s.visibility_mode;
    row.pairs_evaluated = s.fill.pairs_evaluated;
    row.kernel_evaluations = s.fill.kernel_evaluations;
    row.pairs_tested = s.fill.pairs_tested;
    row.pairs_culled = s.fill.pairs_culled;
    row.rays_cast = s.fill.rays_cast;
    row.gather_rays_cast = s.vertex_rays_cast;
    row.form_factor_seconds = seconds_of(s, "form_factors");
    row.solve_seconds = seconds_of(s, "solve");
    row.gather_seconds = seconds_of(s, "vertex_gather");
    row.estimated_bytes = s.estimated_bytes;
    row.matrix_storage = s.matrix_storage;
    row.matrix_bytes = s.matrix_bytes;
    row.threads = s.threads;
    if (closed)
      row.max_row_sum_error = std::max(std::abs(s.checks.max_row_sum - 1.0), std::abs(s.checks.min_row_sum - 1.0));
  } else {
    if (opt.threads > 0) omp_set_num_threads(opt.threads);
    ViewFactorOptions vo;
    vo.patching = c.patching;
    vo.level = AggregateLevel::Face;  // for the memory estimate: no N × N aggregated copy follows
    vo.max_memory_bytes = opt.max_memory_bytes;
    vo.progress = progress;
    const PatchViewFactors v = compute_view_factors(*c.geometry, vo);
    row.total_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    row.visibility = v.visibility_mode;
    row.pairs_evaluated = v.fill.pairs_evaluated;
    row.kernel_evaluations = v.fill.kernel_evaluations;
    row.pairs_tested = v.fill.pairs_tested;
    row.pairs_culled = v.fill.pairs_culled;
    row.rays_cast = v.fill.rays_cast;
    row.form_factor_seconds = row.total_seconds;
    row.solve_seconds = row.gather_seconds = kNaN;
    row.matrix_storage = v.F.description();
    row.matrix_bytes = v.F.bytes();
    row.threads = omp_get_max_threads();
    row.estimated_bytes = v.memory.estimated_bytes;
    if (closed) {
      row.max_row_sum_error = max_row_sum_error(v.F);
      row.peak_memory_bytes = peak_memory_bytes();  // before the check's tables
      exact_errors(v.mesh, v.F, row.max_rel_error, row.max_abs_error);
    }
  }
}

BenchRow run_case(const Case& c, const BenchOptions& opt) {
  BenchRow row;
  row.scene = c.scene;
  row.setting = c.setting;
  row.task = c.task;
  row.max_row_sum_error = row.max_rel_error = row.max_abs_error = kNaN;

  const PatchMesh mesh = subdivide(*c.geometry, c.patching);
  row.patches = mesh.size();
  const StorageChoice storage = estimate_storage(mesh, opt.max_memory_bytes);
  row.estimated_bytes = storage.estimated_bytes;
  if (opt.max_patches > 0 && row.patches > opt.max_patches) {
    row.skipped = format_count(row.patches) + " patches > --max-patches " + format_count(opt.max_patches);
  } else if (!storage.fits) {
    row.skipped = "needs about " + format_bytes(row.estimated_bytes) + " (" + storage.storage + ") but " +
                  storage.limit_description();
  }
  if (!row.skipped.empty()) {
    mark_skipped(row, row.skipped, opt.threads);
    return row;
  }

  row.peak_memory_per_case = reset_peak_memory();
  const auto start = std::chrono::steady_clock::now();
  try {
    measure(c, opt, row, start);
  } catch (const Error& e) {
    // The pipeline's own memory guard (its estimate differs from the one above only by the
    // sampling of facing pairs); any other bad input would be a bug of the generators, which
    // the tests catch (quick rows must not be skipped).
    if (e.kind() != ErrorKind::BadInput) throw;
    mark_skipped(row, std::string("refused: ") + e.what(), opt.threads);
    return row;
  }
  if (!std::isfinite(row.peak_memory_bytes) || row.peak_memory_bytes <= 0) row.peak_memory_bytes = peak_memory_bytes();
  row.pairs_per_second = row.form_factor_seconds > 0 ? double(row.pairs_evaluated) / row.form_factor_seconds : kNaN;
  row.evaluations_per_second =
      row.form_factor_seconds > 0 ? double(row.kernel_evaluations) / row.form_factor_seconds : kNaN;
  row.rays_per_second =
      row.rays_cast > 0 && row.form_factor_seconds > 0 ? double(row.rays_cast) / row.form_factor_seconds : 0.0;
  return row;
}

// CSV field: numbers as they are (NaN empty), strings quoted.
std::string num(double x) {
  if (!std::isfinite(x)) return "";
  std::ostringstream s;
  s << std::setprecision(6) << x;
  return s.str();
}
std::string quoted(const std::string& text) {
  std::string out = "\"";
  for (char ch : text) {
    if (ch == '"') out += '"';
    out += ch;
  }
  return out + "\"";
}

}  // namespace

Scene bench_cube_scene() {
  Scene s = unit_cube_scene(0.5, 1.0, 0);
  s.source = "bench cube";
  return s;
}

PatchingOptions bench_cube_patching(int n) {
  // patching.cpp cuts an edge of length L into ceil(L / max_edge − 1e-9) segments: exactly n.
  return PatchingOptions{1.0 / n, 0.0};
}

std::vector<BenchBox> bench_room_furniture() {
  std::vector<BenchBox> boxes;
  const double cx = kBenchRoomX / 2, cy = kBenchRoomY / 2;
  // Table: top 1.2 (x) × 0.8 (y) × 0.04 m, its top surface at 0.75 m; legs 0.05 m square, inset 0.05 m.
  const double top = 0.75, thick = 0.04, leg = 0.05, inset = 0.05, hx = 0.6, hy = 0.4;
  boxes.push_back({"table top", {cx - hx, cy - hy, top - thick}, {cx + hx, cy + hy, top}});
  int k = 0;
  for (int sx : {-1, 1})
    for (int sy : {-1, 1}) {
      const double x = sx < 0 ? cx - hx + inset : cx + hx - inset - leg;
      const double y = sy < 0 ? cy - hy + inset : cy + hy - inset - leg;
      boxes.push_back({"table leg " + std::to_string(++k), {x, y, 0.0}, {x + leg, y + leg, top - thick}});
    }
  // Chairs: two on each long side, seat 0.45 m square and 0.04 m thick with its top at 0.45 m,
  // legs 0.04 m square under the seat's corners, a 0.04 m thick back 0.45 m high on the far edge.
  const double seat = 0.45, seat_top = 0.45, seat_thick = 0.04, chair_leg = 0.04, back = 0.45;
  int c = 0;
  for (int sy : {-1, 1})
    for (int sx : {-1, 1}) {
      const std::string name = "chair " + std::to_string(++c);
      const double x0 = cx + 0.3 * sx - seat / 2, y0 = cy + 0.6 * sy - seat / 2;
      const double x1 = x0 + seat, y1 = y0 + seat;
      boxes.push_back({name + " seat", {x0, y0, seat_top - seat_thick}, {x1, y1, seat_top}});
      int l = 0;
      for (double lx : {x0, x1 - chair_leg})
        for (double ly : {y0, y1 - chair_leg})
          boxes.push_back({name + " leg " + std::to_string(++l),
                           {lx, ly, 0.0},
                           {lx + chair_leg, ly + chair_leg, seat_top - seat_thick}});
      const double by0 = sy > 0 ? y1 - chair_leg : y0;  // the edge away from the table
      boxes.push_back({name + " back", {x0, by0, seat_top}, {x1, by0 + chair_leg, seat_top + back}});
    }
  return boxes;
}

Scene bench_room_scene() {
  Scene s;
  s.source = "bench room";
  s.materials = {Material{"wall", Rgb::Constant(0.7), Rgb::Zero()}, Material{"floor", Rgb::Constant(0.5), Rgb::Zero()},
                 Material{"light", Rgb::Constant(0.8), Rgb::Constant(10.0)},
                 Material{"table", Rgb::Constant(0.5), Rgb::Zero()},
                 Material{"chair", Rgb::Constant(0.4), Rgb::Zero()}};
  s.groups = {"room", "light", "table", "chairs"};
  add_box(s, Vec3::Zero(), Vec3(kBenchRoomX, kBenchRoomY, kBenchRoomZ), /*inward=*/true, 0, 0);
  s.faces[0].material = 1;  // z = 0: the floor
  // Light: 0.8 m square centred under the ceiling, 1 mm below it, facing down (-z).
  const double cx = kBenchRoomX / 2, cy = kBenchRoomY / 2, z = kBenchRoomZ - 0.001;
  const int b = static_cast<int>(s.vertices.size());
  s.vertices.emplace_back(cx - 0.4, cy - 0.4, z);
  s.vertices.emplace_back(cx - 0.4, cy + 0.4, z);
  s.vertices.emplace_back(cx + 0.4, cy + 0.4, z);
  s.vertices.emplace_back(cx + 0.4, cy - 0.4, z);
  s.faces.push_back({{b, b + 1, b + 2, b + 3}, 2, 1, static_cast<int>(s.faces.size())});
  for (const BenchBox& box : bench_room_furniture()) {
    const bool table = box.name.rfind("table", 0) == 0;
    add_box(s, box.lo, box.hi, /*inward=*/false, table ? 3 : 4, table ? 2 : 3);
  }
  return s;
}

std::vector<double> bench_room_edges() { return {0.24, 0.112, 0.056}; }

Scene bench_room_many_faces_scene(double h) {
  const Scene room = bench_room_scene();
  Scene s;
  s.source = "bench room as faces of edge <= " + format_edge(h);
  s.materials = room.materials;
  s.groups = room.groups;
  // One vertex per distinct point (grid corners shared between neighbouring quads and along the
  // edges where faces meet), as a loader's welding would leave them.
  std::map<std::array<long long, 3>, int> index;
  const auto vertex = [&](const Vec3& p) {
    const std::array<long long, 3> key{std::llround(p.x() * 1e9), std::llround(p.y() * 1e9), std::llround(p.z() * 1e9)};
    const auto [it, added] = index.emplace(key, static_cast<int>(s.vertices.size()));
    if (added) s.vertices.push_back(p);
    return it->second;
  };
  for (const Face& face : room.faces) {
    // Every face of the room is a parallelogram: corners a, b, c, d with c = b + d − a.
    const Vec3 a = room.vertices[size_t(face.vertices[0])], u = room.vertices[size_t(face.vertices[1])] - a,
               v = room.vertices[size_t(face.vertices[3])] - a;
    const int nu = std::max(1, int(std::ceil(u.norm() / h - 1e-9))),
              nv = std::max(1, int(std::ceil(v.norm() / h - 1e-9)));
    for (int j = 0; j < nv; ++j)
      for (int i = 0; i < nu; ++i) {
        const auto at = [&](int di, int dj) { return vertex(a + u * double(i + di) / nu + v * double(j + dj) / nv); };
        Face quad = face;
        quad.vertices = {at(0, 0), at(1, 0), at(1, 1), at(0, 1)};
        quad.source_face = static_cast<int>(s.faces.size());
        s.faces.push_back(quad);
      }
  }
  return s;
}

std::vector<BenchRow> run_bench(const BenchOptions& opt) {
  const Scene cube = bench_cube_scene(), room = bench_room_scene();
  const double faces_edge = opt.quick ? 1.0 : 0.2;
  const Scene room_faces = bench_room_many_faces_scene(faces_edge);
  std::vector<Case> cases;
  for (int n : {8, 16, 32}) {
    if (opt.quick && n != 8) continue;
    const std::string setting = "n=" + std::to_string(n);
    cases.push_back({"cube", setting, "solve", &cube, bench_cube_patching(n)});
    cases.push_back({"cube", setting, "viewfactors", &cube, bench_cube_patching(n)});
  }
  const std::vector<double> edges = bench_room_edges();
  if (opt.quick) {
    // A coarse room (a few hundred patches): --quick only checks that every stage runs.
    cases.push_back({"room", format_edge(0.5), "solve", &room, bench_room_patching(0.5)});
  } else {
    for (double edge : edges) cases.push_back({"room", format_edge(edge), "solve", &room, bench_room_patching(edge)});
  }
  cases.push_back({"room-faces", format_edge(faces_edge), "viewfactors", &room_faces, PatchingOptions{}});
  std::vector<BenchRow> rows;
  for (const Case& c : cases) {
    const std::string label = c.scene + " " + c.setting + " " + c.task;
    if (!opt.only.empty() && label.find(opt.only) == std::string::npos) continue;
    if (opt.on_start) opt.on_start(label);
    rows.push_back(run_case(c, opt));
    if (opt.on_row) opt.on_row(rows.back());
  }
  return rows;
}

std::vector<std::string> bench_columns() {
  return {"scene",
          "setting",
          "task",
          "visibility",
          "patches",
          "pairs_evaluated",
          "pairs_per_s",
          "kernel_evaluations",
          "evaluations_per_s",
          "pairs_tested",
          "pairs_culled",
          "rays_cast",
          "rays_per_s",
          "gather_rays_cast",
          "form_factor_s",
          "solve_s",
          "vertex_gather_s",
          "total_s",
          "peak_memory_bytes",
          "peak_memory_per_case",
          "estimated_bytes",
          "matrix_storage",
          "matrix_bytes",
          "max_row_sum_error",
          "max_rel_error",
          "max_abs_error",
          "threads",
          "skipped"};
}

std::string bench_csv_line(const BenchRow& r) {
  std::ostringstream s;
  s << quoted(r.scene) << ',' << quoted(r.setting) << ',' << quoted(r.task) << ',' << quoted(r.visibility) << ','
    << r.patches << ',' << r.pairs_evaluated << ',' << num(r.pairs_per_second) << ',' << r.kernel_evaluations << ','
    << num(r.evaluations_per_second) << ',' << r.pairs_tested << ',' << r.pairs_culled << ',' << r.rays_cast << ','
    << num(r.rays_per_second) << ',' << r.gather_rays_cast << ',' << num(r.form_factor_seconds) << ','
    << num(r.solve_seconds) << ',' << num(r.gather_seconds) << ',' << num(r.total_seconds) << ','
    << num(r.peak_memory_bytes) << ',' << (r.peak_memory_per_case ? 1 : 0) << ',' << num(r.estimated_bytes) << ','
    << quoted(r.matrix_storage) << ',' << num(r.matrix_bytes) << ',' << num(r.max_row_sum_error) << ','
    << num(r.max_rel_error) << ',' << num(r.max_abs_error) << ',' << r.threads << ',' << quoted(r.skipped);
  return s.str();
}

nlohmann::ordered_json bench_json(const BenchRow& r) {
  auto number = [](double x) { return std::isfinite(x) ? nlohmann::ordered_json(x) : nlohmann::ordered_json(nullptr); };
  return {{"scene", r.scene},
          {"setting", r.setting},
          {"task", r.task},
          {"visibility", r.visibility},
          {"patches", r.patches},
          {"pairs_evaluated", r.pairs_evaluated},
          {"pairs_per_s", number(r.pairs_per_second)},
          {"kernel_evaluations", r.kernel_evaluations},
          {"evaluations_per_s", number(r.evaluations_per_second)},
          {"pairs_tested", r.pairs_tested},
          {"pairs_culled", r.pairs_culled},
          {"rays_cast", r.rays_cast},
          {"rays_per_s", number(r.rays_per_second)},
          {"gather_rays_cast", r.gather_rays_cast},
          {"form_factor_s", number(r.form_factor_seconds)},
          {"solve_s", number(r.solve_seconds)},
          {"vertex_gather_s", number(r.gather_seconds)},
          {"total_s", number(r.total_seconds)},
          {"peak_memory_bytes", number(r.peak_memory_bytes)},
          {"peak_memory_per_case", r.peak_memory_per_case},
          {"estimated_bytes", number(r.estimated_bytes)},
          {"matrix_storage", r.matrix_storage},
          {"matrix_bytes", number(r.matrix_bytes)},
          {"max_row_sum_error", number(r.max_row_sum_error)},
          {"max_rel_error", number(r.max_rel_error)},
          {"max_abs_error", number(r.max_abs_error)},
          {"threads", r.threads},
          {"skipped", r.skipped}};
}

void write_bench_csv(const std::string& path, const std::vector<BenchRow>& rows) {
  AtomicOutput out(path);
  write_bench_csv(out, rows);
  out.commit();
}

void write_bench_csv(AtomicOutput& out, const std::vector<BenchRow>& rows) {
  {
    std::ofstream& f = out.stream();
    const std::vector<std::string> columns = bench_columns();
    for (size_t k = 0; k < columns.size(); ++k) f << (k ? "," : "") << columns[k];
    f << '\n';
    for (const BenchRow& r : rows) f << bench_csv_line(r) << '\n';
  }
}

}  // namespace photometria::validation
