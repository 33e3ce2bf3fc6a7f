#include "gap/effect.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>

#include <Eigen/Core>

#include "plugin/registry.hpp"

namespace kneesim::gap {

namespace {

std::string str(const char* s) { return s ? s : ""; }

}  // namespace

Effect::Effect(const kneesim_effect& table, std::string origin)
    : table_(&table), origin_(std::move(origin)), name_(str(table.name)), description_(str(table.description)),
      physics_(str(table.physics)), separated_by_(str(table.separated_by)) {
  for (int i = 0; i < table.n_params; ++i) {
    const kneesim_param& p = table.params[i];
    params_.push_back({p.name, str(p.unit), str(p.description), p.lower, p.upper, p.default_value,
                       p.typical_scale > 0 ? p.typical_scale : 1.0, p.fixed_by_default != 0});
  }
  for (int i = 0; i < table.n_inputs; ++i) inputs_.emplace_back(table.inputs[i]);
  for (int i = 0; i < table.n_rewrites; ++i) rewrites_.emplace_back(table.rewrites[i]);
}

Effect Effect::fromRegistry(const plugin::Registry& registry, const std::string& name, const SourceLocation& where) {
  return Effect(registry.getEffect(name, where), registry.findOrigin(name));
}

std::vector<std::string> Effect::findMissingInputs(const identify::ChannelMap& channels) const {
  std::vector<std::string> missing;
  for (const auto& in : inputs_)
    if (in != "time" && !channels.count(in)) missing.push_back(in);
  return missing;
}

std::string qualifiedName(const Effect& effect, const identify::LawParameter& param) {
  return effect.getName() + "." + param.name;
}

namespace {

// A baseline law followed by effects; owns the kneesim_contact_law table that describes it.
class ExtendedLaw final : public identify::LawImplementation {
 public:
  ExtendedLaw(const identify::ContactLaw& base, std::vector<Effect> effects)
      : base_(base), effects_(std::move(effects)) {
    const kneesim_contact_law& bt = base.getTable();
    name_ = base.getName();
    description_ = base.getDescription();
    for (const auto& e : effects_) {
      name_ += "+" + e.getName();
      description_ += "; " + e.getName() + ": " + e.getDescription();
    }
    // Parameters: names are stored in param_names_ (stable: reserved before taking c_str()).
    const int nb = base.getNumParameters();
    int np = nb;
    for (const auto& e : effects_) np += e.getNumParameters();
    param_names_.reserve(np);
    for (int j = 0; j < nb; ++j) {
      params_.push_back(bt.params[j]);
      param_names_.push_back(base.getParameter(j).name);
    }
    for (const auto& e : effects_) {
      offsets_.push_back(static_cast<int>(params_.size()));
      for (int j = 0; j < e.getNumParameters(); ++j) {
        params_.push_back(e.getTable().params[j]);
        param_names_.push_back(qualifiedName(e, e.getParameters()[j]));
      }
    }
    for (size_t j = 0; j < params_.size(); ++j) params_[j].name = param_names_[j].c_str();
    // Inputs: the union, baseline first.
    for (const auto& n : base.getInputNames()) addInput(n);
    for (const auto& e : effects_)
      for (const auto& n : e.getInputNames()) addInput(n);
    for (const auto& n : inputs_) input_ptrs_.push_back(n.c_str());
    table_ = bt;  // derived quantities: the baseline's (they read the leading baseline parameters)
    table_.struct_size = sizeof(kneesim_contact_law);
    table_.name = name_.c_str();
    table_.description = description_.c_str();
    table_.n_params = static_cast<int>(params_.size());
    table_.params = params_.data();
    table_.n_inputs = static_cast<int>(input_ptrs_.size());
    table_.inputs = input_ptrs_.data();
    table_.calc_force = nullptr;  // calcForce below answers
    for (size_t k = 0; k < effects_.size(); ++k)
      for (int j = 0; j < effects_[k].getNumParameters(); ++j)
        if (effects_[k].getTable().rewrite_inputs) rewrite_params_.push_back(offsets_[k] + j);
  }

  const kneesim_contact_law& getTable() const override { return table_; }

  int calcForce(const double* params, const kneesim_inputs& in, double* force, double* dforce, char* err,
                int err_len) const override {
    const int n = in.n_frames;
    const int np = table_.n_params;
    if (rewrite_params_.empty() || !dforce) return run(params, in, force, dforce, err, err_len);
    if (int rc = run(params, in, force, dforce, err, err_len)) return rc;
    // Columns of rewriting effects' parameters: central differences through the whole pipeline.
    std::vector<double> p(params, params + np), fp(n), fm(n);
    for (int j : rewrite_params_) {
      const double h = 6e-6 * std::max(std::abs(params[j]), params_[j].typical_scale);
      p[j] = params[j] + h;
      if (int rc = run(p.data(), in, fp.data(), nullptr, err, err_len)) return rc;
      p[j] = params[j] - h;
      if (int rc = run(p.data(), in, fm.data(), nullptr, err, err_len)) return rc;
      p[j] = params[j];
      for (int i = 0; i < n; ++i) dforce[static_cast<size_t>(j) * n + i] = (fp[i] - fm[i]) / (2 * h);
    }
    return 0;
  }

