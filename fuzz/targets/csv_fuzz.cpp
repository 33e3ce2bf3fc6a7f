// Fuzz target: CSV tables (io::readCsv).
#include "harness.hpp"
#include "io/csv.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return kneesim::fuzz::runReader(data, size, ".csv", [](const std::string& path) { kneesim::io::readCsv(path); });
}
