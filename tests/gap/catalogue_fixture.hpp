#pragma once
// The gap tests' shared fixture: the hertz law and every effect of the gap_effects plugin.

#include <gtest/gtest.h>

#include <vector>

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
  plugin::Registry reg;
  std::vector<Effect> catalogue;
};

}  // namespace kneesim::gap::test
