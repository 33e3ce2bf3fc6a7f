#include "plugin/registry.hpp"

#include <dlfcn.h>

#include <cstdlib>
#include <exception>
#include <filesystem>

#include "core/error.hpp"
#include "core/paths.hpp"
#include "core/strings.hpp"

namespace kneesim::plugin {

namespace fs = std::filesystem;

namespace {

/// kneesim/plugins next to the library holding this code: <prefix>/lib/kneesim/plugins once
/// installed, wherever the prefix was moved to ("" if the library cannot be located).
std::string findPluginDirBesideLibrary() {
  Dl_info info;
  if (dladdr(reinterpret_cast<void*>(&findPluginDirBesideLibrary), &info) == 0 || !info.dli_fname) return "";
  return (fs::path(info.dli_fname).parent_path() / "kneesim" / "plugins").lexically_normal().string();
}

}  // namespace

struct Registry::Library {
  std::string path;
  void* handle = nullptr;
  ~Library() {
    if (handle) dlclose(handle);
  }
};

Registry::Registry() {
  if (const char* env = std::getenv("KNEESIM_PLUGIN_PATH"))
    for (auto d : splitOn(env, ':'))
      if (!d.empty()) search_dirs_.emplace_back(d);
  if (const std::string beside = findPluginDirBesideLibrary(); !beside.empty() && fs::is_directory(beside))
    search_dirs_.push_back(beside);
#ifdef KNEESIM_PLUGIN_BUILD_DIR
  search_dirs_.emplace_back(KNEESIM_PLUGIN_BUILD_DIR);
#endif
#ifdef KNEESIM_PLUGIN_INSTALL_DIR
  search_dirs_.emplace_back(KNEESIM_PLUGIN_INSTALL_DIR);
#endif
}

Registry::~Registry() {
  // Tables belong to the libraries: forget them before unloading.
  laws_.clear();
  providers_.clear();
  effects_.clear();
  libraries_.clear();
}

void Registry::addSearchDirectory(const std::string& dir) { search_dirs_.insert(search_dirs_.begin(), dir); }

void Registry::loadPlugin(const std::string& name_or_path, const SourceLocation& context) {
  std::string path;
  const bool is_path = name_or_path.find('/') != std::string::npos || endsWith(name_or_path, ".so");
  if (is_path) {
    if (pathExists(name_or_path)) path = fs::absolute(name_or_path).lexically_normal().string();
  } else {
    for (const auto& d : search_dirs_) {
      for (const std::string& f : {"libkneesim_" + name_or_path + ".so", "lib" + name_or_path + ".so"}) {
        const fs::path p = fs::path(d) / f;
        if (pathExists(p)) {
          path = fs::absolute(p).lexically_normal().string();
          break;
        }
      }
      if (!path.empty()) break;
    }
  }
  if (path.empty()) {
    if (is_path) throw InputError(context, "no plugin '" + name_or_path + "': the file does not exist");
    std::string dirs;
    for (const auto& d : search_dirs_) dirs += (dirs.empty() ? "" : ", ") + d;
    throw InputError(context, "no plugin '" + name_or_path + "' found (looked for libkneesim_" + name_or_path +
                                  ".so and lib" + name_or_path + ".so in: " +
                                  (dirs.empty() ? std::string("no folders; set KNEESIM_PLUGIN_PATH") : dirs) +
                                  ")");
  }
  for (const auto& lib : libraries_)
    if (lib->path == path) return;

  auto lib = std::make_unique<Library>();
  lib->path = path;
  lib->handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!lib->handle) {
    const char* why = dlerror();
    throw InputError(context, "cannot load plugin '" + path + "': " + (why ? why : "unknown error"));
  }
  // The same file reached through another path (a symlink) is already registered.
  for (const auto& other : libraries_)
    if (other->handle == lib->handle) return;  // ~Library drops the extra reference
  auto* fn = reinterpret_cast<kneesim_plugin_register_fn>(dlsym(lib->handle, "kneesim_plugin_register"));
  if (!fn)
    throw InputError(context,
                     "'" + path + "' is not a kneesim plugin: it does not export kneesim_plugin_register");
  kneesim_registrar r{KNEESIM_PLUGIN_ABI_VERSION, this, &Registry::addLawThunk, &Registry::addProviderThunk,
                      &Registry::addEffectThunk};
  loading_ = path;
  reject_.clear();
  added_.clear();
  int rc = 0;
  try {
    rc = fn(&r);
  } catch (const std::exception& e) {  // a C++ plugin that let an exception escape
    rc = -1;
    if (reject_.empty()) reject_ = e.what();
  } catch (...) {
    rc = -1;
  }
  loading_.clear();
  if (rc != 0) {
    // The tables live in the library that is about to be unloaded: forget what it registered.
    for (const auto& [kind, name] : added_) {
      if (kind == Kind::Law) {
        laws_.erase(name);
        law_origins_.erase(name);
      } else if (kind == Kind::Provider) {
        providers_.erase(name);
        provider_origins_.erase(name);
      } else {
        effects_.erase(name);
        effect_origins_.erase(name);
      }
    }
    added_.clear();
    throw InputError(context, "plugin '" + path + "' failed to register (code " + std::to_string(rc) + ")" +
                                  (reject_.empty() ? "" : ": " + reject_));
  }
  added_.clear();
  libraries_.push_back(std::move(lib));
}

