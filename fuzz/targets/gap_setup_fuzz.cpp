// Fuzz target: the gap diagnosis's setup (gap::readGapSetup).
#include "harness.hpp"
#include "gap/tool.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return kneesim::fuzz::runReader(data, size, ".xml", [](const std::string& path) { kneesim::gap::readGapSetup(path); });
}
