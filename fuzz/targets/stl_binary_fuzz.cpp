// Fuzz target: STL meshes from binary seeds (io::readStl; the reader tells ASCII from binary by the
// content, so this target and stl_ascii fuzz the same reader from different seeds). An odd-sized
// input is read with require_closed (the manifold check) as well.
#include "harness.hpp"
#include "io/stl.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  kneesim::io::StlOptions options;
  options.require_closed = size % 2 == 1;
  return kneesim::fuzz::runReader(data, size, ".stl",
                                  [&](const std::string& path) { kneesim::io::readStl(path, options); });
}
