// The where-analysis of the gap diagnosis: the held-out gap over the normalised cycle against the
// repeatability band, per named phase, its correlations with candidate signals, the best time
// shift, and two reference predictors (the training-mean curve, isotonic regression of the area).

#include <algorithm>
#include <cmath>
#include <set>

#include "core/strings.hpp"
#include "gap/diagnosis_detail.hpp"

namespace kneesim::gap::detail {

// Bin means of per-frame values over the normalised cycle, per unit: [unit][bin] (NaN: no frame).
std::vector<std::vector<double>> unitBins(const Context& c, const std::vector<std::vector<double>>& v, int bins) {
  std::vector<std::vector<double>> out(c.units.size(), std::vector<double>(bins, kNaN));
  for (size_t u = 0; u < c.units.size(); ++u) {
    std::vector<double> sum(bins, 0.0);
    std::vector<int> cnt(bins, 0);
    const GapTrial& g = (*c.gap_trials)[c.units[u].trial];
    for (int i : c.units[u].frames) {
      if (!std::isfinite(v[c.units[u].trial][i]) || !std::isfinite(g.cycle_phase[i])) continue;
      const int b = std::min(bins - 1, static_cast<int>(g.cycle_phase[i] * bins));
      sum[b] += v[c.units[u].trial][i];
      ++cnt[b];
    }
    for (int b = 0; b < bins; ++b)
      if (cnt[b] > 0) out[u][b] = sum[b] / cnt[b];
  }
  return out;
}

std::vector<BandCurve> makeBands(const Context& c, const std::vector<std::vector<double>>& gap,
                                 const std::vector<std::vector<double>>& pred, int bins) {
  std::vector<std::vector<double>> meas(c.trials.size());
  for (size_t t = 0; t < c.trials.size(); ++t) meas[t] = c.trials[t].measured_force;
  const auto gb = unitBins(c, gap, bins), mb = unitBins(c, meas, bins), pb = unitBins(c, pred, bins);
  std::vector<BandCurve> out;
  for (const auto& act : activitiesOf(c)) {
    BandCurve bc;
    bc.activity = act;
    for (int b = 0; b < bins; ++b) {
      std::vector<double> g, m, p;
      for (size_t u = 0; u < c.units.size(); ++u) {
        if (c.units[u].activity != act || !std::isfinite(gb[u][b])) continue;
        g.push_back(gb[u][b]);
        m.push_back(mb[u][b]);
        p.push_back(pb[u][b]);
      }
      const MeanInterval gi = meanInterval(g), mi = meanInterval(m), pi = meanInterval(p);
      bc.phase.push_back((b + 0.5) / bins);
      bc.mean_gap.push_back(gi.mean);
      bc.sd_gap.push_back(gi.sd);
      bc.mean_measured.push_back(mi.mean);
      bc.sd_measured.push_back(mi.sd);
      bc.mean_predicted.push_back(pi.mean);
      bc.n_cycles.push_back(static_cast<int>(g.size()));
    }
    out.push_back(bc);
  }
  return out;
}

std::vector<SignalCorrelation> correlate(const Context& c, const std::vector<std::vector<double>>& gap,
                                         const std::vector<std::vector<double>>& pred) {
  // Candidate signals; each is correlated over the trials that have it (GRF and EMG need a C3D).
  std::set<std::string> names;
  for (const auto& t : c.trials)
    for (const auto& [k, v] : t.channels)
      if (k == "knee_flexion" || k == "knee_flexion_rate" || k == "S" || k == "dS_dt" ||
          startsWith(k, "GRF:vertical") || startsWith(k, "EMG:") || startsWith(k, "knee_"))
        names.insert(k);
  std::vector<std::pair<std::string, std::vector<std::vector<double>>>> signals;
  for (const auto& nm : names) {
    std::vector<std::vector<double>> s(c.trials.size());
    for (size_t t = 0; t < c.trials.size(); ++t) {
      auto it = c.trials[t].channels.find(nm);
      s[t] = it != c.trials[t].channels.end() ? it->second
                                              : std::vector<double>(c.trials[t].time.size(), kNaN);
    }
    signals.emplace_back(nm, s);
  }
  signals.emplace_back("predicted force", pred);
  std::vector<std::vector<double>> dpred(c.trials.size());
  for (size_t t = 0; t < c.trials.size(); ++t) {
    std::vector<double> p = pred[t];
    for (double& x : p)
      if (!std::isfinite(x)) x = 0;
    dpred[t] = derivative(c.trials[t].time, p);
  }
  signals.emplace_back("rate of the predicted force", dpred);
  std::vector<SignalCorrelation> out;
  const double rg = pooledLag1(c, gap);
  for (const auto& [nm, s] : signals) {
    std::vector<double> x, y;
    for (const auto& u : c.units)
      for (int i : u.frames)
        if (std::isfinite(s[u.trial][i]) && std::isfinite(gap[u.trial][i])) {
          x.push_back(gap[u.trial][i]);
          y.push_back(s[u.trial][i]);
        }
    SignalCorrelation sc;
    sc.signal = nm;
    sc.n = static_cast<int>(x.size());
    sc.r = pearson(x, y);
    sc.n_eff = effectiveSampleSize(sc.n, rg, pooledLag1(c, s));
    const auto ci = correlationInterval(sc.r, sc.n_eff, c.o->level);
    sc.lower = ci.first;
    sc.upper = ci.second;
    out.push_back(sc);
  }
  std::sort(out.begin(), out.end(), [](const SignalCorrelation& a, const SignalCorrelation& b) {
    const double x = std::isfinite(a.r) ? std::abs(a.r) : -1, y = std::isfinite(b.r) ? std::abs(b.r) : -1;
    return x > y;
  });
  return out;
}

namespace {

// The shift of the prediction that best matches the measured force: measured(t) ~ pred(t - lag).
std::pair<double, double> bestLag(const Context& c, const std::vector<std::vector<double>>& pred, double max_lag) {
  const auto& t0 = c.trials.front().time;
  const double dt = t0.size() > 1 ? (t0.back() - t0.front()) / (t0.size() - 1) : 1.0 / 120;
  const int steps = static_cast<int>(std::round(max_lag / dt));
  double best = 0, best_r = -2;
  for (int k = -steps; k <= steps; ++k) {
    const double lag = k * dt;
    std::vector<double> x, y;
    for (size_t t = 0; t < c.trials.size(); ++t) {
      std::vector<double> at(c.trials[t].time.size());
      for (size_t i = 0; i < at.size(); ++i) at[i] = c.trials[t].time[i] - lag;
      std::vector<double> p = pred[t];
      // Held-out predictions exist only on unit frames: interpolate those.
      std::vector<double> tt, pp;
      for (size_t i = 0; i < p.size(); ++i)
        if (std::isfinite(p[i])) tt.push_back(c.trials[t].time[i]), pp.push_back(p[i]);
      if (tt.size() < 2) continue;
      const std::vector<double> shifted = interpolate(tt, pp, at);
      for (const auto& u : c.units) {
        if (u.trial != static_cast<int>(t)) continue;
        for (int i : u.frames)
          if (std::isfinite(shifted[i])) x.push_back(c.trials[t].measured_force[i]), y.push_back(shifted[i]);
      }
    }
    const double r = pearson(x, y);
    if (std::isfinite(r) && r > best_r) best_r = r, best = lag;
  }
  return {best, best_r};
}

ReferencePredictors references(const Context& c, const Model& base) {
  ReferencePredictors rp;
  const int bins = c.o->bins;
  std::vector<std::vector<double>> meas(c.trials.size());
  for (size_t t = 0; t < c.trials.size(); ++t) meas[t] = c.trials[t].measured_force;
  const auto mb = unitBins(c, meas, bins);
  double sse_mc = 0, sse_base_mc = 0, sse_iso = 0, sse_base = 0;
  int n_mc = 0, n_all = 0;
  for (const auto& fold : c.folds) {
    std::vector<int> train;
    for (size_t u = 0; u < c.units.size(); ++u)
      if (std::find(fold.begin(), fold.end(), static_cast<int>(u)) == fold.end()) train.push_back(static_cast<int>(u));
    std::vector<double> xs, ys;
    for (int u : train)
      for (int i : c.units[u].frames) {
        xs.push_back(c.trials[c.units[u].trial].channels.at("S")[i]);
        ys.push_back(meas[c.units[u].trial][i]);
      }
    const IsotonicFit iso = fitIsotonic(xs, ys);
    for (int u : fold) {
      const Unit& un = c.units[u];
      // Training-mean curve of the activity: bin means over training cycles, gaps filled linearly.
      std::vector<double> curve(bins, kNaN);
      for (int b = 0; b < bins; ++b) {
        double s = 0;
        int k = 0;
        for (int v : train)
          if (c.units[v].activity == un.activity && std::isfinite(mb[v][b])) s += mb[v][b], ++k;
        if (k > 0) curve[b] = s / k;
      }
      std::vector<double> bx, by;
      for (int b = 0; b < bins; ++b)
        if (std::isfinite(curve[b])) bx.push_back((b + 0.5) / bins), by.push_back(curve[b]);
      const GapTrial& g = (*c.gap_trials)[un.trial];
      for (int i : un.frames) {
        const double m = meas[un.trial][i];
        const double pb = base.pred[un.trial][i];
        sse_base += (m - pb) * (m - pb);
        const double pi = iso.evaluate(c.trials[un.trial].channels.at("S")[i]);
        sse_iso += (m - pi) * (m - pi);
        ++n_all;
        if (bx.size() >= 2 && std::isfinite(g.cycle_phase[i])) {
          const double pm = interpolate(bx, by, {g.cycle_phase[i]}, 1.0)[0];
          sse_mc += (m - pm) * (m - pm);
          sse_base_mc += (m - pb) * (m - pb);
          ++n_mc;
        }
      }
    }
  }
  rp.baseline_rmse = std::sqrt(sse_base / std::max(1, n_all));
  rp.isotonic_rmse = std::sqrt(sse_iso / std::max(1, n_all));
  rp.mean_curve_frames = n_mc;
  rp.mean_curve_rmse = n_mc > 0 ? std::sqrt(sse_mc / n_mc) : kNaN;
  rp.baseline_rmse_on_mean_curve_frames = n_mc > 0 ? std::sqrt(sse_base_mc / n_mc) : kNaN;
  std::vector<double> xs, ys;
  for (const auto& u : c.units)
    for (int i : u.frames) xs.push_back(c.trials[u.trial].channels.at("S")[i]), ys.push_back(meas[u.trial][i]);
  rp.isotonic_in_sample_rmse = std::sqrt(fitIsotonic(xs, ys).sse / std::max<size_t>(1, xs.size()));
  return rp;
}

std::vector<PhaseGap> phaseGaps(const Context& c, const std::vector<std::vector<double>>& gap,
                                const std::vector<BandCurve>& bands) {
  std::vector<PhaseGap> out;
  for (const auto& bc : bands) {
    const ActivityDefinition act = getActivityDefinition(bc.activity);
    for (const auto& ph : act.phases) {
      PhaseGap pg;
      pg.activity = bc.activity;
      pg.phase = ph.name;
      double ss = 0, s = 0;
      std::set<int> cyc;
      for (size_t u = 0; u < c.units.size(); ++u) {
        if (c.units[u].activity != bc.activity) continue;
        const GapTrial& g = (*c.gap_trials)[c.units[u].trial];
        for (int i : c.units[u].frames) {
          if (!(g.cycle_phase[i] >= ph.begin && g.cycle_phase[i] < ph.end)) continue;
          const double r = gap[c.units[u].trial][i];
          ss += r * r;
          s += r;
          ++pg.n_frames;
          cyc.insert(static_cast<int>(u));
        }
      }
      pg.n_cycles = static_cast<int>(cyc.size());
      pg.rmse = pg.n_frames ? std::sqrt(ss / pg.n_frames) : kNaN;
      pg.rmse_bw = c.body_weight > 0 ? pg.rmse / c.body_weight : kNaN;
      pg.bias = pg.n_frames ? s / pg.n_frames : kNaN;
      double sys = 0, band = 0;
      int nb = 0, nband = 0;
      for (size_t b = 0; b < bc.phase.size(); ++b) {
        if (bc.phase[b] < ph.begin || bc.phase[b] >= ph.end || !std::isfinite(bc.mean_gap[b])) continue;
        sys += bc.mean_gap[b] * bc.mean_gap[b];
        ++nb;
        if (std::isfinite(bc.sd_measured[b])) band += bc.sd_measured[b] * bc.sd_measured[b], ++nband;
      }
      pg.systematic = nb ? std::sqrt(sys / nb) : kNaN;
      pg.band = nband ? std::sqrt(band / nband) : kNaN;
      if (pg.n_frames == 0) pg.verdict = "no frames";
      else if (!std::isfinite(pg.band)) pg.verdict = "no repeatability band (one cycle)";
      else pg.verdict = pg.systematic > pg.band ? "gap" : "within noise";
      out.push_back(pg);
    }
  }
  return out;
}

}  // namespace

void analyseWhere(const Context& c, const Model& base, TargetDiagnosis& d) {
  const DiagnosisOptions& o = *c.o;
  std::vector<std::vector<double>> gap(c.trials.size());
  for (size_t t = 0; t < c.trials.size(); ++t) {
    gap[t].assign(c.trials[t].time.size(), kNaN);
    for (size_t i = 0; i < gap[t].size(); ++i) gap[t][i] = c.trials[t].measured_force[i] - base.pred[t][i];
  }
  d.bands = makeBands(c, gap, base.pred, o.bins);
  d.phases = phaseGaps(c, gap, d.bands);
  d.correlations = correlate(c, gap, base.pred);
  std::tie(d.best_lag, d.best_lag_r) = bestLag(c, base.pred, o.max_lag);
  d.reference = references(c, base);
}
}  // namespace kneesim::gap::detail
