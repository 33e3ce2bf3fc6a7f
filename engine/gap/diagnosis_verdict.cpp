// The end of the gap diagnosis: whether systematic structure remains in the final model's gap
// (sign-flip permutation test, repeatability band) and the verdict in words.

#include <algorithm>
#include <cmath>

#include "core/strings.hpp"
#include "gap/diagnosis_detail.hpp"

namespace kneesim::gap::detail {

StructureTest structureTest(const Context& c, const Model& m) {
  StructureTest st;
  const int bins = c.o->structure_bins;
  // In-sample residuals: with k-fold cross-validation the cycles of a fold share that fold's
  // parameter error, which would break the exchangeability of signs between cycles; the fit on all
  // cycles only removes structure along the model's own directions (conservative).
  std::vector<std::vector<double>> gap(c.trials.size()), resid(c.trials.size());
  for (size_t t = 0; t < c.trials.size(); ++t) {
    gap[t].assign(c.trials[t].time.size(), kNaN);
    resid[t].assign(c.trials[t].time.size(), kNaN);
    for (size_t i = 0; i < gap[t].size(); ++i) {
      gap[t][i] = c.trials[t].measured_force[i] - m.pred[t][i];
      resid[t][i] = c.trials[t].measured_force[i] - m.fitted[t][i];
    }
  }
  const auto gb = unitBins(c, resid, bins);
  const auto acts = activitiesOf(c);
  auto statistic = [&](const std::vector<int>& sign) {
    double tstat = 0;
    for (const auto& act : acts)
      for (int b = 0; b < bins; ++b) {
        double s = 0;
        int k = 0;
        for (size_t u = 0; u < c.units.size(); ++u)
          if (c.units[u].activity == act && std::isfinite(gb[u][b])) s += sign[u] * gb[u][b], ++k;
        if (k > 0) tstat += s * s / k;
      }
    return tstat;
  };
  st.cycles = static_cast<int>(c.units.size());
  std::vector<int> ones(c.units.size(), 1);
  st.statistic = statistic(ones);
  if (st.cycles < 6) {
    st.p_value = kNaN;
    st.note = "too few cycles (" + std::to_string(st.cycles) + ") for the sign-flip test";
  } else {
    std::mt19937_64 rng(c.o->seed);
    int ge = 0;
    std::vector<int> sign(c.units.size());
    for (int p = 0; p < c.o->permutations; ++p) {
      for (auto& s : sign) s = (rng() & 1) ? 1 : -1;
      if (statistic(sign) >= st.statistic) ++ge;
    }
    st.p_value = (1.0 + ge) / (1.0 + c.o->permutations);
  }
  st.remaining = makeBands(c, gap, m.pred, c.o->bins);
  double sys = 0, band = 0;
  int nb = 0;
  for (const auto& b : st.remaining)
    for (size_t k = 0; k < b.phase.size(); ++k)
      if (b.n_cycles[k] >= 2 && std::isfinite(b.mean_gap[k]) && std::isfinite(b.sd_measured[k])) {
        sys += b.mean_gap[k] * b.mean_gap[k];
        band += b.sd_measured[k] * b.sd_measured[k];
        ++nb;
      }
  st.systematic_gap = nb ? std::sqrt(sys / nb) : kNaN;
  st.repeatability_band = nb ? std::sqrt(band / nb) : kNaN;
  st.exceeds_band = nb > 0 && st.systematic_gap > st.repeatability_band;
  st.significant = (std::isfinite(st.p_value) && st.p_value < c.o->structure_alpha) || st.exceeds_band;
  st.correlations = correlate(c, gap, m.pred);
  return st;
}

void writeVerdict(const Context& c, const Model& current, TargetDiagnosis& d) {
  d.structure = structureTest(c, current);
  const std::string sel = join(d.selected, " + ");
  const std::string pstr = std::isfinite(d.structure.p_value) ? fmt(d.structure.p_value, 3) : "n/a";
  const std::string evidence =
      "sign-flip p = " + pstr + "; systematic gap " + fmt(d.structure.systematic_gap, 3) + " N against a repeatability band of " +
      fmt(d.structure.repeatability_band, 3) + " N";
  std::string remaining_hint;
  if (!d.structure.correlations.empty() && std::isfinite(d.structure.correlations[0].r))
    remaining_hint = " The remaining gap correlates most with " + d.structure.correlations[0].signal + " (r = " +
                     fmt(d.structure.correlations[0].r, 2) + ").";
  if (d.structure.significant) {
    d.verdict = "none of the candidates";
    d.verdict_text = (d.selected.empty()
                          ? "None of the candidates explains the gap: no effect improved the withheld error enough, "
                            "and systematic structure remains over the cycle ("
                          : "None of the candidates explains the whole gap: " + sel +
                                " improve(s) the withheld error, but systematic structure remains over the cycle (") +
                     evidence + ")." + remaining_hint;
  } else if (d.selected.empty()) {
    d.verdict = "baseline";
    d.verdict_text = "The baseline law is adequate at this noise level: no effect improves the withheld error "
                     "significantly, and no systematic structure remains (" + evidence + ").";
  } else {
    d.verdict = sel;
    d.verdict_text = "The gap is explained by " + sel + ": withheld error " + fmt(d.baseline_rmse_heldout, 4) +
                     " N -> " + fmt(std::sqrt(current.cvMse(c.units)), 4) + " N, and no systematic structure remains (" +
                     evidence + ").";
  }
  if (!d.undecided.effect.empty()) {
    const UndecidedCandidate& u = d.undecided;
    d.verdict_text +=
        " Undecided at step " + std::to_string(u.step) + ": " + u.effect + " removes " + fmt(100 * u.reduction, 3) +
        " % of the withheld error, but not significantly (one-sided lower bound " + fmt(100 * u.lower, 3) +
        " %; prewhitened " + fmt(100 * u.whitened, 3) + " %, bound " + fmt(100 * u.whitened_lower, 3) +
        " %). If that reduction and its spread over cycles held, about " + std::to_string(u.cycles_needed) +
        " cycles (instead of " + std::to_string(u.cycles) + ") would make it significant.";
  }
  if (!d.untestable.empty() && d.structure.significant)
    d.verdict_text += " Not testable on these inputs: " + join(d.untestable, "; ") + ".";
  if (!std::isfinite(d.structure.p_value)) d.verdict_text += " (The sign-flip test needs six cycles: " + d.structure.note + ".)";
}
}  // namespace kneesim::gap::detail
