// Fuzz target: C3D files (io::readC3d: header, parameter section, points, analog, force platforms).
#include "harness.hpp"
#include "io/c3d.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return kneesim::fuzz::runReader(data, size, ".c3d", [](const std::string& path) { kneesim::io::readC3d(path); });
}