namespace {

// Why a parameter table is unusable, or "" when it is fine; @p who prefixes the message.
std::string checkParams(const std::string& who, int n_params, const kneesim_param* params) {
  if (n_params < 0 || (n_params > 0 && !params))
    return who + "expected n_params >= 0 with a params array, got n_params = " + std::to_string(n_params);
  for (int i = 0; i < n_params; ++i) {
    const kneesim_param& p = params[i];
    if (!p.name || !*p.name) return who + "parameter " + std::to_string(i) + " has no name";
    for (int j = 0; j < i; ++j)
      if (std::string(params[j].name) == p.name) return who + "parameter '" + p.name + "' appears twice";
    if (!(p.lower <= p.default_value && p.default_value <= p.upper))
      return who + "parameter '" + p.name + "': expected lower <= default <= upper, got " +
             std::to_string(p.lower) + " <= " + std::to_string(p.default_value) + " <= " + std::to_string(p.upper);
    if (!(p.typical_scale > 0)) return who + "parameter '" + p.name + "': expected typical_scale > 0";
  }
  return "";
}

// Why a contact-law table is unusable, or "" when it is fine.
std::string checkLawTable(const kneesim_contact_law* law) {
  if (!law) return "contact-law table is NULL";
  if (law->struct_size < static_cast<int>(sizeof(kneesim_contact_law)))
    return "contact-law table has struct_size " + std::to_string(law->struct_size) + ", expected at least " +
           std::to_string(sizeof(kneesim_contact_law)) + " (ABI version " +
           std::to_string(KNEESIM_PLUGIN_ABI_VERSION) + ")";
  if (!law->name || !*law->name) return "contact-law table has no name";
  const std::string who = std::string("contact law '") + law->name + "': ";
  if (!law->calc_force) return who + "calc_force is NULL";
  if (std::string why = checkParams(who, law->n_params, law->params); !why.empty()) return why;
  if (law->n_inputs < 0 || (law->n_inputs > 0 && !law->inputs)) return who + "invalid n_inputs/inputs";
  for (int i = 0; i < law->n_inputs; ++i)
    if (!law->inputs[i] || !*law->inputs[i]) return who + "input " + std::to_string(i) + " has no name";
  if (law->n_derived < 0 ||
      (law->n_derived > 0 && (!law->derived_names || !law->derived_units || !law->calc_derived)))
    return who + "n_derived > 0 needs derived_names, derived_units and calc_derived";
  for (int i = 0; i < law->n_derived; ++i)
    if (!law->derived_names[i] || !law->derived_units[i])
      return who + "derived quantity " + std::to_string(i) + " has no name or unit";
  return "";
}

// Why an effect table is unusable, or "" when it is fine.
std::string checkEffectTable(const kneesim_effect* e) {
  if (!e) return "effect table is NULL";
  if (e->struct_size < static_cast<int>(sizeof(kneesim_effect)))
    return "effect table has struct_size " + std::to_string(e->struct_size) + ", expected at least " +
           std::to_string(sizeof(kneesim_effect));
  if (!e->name || !*e->name) return "effect table has no name";
  const std::string who = std::string("effect '") + e->name + "': ";
  if (!e->rewrite_inputs && !e->map_force) return who + "expected rewrite_inputs or map_force, got neither";
  if (std::string why = checkParams(who, e->n_params, e->params); !why.empty()) return why;
  if (e->n_inputs < 0 || (e->n_inputs > 0 && !e->inputs)) return who + "invalid n_inputs/inputs";
  for (int i = 0; i < e->n_inputs; ++i)
    if (!e->inputs[i] || !*e->inputs[i]) return who + "input " + std::to_string(i) + " has no name";
  if (e->n_rewrites < 0 || (e->n_rewrites > 0 && (!e->rewrites || !e->rewrite_inputs)) ||
      (e->rewrite_inputs && e->n_rewrites == 0))
    return who + "rewrite_inputs needs n_rewrites > 0 and a rewrites array (and the other way round)";
  for (int c = 0; c < e->n_rewrites; ++c) {
    if (!e->rewrites[c] || !*e->rewrites[c]) return who + "rewritten channel " + std::to_string(c) + " has no name";
    bool listed = false;
    for (int i = 0; i < e->n_inputs; ++i) listed = listed || std::string(e->inputs[i]) == e->rewrites[c];
    if (!listed) return who + "rewritten channel '" + e->rewrites[c] + "' must also be listed in inputs";
  }
  return "";
}

}  // namespace

