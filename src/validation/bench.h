// The speed benchmark behind `photometria bench`: the bench scenes (cube rooms, a furnished
// room), generated in memory, run through the real pipeline, one row of figures per case
// (docs/performance.md, "Running the bench").
//
// Cases, in order (the smallest size of each scene only with `quick`):
//   cube n=8, 16, 32   closed unit cube room, inward-facing, meshed n × n per wall (N = 6 n²),
//                      grey ρ = 0.5, the floor emitting E = 1. Two rows per size:
//                      "solve"        solve_scene with default options (visibility auto: none,
//                                     the room is convex; centroid rule),
//                      "viewfactors"  compute_view_factors at its default accuracy (per-pair rule
//                                     to 1e-7 relative), the fill alone, then every pair
//                                     checked against the exact factors of
//                                     formfactors/aligned_rectangles.h (outside the timing);
//                      both report max |row sum − 1| (exactly 0 for the continuous problem).
//   room edge=...      a 4 × 3 × 2.5 m room (inward), a ceiling light panel, a table (top + four
//                      legs) and four chairs (seat, four legs, back), every piece a closed
//                      outward-facing box; patch edges chosen for N ≈ 1,500, 6,000 and 22,000
//                      (the last not in quick mode). One "solve" row each (visibility auto).
//   room-faces         the same room as a thermal engineer's or a CAD export's mesh: every face
//                      cut into quads of edge <= 0.2 m (1 m in quick mode), each quad its own
//                      input face (bench_room_many_faces_scene). One "viewfactors" row at the
//                      default accuracy, one patch per face (what `viewfactors --by face` fills).
// No timing is asserted anywhere: the numbers are for reading, `quick` is a crash check.
#pragma once

#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "io/atomic_file.h"

#include "patching/patching.h"
#include "scene/scene.h"

