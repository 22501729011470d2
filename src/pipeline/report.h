// Turning a SolveResult into what the user sees: the .vtu grid, the JSON summary, the table.
//
// .vtu arrays (docs/usage.md "Output"): point data radiosity, irradiance (RGB, W/m²); cell data
// radiosity, irradiance, emission (RGB, W/m²), reflectance (RGB), area (m²), face (source face
// index), group (source group index). One cell per patch.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "io/vtu.h"
#include "pipeline/solve.h"

namespace photometria {

VtuGrid result_grid(const Scene& scene, const SolveResult& result);

// Machine summary (`solve --json`): every figure of SolveSummary plus the load statistics.
nlohmann::json summary_json(const Scene& scene, const SolveSummary& summary);

// Human summary (stderr): aligned "key  value" lines.
std::string summary_table(const Scene& scene, const SolveSummary& summary);

}  // namespace photometria
