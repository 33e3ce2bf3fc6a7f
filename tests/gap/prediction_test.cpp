// The gap model (gap/prediction.hpp): what a diagnosis selected, saved as gap_model.json, read back
// and applied to a trial the diagnosis never saw. The reference is the held-out trial's own measured
// force: a prediction "within its noise" leaves an RMSE near the synthetic noise (100 N smooth + 5 N
// white), which the baseline law alone, missing the injected load term, cannot reach.

#include "gap/prediction.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "gap/catalogue_fixture.hpp"
#include "gap/jw_sources.hpp"
#include "gap/synth.hpp"
#include "plugin/registry.hpp"
#include "support/input_error.hpp"

namespace kneesim::gap {
namespace {

using kneesim::test::inputErrorOf;
using ::testing::HasSubstr;

class Prediction : public test::CatalogueFixture {
 protected:
  std::vector<GapTrial> synthetic(unsigned long long seed, int replicates) const {
    SynthOptions so;
    so.base_values = {{"E", 2.5e6 * (1 - 0.45 * 0.45)}};
    so.effects = {{"grf_load", {{"gain", 0.6}}}};  // the blind suite's size: 199 N RMS
    so.seed = seed;
    so.replicates = replicates;
    return makeSyntheticTrials(hertz(), catalogue, test::jwGaitAndStair(), so);
  }
  std::string tempFile(const std::string& name, const std::string& text) const {
    const auto dir = std::filesystem::temp_directory_path() / "kneesim_prediction_test";
    std::filesystem::create_directories(dir);
    const std::string p = (dir / name).string();
    std::ofstream(p) << text;
    return p;
  }
};

double rms(const std::vector<double>& a, const std::vector<double>& b) {
  double s = 0;
  for (size_t i = 0; i < a.size(); ++i) s += (a[i] - b[i]) * (a[i] - b[i]);
  return std::sqrt(s / a.size());
}

// Fitted on two replicates of gait and stairs (seed 1), the selected law predicts a third recording of
// each (seed 2: other noise, other channel variations) within its noise; the baseline does not.
TEST_F(Prediction, TheSelectedLawPredictsAHeldOutTrialWithinItsNoise) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/markers/jw_stairupf1.c3d");
  DiagnosisOptions o = hertzOptions();
  o.where = false;
  o.shrinkage = true;
  o.bootstrap = 0;
  GapReport rep = diagnose(hertz(), catalogue, synthetic(1, 2), o);
  rep.plugins = {"hertz", "gap_effects"};
  rep.setup_file = "synthetic";
  const TargetDiagnosis& d = rep.targets.front();
  ASSERT_FALSE(d.selected.empty()) << d.verdict_text;
  EXPECT_EQ(d.selected.front(), "grf_load");

  const std::string text = formatGapModel(makeGapModel(rep));
  const GapModel m = readGapModel(tempFile("gap_model.json", text));
  ASSERT_EQ(m.targets.size(), 1u);
  EXPECT_EQ(m.targets[0].target, "total");
  EXPECT_EQ(m.targets[0].effects, d.selected);
  EXPECT_EQ(m.plugins, rep.plugins);
  double gain = NAN;
  for (const auto& [n, v] : m.targets[0].parameters)
    if (n == "grf_load.gain") gain = v;
  EXPECT_NEAR(gain, 0.6, 0.15);

  GapModel base = m;
  base.targets[0].effects.clear();
  base.targets[0].parameters = {};
  for (const auto& p : d.baseline.parameters) base.targets[0].parameters.emplace_back(p.name, p.value);

  const auto held_out = synthetic(2, 1);
  const auto pred = predictTrials(m, reg, held_out);
  const auto pred_base = predictTrials(base, reg, held_out);
  ASSERT_EQ(pred.size(), held_out.size());
  for (size_t k = 0; k < pred.size(); ++k) {
    const auto& p = pred[k];
    ASSERT_EQ(p.predicted.at("total").size(), held_out[k].trial.time.size());
    const double e = rms(p.predicted.at("total"), held_out[k].trial.measured_force);
    EXPECT_DOUBLE_EQ(p.rmse.at("total"), e);
    std::printf("[ info     ] %s: held-out RMSE %.1f N with %s, %.1f N with the baseline\n", p.trial.c_str(), e,
                m.targets[0].law.c_str(), pred_base[k].rmse.at("total"));
    EXPECT_LT(e, 125) << p.trial;  // the noise: 100 N smooth + 5 N white, with the fit's own error
    EXPECT_GT(pred_base[k].rmse.at("total"), 1.3 * e) << p.trial;
    const io::Storage s = toStorage(p);
    ASSERT_THAT(s.labels, ::testing::ElementsAre("time", "cycle_phase", "total", "total_measured"));
    EXPECT_EQ(s.data.rows(), static_cast<Eigen::Index>(p.time.size()));
  }
}

// A malformed or incomplete gap_model.json, or one naming a parameter the law lacks, is a one-line
// InputError naming the file and the entry.
TEST_F(Prediction, BadModelsAreOneLineErrors) {
  EXPECT_THAT(inputErrorOf([&] { readGapModel(tempFile("a.json", "{ not json")); }), HasSubstr("expected JSON"));
  EXPECT_THAT(inputErrorOf([&] { readGapModel(tempFile("b.json", R"({"kind": "other"})")); }),
              HasSubstr("expected kind 'kneesim gap model'"));
  const std::string no_value =
      R"({"kind": "kneesim gap model", "plugins": ["hertz"], "law": "hertz", "targets": [{"target": "total",
          "effects": [], "parameters": [{"name": "E", "value": "big"}]}]})";
  EXPECT_THAT(inputErrorOf([&] { readGapModel(tempFile("c.json", no_value)); }),
              HasSubstr("targets[0]/parameters/E: gap model: expected a number, got \"big\""));
  const std::string bad_target =
      R"({"kind": "kneesim gap model", "plugins": ["hertz"], "law": "hertz", "targets": [{"target": "both",
          "effects": [], "parameters": []}]})";
  EXPECT_THAT(inputErrorOf([&] { readGapModel(tempFile("d.json", bad_target)); }), HasSubstr("targets[0]/target"));
  // E missing: the law's parameter is named.
  const std::string missing =
      R"({"kind": "kneesim gap model", "plugins": ["hertz"], "law": "hertz", "targets": [{"target": "total",
          "effects": [], "parameters": [{"name": "nu", "value": 0.45}]}]})";
  const GapModel m = readGapModel(tempFile("e.json", missing));
  EXPECT_THAT(inputErrorOf([&] { predictTrials(m, reg, {}, "e.json"); }), HasSubstr("parameter 'E'"));
  EXPECT_THAT(inputErrorOf([&] { readGapModel("/nonexistent/gap_model.json"); }), HasSubstr("no file"));
}

}  // namespace
}  // namespace kneesim::gap
