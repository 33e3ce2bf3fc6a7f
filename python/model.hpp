#pragma once
// The model as Python sees it: an immutable model::Model and, built when first needed, the
// Simbody system that computes its kinematics (shared by every call on the same model).

#include <memory>
#include <mutex>
#include <string>

#include "model/model.hpp"
#include "sim/system.hpp"

namespace kneesim::python {

/// kneesim.Model: a loaded model and its lazily built system.
class ModelHandle {
 public:
  explicit ModelHandle(model::ModelPtr model) : model_(std::move(model)) {}
  const model::Model& get() const { return *model_; }
  const model::ModelPtr& getPtr() const { return model_; }
  /// The Simbody system of the model, built on first use (thread-safe).
  const sim::System& getSystem() const;

 private:
  model::ModelPtr model_;
  mutable std::once_flag built_;
  mutable std::unique_ptr<sim::System> system_;
};

/// Reads a .osim or .urdf file (by its extension, as the tools do).
model::ModelPtr readModelFile(const std::string& path);

}  // namespace kneesim::python
