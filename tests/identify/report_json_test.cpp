#include "identify/report_json.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "plugin/registry.hpp"
#include "support/test_data.hpp"
#include "synthetic.hpp"

namespace kneesim::identify {
namespace {

TEST(ReportJson, SummaryCarriesTheIdentifiedQuantitiesAndTheIdentifiabilityVerdict) {
  plugin::Registry reg;
  reg.loadPlugin("hertz");
  const ContactLaw hertz(reg.getContactLaw("hertz"), reg.findOrigin("hertz"));
  FitOptions o;
  o.confidence.bootstrap_samples = 20;
  o.phases = {{"stance", 0.0, 0.6, true}};
  const Trial t = test::makeTrial("walk", [](double s) { return test::hertzForce(s, 2e7, 0.037); }, 40.0, 5);
  const FitReport r = fit(hertz, {t}, o);
  const nlohmann::json j = toJson(r);
  EXPECT_EQ(j["law"], "hertz");
  EXPECT_EQ(j["parameters"][1]["name"], "nu");
  EXPECT_EQ(j["parameters"][1]["status"], "fixed: not identifiable");
  EXPECT_EQ(j["parameters"][1]["value_source"], "law default");
  EXPECT_TRUE(j["parameters"][1]["ci_profile"].is_null());  // no interval for a fixed parameter
  EXPECT_EQ(j["derived"][0]["name"], "K");
  EXPECT_EQ(j["derived"][0]["identified"], true);
  EXPECT_DOUBLE_EQ(j["derived"][0]["value"].get<double>(), r.getDerived("K").value);
  EXPECT_EQ(j["derived"][0]["ci_bootstrap"].size(), 2u);
  EXPECT_EQ(j["identifiability"]["start"]["identifiable"], false);
  EXPECT_EQ(j["identifiability"]["start"]["null_directions"][0]["direction"], "-0.453 E + 0.892 nu");
  EXPECT_EQ(j["identifiability"]["fixed"][0]["name"], "nu");
  EXPECT_EQ(j["identifiability"]["final"]["identifiable"], true);
  EXPECT_EQ(j["solver"]["success"], true);
  EXPECT_EQ(j["metrics"]["frames"], 144);
  EXPECT_TRUE(j["metrics"]["rmse_BW"].is_null());  // no body mass given: NaN -> null
  EXPECT_EQ(j["per_trial"][0]["phases"][0]["phase"], "stance");
  EXPECT_EQ(j["bootstrap"]["samples"], 20);
  EXPECT_GE(j["notes"].size(), 2u);

  const std::string dir = kneesim::test::scratchDir("report_json");
  writeFitReport(dir + "/summary.json", r);
  std::ifstream in(dir + "/summary.json");
  const nlohmann::json back = nlohmann::json::parse(in);
  EXPECT_EQ(back, nlohmann::json::parse(j.dump()));

  const PredictionReport p = predict(hertz, r.getValues(), t, o);
  const nlohmann::json pj = toJson(p, true);
  EXPECT_EQ(pj["time_s"].size(), 144u);
  EXPECT_FALSE(toJson(p).contains("time_s"));
}

}  // namespace
}  // namespace kneesim::identify
