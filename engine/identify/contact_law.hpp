#pragma once
// C++ side of a contact law (kneesim_contact_law, see plugin/kneesim_plugin.h).

#include <map>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/error.hpp"
#include "plugin/kneesim_plugin.h"

namespace kneesim::plugin {
class Registry;
}

namespace kneesim::identify {

/// Per-frame channels of one trial by name, in SI units (see kneesim_inputs for the names).
using ChannelMap = std::map<std::string, std::vector<double>>;

/// One parameter of a contact law, copied from the plugin's table.
struct LawParameter {
  std::string name;         ///< Identifier, e.g. "E".
  std::string unit;         ///< Unit, e.g. "Pa".
  std::string description;  ///< One line for reports.
  double lower = 0;         ///< Lower bound used by the identification.
  double upper = 0;         ///< Upper bound used by the identification.
  double default_value = 0; ///< Starting value, and the value a fixed parameter is held at.
  double typical_scale = 1; ///< Magnitude used to scale the parameter in the optimiser (> 0).
  bool fixed_by_default = false;  ///< Held at its value unless the setup frees it.
};

class ContactLaw;

/// The channels of one trial arranged as the C ABI wants them (pointers into a ChannelMap plus the
/// trial's time). Built once per trial; the ChannelMap and time vector must outlive it.
class LawInputs {
 public:
  /// Wraps @p channels (every channel, so a law may read optional ones) and @p time as channel
  /// "time". Throws InputError at @p where if a channel's length differs from time's or if
  /// @p law needs a channel that is missing, naming the law, the channel and @p trial.
  LawInputs(const ContactLaw& law, const ChannelMap& channels, const std::vector<double>& time,
            const std::string& trial, const SourceLocation& where = {});

  LawInputs(const LawInputs& other);
  LawInputs& operator=(const LawInputs& other);
  LawInputs(LawInputs&&) = default;  // vector buffers move with their pointers intact
  LawInputs& operator=(LawInputs&&) = default;

  /// The C view handed to calc_force.
  const kneesim_inputs& get() const { return c_; }
  /// Number of frames.
  int getNumFrames() const { return c_.n_frames; }
  /// The trial's name, for messages.
  const std::string& getTrialName() const { return trial_; }
  /// Where the trial was defined, for messages.
  const SourceLocation& getSource() const { return where_; }

 private:
  std::vector<const char*> names_;
  std::vector<const double*> values_;
  kneesim_inputs c_{};
  std::string trial_;
  SourceLocation where_;
};

/// A law whose force is computed in C++ instead of by a table's calc_force: a baseline law extended
/// by gap-diagnosis effects (gap/extended_law.hpp) is one. It owns its kneesim_contact_law table
/// (names, parameters, inputs), which ContactLaw reads as for a plugin's law.
class LawImplementation {
 public:
  virtual ~LawImplementation() = default;
  /// The table describing the law; its calc_force is not called.
  virtual const kneesim_contact_law& getTable() const = 0;
  /// The contract of kneesim_contact_law::calc_force: force[i] for every frame and, when @p dforce
  /// is not null, dforce[p * n_frames + i]; returns 0, or non-zero with one line in @p err.
  virtual int calcForce(const double* params, const kneesim_inputs& in, double* force, double* dforce, char* err,
                        int err_len) const = 0;
};

/// A contact law from a plugin: its parameters, inputs and derived quantities, and its force with
/// the exact Jacobian. The table must outlive the object (it lives in the plugin library, so keep
/// the plugin::Registry alive).
class ContactLaw {
 public:
  /// Wraps @p table, registered by @p origin (the library path, or "built-in").
  explicit ContactLaw(const kneesim_contact_law& table, std::string origin = "built-in");
  /// Wraps a law computed in C++; the ContactLaw (and its copies) keep @p implementation alive.
  explicit ContactLaw(std::shared_ptr<const LawImplementation> implementation, std::string origin = "built-in");
  /// The law registered as @p name in @p registry (which must outlive it); throws InputError at
  /// @p where listing the loaded laws if there is none.
  static ContactLaw fromRegistry(const plugin::Registry& registry, const std::string& name,
                                 const SourceLocation& where = {});

  const std::string& getName() const { return name_; }
  const std::string& getDescription() const { return description_; }
  const std::string& getOrigin() const { return origin_; }
  const kneesim_contact_law& getTable() const { return *table_; }
  /// The C++ implementation, or nullptr for a plugin's law (whose table's calc_force answers).
  const LawImplementation* getImplementation() const { return impl_.get(); }

  int getNumParameters() const { return static_cast<int>(params_.size()); }
  const std::vector<LawParameter>& getParameters() const { return params_; }
  const LawParameter& getParameter(int i) const { return params_.at(i); }
  /// Index of the parameter @p name, or -1 (cheap).
  int findParameterIndex(const std::string& name) const;
  /// Index of the parameter @p name; throws InputError at @p where listing the law's parameters.
  int getParameterIndex(const std::string& name, const SourceLocation& where = {}) const;
  /// The default values of all parameters, in table order.
  Eigen::VectorXd getDefaultValues() const;

  /// Channel names the law needs.
  const std::vector<std::string>& getInputNames() const { return inputs_; }
  /// Throws InputError at @p where if @p channels (plus "time") lacks a channel the law needs:
  /// "contact law 'hertz' needs input channel 'S', which trial 'x' does not have (channels: ...)".
  void checkInputs(const ChannelMap& channels, const std::string& trial, const SourceLocation& where = {}) const;

  int getNumDerived() const { return static_cast<int>(derived_names_.size()); }
  const std::vector<std::string>& getDerivedNames() const { return derived_names_; }
  const std::vector<std::string>& getDerivedUnits() const { return derived_units_; }
  /// The derived quantities (e.g. K = E/(1-nu^2)) at @p params (all parameters, table order).
  Eigen::VectorXd calcDerived(const Eigen::VectorXd& params) const;

  /// Force of every frame of @p in at @p params (all parameters, table order) into @p force
  /// (n_frames values) and, if @p dforce is not null, dF_i/dp_j into dforce[j * n_frames + i] (the
  /// layout of a column-major n_frames x n_params matrix). Does not allocate. A failure of the
  /// plugin becomes an InputError naming the law and the trial.
  void calcForce(const double* params, const LawInputs& in, double* force, double* dforce) const;
  /// Convenience overload resizing @p force and, if given, @p dforce (n_frames x n_params).
  void calcForce(const Eigen::VectorXd& params, const LawInputs& in, Eigen::VectorXd& force,
                 Eigen::MatrixXd* dforce = nullptr) const;

 private:
  const kneesim_contact_law* table_;
  std::shared_ptr<const LawImplementation> impl_;  // null for plugin laws
  std::string origin_, name_, description_;
  std::vector<LawParameter> params_;
  std::vector<std::string> inputs_, derived_names_, derived_units_;
};

/// Checks a law's analytic Jacobian against central finite differences at @p params on @p in.
/// Returns, per parameter, max_i |analytic - numeric| / max(max_i |analytic|, tiny): about 1e-8 for
/// a correct law, O(1) for a wrong one. Meant for plugin authors and tests.
Eigen::VectorXd calcDerivativeError(const ContactLaw& law, const Eigen::VectorXd& params, const LawInputs& in);

}  // namespace kneesim::identify