int Registry::addLawThunk(void* host, const kneesim_contact_law* law) {
  auto* self = static_cast<Registry*>(host);
  const std::string why = checkLawTable(law);
  if (!why.empty()) {
    self->reject_ = why;
    return 1;
  }
  if (self->laws_.count(law->name)) {
    self->reject_ =
        std::string("contact law '") + law->name + "' is already registered by " + self->law_origins_[law->name];
    return 2;
  }
  self->laws_[law->name] = law;
  self->law_origins_[law->name] = self->loading_.empty() ? "built-in" : self->loading_;
  self->added_.emplace_back(Kind::Law, law->name);
  return 0;
}

int Registry::addProviderThunk(void* host, const kneesim_distance_provider* p) {
  auto* self = static_cast<Registry*>(host);
  if (!p || !p->name || !p->create || !p->compute || !p->destroy) {
    self->reject_ = "invalid distance-provider table";
    return 1;
  }
  if (self->providers_.count(p->name)) {
    self->reject_ = std::string("distance provider '") + p->name + "' is already registered by " +
                    self->provider_origins_[p->name];
    return 2;
  }
  self->providers_[p->name] = p;
  self->provider_origins_[p->name] = self->loading_.empty() ? "built-in" : self->loading_;
  self->added_.emplace_back(Kind::Provider, p->name);
  return 0;
}

int Registry::addEffectThunk(void* host, const kneesim_effect* effect) {
  auto* self = static_cast<Registry*>(host);
  const std::string why = checkEffectTable(effect);
  if (!why.empty()) {
    self->reject_ = why;
    return 1;
  }
  if (self->effects_.count(effect->name)) {
    self->reject_ =
        std::string("effect '") + effect->name + "' is already registered by " + self->effect_origins_[effect->name];
    return 2;
  }
  self->effects_[effect->name] = effect;
  self->effect_origins_[effect->name] = self->loading_.empty() ? "built-in" : self->loading_;
  self->added_.emplace_back(Kind::Effect, effect->name);
  return 0;
}

void Registry::adoptContactLaw(const kneesim_contact_law* law, const std::string& origin) {
  loading_ = origin;
  const int rc = addLawThunk(this, law);
  loading_.clear();
  KNEESIM_CHECK(rc == 0, reject_);
}

void Registry::adoptDistanceProvider(const kneesim_distance_provider* provider, const std::string& origin) {
  loading_ = origin;
  const int rc = addProviderThunk(this, provider);
  loading_.clear();
  KNEESIM_CHECK(rc == 0, reject_);
}

void Registry::adoptEffect(const kneesim_effect* effect, const std::string& origin) {
  loading_ = origin;
  const int rc = addEffectThunk(this, effect);
  loading_.clear();
  KNEESIM_CHECK(rc == 0, reject_);
}

const kneesim_effect* Registry::findEffect(const std::string& name) const {
  auto it = effects_.find(name);
  return it == effects_.end() ? nullptr : it->second;
}

const kneesim_contact_law* Registry::findContactLaw(const std::string& name) const {
  auto it = laws_.find(name);
  return it == laws_.end() ? nullptr : it->second;
}

const kneesim_distance_provider* Registry::findDistanceProvider(const std::string& name) const {
  auto it = providers_.find(name);
  return it == providers_.end() ? nullptr : it->second;
}

namespace {
std::string joinNames(const std::vector<std::string>& v) {
  return v.empty() ? "none; is the plugin listed in the setup file?" : join(v, ", ");
}
}  // namespace

const kneesim_contact_law& Registry::getContactLaw(const std::string& name, const SourceLocation& context) const {
  if (auto* l = findContactLaw(name)) return *l;
  throw InputError(context, "no contact law named '" + name + "' (loaded: " + joinNames(getContactLawNames()) + ")");
}

const kneesim_distance_provider& Registry::getDistanceProvider(const std::string& name,
                                                               const SourceLocation& context) const {
  if (auto* p = findDistanceProvider(name)) return *p;
  throw InputError(context,
                   "no distance provider named '" + name + "' (loaded: " + joinNames(getDistanceProviderNames()) + ")");
}

const kneesim_effect& Registry::getEffect(const std::string& name, const SourceLocation& context) const {
  if (auto* e = findEffect(name)) return *e;
  throw InputError(context, "no effect named '" + name + "' (loaded: " + joinNames(getEffectNames()) + ")");
}

std::vector<std::string> Registry::getEffectNames() const {
  std::vector<std::string> v;
  for (const auto& [n, e] : effects_) v.push_back(n);
  return v;
}

std::vector<std::string> Registry::getContactLawNames() const {
  std::vector<std::string> v;
  for (const auto& [n, l] : laws_) v.push_back(n);
  return v;
}

std::vector<std::string> Registry::getDistanceProviderNames() const {
  std::vector<std::string> v;
  for (const auto& [n, l] : providers_) v.push_back(n);
  return v;
}

std::string Registry::findOrigin(const std::string& name) const {
  if (auto it = law_origins_.find(name); it != law_origins_.end()) return it->second;
  if (auto it = provider_origins_.find(name); it != provider_origins_.end()) return it->second;
  if (auto it = effect_origins_.find(name); it != effect_origins_.end()) return it->second;
  return "";
}

}  // namespace kneesim::plugin
