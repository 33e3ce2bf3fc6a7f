// Frame selection as OpenSim's InverseDynamicsTool picks frames, and the tables it writes.
#include "dynamics/trajectory.hpp"

#include <gtest/gtest.h>

#include "model/osim_reader.hpp"
#include "support/test_data.hpp"

namespace kneesim::dynamics {
namespace {

TEST(Trajectory, SelectsFramesFromTheSampleAtOrBeforeEachEnd) {
  const std::vector<double> t = {-0.2, -0.1, 0.0, 0.0999999, 0.2, 0.3, 0.4, 0.5, 0.6};
  // Range 0.1-0.45: from 0.0999999 (at or before 0.1) to 0.4.
  EXPECT_EQ(selectFrameTimes(t, 0.1, 0.45, 0.0, 0.6), (std::vector<double>{0.0999999, 0.2, 0.3, 0.4}));
  // No range: the file's own span, not the padding before 0.
  EXPECT_EQ(selectFrameTimes(t, -1e30, 1e30, 0.0, 0.6).front(), 0.0);
  EXPECT_EQ(selectFrameTimes(t, -1e30, 1e30, 0.0, 0.6).back(), 0.6);
  EXPECT_TRUE(selectFrameTimes(t, 0.7, 0.9, 0.0, 0.6).empty());
}

TEST(Trajectory, WritesOpenSimsColumnsInTreeOrder) {
  auto model = model::readOsim(test::dataPath("opensim-dynamics-tests/id/arm26.osim"));
  const InverseDynamics id(model);
  TrajectoryResult r;
  r.time = {0.0, 0.1};
  r.generalized_forces.resize(2, model->coordinates.size());
  for (int c = 0; c < r.generalized_forces.cols(); ++c) r.generalized_forces.col(c).setConstant(c);
  const io::Storage s = makeGeneralizedForceStorage(id.getSystem(), r);
  ASSERT_EQ(s.labels.size(), model->coordinates.size() + 1);
  EXPECT_EQ(s.labels[0], "time");
  EXPECT_EQ(s.labels[1], "r_shoulder_elev_moment");
  EXPECT_EQ(s.labels[2], "r_elbow_flex_moment");
  EXPECT_EQ(s.data(1, 2), model->findCoordinate("r_elbow_flex"));
  const std::vector<JointLoadRequest> j = {{model->findJoint("r_elbow"), LoadOnBody::Child, LoadFrame::Ground}};
  r.joint_loads = Eigen::MatrixXd::Zero(2, 9);
  const io::Storage js = makeJointLoadStorage(*model, j, r);
  ASSERT_EQ(js.labels.size(), 10u);
  EXPECT_EQ(js.labels[1], "r_elbow_on_r_ulna_radius_hand_in_ground_fx");
  EXPECT_EQ(js.labels[9], "r_elbow_on_r_ulna_radius_hand_in_ground_pz");
}

}  // namespace
}  // namespace kneesim::dynamics
