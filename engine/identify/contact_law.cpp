#include "identify/contact_law.hpp"

#include <algorithm>
#include <cmath>

#include "core/strings.hpp"
#include "plugin/registry.hpp"

namespace kneesim::identify {

namespace {

std::string joinNames(const std::vector<std::string>& v) { return v.empty() ? "none" : join(v, ", "); }

}  // namespace

LawInputs::LawInputs(const ContactLaw& law, const ChannelMap& channels, const std::vector<double>& time,
                     const std::string& trial, const SourceLocation& where)
    : trial_(trial), where_(where) {
  law.checkInputs(channels, trial, where);
  const size_t n = time.size();
  names_.push_back("time");
  values_.push_back(time.data());
  for (const auto& [name, v] : channels) {
    if (name == "time") continue;
    if (v.size() != n)
      throw InputError(where, "trial '" + trial + "': channel '" + name + "': expected " + std::to_string(n) +
                                  " values (one per time frame), got " + std::to_string(v.size()));
    names_.push_back(name.c_str());
    values_.push_back(v.data());
  }
  c_.n_frames = static_cast<int>(n);
  c_.n_channels = static_cast<int>(names_.size());
  c_.names = names_.data();
  c_.values = values_.data();
}

LawInputs::LawInputs(const LawInputs& other)
    : names_(other.names_), values_(other.values_), c_(other.c_), trial_(other.trial_), where_(other.where_) {
  c_.names = names_.data();
  c_.values = values_.data();
}

LawInputs& LawInputs::operator=(const LawInputs& other) {
  if (this != &other) {
    names_ = other.names_;
    values_ = other.values_;
    c_ = other.c_;
    trial_ = other.trial_;
    where_ = other.where_;
    c_.names = names_.data();
    c_.values = values_.data();
  }
  return *this;
}

ContactLaw::ContactLaw(const kneesim_contact_law& table, std::string origin)
    : table_(&table), origin_(std::move(origin)), name_(table.name ? table.name : ""),
      description_(table.description ? table.description : "") {
  for (int i = 0; i < table.n_params; ++i) {
    const kneesim_param& p = table.params[i];
    params_.push_back({p.name, p.unit ? p.unit : "", p.description ? p.description : "", p.lower, p.upper,
                       p.default_value, p.typical_scale > 0 ? p.typical_scale : 1.0, p.fixed_by_default != 0});
  }
  for (int i = 0; i < table.n_inputs; ++i) inputs_.emplace_back(table.inputs[i]);
  for (int i = 0; i < table.n_derived; ++i) {
    derived_names_.emplace_back(table.derived_names[i]);
    derived_units_.emplace_back(table.derived_units[i]);
  }
}

ContactLaw::ContactLaw(std::shared_ptr<const LawImplementation> implementation, std::string origin)
    : ContactLaw(implementation->getTable(), std::move(origin)) {
  impl_ = std::move(implementation);
}

ContactLaw ContactLaw::fromRegistry(const plugin::Registry& registry, const std::string& name,
                                    const SourceLocation& where) {
  return ContactLaw(registry.getContactLaw(name, where), registry.findOrigin(name));
}

int ContactLaw::findParameterIndex(const std::string& name) const {
  for (size_t i = 0; i < params_.size(); ++i)
    if (params_[i].name == name) return static_cast<int>(i);
  return -1;
}

int ContactLaw::getParameterIndex(const std::string& name, const SourceLocation& where) const {
  const int i = findParameterIndex(name);
  if (i >= 0) return i;
  std::vector<std::string> names;
  for (const auto& p : params_) names.push_back(p.name);
  throw InputError(where, "contact law '" + name_ + "' has no parameter '" + name + "' (parameters: " +
                              joinNames(names) + ")");
}

Eigen::VectorXd ContactLaw::getDefaultValues() const {
  Eigen::VectorXd v(params_.size());
  for (size_t i = 0; i < params_.size(); ++i) v[i] = params_[i].default_value;
  return v;
}

void ContactLaw::checkInputs(const ChannelMap& channels, const std::string& trial, const SourceLocation& where) const {
  for (const auto& in : inputs_) {
    if (in == "time" || channels.count(in)) continue;
    std::vector<std::string> have{"time"};
    for (const auto& [n, v] : channels) have.push_back(n);
    throw InputError(where, "contact law '" + name_ + "' needs input channel '" + in + "', which trial '" + trial +
                                "' does not have (channels: " + joinNames(have) + ")");
  }
}

Eigen::VectorXd ContactLaw::calcDerived(const Eigen::VectorXd& params) const {
  KNEESIM_CHECK(params.size() == getNumParameters(), "parameter vector of the wrong size");
  Eigen::VectorXd out = Eigen::VectorXd::Zero(getNumDerived());
  if (getNumDerived() > 0) table_->calc_derived(params.data(), out.data());
  return out;
}

void ContactLaw::calcForce(const double* params, const LawInputs& in, double* force, double* dforce) const {
  char err[512];
  err[0] = '\0';
  const int rc = impl_ ? impl_->calcForce(params, in.get(), force, dforce, err, static_cast<int>(sizeof err))
                       : table_->calc_force(params, &in.get(), force, dforce, err, static_cast<int>(sizeof err));
  if (rc != 0) {
    err[sizeof err - 1] = '\0';
    throw InputError(in.getSource(), "contact law '" + name_ + "' failed on trial '" + in.getTrialName() +
                                         "': " + (err[0] ? err : "no message (code " + std::to_string(rc) + ")"));
  }
}

void ContactLaw::calcForce(const Eigen::VectorXd& params, const LawInputs& in, Eigen::VectorXd& force,
                           Eigen::MatrixXd* dforce) const {
  KNEESIM_CHECK(params.size() == getNumParameters(), "parameter vector of the wrong size");
  force.resize(in.getNumFrames());
  if (dforce) dforce->resize(in.getNumFrames(), getNumParameters());
  calcForce(params.data(), in, force.data(), dforce ? dforce->data() : nullptr);
}

Eigen::VectorXd calcDerivativeError(const ContactLaw& law, const Eigen::VectorXd& params, const LawInputs& in) {
  const int np = law.getNumParameters();
  Eigen::VectorXd f;
  Eigen::MatrixXd jac;
  law.calcForce(params, in, f, &jac);
  Eigen::VectorXd err(np);
  Eigen::VectorXd fp, fm;
  for (int j = 0; j < np; ++j) {
    // Relative step on the parameter's own scale, shrunk to stay inside the bounds.
    const LawParameter& p = law.getParameter(j);
    double h = 1e-6 * std::max(std::abs(params[j]), p.typical_scale);
    h = std::min({h, 0.5 * (p.upper - params[j]), 0.5 * (params[j] - p.lower)});
    if (!(h > 0)) h = 1e-6 * p.typical_scale;
    Eigen::VectorXd q = params;
    q[j] = params[j] + h;
    law.calcForce(q, in, fp);
    q[j] = params[j] - h;
    law.calcForce(q, in, fm);
    const Eigen::VectorXd numeric = (fp - fm) / (2 * h);
    const double ref = std::max(jac.col(j).cwiseAbs().maxCoeff(), 1e-300);
    err[j] = (jac.col(j) - numeric).cwiseAbs().maxCoeff() / ref;
  }
  return err;
}

}  // namespace kneesim::identify
