// Fuzz target: OpenSim storage files, .mot and .sto (io::readStorage).
#include "harness.hpp"
#include "io/storage.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return kneesim::fuzz::runReader(data, size, ".mot", [](const std::string& path) { kneesim::io::readStorage(path); });
}
