// Fuzz target: the inverse dynamics tool's setup (dynamics::readIdSetup).
#include "harness.hpp"
#include "dynamics/tool.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return kneesim::fuzz::runReader(data, size, ".xml", [](const std::string& path) { kneesim::dynamics::readIdSetup(path); });
}
