#pragma once
// The gap tests' shared fixture: the hertz law and every effect of the gap_effects plugin.

#include <gtest/gtest.h>

#include <vector>

#include "gap/diagnosis.hpp"
#include "gap/effect.hpp"
#include "identify/contact_law.hpp"
#include "plugin/registry.hpp"

namespace kneesim::gap::test {

/// Loads the hertz and gap_effects plugins; catalogue holds every effect they register.
class CatalogueFixture : public ::testing::Test {
 protected:
  void SetUp() override {
    reg.loadPlugin("hertz");
    reg.loadPlugin("gap_effects");
    for (const auto& n : reg.getEffectNames()) catalogue.push_back(Effect::fromRegistry(reg, n));
  }
  /// The hertz law of the registry.
  identify::ContactLaw hertz() const { return identify::ContactLaw::fromRegistry(reg, "hertz"); }
  /// The tests' diagnosis of a Hertz law: K fitted with nu held at 0.45, JW's mass, five folds,
  /// three screened effects, at most two selected, no profile or bootstrap intervals on the law.
  static DiagnosisOptions hertzOptions() {
    DiagnosisOptions o;
    o.fit.free_parameters = {"E", "nu"};
    o.fit.assumed_values = {{"nu", 0.45}};
    o.fit.confidence.profile = false;
    o.fit.confidence.bootstrap_samples = 0;
    o.fit.body_mass = 66.7;
    o.cv_folds = 5;
    o.screen_top = 3;
    o.max_effects = 2;
    return o;
  }
  plugin::Registry reg;
  std::vector<Effect> catalogue;
};

}  // namespace kneesim::gap::test
