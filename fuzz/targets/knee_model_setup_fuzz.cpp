// Fuzz target: the knee model tool's setup (tool::readKneeModelSetup).
#include "harness.hpp"
#include "tool/knee_model.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return kneesim::fuzz::runReader(data, size, ".xml", [](const std::string& path) { kneesim::tool::readKneeModelSetup(path); });
}
