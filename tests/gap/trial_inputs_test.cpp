#include "gap/trial_inputs.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "gap/jw_sources.hpp"
#include "gap/synth.hpp"
#include "io/knee_forces.hpp"
#include "io/storage.hpp"
#include "support/test_data.hpp"
#include "support/input_error.hpp"

namespace kneesim::gap {
namespace {

using kneesim::test::inputErrorOf;
using ::testing::HasSubstr;

using test::jwSource;

// A contact-area file covering @p forces' time span with a constant area (for tests about the other
// channels of a trial that has no workflow areas here, the chair rise).
std::string constantAreaFile(const io::KneeForces& forces, const std::string& path) {
  io::Storage a;
  a.name = "constant";
  a.labels = {"time", "S", "S_medial", "S_lateral"};
  a.data.resize(forces.getNumSamples(), 4);
  for (int i = 0; i < forces.getNumSamples(); ++i) a.data.row(i) << forces.time[size_t(i)], 2.6e-3, 1.3e-3, 1.3e-3;
  io::writeStorage(path, a);
  return path;
}

TEST(TrialInputs, GaitEventsFromThePlatesUnderTheRightFoot) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/markers/jw_ngait_og3.c3d");
  const GapTrial g = assembleTrial(jwSource("ngait_og3", "gait"));
  for (const auto& n : g.notes) std::printf("[ note     ] %s\n", n.c_str());
  EXPECT_FALSE(g.interim_inputs);
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
  // The flexion is the workflow's IK knee_flexion (area file), -3.2 to 67.5 deg; its area derivative
  // is the file's too (not estimated from the rates).
  const auto& th = getChannel(g, "knee_flexion");
  EXPECT_NEAR(*std::max_element(th.begin(), th.end()) * 180 / M_PI, 67.55, 0.05);
  EXPECT_THAT(g.notes, testing::Contains(HasSubstr("knee_flexion from the contact-area file")));
  EXPECT_THAT(g.notes, testing::Not(testing::Contains(HasSubstr("dS_dflexion estimated"))));
  EXPECT_NEAR(getChannel(g, "S_threshold")[0], 0.004, 1e-12);  // the header's threshold_m
  // From GON instead: in degrees in this file (largest 64.687, read with awk), mapped by the engine's
  // calibration to the model's flexion: -4.437 + 1.1742 x 64.687 = 71.52 deg.
  TrialSource gon = jwSource("ngait_og3", "gait");
  gon.flexion_source = "gon";
  const auto& thg = getChannel(assembleTrial(gon), "knee_flexion");
  EXPECT_NEAR(*std::max_element(thg.begin(), thg.end()) * 180 / M_PI, -4.437 + 1.1742 * 64.687, 1e-3);
  const auto& grf = getChannel(g, "GRF:vertical");
  EXPECT_NEAR(*std::max_element(grf.begin(), grf.end()), 695, 15);  // plate 3's peak 695 N (30 Hz low-pass)
  // The other foot (plate 1): its peak 779 N (the plate's Fz averaged over each frame's ten analog
  // samples, read by tests/gap/stress/jw_inputs.py, an independent reader).
  const auto& left = getChannel(g, "GRF:vertical_left");
  EXPECT_NEAR(*std::max_element(left.begin(), left.end()), 779, 15);
  // The instrumented foot's horizontal components: walking along the lab's one horizontal axis,
  // braking then propulsion of 15-25 % of body weight, and a net impulse over a stance near zero
  // (steady walking); the medio-lateral axis carries a few percent.
  {
    const auto& gx = getChannel(g, "GRF:x");
    const auto& gy = getChannel(g, "GRF:y");
    double ix = 0, iax = 0, peak_x = 0, peak_y = 0;
    for (int i = 1; i < g.getNumFrames(); ++i) {
      const double dt = g.trial.time[i] - g.trial.time[i - 1];
      if (g.trial.time[i] >= g.cycles[1].start && g.trial.time[i] < g.cycles[1].mid) ix += gx[i] * dt, iax += std::abs(gx[i]) * dt;
      peak_x = std::max(peak_x, std::abs(gx[i]));
      peak_y = std::max(peak_y, std::abs(gy[i]));
    }
    // JW 66.7 kg (654 N): peak 120 N (18 %) along x; net -7.9 N s of 36.5 N s; 52 N along y.
    EXPECT_GT(peak_x, 0.15 * 654);
    EXPECT_LT(peak_x, 0.25 * 654);
    EXPECT_LT(std::abs(ix), 0.3 * iax);
    EXPECT_LT(peak_y, 0.5 * peak_x);
  }
  {
    const auto& tt = getChannel(g, "trial_time");
    EXPECT_EQ(tt.front(), 0.0);
    EXPECT_NEAR(tt.back(), g.trial.time.back() - g.trial.time.front(), 1e-12);
  }
  EXPECT_EQ(g.trial.channels.count("EMG:vaslat"), 1u);
  EXPECT_EQ(g.trial.channels.count("dS_dflexion"), 1u);
  // Equation 4: medial + lateral = total.
  for (int i = 0; i < g.getNumFrames(); ++i) EXPECT_NEAR(g.medial[i] + g.lateral[i], g.trial.measured_force[i], 1e-9);
}

TEST(TrialInputs, GoniometerInVoltsIsCalibratedAndChairCyclesComeFromFlexion) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/knee-forces/jw_chairrise1_knee_forces.csv");
  const std::string dir = ::kneesim::test::scratchDir("gap_trial_chair");
  TrialSource st = jwSource("stairupf1", "stair");
  st.flexion_source = "gon";
  const GapTrial stair = assembleTrial(st);
  const auto& ths = getChannel(stair, "knee_flexion");
  // 5.300-7.027 V -> 2.16-68.09 goniometer deg -> -1.9 to 75.5 deg of the model's flexion (IK: -3.5
  // to 75.4).
  EXPECT_NEAR(*std::min_element(ths.begin(), ths.end()) * 180 / M_PI, -1.9, 0.3);
  EXPECT_NEAR(*std::max_element(ths.begin(), ths.end()) * 180 / M_PI, 75.5, 0.3);
  EXPECT_THAT(stair.notes, testing::Contains(HasSubstr("V): goniometer deg = 38.1828 V - 200.218")));
  EXPECT_EQ(stair.event_source, "force plates");
  ASSERT_GE(stair.cycles.size(), 2u);
  EXPECT_NEAR(stair.cycles[1].start, 6.23, 0.02);  // right foot on plate 1 at 6.23 s
  TrialSource ch;
  ch.name = "chairrise1";
  ch.activity = "chair";
  ch.knee_forces = ::kneesim::test::dataPath("kgc4-jw/knee-forces/jw_chairrise1_knee_forces.csv");
  ch.contact_area = constantAreaFile(io::readKneeForces(ch.knee_forces), dir + "/chair_area.sto");
  const GapTrial chair = assembleTrial(ch);
  EXPECT_EQ(chair.event_source, "flexion");
  const auto& thc = getChannel(chair, "knee_flexion");
  EXPECT_NEAR(*std::min_element(thc.begin(), thc.end()) * 180 / M_PI, 6.2, 0.3);
  EXPECT_NEAR(*std::max_element(thc.begin(), thc.end()) * 180 / M_PI, 110.6, 0.3);
  for (const auto& c : chair.cycles)
    std::printf("[ cycle    ] chair %.3f (mid %.3f) %.3f%s\n", c.start, c.mid, c.end, c.end_estimated ? " est." : "");
  EXPECT_GE(chair.cycles.size(), 4u);
  EXPECT_EQ(chair.trial.channels.count("GRF:vertical"), 0u);  // no C3D for the chair rise
  // Its knee-force file's GRF column is force plate 1 / 2000: 44-424 N with the scale given.
  ch.knee_forces_grf_scale = io::kJwCsvGrfNewtonsPerUnit;
  const GapTrial chair_grf = assembleTrial(ch);
  const auto& grf = getChannel(chair_grf, "GRF:vertical");
  EXPECT_NEAR(*std::min_element(grf.begin(), grf.end()), 43.6, 0.5);
  EXPECT_NEAR(*std::max_element(grf.begin(), grf.end()), 423.8, 0.5);
  std::vector<GapTrial> all{stair, chair};
  std::printf("[ scatter  ] between-cycle SD of the measured force: %.1f N\n", estimateBetweenCycleScatter(all));
}

