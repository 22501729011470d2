// The rows of the form-factor matrix split over R ranks: a spatial partition balanced by the
// estimated cost of each row, not i mod R.
//
// The receivers are ordered along the Morton (Z-order) curve of their centroids (G. M. Morton,
// "A computer oriented geodetic data base and a new technique in file sequencing", IBM Ltd.,
// 1966), and the curve is cut into R runs of equal estimated cost: each rank's rows are patches
// near each other, whose shafts meet the same occluders, and no rank gets the expensive corner of
// a room while another gets its empty walls.
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

// The rows of `parts` ranks (parts >= 1): each row (0 .. costs.size() - 1) in exactly one part,
// every part a contiguous run of the Morton order of `centroids`, in that order, cut where the
// running cost passes k/parts of the total (a part may be empty when rows are fewer than parts).
std::vector<std::vector<int>> partition_rows(const std::vector<Vec3>& centroids, const std::vector<double>& costs,
                                             int parts);

// The Morton order of points: indices sorted by the interleaved bits of their coordinates,
// quantised to 21 bits per axis in their bounding box (ties by index).
std::vector<int> morton_order(const std::vector<Vec3>& points);

}  // namespace photometria
