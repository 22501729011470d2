// The rows of the form-factor matrix split over R ranks: a spatial partition balanced by the
// estimated cost of each row, not i mod R.
//
// The receivers are ordered along the Morton (Z-order) curve of their centroids (G. M. Morton,
// "A computer oriented geodetic data base and a new technique in file sequencing", IBM Ltd.,
// 1966), the curve is cut into R × K runs ("chunks") of equal estimated cost, and the chunks are
// dealt to the ranks in turn (block-cyclic): each chunk is patches near each other, whose shafts
// meet the same occluders, and each rank gets K chunks from all over the scene, so that where the
// estimate misses (occluded pairs cost more than it counts) the misses average out instead of
// landing on one rank.
//
// The cost of row i is what the fill does for it: one kernel per source facing i (Lambert's
// closed form), estimated from a fixed sample of at most `kCostSample` sources, plus 1 for the row
// itself. Occluded pairs cost more than this counts (formfactors/occluded_row.h); the run's
// summary reports the imbalance as measured, so the estimate's error is visible.
#pragma once

#include <vector>

#include "patching/patching.h"

namespace photometria {

inline constexpr int kCostSample = 256;

// Per patch i: 1 + (sources j facing i, estimated from an even sample of the patches). Size N.
std::vector<double> estimate_row_costs(const PatchMesh& mesh);

// K, the chunks per rank. On 2 ranks the slower rank's fill time over the mean was, on the 5,380-face
// city blocks (make_meshes.py --street-canyons 2), 1.13 with K = 1 and 1.01 with K = 16 or 64; on
// the 6,332-face room with a table (--many-faces 0.1), whose costly rows crowd around the table,
// 1.18 with K = 16, 1.08 with K = 64 and 1.07 with K = 256 (docs/performance.md "On MPI ranks").
inline constexpr int kChunksPerRank = 64;

// The rows of `parts` ranks (parts >= 1): each row (0 .. costs.size() - 1) in exactly one part.
// The Morton order of `centroids` is cut into parts × chunks_per_part chunks where the running
// cost (each row counted at its midpoint) passes c / (parts × chunks_per_part) of the total, and
// chunk c goes to part c mod parts; a part's rows are in curve order. Chunks may be empty when
// rows are fewer than chunks. chunks_per_part = 1: each part one contiguous run of the curve.
std::vector<std::vector<int>> partition_rows(const std::vector<Vec3>& centroids, const std::vector<double>& costs,
                                             int parts, int chunks_per_part = kChunksPerRank);

// The Morton order of points: indices sorted by the interleaved bits of their coordinates,
// quantised to 21 bits per axis in their bounding box (ties by index).
std::vector<int> morton_order(const std::vector<Vec3>& points);

}  // namespace photometria