TEST(TrialInputs, BadInputsAreOneLineErrors) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/knee-forces/jw_ngait_og3_knee_forces.csv");
  const std::string dir = ::kneesim::test::scratchDir("gap_trial_bad");
  TrialSource s = jwSource("ngait_og3", "gait", false);
  // Areas in mm^2.
  io::Storage a = io::readStorage(s.contact_area);
  a.data.col(1) *= 1e6;
  io::writeStorage(dir + "/mm2.sto", a);
  TrialSource bad = s;
  bad.contact_area = dir + "/mm2.sto";
  EXPECT_THAT(inputErrorOf([&] { assembleTrial(bad); }), HasSubstr("contact area: expected m^2"));
  // Times that do not overlap.
  a = io::readStorage(s.contact_area);
  a.data.col(0).array() += 100.0;
  io::writeStorage(dir + "/late.sto", a);
  bad.contact_area = dir + "/late.sto";
  EXPECT_THAT(inputErrorOf([&] { assembleTrial(bad); }), HasSubstr("to overlap by at least 10 frames, got 0"));
  bad.contact_area.clear();
  EXPECT_THROW(assembleTrial(bad), InputError);
  s.events = "sometimes";
  EXPECT_THAT(inputErrorOf([&] { assembleTrial(s); }),
              HasSubstr("events: expected auto, plates, force, flexion or times, got 'sometimes'"));
  // Knee loads that stop before the trial does.
  s.events = "auto";
  io::Storage k = io::readStorage(s.knee_loads);
  k.data.conservativeResize(100, Eigen::NoChange);
  io::writeStorage(dir + "/short_loads.sto", k);
  s.knee_loads = dir + "/short_loads.sto";
  EXPECT_THAT(inputErrorOf([&] { assembleTrial(s); }),
              HasSubstr("short_loads.sto: knee_axial_force: column 'knee_axial_force': expected finite values over"));
}

