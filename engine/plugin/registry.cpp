#include "plugin/registry.hpp"

#include <dlfcn.h>

#include <cstdlib>
#include <filesystem>

#include "core/error.hpp"
#include "core/strings.hpp"

namespace kneesim::plugin {

namespace fs = std::filesystem;

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
  libraries_.clear();
}

void Registry::addSearchDirectory(const std::string& dir) { search_dirs_.insert(search_dirs_.begin(), dir); }

void Registry::loadPlugin(const std::string& name_or_path, const SourceLocation& context) {
  std::string path;
  if (name_or_path.find('/') != std::string::npos || endsWith(name_or_path, ".so")) {
    if (fs::exists(name_or_path)) path = fs::absolute(name_or_path).string();
  } else {
    for (const auto& d : search_dirs_) {
      for (const std::string& f : {"libkneesim_" + name_or_path + ".so", "lib" + name_or_path + ".so"}) {
        const fs::path p = fs::path(d) / f;
        if (fs::exists(p)) {
          path = fs::absolute(p).string();
          break;
        }
      }
      if (!path.empty()) break;
    }
  }
  if (path.empty()) {
    std::string dirs;
    for (const auto& d : search_dirs_) dirs += (dirs.empty() ? "" : ", ") + d;
    throw InputError(context, "no plugin '" + name_or_path + "' found (searched: " +
                                  (dirs.empty() ? std::string("nothing; set KNEESIM_PLUGIN_PATH") : dirs) + ")");
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
  auto* fn = reinterpret_cast<kneesim_plugin_register_fn>(dlsym(lib->handle, "kneesim_plugin_register"));
  if (!fn) throw InputError(context, "'" + path + "' is not a kneesim plugin: it does not export kneesim_plugin_register");
  kneesim_registrar r{KNEESIM_PLUGIN_ABI_VERSION, this, &Registry::addLawThunk, &Registry::addProviderThunk};
  loading_ = path;
  reject_.clear();
  const int rc = fn(&r);
  loading_.clear();
  if (rc != 0)
    throw InputError(context, "plugin '" + path + "' failed to register" + (reject_.empty() ? "" : ": " + reject_));
  libraries_.push_back(std::move(lib));
}

int Registry::addLawThunk(void* host, const kneesim_contact_law* law) {
  auto* self = static_cast<Registry*>(host);
  if (!law || !law->name || !law->calc_force || law->n_params < 0 || (law->n_params > 0 && !law->params)) {
    self->reject_ = "invalid contact-law table";
    return 1;
  }
  if (self->laws_.count(law->name)) {
    self->reject_ = std::string("contact law '") + law->name + "' is already registered by " + self->origins_[law->name];
    return 2;
  }
  self->laws_[law->name] = law;
  self->origins_[law->name] = self->loading_.empty() ? "built-in" : self->loading_;
  return 0;
}

int Registry::addProviderThunk(void* host, const kneesim_distance_provider* p) {
  auto* self = static_cast<Registry*>(host);
  if (!p || !p->name || !p->create || !p->compute || !p->destroy) {
    self->reject_ = "invalid distance-provider table";
    return 1;
  }
  if (self->providers_.count(p->name)) {
    self->reject_ = std::string("distance provider '") + p->name + "' is already registered";
    return 2;
  }
  self->providers_[p->name] = p;
  self->origins_[p->name] = self->loading_.empty() ? "built-in" : self->loading_;
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
  std::string s;
  for (const auto& n : v) s += (s.empty() ? "" : ", ") + n;
  return s.empty() ? "none; is the plugin listed in the setup file?" : s;
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
  auto it = origins_.find(name);
  return it == origins_.end() ? "" : it->second;
}

}  // namespace kneesim::plugin
