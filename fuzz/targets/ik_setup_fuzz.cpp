// Fuzz target: the IK tool's setup (ik::readIkSetup).
#include "harness.hpp"
#include "ik/tool.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return kneesim::fuzz::runReader(data, size, ".xml", [](const std::string& path) { kneesim::ik::readIkSetup(path); });
}