 private:
  void addInput(const std::string& n) {
    if (std::find(inputs_.begin(), inputs_.end(), n) == inputs_.end()) inputs_.push_back(n);
  }

  // The pipeline: rewrites, baseline law, force maps. With dforce, the exact Jacobian for the
  // baseline and force-map parameters (columns of rewriting parameters are left at zero).
  int run(const double* params, const kneesim_inputs& in, double* force, double* dforce, char* err,
          int err_len) const {
    const int n = in.n_frames;
    const int np = table_.n_params, nb = base_.getNumParameters();
    // Stage 1: a private view of the channels whose rewritten ones point into owned buffers.
    std::vector<const char*> names(in.names, in.names + in.n_channels);
    std::vector<const double*> values(in.values, in.values + in.n_channels);
    std::vector<std::vector<double>> buffers;
    buffers.reserve(effects_.size() * 2);
    kneesim_inputs view{n, in.n_channels, names.data(), values.data()};
    for (size_t k = 0; k < effects_.size(); ++k) {
      const kneesim_effect& t = effects_[k].getTable();
      if (!t.rewrite_inputs) continue;
      std::vector<double> out(static_cast<size_t>(t.n_rewrites) * n);
      if (int rc = t.rewrite_inputs(params + offsets_[k], &view, out.data(), err, err_len))
        return fail(k, rc, err, err_len);
      for (int c = 0; c < t.n_rewrites; ++c) {
        buffers.emplace_back(out.begin() + static_cast<long>(c) * n, out.begin() + static_cast<long>(c + 1) * n);
        const double* data = buffers.back().data();
        bool found = false;
        for (int q = 0; q < view.n_channels; ++q)
          if (std::strcmp(names[q], t.rewrites[c]) == 0) {
            values[q] = data;
            found = true;
          }
        if (!found) {
          std::snprintf(err, err_len, "effect '%s' rewrites channel '%s', which the trial does not have",
                        t.name, t.rewrites[c]);
          return 1;
        }
      }
    }
    // Stage 2: the baseline law on the rewritten channels.
    std::vector<double> jb;
    if (dforce) jb.resize(static_cast<size_t>(n) * nb);
    const kneesim_contact_law& bt = base_.getTable();
    int rc;
    if (const identify::LawImplementation* impl = base_.getImplementation()) {  // an extended law extended again
      rc = impl->calcForce(params, view, force, dforce ? jb.data() : nullptr, err, err_len);
    } else {
      rc = bt.calc_force(params, &view, force, dforce ? jb.data() : nullptr, err, err_len);
    }
    if (rc) return rc;
    if (!dforce) {
      std::vector<double> next(n);
      for (size_t k = 0; k < effects_.size(); ++k) {
        const kneesim_effect& t = effects_[k].getTable();
        if (!t.map_force) continue;
        if (int r = t.map_force(params + offsets_[k], &view, force, 0, nullptr, next.data(), nullptr, nullptr, err,
                                err_len))
          return fail(k, r, err, err_len);
        std::copy(next.begin(), next.end(), force);
      }
      return 0;
    }
    // Jacobian so far: baseline columns, zeros elsewhere.
    std::fill(dforce, dforce + static_cast<size_t>(n) * np, 0.0);
    std::copy(jb.begin(), jb.end(), dforce);
    std::vector<double> next(n), tout(static_cast<size_t>(n) * np), own;
    for (size_t k = 0; k < effects_.size(); ++k) {
      const kneesim_effect& t = effects_[k].getTable();
      if (!t.map_force) continue;
      own.assign(static_cast<size_t>(n) * std::max(1, t.n_params), 0.0);
      if (int r = t.map_force(params + offsets_[k], &view, force, np, dforce, next.data(), tout.data(),
                              t.n_params > 0 ? own.data() : nullptr, err, err_len))
        return fail(k, r, err, err_len);
      std::copy(next.begin(), next.end(), force);
      std::copy(tout.begin(), tout.end(), dforce);
      for (int j = 0; j < t.n_params; ++j)
        for (int i = 0; i < n; ++i)
          dforce[static_cast<size_t>(offsets_[k] + j) * n + i] += own[static_cast<size_t>(j) * n + i];
    }
    return 0;
  }

  int fail(size_t k, int rc, char* err, int err_len) const {
    std::string msg = "effect '" + effects_[k].getName() + "': " + std::string(err);
    std::snprintf(err, err_len, "%s", msg.c_str());
    return rc;
  }

  identify::ContactLaw base_;
  std::vector<Effect> effects_;
  std::string name_, description_;
  std::vector<std::string> param_names_, inputs_;
  std::vector<kneesim_param> params_;
  std::vector<const char*> input_ptrs_;
  std::vector<int> offsets_, rewrite_params_;
  kneesim_contact_law table_{};
};

}  // namespace

identify::ContactLaw makeExtendedLaw(const identify::ContactLaw& base, const std::vector<Effect>& effects) {
  return identify::ContactLaw(std::make_shared<const ExtendedLaw>(base, effects), base.getOrigin());
}

}  // namespace kneesim::gap
