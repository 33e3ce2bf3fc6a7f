#pragma once
// Gap-diagnosis effects (kneesim_effect, plugin/kneesim_plugin.h) and baseline laws extended by them.
//
// An extended law is an identify::ContactLaw like any other, so identify::fit() and predict()
// identify and evaluate it unchanged. Its parameters are the baseline's, in order, followed by each
// effect's as "<effect>.<param>"; with the effect parameters at their defaults its force is the
// baseline's, bit for bit (tests/gap/effect_test.cpp checks every catalogued effect).

#include <memory>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "identify/contact_law.hpp"
#include "plugin/kneesim_plugin.h"

namespace kneesim::plugin {
class Registry;
}

namespace kneesim::gap {

/// A gap-diagnosis effect from a plugin, with its table copied into C++ types. The table must
/// outlive the object (keep the plugin::Registry alive).
class Effect {
 public:
  /// Wraps @p table, registered by @p origin (a library path or "built-in").
  explicit Effect(const kneesim_effect& table, std::string origin = "built-in");
  /// The effect registered as @p name; throws InputError at @p where listing the loaded effects.
  static Effect fromRegistry(const plugin::Registry& registry, const std::string& name,
                             const SourceLocation& where = {});

  const std::string& getName() const { return name_; }
  const std::string& getDescription() const { return description_; }
  const std::string& getOrigin() const { return origin_; }
  /// The physics the effect stands for ("" if the plugin gave none).
  const std::string& getPhysics() const { return physics_; }
  /// What data would tell it apart from similar effects ("" if the plugin gave none).
  const std::string& getSeparatedBy() const { return separated_by_; }
  const kneesim_effect& getTable() const { return *table_; }

  int getNumParameters() const { return static_cast<int>(params_.size()); }
  const std::vector<identify::LawParameter>& getParameters() const { return params_; }
  /// Channels the effect reads.
  const std::vector<std::string>& getInputNames() const { return inputs_; }
  /// Channels the effect rewrites before the baseline law (empty for force-only effects).
  const std::vector<std::string>& getRewrites() const { return rewrites_; }
  /// The input channels (other than "time") that @p channels lacks; empty when the effect is usable.
  std::vector<std::string> findMissingInputs(const identify::ChannelMap& channels) const;

 private:
  const kneesim_effect* table_;
  std::string origin_, name_, description_, physics_, separated_by_;
  std::vector<identify::LawParameter> params_;
  std::vector<std::string> inputs_, rewrites_;
};

/// The parameter name an effect parameter has in an extended law: "<effect>.<param>".
std::string qualifiedName(const Effect& effect, const identify::LawParameter& param);

/// The baseline law @p base extended by @p effects (applied in order: every rewrite, then the law,
/// then every force map). Named "<base>+<effect>+..."; parameters: the baseline's, then each
/// effect's as "<effect>.<param>"; inputs: the union of all inputs; derived quantities: the
/// baseline's. With no effects it is the baseline itself under the same name. Derivatives with
/// respect to baseline and force-map parameters are exact; with respect to parameters of effects
/// that rewrite inputs they are central differences (about 1e-9 relative).
identify::ContactLaw makeExtendedLaw(const identify::ContactLaw& base, const std::vector<Effect>& effects);

}  // namespace kneesim::gap
