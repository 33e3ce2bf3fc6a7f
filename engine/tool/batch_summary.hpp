#pragma once
// The summary table of a batch: one row per trial with its status, marker RMS, contact-area peak
// and errors against the measured force, as CSV (batch_summary.csv) and as printed text.

#include <ostream>
#include <string>
#include <vector>

#include "tool/batch_plan.hpp"
#include "tool/batch_run.hpp"
#include "tool/batch_trial.hpp"

namespace kneesim::tool {

/// One row of the summary.
struct BatchSummaryRow {
  std::string subject, trial, activity;
  TrialOutcome outcome;
  TrialFigures figures;  ///< From the trial's summary file (finished trials only).
};

/// The rows of @p plans with their @p outcomes (same order); the figures of finished trials are
/// read from their summary files.
std::vector<BatchSummaryRow> collectBatchSummary(const std::vector<BatchTrialPlan>& plans,
                                                 const std::vector<TrialOutcome>& outcomes);

/// Writes the summary as CSV (atomically): subject, trial, activity, status, seconds, ik_frames,
/// marker_rms_mm, marker_max_mm, contact_peak_mm2, contact_peak_time_s, force_window, force_rmse_N,
/// force_rmse_bw, force_r2, force_peak_measured_N, force_trial_rmse_N, law (name=value;...), error.
void writeBatchSummaryCsv(const std::string& path, const std::vector<BatchSummaryRow>& rows);

/// Prints the summary as an aligned table, then the failures with their messages.
void printBatchSummary(const std::vector<BatchSummaryRow>& rows, std::ostream& os);

}  // namespace kneesim::tool
