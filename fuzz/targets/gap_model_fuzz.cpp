// Fuzz target: gap_model.json, read by kneesim gap --predict (gap::readGapModel).
#include "harness.hpp"
#include "gap/prediction.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return kneesim::fuzz::runReader(data, size, ".json", [](const std::string& path) { kneesim::gap::readGapModel(path); });
}
