// Cross-validation over cycles for the gap diagnosis: the cycles of the trials as units, the
// folds, a model fitted on all units and validated on each held-out fold, and the prewhitening of
// held-out errors.

#include <algorithm>
#include <cmath>
#include <set>

#include "gap/diagnosis_detail.hpp"

namespace kneesim::gap::detail {

namespace {

// A unit's values as one run of consecutive frames (NaN where the unit skips a frame), low-passed
// at kComparisonBandwidth when the run is complete: a measured force does not carry the
// frame-to-frame jitter the kinematics put into a model's areas, and whitening would weigh it most.
constexpr double kComparisonBandwidth = 6;  // Hz
std::vector<double> unitRun(const Context& c, const Unit& u, const std::vector<double>& v) {
  if (u.frames.empty()) return {};
  std::vector<double> run(u.frames.back() - u.frames.front() + 1, kNaN);
  for (int i : u.frames) run[i - u.frames.front()] = v[i];
  const auto& time = c.trials[u.trial].time;
  const double rate = time.size() > 1 ? (time.size() - 1) / (time.back() - time.front()) : 0.0;
  if (run.size() > 12 && rate > 2 * kComparisonBandwidth &&
      std::all_of(run.begin(), run.end(), [](double x) { return std::isfinite(x); }))
    run = lowPass(run, rate, kComparisonBandwidth);
  return run;
}

std::vector<std::pair<double, double>> windowsOf(const Context& c, int trial, const std::vector<int>& unit_ids) {
  std::vector<std::pair<double, double>> w;
  for (int u : unit_ids)
    if (c.units[u].trial == trial) w.emplace_back(c.units[u].begin, c.units[u].end);
  return w;
}

// A partial cycle at a recording's edge much shorter than a whole one says little on its own:
// merge it into its neighbour in the same trial (units are only the blocks of cross-validation
// and of the sign-flip test; frames keep their own cycle position).
void mergeShortUnits(std::vector<Unit>& units) {
  std::map<std::string, std::vector<double>> sizes;
  for (const auto& u : units) sizes[u.activity].push_back(static_cast<double>(u.frames.size()));
  std::map<std::string, double> median;
  for (auto& [a, v] : sizes) {
    std::sort(v.begin(), v.end());
    median[a] = v[v.size() / 2];
  }
  for (size_t k = 0; k < units.size();) {
    const bool tiny = units[k].frames.size() < 0.4 * median[units[k].activity];
    const bool next_same = k + 1 < units.size() && units[k + 1].trial == units[k].trial;
    const bool prev_same = k > 0 && units[k - 1].trial == units[k].trial;
    if (tiny && (next_same || prev_same)) {
      Unit& into = next_same ? units[k + 1] : units[k - 1];
      into.frames.insert(into.frames.end(), units[k].frames.begin(), units[k].frames.end());
      std::sort(into.frames.begin(), into.frames.end());
      units.erase(units.begin() + static_cast<long>(k));
      continue;
    }
    ++k;
  }
}

}  // namespace

// The prewhitened held-out squared errors of each unit from m.pred.
void updateWhitened(const Context& c, Model& m) {
  m.unit_wsse.assign(c.units.size(), 0.0);
  std::vector<double> r;
  for (size_t u = 0; u < c.units.size(); ++u) {
    const Unit& un = c.units[u];
    if (c.ar.empty()) {
      m.unit_wsse[u] = m.unit_sse[u];
      continue;
    }
    r.assign(c.trials[un.trial].time.size(), kNaN);
    for (int i : un.frames) r[i] = c.trials[un.trial].measured_force[i] - m.pred[un.trial][i];
    m.unit_wsse[u] = whitenedSumOfSquares(c.ar, unitRun(c, un, r));
  }
}

// Per-frame values minus their activity's mean over the normalised cycle (bin means over all units
// of the activity, interpolated linearly between bin centres); NaN where fewer than two units cover
// a bin or the frame has no phase. What repeats from cycle to cycle is structure an effect may
// explain; what differs between cycles is the noise (the report's repeatability band).
std::vector<std::vector<double>> cycleDeviations(const Context& c, const std::vector<std::vector<double>>& v, int bins) {
  struct Curve {
    std::vector<double> sum, frames;
    std::vector<int> units;
  };
  std::map<std::string, Curve> curves;
  auto binOf = [&](double phase) { return std::clamp(static_cast<int>(phase * bins), 0, bins - 1); };
  auto usable = [&](const Unit& u, int i) {
    return std::isfinite(v[u.trial][i]) && std::isfinite((*c.gap_trials)[u.trial].cycle_phase[i]);
  };
  for (const auto& u : c.units) {
    Curve& cv = curves[u.activity];
    cv.sum.resize(bins, 0.0);
    cv.frames.resize(bins, 0.0);
    cv.units.resize(bins, 0);
    std::vector<bool> seen(bins, false);
    for (int i : u.frames) {
      if (!usable(u, i)) continue;
      const int b = binOf((*c.gap_trials)[u.trial].cycle_phase[i]);
      cv.sum[b] += v[u.trial][i];
      cv.frames[b] += 1;
      seen[b] = true;
    }
    for (int b = 0; b < bins; ++b) cv.units[b] += seen[b];
  }
  std::vector<std::vector<double>> out(v.size());
  for (size_t t = 0; t < v.size(); ++t) out[t].assign(v[t].size(), kNaN);
  for (const auto& u : c.units) {
    const Curve& cv = curves.at(u.activity);
    auto meanAt = [&](int b) { return cv.units[b] >= 2 ? cv.sum[b] / cv.frames[b] : kNaN; };
    for (int i : u.frames) {
      if (!usable(u, i)) continue;
      const double x = (*c.gap_trials)[u.trial].cycle_phase[i] * bins - 0.5;  // in bin-centre units
      const int b0 = std::clamp(static_cast<int>(std::floor(x)), 0, bins - 1), b1 = std::min(bins - 1, b0 + 1);
      const double w = std::clamp(x - b0, 0.0, 1.0);
      out[u.trial][i] = v[u.trial][i] - ((1 - w) * meanAt(b0) + w * meanAt(b1));
    }
  }
  return out;
}

// The prewhitening filter of a target: an AR model of the baseline's in-sample residuals over the
// units (DiagnosisOptions::prewhiten_order), once their cycle-locked mean is removed (cycleDeviations).
std::vector<double> fitPrewhitening(const Context& c, const std::vector<std::vector<double>>& v, int order) {
  if (order == 0) return {};
  std::vector<std::vector<double>> runs;
  for (const auto& u : c.units) runs.push_back(unitRun(c, u, v[u.trial]));
  return fitAutoregression(runs, order);
}

// The target trials restricted to the given units (trials without any are left out).
std::vector<identify::Trial> restrict(const Context& c, const std::vector<int>& unit_ids) {
  std::vector<identify::Trial> out;
  for (size_t t = 0; t < c.trials.size(); ++t) {
    const auto w = windowsOf(c, static_cast<int>(t), unit_ids);
    if (w.empty()) continue;
    identify::Trial tr = c.trials[t];
    for (const auto& [b, e] : w) tr.windows.push_back({b, e});
    out.push_back(std::move(tr));
  }
  return out;
}

identify::FitOptions fitOptionsFor(const Context& c, const identify::ContactLaw& law, const std::vector<std::string>& free,
                                   const Eigen::VectorXd& start, bool warm) {
  identify::FitOptions fo;
  fo.free_parameters = free;
  for (int j = 0; j < law.getNumParameters(); ++j) fo.parameter_values[law.getParameter(j).name] = start[j];
  for (const auto& [name, b] : c.o->fit.bounds)
    if (law.findParameterIndex(name) >= 0) fo.bounds[name] = b;
  fo.identifiability_tolerance = c.o->fit.identifiability_tolerance;
  fo.weak_identifiability_tolerance = c.o->fit.weak_identifiability_tolerance;
  fo.body_mass = c.o->fit.body_mass;
  fo.confidence.level = c.o->level;
  fo.confidence.asymptotic = true;
  fo.confidence.profile = false;
  fo.confidence.bootstrap_samples = 0;
  fo.max_iterations = c.o->fit.max_iterations;
  fo.tolerance = c.o->fit.tolerance;
  fo.where = c.o->fit.where;
  fo.warm_start = warm;
  return fo;
}

std::vector<int> allUnits(const Context& c) {
  std::vector<int> v(c.units.size());
  std::iota(v.begin(), v.end(), 0);
  return v;
}

// Fits `m` on all units (its law, free set and start in m.params) and cross-validates it.
void fitAndValidate(const Context& c, Model& m) {
  const std::vector<identify::Trial> all = restrict(c, allUnits(c));
  m.fit = identify::fit(m.law, all, fitOptionsFor(c, m.law, m.free, m.params));
  m.params = m.fit.getValues();
  // In-sample forces.
  m.fitted.assign(c.trials.size(), {});
  for (size_t t = 0; t < c.trials.size(); ++t) {
    const identify::LawInputs in(m.law, c.trials[t].channels, c.trials[t].time, c.trials[t].name);
    Eigen::VectorXd f;
    m.law.calcForce(m.params, in, f);
    m.fitted[t].assign(f.data(), f.data() + f.size());
  }
  m.pred.assign(c.trials.size(), {});
  for (size_t t = 0; t < c.trials.size(); ++t) m.pred[t].assign(c.trials[t].time.size(), kNaN);
  m.unit_sse.assign(c.units.size(), 0.0);
  m.fold_params.clear();
  m.cv_failures = 0;
  m.cv_failure_status.clear();
  for (const auto& fold : c.folds) {
    std::vector<int> train;
    for (size_t u = 0; u < c.units.size(); ++u)
      if (std::find(fold.begin(), fold.end(), static_cast<int>(u)) == fold.end()) train.push_back(static_cast<int>(u));
    const identify::FitReport fr =
        identify::fit(m.law, restrict(c, train), fitOptionsFor(c, m.law, m.free, m.params, /*warm=*/true));
    if (!fr.solver.success) ++m.cv_failures, m.cv_failure_status = fr.solver.status;
    const Eigen::VectorXd p = fr.getValues();
    m.fold_params.push_back(p);
    std::set<int> trials_in_fold;
    for (int u : fold) trials_in_fold.insert(c.units[u].trial);
    for (int t : trials_in_fold) {
      const identify::LawInputs in(m.law, c.trials[t].channels, c.trials[t].time, c.trials[t].name);
      Eigen::VectorXd f;
      m.law.calcForce(p, in, f);
      for (int u : fold) {
        if (c.units[u].trial != t) continue;
        double sse = 0;
        for (int i : c.units[u].frames) {
          m.pred[t][i] = f[i];
          const double r = c.trials[t].measured_force[i] - f[i];
          sse += r * r;
        }
        m.unit_sse[u] = sse;
      }
    }
  }
  updateWhitened(c, m);
}

// Lag-1 autocorrelation of per-frame values pooled over units (consecutive frames only).
double pooledLag1(const Context& c, const std::vector<std::vector<double>>& v) {
  double num = 0, den = 0;
  for (const auto& u : c.units) {
    double m = 0;
    int n = 0;
    for (int i : u.frames)
      if (std::isfinite(v[u.trial][i])) m += v[u.trial][i], ++n;
    if (n == 0) continue;
    m /= n;
    for (size_t k = 0; k < u.frames.size(); ++k) {
      const double a = v[u.trial][u.frames[k]] - m;
      if (!std::isfinite(a)) continue;
      den += a * a;
      if (k + 1 < u.frames.size() && std::isfinite(v[u.trial][u.frames[k + 1]]))
        num += a * (v[u.trial][u.frames[k + 1]] - m);
    }
  }
  return den > 0 ? num / den : 0.0;
}

std::vector<std::string> activitiesOf(const Context& c) {
  std::vector<std::string> a;
  for (const auto& u : c.units)
    if (std::find(a.begin(), a.end(), u.activity) == a.end()) a.push_back(u.activity);
  return a;
}

Context makeContext(const identify::ContactLaw& base, const std::vector<GapTrial>& trials, const DiagnosisOptions& o,
                    const std::string& target, std::string& cv_scheme) {
  const SourceLocation& where = o.fit.where;
  Context c;
  c.base = &base;
  c.gap_trials = &trials;
  c.o = &o;
  c.body_weight = o.fit.body_mass * identify::kStandardGravity;
  for (size_t t = 0; t < trials.size(); ++t) {
    c.trials.push_back(makeTargetTrial(trials[t], target));
    const GapTrial& g = trials[t];
    for (size_t k = 0; k < g.cycles.size(); ++k) {
      Unit u;
      u.trial = static_cast<int>(t);
      u.activity = g.activity;
      for (int i = 0; i < g.getNumFrames(); ++i)
        if (g.cycle_index[i] == static_cast<int>(k)) {
          if (!std::isfinite(c.trials[t].measured_force[i]))
            throw InputError(where, "trial '" + g.trial.name + "': measured " + target + " force at t = " +
                                        fmt(g.trial.time[i], 6) + " s: expected a finite value, got NaN");
          u.frames.push_back(i);
        }
      if (!u.frames.empty()) c.units.push_back(std::move(u));
    }
  }
  mergeShortUnits(c.units);
  for (auto& u : c.units) {
    u.begin = trials[u.trial].trial.time[u.frames.front()];
    u.end = trials[u.trial].trial.time[u.frames.back()];
  }
  if (c.units.size() < 2)
    throw InputError(where, "gap diagnosis: expected at least two cycles to hold one out, got " +
                                std::to_string(c.units.size()));
  const int nu = static_cast<int>(c.units.size());
  std::vector<int> order(nu);
  std::iota(order.begin(), order.end(), 0);
  if (o.cv_folds > 1 && o.cv_folds < nu) {
    std::mt19937_64 rng(o.seed);
    for (int i = nu - 1; i > 0; --i) std::swap(order[i], order[rng() % (i + 1)]);
    c.folds.assign(o.cv_folds, {});
    for (int i = 0; i < nu; ++i) c.folds[i % o.cv_folds].push_back(order[i]);
    cv_scheme = std::to_string(o.cv_folds) + " folds of cycles";
  } else {
    for (int i = 0; i < nu; ++i) c.folds.push_back({i});
    cv_scheme = "leave one cycle out";
  }
  return c;
}
}  // namespace kneesim::gap::detail
