#pragma once
// Loading plugins and looking up what they registered.

#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "core/error.hpp"
#include "plugin/kneesim_plugin.h"

namespace kneesim::plugin {

/// The plugins loaded by one run (no global state: each Session owns one registry).
/// Libraries stay loaded until the registry is destroyed.
class Registry {
 public:
  Registry();
  ~Registry();
  Registry(const Registry&) = delete;
  Registry& operator=(const Registry&) = delete;

  /// Loads the plugin @p name_or_path: an existing path (anything with a '/' or ending in ".so"),
  /// or a bare name such as "hertz" searched as libkneesim_<name>.so, then lib<name>.so, in each
  /// search folder in turn. Loading the same library twice is a no-op. Throws a one-line
  /// InputError at @p context (the setup file and element) when the plugin cannot be found
  /// (naming the plugin and every folder searched), cannot be loaded, does not export
  /// kneesim_plugin_register, or is refused (invalid table, a name already registered by another
  /// library). A refused plugin leaves the registry as it was.
  void loadPlugin(const std::string& name_or_path, const SourceLocation& context = {});

  /// Folders searched by loadPlugin, in order: those added here, then $KNEESIM_PLUGIN_PATH
  /// (colon-separated), then kneesim/plugins beside the engine library (an installed prefix,
  /// wherever it was moved), then the build and install folders compiled into the library.
  void addSearchDirectory(const std::string& dir);
  const std::vector<std::string>& getSearchDirectories() const { return search_dirs_; }

  /// Registers a table directly (plugins linked into the executable, tests). The table must outlive
  /// the registry. Throws InternalError if it is invalid or its name is taken.
  void adoptContactLaw(const kneesim_contact_law* law, const std::string& origin = "built-in");
  void adoptDistanceProvider(const kneesim_distance_provider* provider, const std::string& origin = "built-in");
  void adoptEffect(const kneesim_effect* effect, const std::string& origin = "built-in");

  /// The law or provider registered under @p name, or nullptr (cheap).
  const kneesim_contact_law* findContactLaw(const std::string& name) const;
  const kneesim_distance_provider* findDistanceProvider(const std::string& name) const;
  /// The gap-diagnosis effect registered under @p name, or nullptr (cheap).
  const kneesim_effect* findEffect(const std::string& name) const;
  /// Like find*, but throws InputError at @p context listing the available names.
  const kneesim_contact_law& getContactLaw(const std::string& name, const SourceLocation& context = {}) const;
  const kneesim_distance_provider& getDistanceProvider(const std::string& name,
                                                       const SourceLocation& context = {}) const;
  /// Like findEffect, but throws InputError at @p context listing the effects that are loaded.
  const kneesim_effect& getEffect(const std::string& name, const SourceLocation& context = {}) const;

  std::vector<std::string> getContactLawNames() const;
  std::vector<std::string> getDistanceProviderNames() const;
  /// Names of the loaded effects, sorted.
  std::vector<std::string> getEffectNames() const;
  /// The library a law, provider or effect came from ("built-in" for adopted tables).
  std::string findOrigin(const std::string& name) const;

 private:
  struct Library;
  std::vector<std::string> search_dirs_;
  std::vector<std::unique_ptr<Library>> libraries_;
  std::map<std::string, const kneesim_contact_law*> laws_;
  std::map<std::string, const kneesim_distance_provider*> providers_;
  std::map<std::string, std::string> law_origins_;
  std::map<std::string, std::string> provider_origins_;
  std::map<std::string, const kneesim_effect*> effects_;
  std::map<std::string, std::string> effect_origins_;
  std::string loading_;  // library being registered, for the origins
  std::string reject_;   // why the last add_* was refused
  enum class Kind { Law, Provider, Effect };
  std::vector<std::pair<Kind, std::string>> added_;  // registered by the library being loaded

  static int addLawThunk(void* host, const kneesim_contact_law* law);
  static int addProviderThunk(void* host, const kneesim_distance_provider* provider);
  static int addEffectThunk(void* host, const kneesim_effect* effect);
};

}  // namespace kneesim::plugin
