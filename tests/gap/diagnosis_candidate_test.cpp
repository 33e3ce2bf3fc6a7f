// Tests of gap/diagnosis_candidate.cpp: the candidate left undecided where the selection stopped.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "gap/diagnosis.hpp"

namespace kneesim::gap {
namespace {

// The candidate left undecided where the selection stopped, by hand: among those removing at least
// 5 % without significance, the one with the highest lower bound; the cycles that would lift that
// bound to zero at the same spread are n ((mean - lower) / mean)^2 = 12 (0.1 / 0.08)^2 = 18.75 -> 19.
TEST(Undecided, TheClosestNonSignificantCandidateAndTheCyclesThatWouldDecideIt) {
  auto fit = [](const std::string& effect, int step, double mean, double lower, bool accepted = false) {
    CandidateFit c;
    c.effect = effect;
    c.step = step;
    c.converged = true;
    c.accepted = accepted;
    c.relative_improvement = c.reduction.mean = mean;
    c.reduction.n = 12;
    c.one_sided_lower = lower;
    c.whitened_improvement = 0.2;
    c.whitened_one_sided_lower = 0.05;
    return c;
  };
  const std::vector<CandidateFit> step1 = {fit("a", 1, 0.08, -0.02), fit("b", 1, 0.15, -0.06),
                                           fit("c", 1, 0.03, -0.001), fit("d", 1, 0.10, 0.01)};
  const UndecidedCandidate u = findUndecided(step1, 1, 0.05);
  EXPECT_EQ(u.effect, "a");  // c removes under 5 %, d is significant, b's bound is lower
  EXPECT_EQ(u.step, 1);
  EXPECT_EQ(u.cycles, 12);
  EXPECT_EQ(u.cycles_needed, 19);
  EXPECT_DOUBLE_EQ(u.whitened_lower, 0.05);
  // A step that added an effect leaves nothing undecided; neither does a step with no candidate close.
  std::vector<CandidateFit> added = step1;
  added[3].accepted = true;
  EXPECT_TRUE(findUndecided(added, 1, 0.05).effect.empty());
  EXPECT_TRUE(findUndecided(step1, 2, 0.05).effect.empty());
  EXPECT_TRUE(findUndecided({fit("c", 1, 0.03, -0.001)}, 1, 0.05).effect.empty());
  // Its cross-fitted score, if nearer its critical t, decides sooner: t grows like sqrt(cycles),
  // 12 (3.25 / 3)^2 = 14.08 -> 15 cycles. A score already significant makes the candidate significant.
  std::vector<CandidateFit> scored = step1;
  scored[0].score_t = 3;
  scored[0].score_critical = 3.25;
  EXPECT_EQ(findUndecided(scored, 1, 0.05).cycles_needed, 15);
  scored[0].score_t = 1;  // slower than its MSE reduction: 12 (3.25 / 1)^2 = 127 cycles
  EXPECT_EQ(findUndecided(scored, 1, 0.05).cycles_needed, 19);
  scored[0].score_t = 3.5;
  EXPECT_TRUE(scored[0].isSignificant());
  EXPECT_EQ(findUndecided(scored, 1, 0.05).effect, "b");
}

}  // namespace
}  // namespace kneesim::gap
