// The summary of a view-factor job (viewfactors/job.h) as `photometria viewfactors` prints it:
// JSON with --json, text lines otherwise. Both end with the wall time and the peak resident
// memory of this process at the time of the call (pipeline/solve.h peak_memory_bytes).
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "viewfactors/job.h"

namespace photometria {

// One object: "scene", "output", "format", "level", "surfaces", "patches", "faces", "accuracy",
// "visibility", "visibility_reason", "factors" ("geometric", or "script-F" for a .vs3 input with
// C emit=1), "checks" (of the written matrix: row sums, worst row and its name, reciprocity
// error, entry range), "matrix" (patch storage, why, bytes), "memory_estimate" (bytes of each part,
// the limit and where it came from), "pairs" (the FillStats counts), "enforce" (the mode's name),
// "seconds" (s), "peak_memory_bytes"; and, only when they apply, "enforcement" (checks before and
// after, iterations, max change), "exchange" (with script-F: definition, emissivities, the
// geometric factors' checks), "sparse" (threshold and drop statistics), "points" (count and
// output path).
nlohmann::json viewfactor_summary_json(const ViewFactorJobResult& result);

// The human summary: "view factors: G <level>s from N patches -> OUTPUT (format)", then indented
// lines for visibility, script-F (only with C emit=1: the geometric factors' checks), row sums, reciprocity, patch
// matrix, memory estimate, pairs, enforcement, sparse drops and point factors (the last three only when they apply),
// and "  time ... s, peak memory ... MiB". Every line ends with '\n'; numbers in the stream's default format (6
// significant digits).
std::string viewfactor_summary_text(const ViewFactorJobResult& result);

}  // namespace photometria
