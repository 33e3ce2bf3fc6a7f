#pragma once
// Internal to the gap diagnosis (gap/diagnosis.hpp): the types its steps share (a cycle, a model
// fitted on all cycles and cross-validated, the context of one target) and the steps themselves,
// one file each. Not part of the public API (not installed).

#include <limits>
#include <map>
#include <numeric>
#include <random>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "gap/diagnosis.hpp"

namespace kneesim::gap::detail {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

inline std::string fmt(double v, int digits = 3) {
  std::ostringstream s;
  s.precision(digits);
  s << v;
  return s.str();
}

// A cycle of a trial with its frames: the unit of cross-validation.
struct Unit {
  int trial = 0;
  std::string activity;
  double begin = 0, end = 0;
  std::vector<int> frames;
};

// A model (the baseline plus effects) fitted on all units and cross-validated.
struct Model {
  explicit Model(identify::ContactLaw l) : law(std::move(l)) {}
  std::vector<Effect> effects;
  identify::ContactLaw law;
  std::vector<std::string> free;
  identify::FitReport fit;
  Eigen::VectorXd params;
  std::vector<std::vector<double>> pred;  // held-out prediction per trial and frame (NaN elsewhere)
  std::vector<double> unit_sse;
  std::vector<double> unit_wsse;  // prewhitened (Context::ar) held-out squared errors per unit
  std::vector<Eigen::VectorXd> fold_params;
  std::vector<std::vector<double>> fitted;  // in-sample force per trial and frame
  int cv_failures = 0;
  std::string cv_failure_status;  // Ipopt's status of the last fold fit that failed
  double cvMse(const std::vector<Unit>& units) const {
    double s = 0, n = 0;
    for (size_t u = 0; u < units.size(); ++u) s += unit_sse[u], n += units[u].frames.size();
    return n > 0 ? s / n : kNaN;
  }
  double totalWsse() const { return std::accumulate(unit_wsse.begin(), unit_wsse.end(), 0.0); }
};

// Everything the analyses of one target share.
struct Context {
  const identify::ContactLaw* base = nullptr;
  const std::vector<GapTrial>* gap_trials = nullptr;
  std::vector<identify::Trial> trials;  // target trials, no windows
  std::vector<Unit> units;
  std::vector<std::vector<int>> folds;
  const DiagnosisOptions* o = nullptr;
  double body_weight = 0;  // N
  std::vector<double> ar;  // prewhitening filter phi_1..phi_p (empty: none)
};

// ---- cross-validation over cycles (diagnosis_cv.cpp)

// The context of @p target: its trials, their cycles as units (partial cycles much shorter than a
// whole one merged into a neighbour) and the folds of cross-validation; @p cv_scheme says which.
Context makeContext(const identify::ContactLaw& base, const std::vector<GapTrial>& trials, const DiagnosisOptions& o,
                    const std::string& target, std::string& cv_scheme);
// The prewhitened held-out squared errors of each unit from m.pred.
void updateWhitened(const Context& c, Model& m);
// Per-frame values minus their activity's mean over the normalised cycle (NaN where fewer than two
// units cover a bin or the frame has no phase).
std::vector<std::vector<double>> cycleDeviations(const Context& c, const std::vector<std::vector<double>>& v, int bins);
// The prewhitening filter of a target (DiagnosisOptions::prewhiten_order) from per-frame values.
std::vector<double> fitPrewhitening(const Context& c, const std::vector<std::vector<double>>& v, int order);
// The target trials restricted to the given units (trials without any are left out).
std::vector<identify::Trial> restrict(const Context& c, const std::vector<int>& unit_ids);
// Fit options of @p law freeing @p free, started at @p start (the diagnosis's solver settings).
identify::FitOptions fitOptionsFor(const Context& c, const identify::ContactLaw& law, const std::vector<std::string>& free,
                                   const Eigen::VectorXd& start, bool warm = false);
std::vector<int> allUnits(const Context& c);
// Fits `m` on all units (its law, free set and start in m.params) and cross-validates it.
void fitAndValidate(const Context& c, Model& m);
// Lag-1 autocorrelation of per-frame values pooled over units (consecutive frames only).
double pooledLag1(const Context& c, const std::vector<std::vector<double>>& v);
// The distinct activities of the units, in order of first appearance.
std::vector<std::string> activitiesOf(const Context& c);

// ---- screening (diagnosis_screen.cpp)

// Orthonormal basis of the force changes an effect's parameters make at the current model that the
// current model's own parameters cannot make: what the data can see of the effect.
using VisibleBasis = Eigen::MatrixXd;
// Whether @p e is usable on every target trial; if not, @p reason says why.
bool testable(const Context& c, const Effect& e, std::string& reason);
// The score (Lagrange multiplier) test of adding @p e to @p m; fills @p visible if given.
Screening screen(const Context& c, const Model& m, const Effect& e, VisibleBasis* visible = nullptr);
// Largest canonical correlation between two visible bases.
double canonicalCorrelation(const VisibleBasis& a, const VisibleBasis& b);

// ---- a candidate's full fit and its significance tests (diagnosis_candidate.cpp)

// The in-sample force change of @p with against @p without over the units' frames.
std::vector<double> signature(const Context& c, const Model& with, const Model& without);
// Per-unit log ratios ln(a / b) of SSEs (> 0 where b is better).
std::vector<double> unitLogRatios(const std::vector<double>& a, const std::vector<double>& b);
// Fits @p current plus @p e into @p out, cross-validates it and tests its improvement
// (Bonferroni over @p n_candidates fitted and @p n_screened screened effects).
CandidateFit evaluate(const Context& c, const Model& current, const Effect& e, int step, int n_candidates,
                      int n_screened, Model& out);

// ---- forward selection (diagnosis_select.cpp)

// Forward selection from @p base over @p catalogue: fills d's screening, candidates, selected,
// confusable, untestable and undecided; returns the final model.
Model selectEffects(const Context& c, const std::vector<Effect>& catalogue, const Model& base, TargetDiagnosis& d);

// ---- where-analysis (diagnosis_where.cpp)

// Bin means of per-frame values over the normalised cycle, per unit: [unit][bin] (NaN: no frame).
std::vector<std::vector<double>> unitBins(const Context& c, const std::vector<std::vector<double>>& v, int bins);
std::vector<BandCurve> makeBands(const Context& c, const std::vector<std::vector<double>>& gap,
                                 const std::vector<std::vector<double>>& pred, int bins);
std::vector<SignalCorrelation> correlate(const Context& c, const std::vector<std::vector<double>>& gap,
                                         const std::vector<std::vector<double>>& pred);
// Fills d's bands, phases, correlations, best lag and reference predictors from the baseline's
// held-out gap.
void analyseWhere(const Context& c, const Model& base, TargetDiagnosis& d);

// ---- remaining structure and verdict (diagnosis_verdict.cpp)

StructureTest structureTest(const Context& c, const Model& m);
// Fills d.structure, d.verdict and d.verdict_text for the final model @p current.
void writeVerdict(const Context& c, const Model& current, TargetDiagnosis& d);

// ---- shrinkage (diagnosis_shrinkage.cpp)

// Withheld errors of @p base and @p current: leaving one cycle out (overall and per phase), then
// leaving one activity out.
std::vector<ShrinkageRow> shrinkage(const Context& c, const Model& base, const Model& current);
// The withheld errors of the options' alternative baselines and compared effects of @p catalogue
// beside @p base's on @p target: leaving one cycle out (overall, per activity), then leaving one
// activity out.
std::vector<Comparison> compare(const Context& c, const std::vector<Effect>& catalogue, const Model& base,
                                const std::string& target);

}  // namespace kneesim::gap::detail
