#pragma once
// Output of the gap diagnosis: gap_report.json (ranking, statistics, shrinkage, confusable pairs),
// a readable gap_report.md, and plots drawn with gnuplot (residual bands over the cycle, before/
// after fits, ranking chart).

#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "gap/diagnosis.hpp"

namespace kneesim::gap {

/// Reference figures quoted next to total-force errors (Knee Grand Challenge).
struct Anchors {
  double winners_rms_low = 229, winners_rms_high = 326;  ///< N, per compartment, competition winners.
  double elastic_foundation_bw = 0.51;                   ///< Body weights, total force, an elastic-foundation co-simulation.
  double jw_body_mass = 66.7;                            ///< kg.
};

/// The report as JSON. NaN becomes null. Per-frame series are left out (they go to .dat files).
nlohmann::json toJson(const GapReport& report, const Anchors& anchors = {});

/// The readable report (Markdown). @p plots are the image files to show, relative to the report.
std::string formatMarkdown(const GapReport& report, const std::vector<std::string>& plots = {},
                           const Anchors& anchors = {});

/// Options of writeGapReport.
struct ReportOptions {
  bool plots = true;             ///< Draw PNGs with gnuplot (skipped with a note when it is missing).
  std::string gnuplot = "gnuplot";  ///< Program to run.
  Anchors anchors;
};

/// Writes into @p directory: gap_report.json, gap_report.md, per target <target>_series.dat,
/// <target>_bands.dat, <target>_ranking.dat, the gnuplot scripts <target>_*.gp and, when gnuplot
/// runs, <target>_bands.png, <target>_fits.png and <target>_ranking.png. Every file is written
/// atomically after the diagnosis is complete. Returns the files written.
std::vector<std::string> writeGapReport(const std::string& directory, const GapReport& report,
                                        const ReportOptions& options = {});

}  // namespace kneesim::gap
