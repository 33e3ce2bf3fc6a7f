// Shrinkage of the gap diagnosis: withheld RMSE of the baseline and of the selected model, leaving
// one cycle out (overall and per phase) and leaving one activity out, with bootstrap intervals over
// cycles; and the same withheld errors of the alternatives the options name beside the baseline's
// (an alternative baseline read from a channel, an effect added whether or not it was selected).

#include <algorithm>
#include <cmath>

#include "core/strings.hpp"
#include "gap/diagnosis_detail.hpp"

namespace kneesim::gap::detail {

namespace {

double bootstrapRatio(const std::vector<double>& a, const std::vector<double>& b, std::mt19937_64& rng, int samples,
                      double q) {
  std::vector<double> v;
  const size_t n = a.size();
  for (int s = 0; s < samples; ++s) {
    double sa = 0, sb = 0;
    for (size_t k = 0; k < n; ++k) {
      const size_t u = rng() % n;
      sa += a[u];
      sb += b[u];
    }
    if (sa > 0) v.push_back(1 - std::sqrt(sb / sa));
  }
  if (v.empty()) return kNaN;
  std::sort(v.begin(), v.end());
  const double pos = q * (v.size() - 1);
  const size_t i = static_cast<size_t>(pos);
  return i + 1 < v.size() ? v[i] + (pos - i) * (v[i + 1] - v[i]) : v[i];
}

ShrinkageRow shrinkRow(const Context& c, const std::string& scheme, const std::string& scope, const std::string& train,
                       const std::vector<double>& sse_base, const std::vector<double>& sse_final, int frames,
                       std::mt19937_64& rng) {
  ShrinkageRow r;
  r.scheme = scheme;
  r.scope = scope;
  r.train = train;
  r.n_frames = frames;
  r.n_cycles = static_cast<int>(sse_base.size());
  const double sb = std::accumulate(sse_base.begin(), sse_base.end(), 0.0),
               sf = std::accumulate(sse_final.begin(), sse_final.end(), 0.0);
  r.rmse_base = std::sqrt(sb / std::max(1, frames));
  r.rmse_final = std::sqrt(sf / std::max(1, frames));
  r.rmse_base_bw = c.body_weight > 0 ? r.rmse_base / c.body_weight : kNaN;
  r.rmse_final_bw = c.body_weight > 0 ? r.rmse_final / c.body_weight : kNaN;
  r.reduction = r.rmse_base > 0 ? 1 - r.rmse_final / r.rmse_base : kNaN;
  if (sse_base.size() >= 2) {
    const double a = (1 - c.o->level) / 2;
    r.ci = {bootstrapRatio(sse_base, sse_final, rng, c.o->bootstrap, a),
            bootstrapRatio(sse_base, sse_final, rng, c.o->bootstrap, 1 - a)};
  }
  return r;
}

// Leaving one cycle out, overall and per phase of each activity: the cross-validation's own
// withheld errors.
void leaveOneCycleOut(const Context& c, const Model& base, const Model& current, std::mt19937_64& rng,
                      std::vector<ShrinkageRow>& rows) {
  int frames = 0;
  for (const auto& u : c.units) frames += static_cast<int>(u.frames.size());
  rows.push_back(shrinkRow(c, "leave one cycle out", "overall", "all other cycles", base.unit_sse,
                           current.unit_sse, frames, rng));
  for (const auto& act : activitiesOf(c)) {
    for (const auto& ph : getActivityDefinition(act).phases) {
      std::vector<double> sb, sf;
      int n = 0;
      for (const auto& u : c.units) {
        if (u.activity != act) continue;
        const GapTrial& g = (*c.gap_trials)[u.trial];
        double a = 0, b = 0;
        bool any = false;
        for (int i : u.frames) {
          if (!(g.cycle_phase[i] >= ph.begin && g.cycle_phase[i] < ph.end)) continue;
          const double m = c.trials[u.trial].measured_force[i];
          a += (m - base.pred[u.trial][i]) * (m - base.pred[u.trial][i]);
          b += (m - current.pred[u.trial][i]) * (m - current.pred[u.trial][i]);
          ++n;
          any = true;
        }
        if (any) sb.push_back(a), sf.push_back(b);
      }
      if (n > 0)
        rows.push_back(shrinkRow(c, "leave one cycle out", act + ": " + ph.name, "all other cycles", sb, sf, n, rng));
    }
  }
}

// Forces of @p m fitted on the @p train units, on the trials of the @p test units; false if the fit
// refuses the training units (e.g. a parameter they cannot determine).
bool forcesFittedOn(const Context& c, const Model& m, const std::vector<int>& train, const std::vector<int>& test,
                    std::map<int, Eigen::VectorXd>& forces) {
  identify::FitReport fr;
  try {
    fr = identify::fit(m.law, restrict(c, train), fitOptionsFor(c, m.law, m.free, m.params, /*warm=*/true));
  } catch (const InputError&) {
    return false;  // e.g. a parameter the other activities cannot determine
  }
  const Eigen::VectorXd p = fr.getValues();
  for (int u : test) {
    const int t = c.units[u].trial;
    if (forces.count(t)) continue;
    const identify::LawInputs in(m.law, c.trials[t].channels, c.trials[t].time, c.trials[t].name);
    m.law.calcForce(p, in, forces[t]);
  }
  return true;
}

// The same for both models (base, current).
bool forcesFittedOn(const Context& c, const Model& base, const Model& current, const std::vector<int>& train,
                    const std::vector<int>& test, std::map<int, Eigen::VectorXd> (&forces)[2]) {
  return forcesFittedOn(c, base, train, test, forces[0]) && forcesFittedOn(c, current, train, test, forces[1]);
}

// Leaving one activity out: both models fitted on the other activities predict it, overall and per
// phase.
void leaveOneActivityOut(const Context& c, const Model& base, const Model& current, std::mt19937_64& rng,
                         std::vector<ShrinkageRow>& rows) {
  const auto acts = activitiesOf(c);
  for (const auto& act : acts) {
    std::vector<int> train, test;
    for (size_t u = 0; u < c.units.size(); ++u) (c.units[u].activity == act ? test : train).push_back(static_cast<int>(u));
    std::vector<std::string> others;
    for (const auto& a : acts)
      if (a != act) others.push_back(a);
    // Forces of both models, fitted on the other activities, on the left-out activity's trials.
    std::map<int, Eigen::VectorXd> forces[2];
    if (!forcesFittedOn(c, base, current, train, test, forces)) continue;
    // Overall, then per phase of the left-out activity: per-cycle SSEs of both models.
    const auto phases = getActivityDefinition(act).phases;
    for (int ph = -1; ph < static_cast<int>(phases.size()); ++ph) {
      std::vector<double> sb, sf;
      int n = 0;
      for (int u : test) {
        const int t = c.units[u].trial;
        const GapTrial& g = (*c.gap_trials)[t];
        double a = 0, b = 0;
        bool any = false;
        for (int i : c.units[u].frames) {
          if (ph >= 0 && !(g.cycle_phase[i] >= phases[ph].begin && g.cycle_phase[i] < phases[ph].end)) continue;
          const double m = c.trials[t].measured_force[i];
          a += (m - forces[0][t][i]) * (m - forces[0][t][i]);
          b += (m - forces[1][t][i]) * (m - forces[1][t][i]);
          ++n;
          any = true;
        }
        if (any) sb.push_back(a), sf.push_back(b);
      }
      if (n == 0) continue;
      rows.push_back(shrinkRow(c, "leave one activity out", ph < 0 ? act : act + ": " + phases[ph].name,
                               join(others, " + "), sb, sf, n, rng));
    }
  }
}

// The units of activity @p act (test) and the others (train).
void splitByActivity(const Context& c, const std::string& act, std::vector<int>& train, std::vector<int>& test) {
  for (size_t u = 0; u < c.units.size(); ++u) (c.units[u].activity == act ? test : train).push_back(static_cast<int>(u));
}

// Squared error of @p pred(trial, frame) over each unit of @p units.
template <class Prediction>
std::vector<double> unitSse(const Context& c, const std::vector<int>& units, const Prediction& pred) {
  std::vector<double> sse;
  for (int u : units) {
    const int t = c.units[u].trial;
    double a = 0;
    for (int i : c.units[u].frames) {
      const double e = c.trials[t].measured_force[i] - pred(t, i);
      a += e * e;
    }
    sse.push_back(a);
  }
  return sse;
}

int framesOf(const Context& c, const std::vector<int>& units) {
  int n = 0;
  for (int u : units) n += static_cast<int>(c.units[u].frames.size());
  return n;
}

// The rows of one comparison: @p alt_loco the alternative's withheld squared error per unit (all
// cycles but each); @p alt_loao(train, test, sse) its squared errors on the test units, fitted on the
// train units (false: it cannot be fitted there).
template <class LeaveActivityOut>
void comparisonRows(const Context& c, const Model& base, const std::vector<double>& alt_loco,
                    const LeaveActivityOut& alt_loao, std::mt19937_64& rng, std::vector<ShrinkageRow>& rows) {
  const auto acts = activitiesOf(c);
  const std::vector<int> all = allUnits(c);
  rows.push_back(shrinkRow(c, "leave one cycle out", "overall", "all other cycles", base.unit_sse, alt_loco,
                           framesOf(c, all), rng));
  if (acts.size() >= 2)
    for (const auto& act : acts) {
      std::vector<int> train, test;
      splitByActivity(c, act, train, test);
      std::vector<double> sb, sa;
      for (int u : test) sb.push_back(base.unit_sse[u]), sa.push_back(alt_loco[u]);
      rows.push_back(shrinkRow(c, "leave one cycle out", act, "all other cycles", sb, sa, framesOf(c, test), rng));
    }
  if (!c.o->shrinkage || acts.size() < 2) return;
  for (const auto& act : acts) {
    std::vector<int> train, test;
    splitByActivity(c, act, train, test);
    std::vector<std::string> others;
    for (const auto& a : acts)
      if (a != act) others.push_back(a);
    std::map<int, Eigen::VectorXd> fb;
    std::vector<double> sa;
    if (!forcesFittedOn(c, base, train, test, fb) || !alt_loao(train, test, sa)) continue;
    const auto sb = unitSse(c, test, [&](int t, int i) { return fb[t][i]; });
    rows.push_back(shrinkRow(c, "leave one activity out", act, join(others, " + "), sb, sa, framesOf(c, test), rng));
  }
}

// A channel taken as the force: nothing is fitted, so its withheld error is its error.
Comparison compareChannel(const Context& c, const Model& base, const std::string& name, const std::string& target,
                          std::mt19937_64& rng) {
  Comparison cmp;
  cmp.name = cmp.channel = name;
  cmp.kind = "alternative baseline";
  // makeTargetTrial reads a compartment's <p>_medial or <p>_lateral under the whole knee's name.
  if (target != "total" && endsWith(name, "_total")) cmp.channel = name.substr(0, name.size() - 5) + target;
  for (const auto& t : c.trials)
    if (!t.channels.count(name)) {
      cmp.note = "trial '" + t.name + "' has no channel '" + cmp.channel + "'";
      return cmp;
    }
  auto channel = [&](int t, int i) { return c.trials[t].channels.at(name)[i]; };
  const std::vector<double> loco = unitSse(c, allUnits(c), channel);
  comparisonRows(
      c, base, loco,
      [&](const std::vector<int>&, const std::vector<int>& test, std::vector<double>& sse) {
        sse = unitSse(c, test, channel);
        return true;
      },
      rng, cmp.rows);
  return cmp;
}

// The baseline plus @p e, fitted and cross-validated like a first-step candidate.
Comparison compareEffect(const Context& c, const Model& base, const Effect& e, std::mt19937_64& rng) {
  Comparison cmp;
  cmp.name = e.getName();
  cmp.kind = "baseline + effect";
  if (std::string why; !testable(c, e, why)) {
    cmp.note = why;
    return cmp;
  }
  Model m(*c.base);
  const CandidateFit cf = evaluate(c, base, e, 1, 1, 1, m);
  if (!cf.converged) cmp.note = join(cf.notes, "; ");
  comparisonRows(
      c, base, m.unit_sse,
      [&](const std::vector<int>& train, const std::vector<int>& test, std::vector<double>& sse) {
        std::map<int, Eigen::VectorXd> f;
        if (!forcesFittedOn(c, m, train, test, f)) return false;
        sse = unitSse(c, test, [&](int t, int i) { return f[t][i]; });
        return true;
      },
      rng, cmp.rows);
  return cmp;
}

}  // namespace

std::vector<Comparison> compare(const Context& c, const std::vector<Effect>& catalogue, const Model& base,
                                const std::string& target) {
  std::vector<Comparison> out;
  std::mt19937_64 rng(c.o->seed + 1);
  for (const auto& name : c.o->alternative_baselines) out.push_back(compareChannel(c, base, name, target, rng));
  for (const auto& name : c.o->compared_effects)
    for (const Effect& e : catalogue)
      if (e.getName() == name) out.push_back(compareEffect(c, base, e, rng));
  return out;
}

std::vector<ShrinkageRow> shrinkage(const Context& c, const Model& base, const Model& current) {
  std::vector<ShrinkageRow> rows;
  std::mt19937_64 rng(c.o->seed);
  leaveOneCycleOut(c, base, current, rng, rows);
  if (c.o->shrinkage && activitiesOf(c).size() >= 2) leaveOneActivityOut(c, base, current, rng, rows);
  return rows;
}
}  // namespace kneesim::gap::detail
