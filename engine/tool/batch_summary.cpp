// Collects, writes (CSV) and prints the per-trial summary of a batch.
#include "tool/batch_summary.hpp"

#include <cmath>
#include <cstdio>

#include "core/atomic_file.hpp"
#include "core/error.hpp"

namespace kneesim::tool {

namespace {

std::string fmt(double v, const char* format = "%.6g") {
  if (!std::isfinite(v)) return "";
  char buf[48];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

// A CSV cell: quoted when it holds a comma, a quote or a line end.
std::string cell(const std::string& s) {
  if (s.find_first_of(",\"\n\r") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

}  // namespace

std::vector<BatchSummaryRow> collectBatchSummary(const std::vector<BatchTrialPlan>& plans,
                                                 const std::vector<TrialOutcome>& outcomes) {
  KNEESIM_CHECK(plans.size() == outcomes.size(), "collectBatchSummary: one outcome per plan");
  std::vector<BatchSummaryRow> rows;
  for (size_t i = 0; i < plans.size(); ++i) {
    BatchSummaryRow r{plans[i].spec.subject, plans[i].spec.trial, plans[i].spec.activity, outcomes[i], {}};
    const auto s = outcomes[i].status;
    if (s == TrialOutcome::Status::done || s == TrialOutcome::Status::done_earlier) {
      try {
        r.figures = readTrialFigures(plans[i].summary_file);
      } catch (const InputError& e) {
        r.outcome.message = e.what();
      }
    }
    rows.push_back(std::move(r));
  }
  return rows;
}

void writeBatchSummaryCsv(const std::string& path, const std::vector<BatchSummaryRow>& rows) {
  writeFileAtomically(path, [&](std::ostream& os) {
    os << "subject,trial,activity,status,seconds,ik_frames,marker_rms_mm,marker_max_mm,contact_peak_mm2,"
          "contact_peak_time_s,force_window,force_rmse_N,force_rmse_bw,force_r2,force_peak_measured_N,"
          "force_trial_rmse_N,law,error\n";
    for (const BatchSummaryRow& r : rows) {
      const TrialFigures& f = r.figures;
      std::string law;
      for (const auto& [k, v] : f.law) law += (law.empty() ? "" : ";") + k + "=" + fmt(v, "%.9g");
      os << cell(r.subject) << ',' << cell(r.trial) << ',' << cell(r.activity) << ',' << toString(r.outcome.status)
         << ',' << fmt(r.outcome.seconds, "%.3f") << ',' << (f.ik_frames > 0 ? std::to_string(f.ik_frames) : "")
         << ',' << fmt(f.marker_rms_mm) << ',' << fmt(f.marker_max_mm) << ',' << fmt(f.contact_peak_mm2) << ','
         << fmt(f.contact_peak_time) << ',' << cell(f.force_window) << ',' << fmt(f.force_rmse_n) << ','
         << fmt(f.force_rmse_bw) << ',' << fmt(f.force_r2) << ',' << fmt(f.force_peak_measured_n) << ','
         << fmt(f.force_trial_rmse_n) << ',' << cell(law) << ',' << cell(r.outcome.message) << '\n';
    }
  });
}

void printBatchSummary(const std::vector<BatchSummaryRow>& rows, std::ostream& os) {
  char line[256];
  std::snprintf(line, sizeof line, "%-12s %-14s %-12s %8s %10s %12s %12s %9s\n", "subject", "trial", "status",
                "time (s)", "marker RMS", "area peak", "force RMSE", "force R2");
  os << line;
  std::snprintf(line, sizeof line, "%-12s %-14s %-12s %8s %10s %12s %12s %9s\n", "", "", "", "", "(mm)", "(mm^2)",
                "(N)", "");
  os << line;
  int failed = 0, done = 0;
  for (const BatchSummaryRow& r : rows) {
    const TrialFigures& f = r.figures;
    const auto show = [](double v, const char* format) { return std::isfinite(v) ? fmt(v, format) : std::string("-"); };
    std::snprintf(line, sizeof line, "%-12s %-14s %-12s %8s %10s %12s %12s %9s\n", r.subject.c_str(), r.trial.c_str(),
                  toString(r.outcome.status).c_str(), show(r.outcome.seconds, "%.1f").c_str(),
                  show(f.marker_rms_mm, "%.2f").c_str(), show(f.contact_peak_mm2, "%.0f").c_str(),
                  show(f.force_rmse_n, "%.1f").c_str(), show(f.force_r2, "%.3f").c_str());
    os << line;
    if (r.outcome.status == TrialOutcome::Status::failed) ++failed;
    if (r.outcome.status == TrialOutcome::Status::done || r.outcome.status == TrialOutcome::Status::done_earlier) ++done;
  }
  os << done << " of " << rows.size() << " trials finished, " << failed << " failed";
  const size_t pending = rows.size() - size_t(done) - size_t(failed);
  if (pending > 0) os << ", " << pending << " not run";
  os << "\n";
  for (const BatchSummaryRow& r : rows)
    if (!r.outcome.message.empty()) os << "  " << r.subject << "/" << r.trial << ": " << r.outcome.message << "\n";
}

}  // namespace kneesim::tool
