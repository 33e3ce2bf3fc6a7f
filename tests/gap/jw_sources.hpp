#pragma once
// JW trials with INTERIM contact areas (gap/interim_inputs.hpp: Hertz inverted on the measured
// force), for driving synthetic trials in tests. Not real contact areas.

#include <string>
#include <vector>

#include "gap/interim_inputs.hpp"
#include "gap/trial_inputs.hpp"
#include "io/knee_forces.hpp"
#include "io/storage.hpp"
#include "support/test_data.hpp"

namespace kneesim::gap::test {

inline TrialSource interimSource(const std::string& trial, const std::string& activity, bool with_c3d,
                                 const std::string& dir) {
  TrialSource s;
  s.name = trial;
  s.activity = activity;
  s.knee_forces = ::kneesim::test::dataPath("kgc4-jw/knee-forces/jw_" + trial + "_knee_forces.csv");
  if (with_c3d) s.c3d = ::kneesim::test::dataPath("kgc4-jw/markers/jw_" + trial + ".c3d");
  s.contact_area = dir + "/" + trial + "_interim_area.sto";
  io::writeStorage(s.contact_area, interim::makeInterimContactAreas(io::readKneeForces(s.knee_forces)));
  return s;
}

/// ngait_og3 and stairupf1 with interim areas, EMG normalised.
inline std::vector<GapTrial> jwGaitAndStair(const std::string& dir) {
  std::vector<GapTrial> v{assembleTrial(interimSource("ngait_og3", "gait", true, dir)),
                          assembleTrial(interimSource("stairupf1", "stair", true, dir))};
  const TrialSource defaults;
  normalizeEmg(v, defaults.emg_flexors, defaults.emg_extensors);
  return v;
}

}  // namespace kneesim::gap::test
