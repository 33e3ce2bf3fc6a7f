// Fuzz target: batch manifests in CSV (tool::readManifest).
#include "harness.hpp"
#include "tool/batch_manifest.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return kneesim::fuzz::runReader(data, size, ".csv", [](const std::string& path) { kneesim::tool::readManifest(path); });
}
