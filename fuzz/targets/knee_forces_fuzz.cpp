// Fuzz target: the eKnee load-cell CSV of the Grand Challenge (io::readKneeForces).
#include "harness.hpp"
#include "io/knee_forces.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return kneesim::fuzz::runReader(data, size, ".csv", [](const std::string& path) { kneesim::io::readKneeForces(path); });
}
