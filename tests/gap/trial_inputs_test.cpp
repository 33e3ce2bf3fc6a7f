#include "gap/trial_inputs.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "gap/interim_inputs.hpp"
#include "gap/synth.hpp"
#include "io/knee_forces.hpp"
#include "io/storage.hpp"
#include "support/test_data.hpp"

namespace kneesim::gap {
namespace {

using ::testing::HasSubstr;

// Writes the interim areas of a JW trial and returns the source describing it.
TrialSource jwSource(const std::string& trial, const std::string& activity, bool with_c3d, const std::string& dir) {
  TrialSource s;
  s.name = trial;
  s.activity = activity;
  s.knee_forces = test::dataPath("kgc4-jw/knee-forces/jw_" + trial + "_knee_forces.csv");
  if (with_c3d) s.c3d = test::dataPath("kgc4-jw/markers/jw_" + trial + ".c3d");
  s.contact_area = dir + "/" + trial + "_interim_area.sto";
  io::writeStorage(s.contact_area, interim::makeInterimContactAreas(io::readKneeForces(s.knee_forces)));
  return s;
}

TEST(TrialInputs, GaitEventsFromThePlatesUnderTheRightFoot) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/markers/jw_ngait_og3.c3d");
  const std::string dir = test::scratchDir("gap_trial_gait");
  const GapTrial g = assembleTrial(jwSource("ngait_og3", "gait", true, dir));
  for (const auto& n : g.notes) std::printf("[ note     ] %s\n", n.c_str());
  EXPECT_TRUE(g.interim_inputs);
  EXPECT_EQ(g.event_source, "force plates");
  // Plates 2 and 3 carry the right foot (plate 1 the left): heel strikes where their vertical
  // force passes 20 N (2.066 s and 3.197 s by a direct read of the C3D), toe-offs 2.796 s and 3.945 s.
  ASSERT_EQ(g.cycles.size(), 3u);
  EXPECT_TRUE(g.cycles[0].start_estimated);
  EXPECT_NEAR(g.cycles[1].start, 2.066, 0.01);
  EXPECT_NEAR(g.cycles[1].mid, 2.796, 0.01);
  EXPECT_NEAR(g.cycles[2].start, 3.197, 0.01);
  EXPECT_NEAR(g.cycles[2].mid, 3.945, 0.01);
  EXPECT_TRUE(g.cycles[2].end_estimated);
  EXPECT_NEAR(g.cycles[2].end - g.cycles[2].start, g.cycles[1].end - g.cycles[1].start, 1e-9);
  // Toe-off sits at 62 % of the normalised cycle.
  for (int i = 1; i < g.getNumFrames(); ++i) {
    if (g.trial.time[i - 1] < g.cycles[1].mid && g.trial.time[i] >= g.cycles[1].mid) {
      EXPECT_NEAR(g.cycle_phase[i], 0.62, 0.01);
    }
  }
  // GON is in degrees in this file: its largest value is 64.687 deg (read with awk).
  const auto& th = getChannel(g, "knee_flexion");
  EXPECT_NEAR(*std::max_element(th.begin(), th.end()) * 180 / M_PI, 64.687, 1e-3);
  const auto& grf = getChannel(g, "GRF:vertical");
  EXPECT_NEAR(*std::max_element(grf.begin(), grf.end()), 695, 15);  // plate 3's peak 695 N (30 Hz low-pass)
  EXPECT_EQ(g.trial.channels.count("EMG:vaslat"), 1u);
  EXPECT_EQ(g.trial.channels.count("dS_dflexion"), 1u);
  // Equation 4: medial + lateral = total.
  for (int i = 0; i < g.getNumFrames(); ++i) EXPECT_NEAR(g.medial[i] + g.lateral[i], g.trial.measured_force[i], 1e-9);
}

TEST(TrialInputs, GoniometerInVoltsIsCalibratedAndChairCyclesComeFromFlexion) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/knee-forces/jw_chairrise1_knee_forces.csv");
  const std::string dir = test::scratchDir("gap_trial_chair");
  const GapTrial stair = assembleTrial(jwSource("stairupf1", "stair", true, dir));
  const auto& ths = getChannel(stair, "knee_flexion");
  // 5.30-7.02 V -> 2-68 deg with the ngait_og3 calibration.
  EXPECT_NEAR(*std::min_element(ths.begin(), ths.end()) * 180 / M_PI, 2.5, 2.0);
  EXPECT_NEAR(*std::max_element(ths.begin(), ths.end()) * 180 / M_PI, 66, 3.0);
  EXPECT_THAT(stair.notes, testing::Contains(HasSubstr("in volts in this file")));
  EXPECT_EQ(stair.event_source, "force plates");
  ASSERT_GE(stair.cycles.size(), 2u);
  EXPECT_NEAR(stair.cycles[1].start, 6.23, 0.02);  // right foot on plate 1 at 6.23 s
  const GapTrial chair = assembleTrial(jwSource("chairrise1", "chair", false, dir));
  EXPECT_EQ(chair.event_source, "flexion");
  for (const auto& c : chair.cycles)
    std::printf("[ cycle    ] chair %.3f (mid %.3f) %.3f%s\n", c.start, c.mid, c.end, c.end_estimated ? " est." : "");
  EXPECT_GE(chair.cycles.size(), 4u);
  EXPECT_EQ(chair.trial.channels.count("GRF:vertical"), 0u);  // no C3D for the chair rise
  std::vector<GapTrial> all{stair, chair};
  std::printf("[ scatter  ] between-cycle SD of the measured force: %.1f N\n", estimateBetweenCycleScatter(all));
}

