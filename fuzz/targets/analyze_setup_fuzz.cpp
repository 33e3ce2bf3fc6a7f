// Fuzz target: the analyze tool's setup: static optimization, joint reaction (muscle::readAnalyzeSetup).
#include "harness.hpp"
#include "muscle/analyze_tool.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return kneesim::fuzz::runReader(data, size, ".xml", [](const std::string& path) { kneesim::muscle::readAnalyzeSetup(path); });
}