// The knee's net loads from inverse dynamics are channels of the trial, on its frames.
TEST(TrialInputs, KneeLoadsBecomeChannels) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/knee-forces/jw_ngait_og3_knee_forces.csv");
  const TrialSource s = jwSource("ngait_og3", "gait", false);
  const GapTrial g = assembleTrial(s);
  const io::Storage k = io::readStorage(s.knee_loads);
  const auto& axial = getChannel(g, "knee_axial_force");
  ASSERT_EQ(int(axial.size()), g.getNumFrames());
  // The fixture's row nearest each frame, within half a frame at 120 Hz.
  const int col = k.findColumn("knee_axial_force");
  for (int i = 0; i < g.getNumFrames(); i += 37) {
    int r = 0;
    while (r + 1 < k.getNumRows() && std::abs(k.data(r + 1, 0) - g.trial.time[i]) < std::abs(k.data(r, 0) - g.trial.time[i])) ++r;
    EXPECT_NEAR(axial[i], k.data(r, col), 0.05 * std::abs(k.data(r, col)) + 5.0) << g.trial.time[i];
  }
  for (const char* c : {"knee_flexion_moment", "knee_adduction_moment", "knee_ap_force"}) EXPECT_NO_THROW(getChannel(g, c));
}

TEST(TrialInputs, AMissingInputFileIsNamedWithTheSetupElementThatNamedIt) {
  // No data needed: the files are checked before any is read, in the order of the Trial's elements.
  const std::string dir = ::kneesim::test::scratchDir("gap_trial_missing");
  TrialSource s;
  s.name = "walk";
  s.where = {"gap.xml", 12, "GapTool/trials/Trial[walk]"};
  s.knee_forces = dir + "/none.csv";
  s.contact_area = dir + "/none.sto";
  EXPECT_EQ(inputErrorOf([&] { assembleTrial(s); }),
            "gap.xml:12: GapTool/trials/Trial[walk]/knee_forces: trial 'walk': knee-force file not found: " + dir +
                "/none.csv");
  io::Storage a;
  a.labels = {"time", "S"};
  a.data.resize(2, 2);
  a.data << 0, 2e-3, 1, 2e-3;
  io::writeStorage(dir + "/forces.csv", a);  // exists: the next missing one is reported
  s.knee_forces = dir + "/forces.csv";
  s.c3d = dir + "/none.c3d";
  EXPECT_EQ(inputErrorOf([&] { assembleTrial(s); }),
            "gap.xml:12: GapTool/trials/Trial[walk]/c3d: trial 'walk': C3D file not found: " + dir + "/none.c3d");
  s.c3d.clear();
  EXPECT_EQ(inputErrorOf([&] { assembleTrial(s); }),
            "gap.xml:12: GapTool/trials/Trial[walk]/contact_area: trial 'walk': contact-area file not found: " + dir +
                "/none.sto");
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
