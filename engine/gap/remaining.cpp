#include "gap/remaining.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <random>
#include <set>

#include "core/error.hpp"
#include "core/strings.hpp"
#include "gap/signals.hpp"

namespace kneesim::gap {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The channels the model-agnostic check reads: kinematics, areas and their rates, loads, EMG, time.
bool isCheckSignal(const std::string& k) {
  static const std::set<std::string> named{"knee_flexion", "knee_flexion_rate", "S",          "S_medial",
                                           "S_lateral",    "dS_dt",             "dS_medial_dt", "dS_lateral_dt",
                                           "trial_time"};
  return named.count(k) || startsWith(k, "GRF:") || startsWith(k, "EMG:");
}
// Signals whose recent past is a feature too (short lags).
bool isLagged(const std::string& k) {
  return k == "knee_flexion" || k == "knee_flexion_rate" || k == "S" || k == "GRF:vertical" ||
         k == "GRF:vertical_left" || k == "predicted force";
}

// Frames thinned to about options.sample_rate, with a finite residual and a unit.
struct Rows {
  std::vector<int> trial, frame, unit;
};

Rows thinnedRows(const RemainingData& d, double sample_rate, bool need_residual = true) {
  Rows r;
  for (size_t t = 0; t < d.trials.size(); ++t) {
    const auto& time = d.trials[t]->time;
    const int n = static_cast<int>(time.size());
    const double rate = n > 1 ? (n - 1) / (time.back() - time.front()) : sample_rate;
    const int stride = std::max(1, static_cast<int>(std::lround(rate / sample_rate)));
    for (int i = 0; i < n; i += stride) {
      if (d.unit[t][i] < 0 || (need_residual && !std::isfinite(d.residual[t][i]))) continue;
      r.trial.push_back(static_cast<int>(t));
      r.frame.push_back(i);
      r.unit.push_back(d.unit[t][i]);
    }
  }
  return r;
}

// Per-trial series of one signal (NaN where a trial lacks it).
std::vector<std::vector<double>> seriesOf(const RemainingData& d, const std::string& name) {
  std::vector<std::vector<double>> s(d.trials.size());
  for (size_t t = 0; t < d.trials.size(); ++t) {
    const auto& tr = *d.trials[t];
    const int n = static_cast<int>(tr.time.size());
    if (name == "predicted force") {
      s[t] = d.prediction[t];
    } else if (name == "cycle phase") {
      s[t] = d.phase[t];
    } else if (name == "knee_flexion_acceleration") {
      auto it = tr.channels.find("knee_flexion_rate");
      s[t] = it != tr.channels.end() ? derivative(tr.time, it->second) : std::vector<double>(n, kNaN);
    } else {
      auto it = tr.channels.find(name);
      s[t] = it != tr.channels.end() ? it->second : std::vector<double>(n, kNaN);
    }
  }
  return s;
}

struct Features {
  std::vector<std::vector<double>> columns;  // per feature, per row
  std::vector<std::string> source;           // per feature: the signal it comes from
  std::vector<std::string> signals;          // distinct sources, in order
};

Features buildFeatures(const RemainingData& d, const Rows& rows, const std::vector<double>& lags) {
  std::set<std::string> names;
  for (const auto* tr : d.trials)
    for (const auto& [k, v] : tr->channels)
      if (isCheckSignal(k)) names.insert(k);
  std::vector<std::string> order(names.begin(), names.end());
  order.push_back("knee_flexion_acceleration");
  order.push_back("cycle phase");
  order.push_back("predicted force");
  Features f;
  for (const auto& name : order) {
    if (name == "knee_flexion_acceleration" && !names.count("knee_flexion_rate")) continue;
    const auto s = seriesOf(d, name);
    std::vector<double> col(rows.trial.size());
    for (size_t r = 0; r < col.size(); ++r) col[r] = s[rows.trial[r]][rows.frame[r]];
    f.columns.push_back(std::move(col));
    f.source.push_back(name);
    f.signals.push_back(name);
    if (!isLagged(name)) continue;
    for (double lag : lags) {
      std::vector<std::vector<double>> shifted(d.trials.size());
      for (size_t t = 0; t < d.trials.size(); ++t) {
        std::vector<double> at(d.trials[t]->time);
        for (double& x : at) x -= lag;
        shifted[t] = interpolate(d.trials[t]->time, s[t], at);
      }
      std::vector<double> c(rows.trial.size());
      for (size_t r = 0; r < c.size(); ++r) c[r] = shifted[rows.trial[r]][rows.frame[r]];
      f.columns.push_back(std::move(c));
      f.source.push_back(name);
    }
  }
  return f;
}

int countUnits(const RemainingData& d) {
  int n = 0;
  for (const auto& u : d.unit)
    for (int x : u) n = std::max(n, x + 1);
  return n;
}

// One-sided upper-tail p of a Student t.
double upperP(double t, double dof) { return std::isfinite(t) ? 1 - studentCdf(t, dof) : 1.0; }

}  // namespace

