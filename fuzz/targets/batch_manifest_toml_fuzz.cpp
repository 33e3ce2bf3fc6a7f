// Fuzz target: batch manifests in TOML (tool::readManifest, cpptoml behind it).
#include "harness.hpp"
#include "tool/batch_manifest.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return kneesim::fuzz::runReader(data, size, ".toml", [](const std::string& path) { kneesim::tool::readManifest(path); });
}
