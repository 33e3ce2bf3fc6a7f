// Forward selection of the gap diagnosis: at each step, screen the effects not chosen yet, fit the
// top ones, choose which (if any) the step adds and say why in words, and report the pairs and
// rivals the data cannot tell apart.

#include <algorithm>
#include <cmath>

#include "core/strings.hpp"
#include "gap/diagnosis_detail.hpp"

namespace kneesim::gap::detail {

namespace {

// What one selection step screened and fitted.
struct Step {
  int step = 1;
  std::vector<Screening> scr;                    // ranked
  std::map<std::string, VisibleBasis> visible;   // per screened effect
  std::vector<const Effect*> top;                // fitted fully
  int n_screened = 0;                            // testable effects screened
  std::vector<CandidateFit> fits;                // one per top effect
  std::vector<Model> models;                     // their fitted models
  std::map<std::string, std::vector<double>> sigs;  // their in-sample force changes, by effect
};

// Which candidate of a step is chosen (best, -1: none), the gate (significant) and why the others
// were not eligible.
struct Choice {
  int best = -1;
  int significant = -1;
  bool by_whitened = false;
  std::vector<bool> eligible;
  std::vector<std::string> left_out;  // why a candidate not significant on its own was not eligible
};

// Screens every effect not chosen yet at the current model, ranks them (testable first, by z) and
// fits the top ones.
Step screenAndFit(const Context& c, const Model& current, const std::vector<Effect>& catalogue,
                  const std::vector<std::string>& chosen, int step) {
  const DiagnosisOptions& o = *c.o;
  Step s;
  s.step = step;
  for (const auto& e : catalogue)
    if (std::find(chosen.begin(), chosen.end(), e.getName()) == chosen.end())
      s.scr.push_back(screen(c, current, e, &s.visible[e.getName()]));
  std::stable_sort(s.scr.begin(), s.scr.end(), [](const Screening& a, const Screening& b) {
    if (a.testable != b.testable) return a.testable;
    return a.z > b.z;
  });
  for (const auto& x : s.scr) {
    if (!x.testable || static_cast<int>(s.top.size()) >= o.screen_top) continue;
    for (const auto& e : catalogue)
      if (e.getName() == x.effect) s.top.push_back(&e);
  }
  if (s.top.empty()) return s;
  s.n_screened =
      static_cast<int>(std::count_if(s.scr.begin(), s.scr.end(), [](const Screening& x) { return x.testable; }));
  s.models.assign(s.top.size(), Model(*c.base));
  for (size_t k = 0; k < s.top.size(); ++k) {
    s.fits.push_back(
        evaluate(c, current, *s.top[k], step, static_cast<int>(s.top.size()), s.n_screened, s.models[k]));
    s.sigs[s.top[k]->getName()] = signature(c, s.models[k], current);
  }
  return s;
}

// The step needs a gate: a candidate that would be accepted on its own, i.e. significant by its
// withheld improvement or its cross-fitted score (CandidateFit::isSignificant) and removing at least
// min_relative_improvement (a steady but negligible improvement does not make a step). Which effect the
// step adds is then chosen among the significant candidates that remove at least
// min_relative_improvement and those whose withheld error is not significantly worse than the gate's
// while their prewhitened error is significantly lower (two-sided intervals of the relative reduction
// of the pooled MSE over cycles), by the prewhitened errors: they weigh the fast differences between
// rivals, which the smooth gap does not hide, where raw squared errors are dominated by the slow ones,
// which it does. A larger effect whose reduction varies more from cycle to cycle (the proximity
// threshold acts most on a few loud cycles) otherwise lost to a smaller, steadier rival.
Choice choose(const Step& s, const DiagnosisOptions& o) {
  const auto& fits = s.fits;
  const auto& models = s.models;
  Choice ch;
  int& best = ch.best;
  for (size_t k = 0; k < fits.size(); ++k)
    if (fits[k].converged && (best < 0 || fits[k].relative_improvement > fits[best].relative_improvement))
      best = static_cast<int>(k);
  int& significant = ch.significant;  // the gate
  for (size_t k = 0; k < fits.size(); ++k)
    if (fits[k].converged && fits[k].isSignificant() && fits[k].relative_improvement >= o.min_relative_improvement &&
        (significant < 0 || fits[k].whitened_improvement > fits[significant].whitened_improvement))
      significant = static_cast<int>(k);
  std::vector<bool>& eligible = ch.eligible;
  eligible.assign(fits.size(), false);
  std::vector<std::string>& left_out = ch.left_out;
  left_out.assign(fits.size(), "");
  bool& by_whitened = ch.by_whitened;
  const int best_raw = best;
  if (significant >= 0) {
    best = significant;
    const std::string& g = fits[significant].effect;
    for (size_t k = 0; k < fits.size(); ++k) {
      if (!fits[k].converged) continue;
      if (fits[k].relative_improvement < o.min_relative_improvement) {
        left_out[k] = "it removes under " + fmt(100 * o.min_relative_improvement, 2) + " % of the withheld error";
        continue;
      }
      // One not significant on its own must be comparable in raw error and significantly better than
      // the gate in prewhitened error: a close call between them stays with the significant one.
      if (fits[k].isSignificant())
        eligible[k] = true;
      else if (relativeReductionInterval(models[significant].unit_sse, models[k].unit_sse, o.level).upper < 0)
        left_out[k] = "its withheld error is significantly worse than " + g + "'s";
      else if (!(relativeReductionInterval(models[significant].unit_wsse, models[k].unit_wsse, o.level).lower > 0))
        left_out[k] = "its prewhitened withheld error is not significantly lower than " + g + "'s";
      else
        eligible[k] = true;
      if (eligible[k] && fits[k].whitened_improvement > fits[best].whitened_improvement) best = static_cast<int>(k);
    }
    by_whitened = best != best_raw;
  } else {
    // No gate: the step fails; the decision names the significant candidate (if any) it would have been.
    for (size_t k = 0; k < fits.size(); ++k)
      if (best >= 0 && fits[k].converged && fits[k].isSignificant() &&
          (!fits[best].isSignificant() || fits[k].whitened_improvement > fits[best].whitened_improvement)) {
        by_whitened = by_whitened || static_cast<int>(k) != best;
        best = static_cast<int>(k);
      }
    for (size_t k = 0; k < fits.size(); ++k) eligible[k] = fits[k].converged && fits[k].isSignificant();
  }
  return ch;
}

// What would separate effects a and b, after the evidence that they are confusable.
std::string separatedBy(const std::vector<Effect>& catalogue, const std::string& a, const std::string& b,
                        const std::string& evidence) {
  std::string sa, sb;
  for (const auto& e : catalogue) {
    if (e.getName() == a) sa = e.getSeparatedBy();
    if (e.getName() == b) sb = e.getSeparatedBy();
  }
  return evidence + "; trials where they differ would separate them: " + a + ": " + sa + "; " + b + ": " + sb;
}

// Confusable pairs: both significant, withheld errors alike, force changes nearly proportional.
void findConfusablePairs(const Step& s, const std::vector<Effect>& catalogue, const DiagnosisOptions& o,
                         TargetDiagnosis& d) {
  const auto& fits = s.fits;
  for (size_t a = 0; a < fits.size(); ++a)
    for (size_t b = a + 1; b < fits.size(); ++b) {
      if (!(fits[a].isSignificant() && fits[b].isSignificant())) continue;
      const MeanInterval diff = meanInterval(unitLogRatios(s.models[b].unit_sse, s.models[a].unit_sse), o.level);
      const double r = pearson(s.sigs.at(fits[a].effect), s.sigs.at(fits[b].effect));
      if (diff.lower <= 0 && diff.upper >= 0 && std::abs(r) >= 0.8) {
        ConfusablePair cp;
        cp.a = fits[a].effect;
        cp.b = fits[b].effect;
        cp.signature_r = r;
        cp.difference = diff;
        cp.separated_by =
            separatedBy(catalogue, cp.a, cp.b, "their force changes correlate at r = " + fmt(r, 2) + " on these trials");
        d.confusable.push_back(cp);
      }
    }
}

// Both significance tests of a candidate, in words.
std::string testsInWords(const CandidateFit& f, size_t n_fits, const DiagnosisOptions& o) {
  return "MSE reduction " + fmt(100 * f.relative_improvement, 3) + " %, one-sided lower bound " +
         fmt(100 * f.one_sided_lower, 3) + " % at level " + fmt(1 - o.alpha / n_fits, 3) +
         "; cross-fitted score t = " + fmt(f.score_t, 3) + " against " + fmt(f.score_critical, 3);
}

// Whether the chosen candidate is accepted; writes every candidate's decision.
bool decide(Step& s, const Choice& ch, const DiagnosisOptions& o) {
  auto& fits = s.fits;
  const int best = ch.best, significant = ch.significant, step = s.step;
  const bool by_whitened = ch.by_whitened;
  auto tests = [&](const CandidateFit& f) { return testsInWords(f, fits.size(), o); };
  bool accept = false;
  if (best >= 0) {
    CandidateFit& f = fits[best];
    std::vector<std::string> why;
    if (!(f.isSignificant() || significant >= 0))
      why.push_back("neither its withheld improvement nor its cross-fitted score is significant (" + tests(f) + ")");
    if (f.relative_improvement < o.min_relative_improvement)
      why.push_back("it removes only " + fmt(100 * f.relative_improvement, 2) + " % of the withheld mean square error");
    if (!(f.d_bic < 0)) why.push_back("BIC does not favour it (dBIC " + fmt(f.d_bic, 3) + ")");
    for (const auto& p : f.parameters)
      if (!p.identified) why.push_back("its parameter '" + p.name + "' is not identifiable");
    accept = why.empty();
    f.accepted = accept;
    const std::string whitened = "best prewhitened withheld improvement (" + fmt(100 * f.whitened_improvement, 3) +
                                 "%; MSE " + fmt(100 * f.relative_improvement, 3) + "%)";
    std::string how;
    if (f.isSignificant() && !by_whitened)
      how = "best withheld improvement (" + fmt(100 * f.relative_improvement, 3) + "% of the MSE), significant (" +
            tests(f) + ")";
    else if (f.isSignificant() || significant < 0)
      how = whitened + " among the significant ones (" + tests(f) + ")";
    else
      how = whitened + ", not significant on its own (" + tests(f) +
            ") but significantly lower in prewhitened error than " + fits[significant].effect +
            ", which is significant, and not significantly worse in raw error";
    f.decision = accept ? "selected: " + how + ", dBIC " + fmt(f.d_bic, 3) : "not selected: " + join(why, "; ");
  }
  for (size_t k = 0; k < fits.size(); ++k)
    if (static_cast<int>(k) != best)
      fits[k].decision =
          by_whitened && !ch.eligible[k]
              ? (fits[k].isSignificant() ? "not eligible at step " + std::to_string(step) + ": " + ch.left_out[k]
                                         : "not significant at step " + std::to_string(step) + " (" + tests(fits[k]) +
                                               ")" + (ch.left_out[k].empty() ? "" : ", and " + ch.left_out[k]))
              : std::string("not the best ") + (by_whitened ? "prewhitened " : "") + "withheld improvement at step " +
                    std::to_string(step);
  return accept;
}

// Rivals of the selected effect: effects whose force change, as far as the baseline leaves it
// visible, nearly spans the same direction on these trials (canonical correlation of the
// visible bases >= o.confusable_correlation). Each is fitted fully (unless it was) and
// reported confusable when the withheld errors of the two cannot be told apart.
void findRivals(const Context& c, const Model& current, const std::vector<Effect>& catalogue, Step& s, int best,
                TargetDiagnosis& d) {
  const DiagnosisOptions& o = *c.o;
  const auto& fits = s.fits;
  const std::string sel = fits[best].effect;
  const Model& sel_model = s.models[best];
  for (const auto& sc : s.scr) {
    if (!sc.testable || sc.effect == sel) continue;
    const bool listed = std::any_of(d.confusable.begin(), d.confusable.end(), [&](const ConfusablePair& p) {
      return (p.a == sel && p.b == sc.effect) || (p.b == sel && p.a == sc.effect);
    });
    if (listed) continue;
    const double rho = canonicalCorrelation(s.visible[sel], s.visible[sc.effect]);
    if (rho < o.confusable_correlation) continue;
    const Model* rival = nullptr;
    double rival_reduction = 0;
    Model extra(*c.base);
    for (size_t k = 0; k < fits.size(); ++k)
      if (fits[k].effect == sc.effect) {
        rival = &s.models[k];
        rival_reduction = fits[k].relative_improvement;
      }
    if (!rival) {
      const Effect* e = nullptr;
      for (const auto& x : catalogue)
        if (x.getName() == sc.effect) e = &x;
      const CandidateFit rf = evaluate(c, current, *e, s.step, static_cast<int>(s.top.size()), s.n_screened, extra);
      if (!rf.converged) continue;
      rival = &extra;
      rival_reduction = rf.relative_improvement;
    }
    // A rival must explain the gap itself, as much as a selected effect must: one that its bounds
    // hold at the baseline (adhesion cannot pull) reproduces nothing, however alike its direction.
    if (!(rival_reduction >= o.min_relative_improvement)) continue;
    const MeanInterval diff = meanInterval(unitLogRatios(rival->unit_sse, sel_model.unit_sse), o.level);
    if (!(diff.lower <= 0 && diff.upper >= 0)) continue;
    ConfusablePair cp;
    cp.a = sel;
    cp.b = sc.effect;
    cp.signature_r = rho;
    cp.difference = diff;
    cp.separated_by = separatedBy(
        catalogue, cp.a, cp.b,
        "what the baseline leaves visible of their force changes correlates at " + fmt(rho, 3) +
            " (canonical correlation at step " + std::to_string(s.step) +
            ") and their withheld errors do not differ (per-cycle log SSE ratio " + fmt(diff.mean, 3) + " [" +
            fmt(diff.lower, 3) + ", " + fmt(diff.upper, 3) + "])");
    d.confusable.push_back(cp);
  }
}

}  // namespace

Model selectEffects(const Context& c, const std::vector<Effect>& catalogue, const Model& base, TargetDiagnosis& d) {
  const DiagnosisOptions& o = *c.o;
  for (const auto& e : catalogue) {
    std::string why;
    if (!testable(c, e, why)) d.untestable.push_back(e.getName() + ": " + why);
  }
  Model current = base;
  std::vector<std::string> chosen;
  for (int step = 1; step <= o.max_effects; ++step) {
    Step s = screenAndFit(c, current, catalogue, chosen, step);
    d.screening.push_back(s.scr);
    if (s.top.empty()) break;
    const Choice ch = choose(s, o);
    findConfusablePairs(s, catalogue, o, d);
    const bool accept = decide(s, ch, o);
    if (accept) findRivals(c, current, catalogue, s, ch.best, d);
    d.candidates.insert(d.candidates.end(), s.fits.begin(), s.fits.end());
    if (!accept) break;
    chosen.push_back(s.fits[ch.best].effect);
    current = std::move(s.models[ch.best]);
  }
  d.selected = chosen;
  d.undecided = findUndecided(d.candidates, static_cast<int>(chosen.size()) + 1, o.min_relative_improvement);
  return current;
}

}  // namespace kneesim::gap::detail
