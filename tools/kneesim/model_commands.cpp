// `kneesim model info` and `kneesim model check` (see the header).
#include "model_commands.hpp"

#include <cstdio>
#include <iostream>

#include "ik/round_trip.hpp"
#include "model/model_info.hpp"
#include "model/read_model.hpp"

namespace kneesim::cli {

void addModelCommands(CLI::App& app, ModelCommandState& s) {
  s.model = app.add_subcommand("model", "Look at a model: what it holds (info), whether IK can use it (check)");
  s.model->require_subcommand(1);
  s.info = s.model->add_subcommand(
      "info", "Format, bodies, joints, coordinates with ranges, markers, constraints, and every component "
              "kneesim does not simulate (with its type)");
  s.info->add_option("model", s.file, "Model file (.osim or .urdf)")->required();
  s.check = s.model->add_subcommand(
      "check", "Load the model and run the IK round trip: poses near the default one, their markers (three per "
               "body when the model has none), IK back; one line, exit status 3 if off");
  s.check->add_option("model", s.file, "Model file (.osim or .urdf)")->required();
  s.check->add_option("--frames", s.frames, "Poses in the round trip (default 5)")->check(CLI::Range(1, 1000));
  s.check->add_option("--tolerance", s.tolerance_mm, "Largest marker RMS after IK that passes, mm (default 0.01)");
  s.check->add_flag("--tsv", s.tsv,
                    "Print one tab-separated row: file, OK or IK-OFF, format, bodies, coordinates, constraints, "
                    "couplers, markers (s: synthetic), RMS mm, max mm, constraint error, components not simulated, "
                    "of which posing the model");
}

bool isModelCommand(const ModelCommandState& s) { return s.model && s.model->parsed(); }

int runModelCommand(const ModelCommandState& s, bool quiet) {
  const model::ModelPtr m = model::readModel(s.file);
  if (s.info->parsed()) {
    model::printModelInfo(*m, std::cout);
    return 0;
  }
  const ik::RoundTripResult r = ik::runRoundTrip(m, s.frames);
  const bool ok = r.converged && r.rms_error * 1e3 <= s.tolerance_mm && r.max_constraint_error <= 1e-6;
  int poses_kinematics = 0;
  for (const auto& c : m->ignored) poses_kinematics += c.affects_kinematics ? 1 : 0;
  if (s.tsv)
    std::printf("%s\t%s\t%d\t%zu\t%zu\t%zu\t%zu\t%d%s\t%.3g\t%.3g\t%.3g\t%zu\t%d\n", s.file.c_str(), ok ? "OK" : "IK-OFF",
                m->format_version, m->bodies.size() - 1, m->coordinates.size(), m->constraints.size(), m->couplers.size(),
                r.markers, r.synthetic_markers ? "s" : "", r.rms_error * 1e3, r.max_error * 1e3, r.max_constraint_error,
                m->ignored.size(), poses_kinematics);
  else if (!quiet)
    std::printf("%s: %s; format %d, %zu bodies, %zu coordinates, %zu constraints%s, %d %smarkers; IK round trip over "
                "%d poses: RMS %.2g mm, max %.2g mm, constraint error %.2g; %zu components not simulated%s\n",
                s.file.c_str(), ok ? "OK" : "IK OFF", m->format_version, m->bodies.size() - 1, m->coordinates.size(),
                m->constraints.size(), m->couplers.empty() ? "" : (" + " + std::to_string(m->couplers.size()) + " couplers").c_str(),
                r.markers, r.synthetic_markers ? "synthetic " : "", r.frames, r.rms_error * 1e3, r.max_error * 1e3,
                r.max_constraint_error, m->ignored.size(),
                poses_kinematics ? (" (" + std::to_string(poses_kinematics) + " pose the model in OpenSim)").c_str() : "");
  return ok ? 0 : 3;
}

}  // namespace kneesim::cli