namespace photometria::validation {

// --- scenes ------------------------------------------------------------------------------------

// Closed unit cube [0,1]^3 facing inward, ρ = 0.5, the floor (z = 0) emitting E = 1; six faces,
// meshed n × n per wall by bench_cube_patching(n).
Scene bench_cube_scene();
PatchingOptions bench_cube_patching(int n);

// An axis-aligned box of the room's furniture (metres, z up).
struct BenchBox {
  std::string name;  // "table top", "table leg 1", "chair 2 seat", ...
  Vec3 lo, hi;
};
// Room size: x 4 m, y 3 m, z (up) 2.5 m.
inline constexpr double kBenchRoomX = 4.0, kBenchRoomY = 3.0, kBenchRoomZ = 2.5;
// The table (top 1.2 × 0.8 × 0.04 m at 0.75 m, four 0.05 m legs) and four chairs (0.45 m square
// seat at 0.45 m, four 0.04 m legs, a 0.45 m high back), interiors pairwise disjoint (pieces
// of one table or chair touch).
std::vector<BenchBox> bench_room_furniture();
// Groups: 0 "room" (walls, floor, ceiling; inward), 1 "light" (a 0.8 m square panel 1 mm below
// the ceiling facing down, E = 10 W/m², one-sided sheet), 2 "table", 3 "chairs" (closed
// outward-facing boxes). Materials: wall ρ 0.7, floor ρ 0.5, light ρ 0.8 E 10, table ρ 0.5,
// chair ρ 0.4. Faces in order: the room's six (z = 0, z = top, y = 0, x = top, y = top, x = 0),
// the light, then six per box of bench_room_furniture() in its order. 181 faces, few occluders
// per shaft: visibility `auto` clips exactly (visibility/choice.h).
Scene bench_room_scene();
// Patch edges (metres) of the three room sizes, giving N ≈ 1,500, 6,000 and 22,000.
std::vector<double> bench_room_edges();  // {0.24, 0.112, 0.056}: 1,520, 6,088, 22,419 patches
inline PatchingOptions bench_room_patching(double edge) { return PatchingOptions{edge, 0.0}; }
// bench_room_scene() with every face cut into nu × nv quads of edge at most h metres (nu, nv the
// smallest counts that reach it), each quad its own face of the face's material and group,
// vertices shared where quads meet: 2,130 faces at h = 0.2, 446 at h = 0.5.
Scene bench_room_many_faces_scene(double h);

// --- runner ------------------------------------------------------------------------------------

struct BenchRow {
  std::string scene;       // "cube", "room" or "room-faces"
  std::string setting;     // "n=32", "edge=0.1 m"
  std::string task;        // "solve" or "viewfactors"
  std::string visibility;  // mode used: "none", "exact" or "rays"
  int patches = 0;
  long long pairs_evaluated = 0;                 // form-factor fill: pairs whose kernel was evaluated
  double pairs_per_second = 0.0;                 // pairs_evaluated / form_factor_seconds
  long long kernel_evaluations = 0;              // point-to-polygon evaluations of the fill (FillStats)
  double evaluations_per_second = 0.0;           // kernel_evaluations / form_factor_seconds
  long long pairs_tested = 0, pairs_culled = 0;  // shaft tests of the fill, and those found empty
  long long rays_cast = 0;                       // in the fill (0 unless visibility is "rays")
  double rays_per_second = 0.0;                  // rays_cast / form_factor_seconds (0 when no ray was cast)
  long long gather_rays_cast = 0;                // in the vertex gather (solve rows)
  // Wall seconds. "viewfactors" rows have no solve and no gather (NaN there); total is the
  // whole call (solve_scene or compute_view_factors, patching and visibility set-up included).
  double form_factor_seconds = 0.0, solve_seconds = 0.0, gather_seconds = 0.0, total_seconds = 0.0;
  // Peak resident memory of this case (the process's high-water mark, reset before the case
  // when /proc/self/clear_refs allows it, else the process's peak so far), bytes.
  double peak_memory_bytes = 0.0;
  bool peak_memory_per_case = false;  // whether the reset worked
  double estimated_bytes = 0.0;       // the estimate checked against the memory limit
  std::string matrix_storage;         // "dense double", "sparse float", ...
  double matrix_bytes = 0.0;
  // max_i |Σ_j F_ij − 1|: cube rows (closed room); NaN for the room (its light panel is a
  // one-sided sheet and its legs stand on the floor, so rows do not sum to 1 there).
  double max_row_sum_error = 0.0;
  // Cube "viewfactors" rows (NaN elsewhere): over every ordered pair i != j with an exact factor
  // F*_ij > 0, max |F_ij − F*_ij| / F*_ij and max |F_ij − F*_ij|.
  double max_rel_error = 0.0, max_abs_error = 0.0;
  int threads = 1;
  std::string skipped;  // non-empty: the case did not run, and why (the numbers are then 0/NaN)
};

struct BenchOptions {
  bool quick = false;             // smallest size of each scene only
  int threads = 0;                // 0 = all cores
  double max_memory_bytes = 0.0;  // skip a case whose estimate exceeds this; 0 = MemAvailable
  int max_patches = 0;            // > 0: skip cases with more patches
  std::string only;               // non-empty: run only the cases whose label contains it (not
                                  // returned otherwise); labels are "<scene> <setting> <task>",
                                  // e.g. "cube n=32 solve", "room edge=0.112 m solve"
  std::function<void(const std::string& label)> on_start;  // before each case ("cube n=8 solve")
  std::function<void(const BenchRow&)> on_row;             // after each case (also skipped ones)
  // Optional: a case's stages ("<label>: form factors", ...) and their fraction done, as
  // SolveOptions::progress.
  std::function<void(const std::string& stage, double fraction)> progress;
};

// Runs every case in order. Solver failures propagate (photometria::Error); a case that would
// not fit in memory (or exceeds max_patches) is returned as a skipped row instead of run.
std::vector<BenchRow> run_bench(const BenchOptions& options);

// The column names of bench_csv_line, in order.
std::vector<std::string> bench_columns();
// One CSV line per row (no newline); NaN fields are empty.
std::string bench_csv_line(const BenchRow& row);
// The row as one JSON object, keys = the column names in their order (NaN fields are null).
nlohmann::ordered_json bench_json(const BenchRow& row);
// Writes the header and the rows atomically (io/atomic_file.h); throws Error(Io) naming the file
// when its bytes do not reach the disk. The first form fills `out` without committing it.
void write_bench_csv(AtomicOutput& out, const std::vector<BenchRow>& rows);
void write_bench_csv(const std::string& path, const std::vector<BenchRow>& rows);

}  // namespace photometria::validation
