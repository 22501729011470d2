// Memory needed by a solve, estimated before the form-factor fill so that a run that cannot fit
// is refused in a second rather than killed by the kernel after minutes.
//
// Dense storage (what the pipeline uses today): the N × N double form-factor matrix, N² × 8
// bytes, plus the per-patch arrays (patches, RGB emission / reflectance / radiosity /
// irradiance, solver vectors, output points and the .vtu copy): per_patch_bytes × N.
// Sparse storage (what a CSR matrix would need): only pairs that can exchange light are
// stored, 12 bytes each (8-byte value + 4-byte column index) plus 8 bytes of row pointer per
// patch, plus the same per-patch arrays. The number of such pairs is estimated by testing
// random ordered pairs with the same facing test the fill uses (formfactors.h facing_away):
// exact when N (N − 1) ≤ 16384, else from 16384 samples (standard error ≤ 0.4 % of N (N − 1)).
#pragma once

#include <cstdint>
#include <string>

#include "formfactors/storage.h"
#include "patching/patching.h"

namespace photometria {

struct MemoryEstimate {
  int patches = 0;
  long long pairs_total = 0;     // N (N − 1)
  long long nonzero_pairs = 0;   // pairs facing each other (estimate, see above)
  double per_patch_bytes = 0.0;  // the arrays other than the matrix, per patch
  double dense_bytes = 0.0;      // N² × 8 + per_patch_bytes × N
  double sparse_bytes = 0.0;     // nonzero_pairs × 12 + (N + 1) × 8 + per_patch_bytes × N
};

// Estimates both storages for `mesh`; `seed` makes the pair sampling repeatable.
MemoryEstimate estimate_memory(const PatchMesh& mesh, uint64_t seed = 1);
// The same estimate before patching, from the counts of count_patches(scene, options) and the
// patches' shapes computed one at a time (patching.h ImplicitPatches): nothing is allocated that
// grows with the patch count. Equal to the estimate of the mesh subdivide() makes, up to the
// rounding of patch corners. Beyond what a mesh can index (!grid.fits_int()) nothing is
// sampled: patches = INT_MAX, pairs = LLONG_MAX, and dense_bytes = sparse_bytes from the count.
MemoryEstimate estimate_memory(const Scene& scene, const PatchGrid& grid, uint64_t seed = 1);

// A patch count for messages: "14,000", or "1.2e+12" beyond what a long long holds exactly.
std::string format_patch_count(double patches);

// The form-factor storage a run uses, chosen before the fill (the solve and `viewfactors` both).
struct StorageChoice {
  MatrixLayout layout = MatrixLayout::Dense;            // resolved: Dense or Sparse
  MatrixPrecision precision = MatrixPrecision::Double;  // resolved: Double or Float
  std::string storage;                                  // "dense double", "sparse float", ...
  std::string reason;            // why, for the summary ("auto: 74.2% of pairs face each other, ...")
  double matrix_bytes = 0.0;     // the matrix in that storage
  double estimated_bytes = 0.0;  // matrix_bytes + other_bytes
  double limit_bytes = 0.0;      // what it must fit in (0: unknown, no limit)
  std::string limit_source;      // "--max-memory" or "MemAvailable"
  bool fits = true;              // estimated_bytes <= limit_bytes (or no limit)
  // For a refusal: "--max-memory is 2 GiB" or "only 1.2 GiB is available (MemAvailable; set
  // --max-memory to override)".
  std::string limit_description() const;  // memory_limit_description(limit_bytes, limit_source)
};
// "--max-memory is 2 GiB" (limit_source "--max-memory") or "only 1.2 GiB is available
// (MemAvailable; set --max-memory to override)".
std::string memory_limit_description(double limit_bytes, const std::string& limit_source);

// Layout auto: the smaller of dense and sparse for `nonzeros` expected non-zero entries of an
// n × n matrix (choose_layout). Precision auto: double, unless the matrix in double and
// `other_bytes` would exceed the limit while float fits (everything is double by default; float
// storage is said in the summary: docs/theory.md "Units and conventions", docs/usage.md
// `--matrix-precision`). The limit is `max_memory_bytes` when > 0, else
// MemAvailable.
StorageChoice choose_storage(MatrixLayout layout, MatrixPrecision precision, double n, double nonzeros,
                             double other_bytes, double max_memory_bytes);

// The storage decision and the memory check of a run, the solve's and `viewfactors`' alike:
// choose_storage() for `patches` patches (nonzero pairs and per-patch bytes from `estimate`)
// plus `extra_bytes` of the run's own (viewfactors: its output matrices), refused with
// Error(BadInput) when the estimate exceeds the limit, in one line:
//   "<subject> <bytes> for <N> patches (<storage> form factors<what_else>) but <limit>;
//    raise --max-edge[, try --matrix-precision float][, <more_ways>] or raise --max-memory"
// (the float advice only when the matrix was double). Called before patching, from the
// counts, and again after, from the mesh.
StorageChoice check_storage(const MemoryEstimate& estimate, double patches, double extra_bytes, MatrixLayout layout,
                            MatrixPrecision precision, double max_memory_bytes, const std::string& subject,
                            const std::string& what_else = "", const std::string& more_ways = "");

// MemAvailable from /proc/meminfo, bytes; 0 when it cannot be read.
double available_memory_bytes();

// "1.6 GiB", "512 MiB", "3.2 KiB", "100 bytes": powers of 1024, one decimal below 10 units ("1 GiB"
// when it is .0), whole units from 10 up.
std::string format_bytes(double bytes);
// 14000 -> "14,000".
std::string format_count(long long n);

// "1G", "1.5GiB", "512M", "800MB", "64k", "1000000" -> bytes (K, M, G, T are powers of 1024,
// with an optional "B" or "iB"). Returns false for anything else, or a value <= 0 or not finite.
bool parse_memory_size(const std::string& text, double& bytes);

}  // namespace photometria