AgnosticCheck runAgnosticCheck(const RemainingData& d, const RemainingOptions& o) {
  AgnosticCheck c;
  const Rows rows = thinnedRows(d, o.sample_rate);
  const int n_units = countUnits(d);
  std::vector<int> fold_of(n_units, -1);
  for (size_t f = 0; f < d.folds.size(); ++f)
    for (int u : d.folds[f]) fold_of[u] = static_cast<int>(f);
  std::set<int> present(rows.unit.begin(), rows.unit.end());
  c.units = static_cast<int>(present.size());
  c.frames = static_cast<int>(rows.trial.size());
  if (c.units < 4 || d.folds.size() < 2) {
    c.note = "needs at least 4 cycles in 2 folds (has " + std::to_string(c.units) + ")";
    return c;
  }
  const Features feats = buildFeatures(d, rows, o.lags);
  const BinnedFeatures x(feats.columns, 16);
  c.features = x.getNumFeatures();
  c.signals = feats.signals;
  std::vector<double> y(rows.trial.size());
  for (size_t r = 0; r < y.size(); ++r) y[r] = d.residual[rows.trial[r]][rows.frame[r]];
  // Cross-validation over the diagnosis's folds: per unit, the residual's withheld SSE without and
  // with the trees, and the cross-fitted score sum(prediction x residual).
  std::vector<double> a(n_units, 0.0), b(n_units, 0.0), s(n_units, 0.0);
  for (size_t f = 0; f < d.folds.size(); ++f) {
    std::vector<int> train, test;
    for (size_t r = 0; r < y.size(); ++r) (fold_of[rows.unit[r]] == static_cast<int>(f) ? test : train).push_back(int(r));
    if (test.empty() || train.empty()) continue;
    const BoostedTrees m = BoostedTrees::fit(x, y, rows.unit, train, o.boosting);
    for (int r : test) {
      const double g = m.predict(x, r);
      a[rows.unit[r]] += y[r] * y[r];
      b[rows.unit[r]] += (y[r] - g) * (y[r] - g);
      s[rows.unit[r]] += g * y[r];
    }
  }
  std::vector<double> av, bv, sv;
  for (int u : present) av.push_back(a[u]), bv.push_back(b[u]), sv.push_back(s[u]);
  const int n = static_cast<int>(av.size());
  // Each test at alpha / 2 (Bonferroni): the two-sided interval at 1 - alpha has alpha / 2 per tail.
  const MeanInterval red = relativeReductionInterval(av, bv, 1 - o.alpha);
  c.reduction = red.mean;
  c.reduction_lower = red.lower;
  const MeanInterval sc = meanInterval(sv, 0.95);
  c.score_t = sc.sd > 0 ? sc.mean / (sc.sd / std::sqrt(n)) : 0.0;
  c.score_critical = studentQuantile(1 - o.alpha / 2, n - 1);
  const double red_t = red.sd > 0 ? red.mean / (red.sd / std::sqrt(n)) : 0.0;
  c.p_value = std::min(1.0, 2 * std::min(upperP(c.score_t, n - 1), upperP(red_t, n - 1)));
  c.significant = c.reduction_lower > 0 || c.score_t > c.score_critical;
  // Which signals carry it: the trees fitted on every cycle.
  std::vector<int> all(y.size());
  std::iota(all.begin(), all.end(), 0);
  const BoostedTrees m = BoostedTrees::fit(x, y, rows.unit, all, o.boosting);
  std::map<std::string, double> share;
  double total = 0;
  for (int f = 0; f < x.getNumFeatures(); ++f) share[feats.source[f]] += m.getGains()[f], total += m.getGains()[f];
  for (const auto& [sig, g] : share)
    if (total > 0 && g > 0) c.importance.push_back({sig, g / total});
  std::sort(c.importance.begin(), c.importance.end(),
            [](const SignalImportance& p, const SignalImportance& q) { return p.share > q.share; });
  for (size_t k = 0; k < c.importance.size() && static_cast<int>(k) < o.dependence_signals; ++k) {
    const int f = static_cast<int>(std::find(feats.source.begin(), feats.source.end(), c.importance[k].signal) -
                                   feats.source.begin());
    PartialDependence pd;
    pd.signal = c.importance[k].signal;
    for (int bin = 1; bin < x.getNumBins(f); ++bin) {
      double sum = 0;
      for (int r : all) sum += m.predictWith(x, r, f, bin);
      pd.x.push_back(x.getBinValue(f, bin));
      pd.y.push_back(sum / all.size());
    }
    c.dependence.push_back(std::move(pd));
  }
  c.run = true;
  c.note = std::to_string(c.features) + " features of " + std::to_string(c.signals.size()) + " signals, " +
           std::to_string(c.frames) + " frames, " + std::to_string(c.units) + " cycles in " +
           std::to_string(d.folds.size()) + " folds";
  return c;
}

