// Fuzz target: a batch trial's setup (tool::readBatchTrialSetup).
#include "harness.hpp"
#include "tool/batch_trial.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return kneesim::fuzz::runReader(data, size, ".xml", [](const std::string& path) { kneesim::tool::readBatchTrialSetup(path); });
}
