#include "identify/trial.hpp"

#include <algorithm>
#include <cmath>

#include "core/strings.hpp"

namespace kneesim::identify {

namespace {

std::string fmt(double v) { return formatSignificant(v, 6); }

std::string describeWindows(const std::vector<TimeWindow>& w) {
  std::string s;
  for (const auto& x : w) s += (s.empty() ? "" : ", ") + std::string("[") + fmt(x.begin) + ", " + fmt(x.end) + "]";
  return s;
}

}  // namespace

const SourceLocation& locate(const Trial& t, const SourceLocation& fallback) {
  return t.source.file.empty() && t.source.element.empty() ? fallback : t.source;
}

void checkTrial(const Trial& t, const SourceLocation& fallback) {
  const SourceLocation& where = locate(t, fallback);
  const std::string who = "trial '" + t.name + "': ";
  const size_t n = t.time.size();
  if (n == 0) throw InputError(where, who + "expected at least one frame, got none");
  for (size_t i = 0; i < n; ++i) {
    if (!std::isfinite(t.time[i]))
      throw InputError(where, who + "time[" + std::to_string(i) + "]: expected a finite time, got " + fmt(t.time[i]));
    if (i > 0 && !(t.time[i] > t.time[i - 1]))
      throw InputError(where, who + "time[" + std::to_string(i) + "]: expected strictly increasing times, got " +
                                     fmt(t.time[i]) + " after " + fmt(t.time[i - 1]));
  }
  if (t.measured_force.size() != n)
    throw InputError(where, who + "measured force: expected " + std::to_string(n) + " values (one per frame), got " +
                                   std::to_string(t.measured_force.size()));
  if (!t.weight.empty()) {
    if (t.weight.size() != n)
      throw InputError(where, who + "weight: expected " + std::to_string(n) + " values or none, got " +
                                     std::to_string(t.weight.size()));
    for (size_t i = 0; i < n; ++i)
      if (!(t.weight[i] >= 0) || !std::isfinite(t.weight[i]))
        throw InputError(where, who + "weight[" + std::to_string(i) + "]: expected a finite weight >= 0, got " +
                                       fmt(t.weight[i]));
  }
  for (const auto& [name, v] : t.channels)
    if (v.size() != n)
      throw InputError(where, who + "channel '" + name + "': expected " + std::to_string(n) +
                                     " values (one per frame), got " + std::to_string(v.size()));
  for (const auto& w : t.windows)
    if (!(w.begin <= w.end))
      throw InputError(where, who + "time window: expected begin <= end, got [" + fmt(w.begin) + ", " +
                                     fmt(w.end) + "]");
}

std::vector<int> selectFrames(const Trial& t, const SourceLocation& fallback) {
  std::vector<int> out;
  for (size_t i = 0; i < t.time.size(); ++i) {
    bool in = t.windows.empty();
    for (const auto& w : t.windows)
      if (t.time[i] >= w.begin && t.time[i] <= w.end) in = true;
    if (in) out.push_back(static_cast<int>(i));
  }
  if (out.empty()) {
    const std::string range =
        t.time.empty() ? std::string("no frames") : "t = " + fmt(t.time.front()) + " .. " + fmt(t.time.back()) + " s";
    throw InputError(locate(t, fallback), "trial '" + t.name + "': time windows " + describeWindows(t.windows) +
                                   ": expected at least one frame inside, got none (trial has " + range + ")");
  }
  return out;
}

TimeWindow resolvePhase(const Trial& t, const Phase& p) {
  if (!p.fraction_of_trial || t.time.empty()) return {p.begin, p.end};
  const double t0 = t.time.front(), d = t.time.back() - t.time.front();
  return {t0 + p.begin * d, t0 + p.end * d};
}

std::vector<int> selectPhase(const Trial& t, const std::vector<int>& frames, const Phase& p) {
  const TimeWindow w = resolvePhase(t, p);
  // A small tolerance so that fractions 0 and 1 include the end frames despite rounding.
  const double tol = 1e-9 * (t.time.empty() ? 1.0 : std::max(1.0, std::abs(t.time.back())));
  std::vector<int> out;
  for (int i : frames)
    if (t.time[i] >= w.begin - tol && t.time[i] <= w.end + tol) out.push_back(i);
  return out;
}

}  // namespace kneesim::identify
