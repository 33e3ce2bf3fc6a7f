#pragma once
// The JSON value of a number for the JSON reports (identification, gap diagnosis, workflow, batch):
// JSON has no NaN or infinity, so an undefined figure is written as null.

#include <cmath>

#include <nlohmann/json.hpp>

namespace kneesim {

/// Returns @p v as a JSON number when it is finite, JSON null otherwise (NaN, ±infinity): an
/// undefined value (no body mass, a singular matrix, an empty window) is written as null rather
/// than as the invalid JSON token NaN.
inline nlohmann::json jsonNumber(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}

}  // namespace kneesim
