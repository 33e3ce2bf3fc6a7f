// Fuzz target: the knee contact workflow's setup, the paper workflow (tool::readWorkflowSetup).
#include "harness.hpp"
#include "tool/knee_contact_workflow.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return kneesim::fuzz::runReader(data, size, ".xml", [](const std::string& path) { kneesim::tool::readWorkflowSetup(path); });
}
