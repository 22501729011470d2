// The form-factor fill's statistics (formfactors.h FillStats) of an MPI run: each rank filled
// some rows; the summary reports the whole run's.
#pragma once

#include <vector>

#include "formfactors/formfactors.h"

namespace photometria {

// The counts summed over the ranks, the maxima the largest of any rank's (on every rank; a
// collective call: every rank calls it once, at the same point). Lists every FillStats field.
void sum_over_ranks(FillStats& f);

// The load imbalance of a fill from each rank's seconds: max / mean (1: balanced; 1 when empty).
double load_imbalance(const std::vector<double>& fill_seconds_per_rank);

}  // namespace photometria
