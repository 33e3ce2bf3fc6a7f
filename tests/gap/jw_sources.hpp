#pragma once
// JW trials with their REAL contact areas: the paper workflow's contact-area files of ngait_og3 and
// stairupf1 (model kinematics from IK, areas at 1-6 mm, knee_flexion, dS_dflexion, dS_dap), and the
// knee's net loads from inverse dynamics, kept as fixtures in tests/gap/fixtures/ (README there: how
// they were made; the workflow and ID tests check that they still match what those compute).

#include <string>
#include <vector>

#include "gap/trial_inputs.hpp"
#include "support/test_data.hpp"

namespace kneesim::gap::test {

/// The fixture contact-area file of a JW trial (ngait_og3 or stairupf1).
inline std::string jwAreaFixture(const std::string& trial) {
  return ::kneesim::test::sourcePath("tests/gap/fixtures/jw_" + trial + "_contact_area.sto");
}

/// The fixture knee-load file of a JW trial (the InverseDynamicsTool's <KneeLoads> output).
inline std::string jwKneeLoadFixture(const std::string& trial) {
  return ::kneesim::test::sourcePath("tests/gap/fixtures/jw_" + trial + "_knee_loads.sto");
}

/// The inputs of JW's @p trial with the workflow's areas and the knee's net loads (and its C3D
/// when @p with_c3d).
inline TrialSource jwSource(const std::string& trial, const std::string& activity, bool with_c3d = true) {
  TrialSource s;
  s.name = trial;
  s.activity = activity;
  s.knee_forces = ::kneesim::test::dataPath("kgc4-jw/knee-forces/jw_" + trial + "_knee_forces.csv");
  if (with_c3d) s.c3d = ::kneesim::test::dataPath("kgc4-jw/markers/jw_" + trial + ".c3d");
  s.contact_area = jwAreaFixture(trial);
  s.knee_loads = jwKneeLoadFixture(trial);
  return s;
}

/// ngait_og3 and stairupf1 with the workflow's areas, EMG normalised.
inline std::vector<GapTrial> jwGaitAndStair() {
  std::vector<GapTrial> v{assembleTrial(jwSource("ngait_og3", "gait")), assembleTrial(jwSource("stairupf1", "stair"))};
  const TrialSource defaults;
  normalizeEmg(v, defaults.emg_flexors, defaults.emg_extensors);
  return v;
}

}  // namespace kneesim::gap::test
