#include "identify/trial.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

namespace kneesim::identify {
namespace {

using ::testing::HasSubstr;

Trial small() {
  Trial t;
  t.name = "w";
  t.time = {0.0, 0.5, 1.0, 1.5, 2.0};
  t.channels["S"] = {0, 1e-4, 2e-4, 1e-4, 0};
  t.measured_force = {0, 10, 20, 10, 0};
  t.source = {"id.xml", 3, "Trial[w]"};
  return t;
}

std::string errorOf(const Trial& t) {
  try {
    checkTrial(t);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(Trial, MalformedTrialsAreOneLineErrors) {
  EXPECT_EQ(errorOf(small()), "");
  Trial t = small();
  t.time[2] = 0.5;
  EXPECT_EQ(errorOf(t), "id.xml:3: Trial[w]: trial 'w': time[2]: expected strictly increasing times, got 0.5 after 0.5");
  t = small();
  t.measured_force.pop_back();
  EXPECT_EQ(errorOf(t), "id.xml:3: Trial[w]: trial 'w': measured force: expected 5 values (one per frame), got 4");
  t = small();
  t.weight = {1, 1, -1, 1, 1};
  EXPECT_THAT(errorOf(t), HasSubstr("weight[2]: expected a finite weight >= 0, got -1"));
  t = small();
  t.channels["S"].push_back(0);
  EXPECT_THAT(errorOf(t), HasSubstr("channel 'S': expected 5 values (one per frame), got 6"));
  t = small();
  t.windows = {{1.0, 0.5}};
  EXPECT_THAT(errorOf(t), HasSubstr("time window: expected begin <= end, got [1, 0.5]"));
  t = small();
  t.time.clear();
  EXPECT_THAT(errorOf(t), HasSubstr("expected at least one frame, got none"));
}

TEST(Trial, WindowsSelectFramesInclusively) {
  Trial t = small();
  EXPECT_EQ(selectFrames(t), (std::vector<int>{0, 1, 2, 3, 4}));
  t.windows = {{0.5, 1.0}, {2.0, 9.0}};
  EXPECT_EQ(selectFrames(t), (std::vector<int>{1, 2, 4}));
  t.windows = {{0.6, 0.9}};
  try {
    selectFrames(t);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "id.xml:3: Trial[w]: trial 'w': time windows [0.6, 0.9]: expected at least one frame "
                           "inside, got none (trial has t = 0 .. 2 s)");
  }
}

TEST(Trial, PhasesInSecondsOrFractions) {
  const Trial t = small();
  const std::vector<int> all{0, 1, 2, 3, 4};
  EXPECT_EQ(selectPhase(t, all, {"early", 0.0, 0.5, true}), (std::vector<int>{0, 1, 2}));  // 0 .. 1 s
  EXPECT_EQ(selectPhase(t, all, {"late", 1.2, 2.0, false}), (std::vector<int>{3, 4}));
  EXPECT_EQ(selectPhase(t, {0, 1}, {"late", 1.2, 2.0, false}), std::vector<int>{});
  const TimeWindow w = resolvePhase(t, {"x", 0.25, 0.75, true});
  EXPECT_DOUBLE_EQ(w.begin, 0.5);
  EXPECT_DOUBLE_EQ(w.end, 1.5);
}

}  // namespace
}  // namespace kneesim::identify
