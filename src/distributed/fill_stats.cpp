#include "distributed/fill_stats.h"

#include <algorithm>
#include <vector>

#include "distributed/ranks.h"

namespace photometria {

// The fill's counts summed over the ranks, its maxima the largest of any rank's.
void sum_over_ranks(FillStats& f) {
  long long* fields[] = {&f.pairs_evaluated,
                         &f.pairs_backfacing,
                         &f.pairs_tested,
                         &f.pairs_culled,
                         &f.pairs_occluded,
                         &f.pairs_blocked_whole,
                         &f.rays_cast,
                         &f.above_unoccluded,
                         &f.points_rescaled,
                         &f.pairs_fixed_rule,
                         &f.pairs_gauss,
                         &f.pairs_adaptive,
                         &f.pairs_exact_rectangles,
                         &f.kernel_evaluations,
                         &f.pairs_occluded_adaptive,
                         &f.occluded_evaluations,
                         &f.occluded_budget_exhausted};
  std::vector<long long> counts;
  for (long long* field : fields) counts.push_back(*field);
  ranks::sum(counts);
  for (size_t k = 0; k < counts.size(); ++k) *fields[k] = counts[k];
  f.max_point_row_sum = ranks::max(f.max_point_row_sum);
  f.max_row_error_estimate = ranks::max(f.max_row_error_estimate);
  f.max_row_ray_error = ranks::max(f.max_row_ray_error);
}

double load_imbalance(const std::vector<double>& seconds) {
  double sum = 0.0, most = 0.0;
  for (double t : seconds) {
    sum += t;
    most = std::max(most, t);
  }
  return sum > 0.0 ? most * double(seconds.size()) / sum : 1.0;
}

}  // namespace photometria
