// Fuzz target: OpenSim models, .osim (model::readOsim: every format kneesim reads).
#include "harness.hpp"
#include "model/osim_reader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return kneesim::fuzz::runReader(data, size, ".osim", [](const std::string& path) { kneesim::model::readOsim(path); });
}