TEST(TrialInputs, BadInputsAreOneLineErrors) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/knee-forces/jw_ngait_og3_knee_forces.csv");
  const std::string dir = test::scratchDir("gap_trial_bad");
  TrialSource s = jwSource("ngait_og3", "gait", false, dir);
  // Areas in mm^2.
  io::Storage a = io::readStorage(s.contact_area);
  a.data.col(1) *= 1e6;
  io::writeStorage(dir + "/mm2.sto", a);
  TrialSource bad = s;
  bad.contact_area = dir + "/mm2.sto";
  try {
    assembleTrial(bad);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("contact area: expected m^2"));
  }
  // Times that do not overlap.
  a = io::readStorage(s.contact_area);
  a.data.col(0).array() += 100.0;
  io::writeStorage(dir + "/late.sto", a);
  bad.contact_area = dir + "/late.sto";
  try {
    assembleTrial(bad);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("to overlap by at least 10 frames, got 0"));
  }
  bad.contact_area.clear();
  EXPECT_THROW(assembleTrial(bad), InputError);
  s.events = "sometimes";
  try {
    assembleTrial(s);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("events: expected auto, plates, force, flexion or times, got 'sometimes'"));
  }
}

TEST(TrialInputs, CrossingsAndCyclesOnAHandMadeSignal) {
  // A 1 Hz square-ish wave: rising crossings of 0 at 0, 1, 2 s; falling at 0.5, 1.5, 2.5 s.
  std::vector<double> t, x;
  for (int i = 0; i <= 300; ++i) {
    t.push_back(-0.25 + i / 100.0);
    x.push_back(std::sin(2 * M_PI * t.back()));
  }
  const auto up = findCrossings(t, x, 0.0, 0.5, true, 0.3);
  ASSERT_EQ(up.size(), 3u);  // the first rise at 0 s is seen (the signal started at -1)
  EXPECT_NEAR(up[0], 0.0, 1e-3);
  EXPECT_NEAR(up[2], 2.0, 1e-3);
  // With hysteresis 1.5 the signal never returns far enough below 0 after starting there.
  EXPECT_TRUE(findCrossings(t, x, 0.0, 1.5, true, 0.3).empty());
  const auto down = findCrossings(t, x, 0.0, 0.5, false, 0.3);
  ASSERT_EQ(down.size(), 3u);
  EXPECT_NEAR(down[0], 0.5, 1e-3);
  GapTrial g;
  g.activity = "gait";
  g.trial.time = t;
  setCycles(g, up, down);
  // Before 0 s (estimated start -1 s), 0-1 s, 1-2 s, from 2 s (estimated end 3 s).
  ASSERT_EQ(g.cycles.size(), 4u);
  EXPECT_NEAR(g.cycles[0].start, -1.0, 1e-3);
  EXPECT_TRUE(g.cycles[0].start_estimated);
  EXPECT_NEAR(g.cycles[3].end, 3.0, 1e-3);
  EXPECT_TRUE(g.cycles[3].end_estimated);
  EXPECT_NEAR(g.cycles[2].mid, 1.5, 1e-3);
  for (size_t i = 0; i < t.size(); ++i) {
    // 1.25 s: half-way from the start (1 s) to the middle event (1.5 s), which sits at 62 %.
    if (std::abs(t[i] - 1.25) < 1e-9) {
      EXPECT_NEAR(g.cycle_phase[i], 0.31, 1e-3);
    }
    // 1.75 s: half-way from the middle event to the end.
    if (std::abs(t[i] - 1.75) < 1e-9) {
      EXPECT_NEAR(g.cycle_phase[i], 0.81, 1e-3);
    }
    EXPECT_EQ(g.cycle_index[i], t[i] < 0 ? 0 : t[i] < 1 ? 1 : t[i] < 2 ? 2 : 3) << t[i];
  }
}

}  // namespace
}  // namespace kneesim::gap
