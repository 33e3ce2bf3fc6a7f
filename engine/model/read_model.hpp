#pragma once
// One entry point for model files: OpenSim .osim or URDF, chosen by the file's extension.

#include <string>

#include "model/model.hpp"

namespace kneesim::model {

/// Reads the model at @p path: readUrdf() for a ".urdf" file (any case), readOsim() otherwise.
/// Throws InputError naming the file when it does not exist or does not parse.
ModelPtr readModel(const std::string& path);

}  // namespace kneesim::model
