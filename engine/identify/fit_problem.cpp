// The problem a fit solves: the request checked, the parameters' values, bounds and free set from
// the options, and the trials' selected frames as weighted residuals (with the start checked).

#include <algorithm>
#include <set>

#include "identify/fit_detail.hpp"

namespace kneesim::identify::detail {

void checkRequest(const ContactLaw& law, const std::vector<Trial>& trials, const FitOptions& o) {
  const std::string lawq = "contact law '" + law.getName() + "'";
  if (trials.empty()) throw InputError(o.where, lawq + ": expected at least one trial to fit, got none");
  {
    std::set<std::string> seen;
    for (const auto& t : trials)
      if (!seen.insert(t.name).second)
        throw InputError(o.where, "trial names: expected unique names, got '" + t.name + "' twice");
  }
  if (!(o.confidence.level > 0 && o.confidence.level < 1))
    throw InputError(o.where, "confidence level: expected a value in (0, 1), got " + fmt(o.confidence.level));
}

FitParameters resolveParameters(const ContactLaw& law, const FitOptions& o) {
  const int np = law.getNumParameters();
  const std::string lawq = "contact law '" + law.getName() + "'";
  FitParameters p;
  Eigen::VectorXd& full = p.full;
  std::vector<double>& lower = p.lower;
  std::vector<double>& upper = p.upper;
  std::vector<std::string>& source = p.source;
  full = law.getDefaultValues();
  lower.resize(np);
  upper.resize(np);
  source.assign(np, "law default");
  for (int j = 0; j < np; ++j) {
    lower[j] = law.getParameter(j).lower;
    upper[j] = law.getParameter(j).upper;
  }
  for (const auto& [name, v] : o.parameter_values) {
    const int j = law.getParameterIndex(name, o.where);
    if (!std::isfinite(v))
      throw InputError(o.where, lawq + ": parameter '" + name + "': expected a finite value, got " + fmt(v));
    full[j] = v;
    source[j] = "setup";
  }
  for (const auto& [name, b] : o.bounds) {
    const int j = law.getParameterIndex(name, o.where);
    if (!(b.first < b.second))
      throw InputError(o.where, lawq + ": parameter '" + name + "': expected bounds lower < upper, got [" +
                                    fmt(b.first) + ", " + fmt(b.second) + "]");
    lower[j] = b.first;
    upper[j] = b.second;
  }
  for (const auto& [name, v] : o.assumed_values) {
    const int j = law.getParameterIndex(name, o.where);
    if (!(v >= lower[j] && v <= upper[j]))
      throw InputError(o.where, lawq + ": assumed value of '" + name + "': expected a value in [" + fmt(lower[j]) +
                                    ", " + fmt(upper[j]) + "], got " + fmt(v));
  }
  std::vector<int>& freed = p.freed;
  if (o.free_parameters.empty()) {
    for (int j = 0; j < np; ++j)
      if (!law.getParameter(j).fixed_by_default) freed.push_back(j);
  } else {
    for (const auto& name : o.free_parameters) {
      const int j = law.getParameterIndex(name, o.where);
      if (std::find(freed.begin(), freed.end(), j) == freed.end()) freed.push_back(j);
    }
    std::sort(freed.begin(), freed.end());
  }
  std::vector<std::string>& start_notes = p.start_notes;
  for (int j : freed)
    if (source[j] == "law default" && !(full[j] >= lower[j] && full[j] <= upper[j])) {
      // The setup narrowed the bounds past the law's default start: start on the nearest bound.
      const double v = std::clamp(full[j], lower[j], upper[j]);
      start_notes.push_back("start value of '" + law.getParameter(j).name + "' moved from the law default " +
                            fmt(full[j]) + " into the bounds: " + fmt(v));
      full[j] = v;
    }
  for (int j : freed)
    if (!(full[j] >= lower[j] && full[j] <= upper[j]))
      throw InputError(o.where, lawq + ": parameter '" + law.getParameter(j).name + "': expected a start value in [" +
                                    fmt(lower[j]) + ", " + fmt(upper[j]) + "], got " + fmt(full[j]));
  return p;
}

std::vector<TrialData> makeTrialData(const ContactLaw& law, const std::vector<Trial>& trials, const FitOptions& o) {
  std::vector<TrialData> tds;
  for (const auto& t : trials) {
    const SourceLocation& where = locate(t, o.where);
    checkTrial(t, o.where);
    TrialData td{&t, LawInputs(law, t.channels, t.time, t.name, where), selectFrames(t, o.where), {}, {}, {}, 0};
    for (int i : td.frames) {
      if (!std::isfinite(t.measured_force[i]))
        throw InputError(where, "trial '" + t.name + "': measured force at t = " + fmt(t.time[i]) +
                                    " s: expected a finite force, got " + fmt(t.measured_force[i]) +
                                    " (leave such frames out with a time window)");
      td.weight.push_back(t.weight.empty() ? 1.0 : t.weight[i]);
    }
    tds.push_back(std::move(td));
  }
  return tds;
}

void checkStartForces(Dataset& data, const ContactLaw& law, const Eigen::VectorXd& full) {
  const std::string lawq = "contact law '" + law.getName() + "'";
  for (auto& t : data.getTrials()) {
    law.calcForce(full.data(), t.inputs, t.force.data(), nullptr);
    for (int i : t.frames)
      if (!std::isfinite(t.force[i]))
        throw InputError(t.inputs.getSource(), lawq + " gives a non-finite force (" + fmt(t.force[i]) + ") at t = " +
                                                   fmt(t.trial->time[i]) + " s of trial '" + t.trial->name +
                                                   "' at the start values: check its input channels there");
  }
}

void holdOneOut(const ContactLaw& law, const std::vector<int>& f, int held, const Eigen::VectorXd& p,
                const std::vector<double>& lower, const std::vector<double>& upper, std::vector<int>& rest,
                std::vector<double>& y0, LeastSquaresOptions& lo) {
  lo.lower.clear();
  lo.upper.clear();
  lo.scale.clear();
  for (size_t b = 0; b < f.size(); ++b)
    if (static_cast<int>(b) != held) {
      rest.push_back(f[b]);
      y0.push_back(p[f[b]]);
      lo.lower.push_back(lower[f[b]]);
      lo.upper.push_back(upper[f[b]]);
      lo.scale.push_back(law.getParameter(f[b]).typical_scale);
    }
}

double lag1Correlation(Dataset& data, const Eigen::VectorXd& r) {
  double num = 0, den = 0;
  for (const auto& t : data.getTrials()) {
    for (size_t s = 0; s < t.frames.size(); ++s) {
      const double a = r[t.offset + s];
      den += a * a;
      if (s + 1 < t.frames.size() && t.frames[s + 1] == t.frames[s] + 1) num += a * r[t.offset + s + 1];
    }
  }
  return den > 0 ? num / den : 0.0;
}

}  // namespace kneesim::identify::detail
