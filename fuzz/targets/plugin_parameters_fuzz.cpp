// Fuzz target: the parameters a setup gives a contact-law plugin -- the workflow's <ContactLaw>
// (law name, parameter values, bounds, assumed values, free parameters) read by
// tool::readWorkflowSetup and resolved against the law's own table by the fit
// (identify::detail::resolveParameters), with the hertz and elastic_foundation plugins of this
// build loaded. The setup's own <plugins> list is not loaded (it names libraries to dlopen).
#include "harness.hpp"
#include "identify/contact_law.hpp"
#include "identify/fit_detail.hpp"
#include "plugin/registry.hpp"
#include "tool/knee_contact_workflow.hpp"

namespace {

const kneesim::plugin::Registry& registry() {
  static const auto* r = [] {
    auto* reg = new kneesim::plugin::Registry();
    reg->addSearchDirectory(KNEESIM_PLUGIN_BUILD_DIR);
    reg->loadPlugin("hertz");
    reg->loadPlugin("elastic_foundation");
    return reg;
  }();
  return *r;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const kneesim::plugin::Registry& reg = registry();
  return kneesim::fuzz::runReader(data, size, ".xml", [&](const std::string& path) {
    const kneesim::tool::WorkflowSetup s = kneesim::tool::readWorkflowSetup(path);
    const auto law = kneesim::identify::ContactLaw::fromRegistry(reg, s.law, s.fit.where);
    kneesim::identify::detail::resolveParameters(law, s.fit);
  });
}
