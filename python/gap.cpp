// Python bindings of the sim-to-real gap diagnosis: kneesim.run_gap runs a <GapTool> setup file as
// `kneesim gap` does (writing gap_report.json, gap_report.md and the plots) and returns the report
// as a dict, the same one gap_report.json holds.

#include <nlohmann/json.hpp>
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "gap/report.hpp"
#include "gap/tool.hpp"

namespace kneesim::python {

namespace {

py::object runGapSetup(const std::string& path, const py::object& results_directory, const py::object& workflow_results,
                       const py::object& areas, const py::object& targets, const py::object& plots) {
  std::vector<std::string> target_list;
  if (!targets.is_none()) {
    target_list = targets.cast<std::vector<std::string>>();
    for (const std::string& t : target_list)
      if (const std::string why = gap::findTargetProblem(t); !why.empty())
        throw InputError({"", 0, "run_gap/targets"}, why);
  }
  // Python objects are read before the GIL is released.
  const auto text_of = [](const py::object& o) { return o.is_none() ? std::string() : o.cast<std::string>(); };
  const std::string results = text_of(results_directory), workflow = text_of(workflow_results),
                    area_dir = text_of(areas);
  const int plot = plots.is_none() ? -1 : int(plots.cast<bool>());
  std::string text;
  {
    py::gil_scoped_release release;
    gap::GapSetup setup = gap::readGapSetup(path);
    if (!workflow.empty()) gap::setWorkflowResults(setup, workflow);
    if (!area_dir.empty()) gap::setContactAreaDirectory(setup, area_dir);
    if (!results.empty()) setup.results_directory = results;
    if (!target_list.empty()) setup.options.targets = target_list;
    if (plot >= 0) setup.report.plots = plot == 1;
    const gap::GapRunResult r = gap::runGap(setup);
    text = gap::toJson(r.report, setup.report.anchors).dump();
  }
  return py::module_::import("json").attr("loads")(text);
}

}  // namespace

void bindGap(py::module_& m) {
  m.def("run_gap", &runGapSetup, py::arg("setup_file"), py::arg("results_directory") = py::none(),
        py::arg("workflow_results") = py::none(), py::arg("areas") = py::none(), py::arg("targets") = py::none(),
        py::arg("plots") = py::none(),
        "Runs a GapTool setup file (writing its report into results_directory, default the setup's) and returns "
        "the report as a dict (gap_report.json's contents). workflow_results / areas point the trials at a "
        "KneeContactWorkflow's results or a folder of contact-area files, as `kneesim gap` does.");
}

}  // namespace kneesim::python
