// Fuzz target: the marker placer's setup (ik::readMarkerPlacerSetup).
#include "harness.hpp"
#include "ik/marker_placer.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return kneesim::fuzz::runReader(data, size, ".xml", [](const std::string& path) { kneesim::ik::readMarkerPlacerSetup(path); });
}
