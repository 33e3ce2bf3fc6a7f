#pragma once
// JSON form of identification reports (nlohmann::json), e.g. for a workflow's summary.json.

#include <string>

#include <nlohmann/json_fwd.hpp>

#include "identify/fit.hpp"

namespace kneesim::identify {

/// The report as JSON: law, parameters (value, unit, status, bounds, intervals), derived quantities,
/// identifiability (singular values, condition number, null directions by parameter name), solver,
/// metrics overall / per trial / per phase, bootstrap settings and notes. NaN becomes null.
nlohmann::json toJson(const FitReport& report);
/// A prediction as JSON; the time series are included only if @p with_series.
nlohmann::json toJson(const PredictionReport& report, bool with_series = false);
nlohmann::json toJson(const FitMetrics& metrics);
nlohmann::json toJson(const IdentifiabilityReport& report);

/// Writes toJson(report) to @p path atomically (pretty-printed).
void writeFitReport(const std::string& path, const FitReport& report);

}  // namespace kneesim::identify
