// Fuzz target: URDF models (model::readUrdf, urdfdom behind kneesim's own checks).
#include "harness.hpp"
#include "model/urdf.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return kneesim::fuzz::runReader(data, size, ".urdf", [](const std::string& path) { kneesim::model::readUrdf(path); });
}
