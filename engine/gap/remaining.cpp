#include "gap/remaining.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <random>
#include <set>
#include <sstream>

#include <Eigen/Dense>

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
    } else if (name == "recording") {
      s[t].assign(n, static_cast<double>(t));
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
  // Which recording a frame belongs to: structure of a recording's own (an offset, a drift with
  // trial_time) is learnt from its other cycles.
  if (d.trials.size() > 1) order.push_back("recording");
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
  if (!c.significant && c.score_t > 0)
    c.cycles_needed = static_cast<int>(std::ceil(n * std::pow(c.score_critical / c.score_t, 2)));
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
  // foot's vertical GRF, and the time in the recording (the nearest cycle in time: a slow drift is
  // structure, not noise) -- each where every trial has it.
  std::vector<std::string> names{"cycle phase"};
  for (const char* k : {"knee_flexion", "knee_flexion_rate", "S", "GRF:vertical", "trial_time"}) {
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
  // Cycles that would settle it at the same spread (a bound moves by sqrt(n / n')): the fewer of those
  // lifting the lower bound above zero and those bringing the upper bound under the tolerance.
  if (!nf.above && !nf.consistent) {
    double best = std::numeric_limits<double>::infinity();
    if (nf.excess > 0 && nf.excess > ex_test.lower)
      best = std::min(best, nf.units * std::pow((nf.excess - ex_test.lower) / nf.excess, 2));
    if (nf.excess < max_share && ex.upper > nf.excess)
      best = std::min(best, nf.units * std::pow((ex.upper - nf.excess) / (max_share - nf.excess), 2));
    if (std::isfinite(best)) nf.cycles_needed = static_cast<int>(std::ceil(best));
  }
  nf.run = true;
  nf.note = std::to_string(nf.pairs) + " frames matched to the nearest frame of another cycle on " + nf.matched_on;
  return nf;
}

namespace {

constexpr int kSlots = 3;

// One cycle's slots (thirds by phase): the residual's offset and relative gain in each.
struct SlotCycle {
  std::array<double, kSlots> m, g;
};

// Per activity, the cycles with every slot: per unit and third of the cycle (their outer fifths
// dropped: slots of a gait cycle are 0.15 s -- three correlation times of the smooth noise -- apart),
// the residual's offset (its mean) and relative gain (its projection on the prediction,
// sum(r F) / sum(F^2)).
std::map<std::string, std::vector<SlotCycle>> slotCycles(const RemainingData& d) {
  const int n_units = countUnits(d);
  struct Sums {
    double r = 0, rf = 0, ff = 0;
    int n = 0;
  };
  std::vector<std::array<Sums, kSlots>> sums(n_units);
  for (size_t t = 0; t < d.trials.size(); ++t)
    for (size_t i = 0; i < d.unit[t].size(); ++i) {
      const int u = d.unit[t][i];
      const double ph = d.phase[t][i], r = d.fitted_residual[t][i], f = d.prediction[t][i];
      if (u < 0 || !std::isfinite(ph) || !std::isfinite(r) || !std::isfinite(f)) continue;
      const int k = std::min(kSlots - 1, static_cast<int>(ph * kSlots));
      const double x = ph * kSlots - k;
      if (x < 0.2 || x > 0.8) continue;
      Sums& sm = sums[u][k];
      sm.r += r, sm.rf += r * f, sm.ff += f * f, ++sm.n;
    }
  std::map<std::string, std::vector<SlotCycle>> by_act;
  for (int u = 0; u < n_units; ++u) {
    SlotCycle c{};
    bool ok = true;
    for (int k = 0; k < kSlots && ok; ++k) {
      const Sums& sm = sums[u][k];
      ok = sm.n >= 5 && sm.ff > 0;
      if (ok) c.m[k] = sm.r / sm.n, c.g[k] = sm.rf / sm.ff;
    }
    if (ok) by_act[d.unit_activity[u]].push_back(c);
  }
  return by_act;
}

// The statistic's null distribution: each slot gets the values of another cycle of the same activity
// (slot by slot, independently); every pairing when there are few, else 2000 drawn. Returns the
// p-value and the pairings counted.
std::pair<double, int> pairingP(const std::vector<std::vector<SlotCycle>>& groups, double vm, double vg,
                                double observed) {
  using Perm = std::vector<std::array<std::vector<int>, kSlots>>;
  auto statistic = [&](const Perm& perm) {
    double s = 0;
    for (size_t a = 0; a < groups.size(); ++a)
      for (size_t u = 0; u < groups[a].size(); ++u)
        for (int k = 0; k < kSlots; ++k)
          for (int l = k + 1; l < kSlots; ++l) {
            const SlotCycle& x = groups[a][perm[a][k][u]];
            const SlotCycle& y = groups[a][perm[a][l][u]];
            s += x.m[k] * y.m[l] / vm + x.g[k] * y.g[l] / vg;
          }
    return s;
  };
  Perm perm(groups.size());
  double count = 1;
  for (size_t a = 0; a < groups.size(); ++a)
    for (int k = 0; k < kSlots; ++k) {
      perm[a][k].resize(groups[a].size());
      std::iota(perm[a][k].begin(), perm[a][k].end(), 0);
      if (k > 0)  // the first slot may stay: only the pairing between slots matters
        for (size_t j = 2; j <= groups[a].size() && count <= 1e7; ++j) count *= double(j);
    }
  int ge = 0, total = 0;
  if (count <= 5000) {
    Perm cur = perm;
    while (true) {
      ge += statistic(cur) >= observed - 1e-9 * std::abs(observed);
      ++total;
      size_t a = 0;
      int k = 1;
      // odometer over every group's slots 1..K-1
      while (a < cur.size() && !std::next_permutation(cur[a][k].begin(), cur[a][k].end())) {
        if (++k == kSlots) k = 1, ++a;
      }
      if (a == cur.size()) break;
    }
  } else {
    std::mt19937_64 rng(20150101);
    Perm cur = perm;
    ge = 1, total = 1;
    for (int r = 0; r < 2000; ++r) {
      for (auto& g : cur)
        for (int k = 1; k < kSlots; ++k) std::shuffle(g[k].begin(), g[k].end(), rng);
      ge += statistic(cur) >= observed - 1e-9 * std::abs(observed);
      ++total;
    }
  }
  return {double(ge) / total, total};
}

}  // namespace

CycleHeterogeneity testCycleHeterogeneity(const RemainingData& d, const RemainingOptions& o) {
  CycleHeterogeneity h;
  // Centred per activity and slot; scaled by the pooled variance of the slot estimates.
  std::vector<std::vector<SlotCycle>> groups;
  int used = 0;
  double vm = 0, vg = 0, nv = 0;
  for (auto& [act, v] : slotCycles(d)) {
    if (v.size() < 2) continue;
    for (int k = 0; k < kSlots; ++k) {
      double mm = 0, mg = 0;
      for (const auto& c : v) mm += c.m[k], mg += c.g[k];
      mm /= v.size(), mg /= v.size();
      for (auto& c : v) {
        c.m[k] -= mm, c.g[k] -= mg;
        vm += c.m[k] * c.m[k], vg += c.g[k] * c.g[k], ++nv;
      }
    }
    used += static_cast<int>(v.size());
    groups.push_back(v);
  }
  h.units = used;
  if (used < 3 || groups.empty()) {
    h.note = "needs at least 3 cycles with every third of the cycle, two of one activity (has " +
             std::to_string(used) + ")";
    return h;
  }
  vm = std::max(vm / nv, 1e-300);
  vg = std::max(vg / nv, 1e-300);
  // Statistic: the cross-products of a cycle's slots (each pair of slots), summed. A cycle's own offset
  // or gain shows in all its slots; the slots' noise is independent.
  double stat = 0, cm = 0, cg = 0, np = 0;
  for (const auto& v : groups)
    for (const auto& c : v)
      for (int k = 0; k < kSlots; ++k)
        for (int l = k + 1; l < kSlots; ++l) {
          stat += c.m[k] * c.m[l] / vm + c.g[k] * c.g[l] / vg;
          cm += c.m[k] * c.m[l], cg += c.g[k] * c.g[l], ++np;
        }
  h.statistic = stat;
  const auto [p, total] = pairingP(groups, vm, vg, h.statistic);
  h.p_value = p;
  h.dof = total;
  h.significant = h.p_value < o.alpha;
  // Sizes: the mean cross-product of two slots of a cycle is the variance of what the cycle itself
  // carries (their noise is independent).
  h.offset_sd = std::sqrt(std::max(0.0, cm / np));
  h.gain_sd = std::sqrt(std::max(0.0, cg / np));
  h.run = true;
  h.note = "offsets and gains of the thirds of " + std::to_string(used) + " cycles, " + std::to_string(total) +
           " pairings";
  return h;
}

namespace {

// Slots of a cycle for the wander test: quarters by phase, their outer quarters dropped (the used parts of
// neighbouring quarters of a 1.1 s gait cycle are 0.14 s -- nearly three correlation times of the smooth
// noise -- apart, so their means' noise correlates by about 0.03).
constexpr int kWanderSlots = 4;
// Draws of the Monte Carlo null of the wander test.
constexpr int kWanderDraws = 2000;

// One recording's cells (cycle, quarter) in time order: their mean in-sample residuals; and its cycles.
struct WanderCells {
  std::vector<double> y;
  int cycles = 0;
};

// Per recording, the cells that hold at least a fifth of the recording's median frames per cell (a cycle
// cut by the recording's edge keeps its whole quarters), ordered by their mean time.
std::vector<WanderCells> wanderCells(const RemainingData& d) {
  const int n_units = countUnits(d);
  struct Sums {
    double r = 0, t = 0;
    int n = 0;
  };
  std::vector<std::array<Sums, kWanderSlots>> sums(n_units);
  std::vector<int> trial_of(n_units, -1);
  for (size_t t = 0; t < d.trials.size(); ++t)
    for (size_t i = 0; i < d.unit[t].size(); ++i) {
      const int u = d.unit[t][i];
      if (u < 0) continue;
      trial_of[u] = static_cast<int>(t);
      const double ph = d.phase[t][i], r = d.fitted_residual[t][i];
      if (!std::isfinite(ph) || !std::isfinite(r)) continue;
      const int k = std::clamp(static_cast<int>(ph * kWanderSlots), 0, kWanderSlots - 1);
      const double x = ph * kWanderSlots - k;
      if (x < 0.25 || x > 0.75) continue;  // the middle half of the quarter
      sums[u][k].r += r, sums[u][k].t += d.trials[t]->time[i], ++sums[u][k].n;
    }
  std::vector<WanderCells> out(d.trials.size());
  for (size_t t = 0; t < d.trials.size(); ++t) {
    std::vector<int> counts;
    for (int u = 0; u < n_units; ++u)
      if (trial_of[u] == static_cast<int>(t))
        for (int k = 0; k < kWanderSlots; ++k)
          if (sums[u][k].n > 0) counts.push_back(sums[u][k].n);
    if (counts.empty()) continue;
    std::sort(counts.begin(), counts.end());
    const int min_frames = std::max(5, counts[counts.size() / 2] / 5);
    std::vector<std::pair<double, double>> cells;  // (mean time, mean residual)
    for (int u = 0; u < n_units; ++u) {
      if (trial_of[u] != static_cast<int>(t)) continue;
      bool any = false;
      for (int k = 0; k < kWanderSlots; ++k)
        if (sums[u][k].n >= min_frames) {
          cells.emplace_back(sums[u][k].t / sums[u][k].n, sums[u][k].r / sums[u][k].n);
          any = true;
        }
      out[t].cycles += any;
    }
    std::sort(cells.begin(), cells.end());
    for (const auto& [time, y] : cells) out[t].y.push_back(y);
  }
  return out;
}

// Half the mean squared difference of neighbouring cells: a cell's noise variance, free of what moves
// slowly from one cell to the next (the recording's offset, a wander, a smooth mean curve).
double successiveVariance(const double* y, int n) {
  double s = 0;
  for (int k = 1; k < n; ++k) s += (y[k] - y[k - 1]) * (y[k] - y[k - 1]);
  return s / (2.0 * (n - 1));
}

// The statistic over recordings: sum of n ln(mean square / successive variance). Each recording's term
// is free of its noise level, so recordings of different noise combine.
double slowStatistic(const std::vector<std::vector<double>>& ys) {
  double s = 0;
  for (const auto& y : ys) {
    const int n = static_cast<int>(y.size());
    double ms = 0;
    for (double v : y) ms += v * v / n;
    const double sv = successiveVariance(y.data(), n);
    if (ms > 0 && sv > 0) s += n * std::log(ms / sv);
  }
  return s;
}

}  // namespace

RecordingWander testRecordingWander(const RemainingData& d, const RemainingOptions& o) {
  RecordingWander w;
  std::vector<std::vector<double>> ys;
  double excess = 0;
  for (WanderCells& c : wanderCells(d)) {
    const int n = static_cast<int>(c.y.size());
    if (n < 3) continue;
    const double sv = successiveVariance(c.y.data(), n);
    for (double v : c.y) excess += v * v - sv;
    w.units += c.cycles;
    w.cells += n;
    ++w.recordings;
    ys.push_back(std::move(c.y));
  }
  if (w.recordings == 0) {
    w.note = "needs a recording with at least 3 quarter cycles";
    return w;
  }
  w.statistic = slowStatistic(ys);
  // The null: every cell independent noise of its recording's level (the statistic does not depend on
  // the level), drawn; the draws are fixed so that a diagnosis is reproducible.
  std::mt19937_64 rng(20150101);
  std::normal_distribution<double> z(0, 1);
  std::vector<std::vector<double>> draw(ys.size());
  int ge = 1;
  for (int r = 0; r < kWanderDraws; ++r) {
    for (size_t k = 0; k < ys.size(); ++k) {
      draw[k].resize(ys[k].size());
      for (double& v : draw[k]) v = z(rng);
    }
    ge += slowStatistic(draw) >= w.statistic;
  }
  w.draws = kWanderDraws;
  w.p_value = double(ge) / (kWanderDraws + 1);
  w.significant = w.p_value < o.alpha;
  w.wander_sd = std::sqrt(std::max(0.0, excess / w.cells));
  w.run = true;
  std::ostringstream note;
  note.precision(3);
  note << "statistic " << w.statistic << " over " << w.cells << " quarters of " << w.units << " cycles in "
       << w.recordings << " recordings, against " << kWanderDraws << " draws of independent quarters";
  w.note = note.str();
  return w;
}

}  // namespace kneesim::gap
