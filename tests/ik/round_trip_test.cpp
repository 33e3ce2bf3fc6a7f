// The IK round trip `kneesim model check` runs: OpenSim's knee_patella_ligament model (its
// patellar ligament a ConstantDistanceConstraint) and a model without markers (three made up
// per body).
#include "ik/round_trip.hpp"

#include <gtest/gtest.h>

#include "model/osim_reader.hpp"
#include "support/test_data.hpp"

namespace kneesim::ik {
namespace {

TEST(RoundTrip, RecoversPosesOnAConstrainedOpenSimModel) {
  const auto m = model::readOsim(test::sourcePath("tests/model/corpus/knee_patella_ligament.osim"));
  const RoundTripResult r = runRoundTrip(m, 4);
  EXPECT_EQ(r.frames, 4);
  EXPECT_EQ(r.markers, 2);
  EXPECT_FALSE(r.synthetic_markers);
  EXPECT_TRUE(r.converged);
  EXPECT_LT(r.rms_error, 1e-8);  // m
  EXPECT_LT(r.max_constraint_error, 1e-9);
}

TEST(RoundTrip, MakesUpMarkersForAModelWithout) {
  const auto m = model::readOsim(test::sourcePath("tests/model/corpus/double_pendulum_30501.osim"));
  ASSERT_TRUE(m->markers.empty());
  const RoundTripResult r = runRoundTrip(m);
  EXPECT_TRUE(r.synthetic_markers);
  EXPECT_EQ(r.markers, 6);  // three per body
  EXPECT_LT(r.rms_error, 1e-8);
}

}  // namespace
}  // namespace kneesim::ik
