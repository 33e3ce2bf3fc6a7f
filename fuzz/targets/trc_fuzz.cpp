// Fuzz target: TRC marker files (io::readTrc).
#include "harness.hpp"
#include "io/trc.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return kneesim::fuzz::runReader(data, size, ".trc", [](const std::string& path) { kneesim::io::readTrc(path); });
}