NoiseFloor estimateNoiseFloor(const RemainingData& d, const RemainingOptions& o) {
  NoiseFloor nf;
  nf.tolerance = o.noise_tolerance;
  const Rows rows = thinnedRows(d, o.sample_rate);
  const int n_units = countUnits(d);
  // Matching signals: the cycle's phase, the flexion and its rate, the contact area, the instrumented
  // foot's vertical GRF -- each where every trial has it.
  std::vector<std::string> names{"cycle phase"};
  for (const char* k : {"knee_flexion", "knee_flexion_rate", "S", "GRF:vertical"}) {
    bool all = true;
    for (const auto* tr : d.trials) all = all && tr->channels.count(k);
    if (all) names.push_back(k);
  }
  nf.matched_on = join(names, ", ");
  std::vector<std::vector<double>> z;
  for (const auto& nm : names) {
    const auto s = seriesOf(d, nm);
    std::vector<double> col(rows.trial.size());
    for (size_t r = 0; r < col.size(); ++r) col[r] = s[rows.trial[r]][rows.frame[r]];
    z.push_back(std::move(col));
  }
  // Standardised within each activity; nearest frame of another cycle of the same activity.
  std::map<std::string, std::vector<int>> by_act;
  for (size_t r = 0; r < rows.trial.size(); ++r) by_act[d.unit_activity[rows.unit[r]]].push_back(int(r));
  std::vector<double> a(n_units, 0.0), b(n_units, 0.0);
  std::vector<int> cnt(n_units, 0);
  for (const auto& [act, idx] : by_act) {
    std::vector<double> scale(z.size(), 1.0);
    for (size_t k = 0; k < z.size(); ++k) {
      std::vector<double> v;
      for (int r : idx)
        if (std::isfinite(z[k][r])) v.push_back(z[k][r]);
      const MeanInterval m = meanInterval(v);
      scale[k] = m.sd > 0 ? m.sd : 1.0;
    }
    for (int i : idx) {
      double best = std::numeric_limits<double>::infinity();
      int bj = -1;
      for (int j : idx) {
        if (rows.unit[j] == rows.unit[i]) continue;
        double dist = 0;
        for (size_t k = 0; k < z.size() && dist < best; ++k) {
          const double dz = (z[k][i] - z[k][j]) / scale[k];
          dist += std::isfinite(dz) ? dz * dz : 4.0;  // a missing value counts as two SDs apart
        }
        if (dist < best) best = dist, bj = j;
      }
      if (bj < 0) continue;
      const double ri = d.residual[rows.trial[i]][rows.frame[i]], rj = d.residual[rows.trial[bj]][rows.frame[bj]];
      a[rows.unit[i]] += ri * ri;
      b[rows.unit[i]] += 0.5 * (ri - rj) * (ri - rj);
      ++cnt[rows.unit[i]];
      ++nf.pairs;
    }
  }
  std::vector<double> av, bv;
  double sa = 0, sb = 0, sn = 0;
  for (int u = 0; u < n_units; ++u)
    if (cnt[u] > 0) av.push_back(a[u]), bv.push_back(b[u]), sa += a[u], sb += b[u], sn += cnt[u];
  nf.units = static_cast<int>(av.size());
  if (nf.units < 3 || sn == 0) {
    nf.note = "needs at least 3 cycles with a matching cycle of the same activity (has " + std::to_string(nf.units) + ")";
    return nf;
  }
  nf.rmse = std::sqrt(sa / sn);
  nf.floor = std::sqrt(sb / sn);
  // Above the floor: the one-sided lower bound at alpha (a test of the structure family); consistent
  // with it: the one-sided upper bound at the level below the tolerance's share.
  const MeanInterval ex = relativeReductionInterval(av, bv, 2 * o.level - 1);
  const MeanInterval ex_test = relativeReductionInterval(av, bv, 1 - 2 * o.alpha);
  nf.excess = ex.mean;
  nf.excess_lower = ex_test.lower;
  nf.excess_upper = ex.upper;
  const double max_share = 1 - 1 / (o.noise_tolerance * o.noise_tolerance);
  nf.above = ex_test.lower > 0;
  nf.consistent = ex.upper < max_share;
  // Cycles that would settle it at the same spread: the bound moving by sqrt(n / n').
  const double half = ex.upper - ex.mean;
  if (!nf.above && !nf.consistent && half > 0) {
    const double room = nf.excess < max_share ? max_share - nf.excess : nf.excess;
    const double need = nf.excess < max_share ? half : nf.excess - ex.lower;
    if (room > 0) nf.cycles_needed = static_cast<int>(std::ceil(nf.units * std::pow(need / room, 2)));
  }
  nf.run = true;
  nf.note = std::to_string(nf.pairs) + " frames matched to the nearest frame of another cycle on " + nf.matched_on;
  return nf;
}

