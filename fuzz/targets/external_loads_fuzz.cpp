// Fuzz target: ExternalLoads files (dynamics::readExternalLoads).
#include "harness.hpp"
#include "dynamics/external_loads.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return kneesim::fuzz::runReader(data, size, ".xml", [](const std::string& path) { kneesim::dynamics::readExternalLoads(path); });
}
