// Fuzz target: the contact-area tool's setup (tool::readContactAreaSetup).
#include "harness.hpp"
#include "tool/contact_area_tool.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return kneesim::fuzz::runReader(data, size, ".xml", [](const std::string& path) { kneesim::tool::readContactAreaSetup(path); });
}