namespace {

// Offset and relative gain of the residual over frames lo..hi-1: its mean m, and its projection on the
// prediction g = sum(r F) / sum(F^2) (a residual g F has exactly g).
bool halfFit(const RemainingData& d, const std::vector<std::pair<int, int>>& fr, size_t lo, size_t hi, double& m,
             double& g) {
  if (hi <= lo + 10) return false;
  double sr = 0, srf = 0, sff = 0;
  for (size_t k = lo; k < hi; ++k) {
    const double r = d.fitted_residual[fr[k].first][fr[k].second], f = d.prediction[fr[k].first][fr[k].second];
    sr += r, srf += r * f, sff += f * f;
  }
  m = sr / double(hi - lo);
  g = sff > 0 ? srf / sff : 0.0;
  return true;
}

}  // namespace

CycleHeterogeneity testCycleHeterogeneity(const RemainingData& d, const RemainingOptions& o) {
  CycleHeterogeneity h;
  const int n_units = countUnits(d);
  // Per unit, its frames with a finite in-sample residual and prediction, in time order.
  std::vector<std::vector<std::pair<int, int>>> frames(n_units);
  for (size_t t = 0; t < d.trials.size(); ++t)
    for (size_t i = 0; i < d.unit[t].size(); ++i)
      if (d.unit[t][i] >= 0 && std::isfinite(d.fitted_residual[t][i]) && std::isfinite(d.prediction[t][i]))
        frames[d.unit[t][i]].emplace_back(int(t), int(i));
  // Split-half: the offset and gain of each half of a cycle, the halves 0.3 s apart (six correlation
  // times of the smooth noise). A cycle's own offset or gain shows in both halves; noise does not.
  struct Half {
    double m1, g1, m2, g2;
  };
  std::map<std::string, std::vector<Half>> by_act;
  for (int u = 0; u < n_units; ++u) {
    const auto& fr = frames[u];
    if (fr.size() < 30) continue;
    const auto& time = d.trials[fr.front().first]->time;
    const double t_mid = 0.5 * (time[fr.front().second] + time[fr.back().second]);
    size_t a = 0, b = fr.size();
    for (size_t k = 0; k < fr.size(); ++k) {
      const double tk = d.trials[fr[k].first]->time[fr[k].second];
      if (tk < t_mid - 0.15) a = k + 1;
      if (tk > t_mid + 0.15 && b == fr.size()) b = k;
    }
    Half hv{};
    if (!halfFit(d, fr, 0, a, hv.m1, hv.g1) || !halfFit(d, fr, b, fr.size(), hv.m2, hv.g2)) continue;
    by_act[d.unit_activity[u]].push_back(hv);
    ++h.units;
  }
  // Statistic: within each activity, the cross-products of the two halves' centred offsets and gains,
  // each scaled by the pooled variance of the half estimates; the null pairs each first half with
  // another cycle's second half of the same activity (every pairing when there are few, else 2000).
  std::vector<std::vector<Half>> groups;
  for (auto& [act, v] : by_act)
    if (v.size() >= 2) groups.push_back(v);
  int used = 0;
  double vm = 0, vg = 0;
  for (auto& v : groups) {
    double mm = 0, mg = 0, m2 = 0, g2 = 0;
    for (const auto& x : v) mm += x.m1 + x.m2, mg += x.g1 + x.g2;
    mm /= 2.0 * v.size();
    mg /= 2.0 * v.size();
    for (auto& x : v) {
      x.m1 -= mm, x.m2 -= mm, x.g1 -= mg, x.g2 -= mg;
      m2 += x.m1 * x.m1 + x.m2 * x.m2;
      g2 += x.g1 * x.g1 + x.g2 * x.g2;
    }
    vm += m2, vg += g2;
    used += static_cast<int>(v.size());
  }
  if (used < 3) {
    h.note = "needs at least 3 cycles of 30 frames, two of one activity (has " + std::to_string(used) + ")";
    return h;
  }
  vm = std::max(vm / (2.0 * used), 1e-12);
  vg = std::max(vg / (2.0 * used), 1e-12);
  auto statistic = [&](const std::vector<std::vector<int>>& perm) {
    double s = 0;
    for (size_t k = 0; k < groups.size(); ++k)
      for (size_t u = 0; u < groups[k].size(); ++u) {
        const Half& a = groups[k][u];
        const Half& b = groups[k][perm[k][u]];
        s += a.m1 * b.m2 / vm + a.g1 * b.g2 / vg;
      }
    return s;
  };
  std::vector<std::vector<int>> perm(groups.size());
  double count = 1;
  for (size_t k = 0; k < groups.size(); ++k) {
    perm[k].resize(groups[k].size());
    std::iota(perm[k].begin(), perm[k].end(), 0);
    for (size_t j = 2; j <= groups[k].size() && count <= 1e6; ++j) count *= double(j);
  }
  h.statistic = statistic(perm);
  int ge = 0, total = 0;
  if (count <= 5000) {
    // Every pairing: odometer over the groups' permutations (the identity included).
    std::vector<std::vector<int>> cur = perm;
    while (true) {
      ge += statistic(cur) >= h.statistic - 1e-12;
      ++total;
      size_t k = 0;
      while (k < cur.size() && !std::next_permutation(cur[k].begin(), cur[k].end())) ++k;
      if (k == cur.size()) break;
    }
  } else {
    std::mt19937_64 rng(20150101);
    std::vector<std::vector<int>> cur = perm;
    ge = 1, total = 1;
    for (int r = 0; r < 2000; ++r) {
      for (auto& p : cur) std::shuffle(p.begin(), p.end(), rng);
      ge += statistic(cur) >= h.statistic - 1e-12;
      ++total;
    }
  }
  h.p_value = double(ge) / total;
  h.dof = total;
  h.significant = h.p_value < o.alpha;
  // Sizes: the covariance of the two halves' estimates over cycles is the variance of what the cycle
  // itself carries (the halves' noise is independent).
  double cm = 0, cg = 0;
  for (const auto& v : groups)
    for (const auto& x : v) cm += x.m1 * x.m2, cg += x.g1 * x.g2;
  h.offset_sd = std::sqrt(std::max(0.0, cm / used));
  h.gain_sd = std::sqrt(std::max(0.0, cg / used));
  h.run = true;
  h.note = "split-half offsets and gains of " + std::to_string(used) + " cycles, " + std::to_string(total) +
           " pairings";
  return h;
}

}  // namespace kneesim::gap
