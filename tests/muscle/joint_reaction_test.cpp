// Joint reactions against OpenSim's SinglePin answer (its AnalyzeTool setup, a states file, three
// frames including the joint's own) and forward accelerations against a pendulum's closed form.
#include "muscle/joint_reaction.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include "dynamics/pendulum_model.hpp"
#include "muscle/analyze_tool.hpp"
#include "support/test_data.hpp"

using namespace kneesim;
using kneesim::test::dataPath;

namespace {

TEST(JointReaction, SinglePinMatchesOpenSim) {
  KNEESIM_REQUIRE_DATA("opensim-dynamics-tests/jr/std_SinglePin_JointReaction_ReactionLoads.sto");
  muscle::AnalyzeSetup s = muscle::readAnalyzeSetup(dataPath("opensim-dynamics-tests/jr/SinglePin_Setup_JointReaction.xml"));
  s.results_directory = test::scratchDir("jr_single_pin");
  const muscle::AnalyzeReport r = muscle::runAnalyzeTool(s);
  ASSERT_EQ(r.outputs.size(), 1u);
  EXPECT_NE(r.outputs[0].find("SinglePin_JointReaction_ReactionLoads.sto"), std::string::npos);
  // OpenSim's file says nRows=302 and holds 301 rows, which io::readStorage refuses: read it here.
  io::Storage theirs;
  {
    std::ifstream in(dataPath("opensim-dynamics-tests/jr/std_SinglePin_JointReaction_ReactionLoads.sto"));
    std::string line;
    while (std::getline(in, line) && line.rfind("endheader", 0) != 0) {}
    std::getline(in, line);
    std::istringstream head(line);
    for (std::string l; std::getline(head, l, '\t');) theirs.labels.push_back(l);
    std::vector<std::vector<double>> rows;
    while (std::getline(in, line)) {
      std::istringstream row(line);
      std::vector<double> v;
      for (double x; row >> x;) v.push_back(x);
      if (v.size() == theirs.labels.size()) rows.push_back(v);
    }
    theirs.data.resize(Eigen::Index(rows.size()), Eigen::Index(theirs.labels.size()));
    for (size_t r = 0; r < rows.size(); ++r)
      for (size_t c = 0; c < rows[r].size(); ++c) theirs.data(Eigen::Index(r), Eigen::Index(c)) = rows[r][c];
  }
  const io::Storage ours = io::readStorage(r.outputs[0]);
  ASSERT_GE(ours.getNumRows(), theirs.getNumRows());
  ASSERT_EQ(ours.labels.size(), 28u);
  double worst = 0;
  for (size_t c = 1; c < ours.labels.size(); ++c) {
    const int k = theirs.findColumn(ours.labels[c]);
    ASSERT_GE(k, 0) << ours.labels[c];
    for (int row = 0; row < theirs.getNumRows(); ++row) {
      EXPECT_NEAR(ours.data(row, 0), theirs.data(row, 0), 1e-9);
      worst = std::max(worst, std::abs(ours.data(row, int(c)) - theirs.data(row, k)));
    }
  }
  EXPECT_LT(worst, 1e-5);  // OpenSim's testJointReactions: 1e-5 per column
}

TEST(JointReaction, ForwardAccelerationsOfAPendulumAreItsClosedForm) {
  test::PendulumSpec p;
  p.mass = 2.0;
  p.mass_center = model::Vec3(0.3, 0, 0);
  p.inertia = model::Vec3(0.01, 0.02, 0.05);
  p.gravity = 9.81;
  const dynamics::InverseDynamics id(std::shared_ptr<const model::Model>(test::makePendulum(p)));
  auto ws = id.createWorkspace();
  muscle::ForwardAccelerations fwd(id);
  const double q = 0.4, torque = 1.5;
  const Eigen::VectorXd Q = Eigen::VectorXd::Constant(1, q), U = Eigen::VectorXd::Constant(1, 2.0),
                        mobility = Eigen::VectorXd::Constant(1, torque);
  id.setState(*ws, Q, U);
  Eigen::VectorXd qddot(1);
  fwd.calc(*ws, Q, U, mobility, qddot);
  // (I + m l^2) qddot = torque - m g l cos q
  EXPECT_NEAR(qddot[0], (torque - 2.0 * 9.81 * 0.3 * std::cos(q)) / (0.05 + 2.0 * 0.09), 1e-10);
}

TEST(JointReaction, UnknownJointOrFrameIsAnInputError) {
  test::PendulumSpec p;
  const auto m = test::makePendulum(p);
  EXPECT_THROW(muscle::resolveReactions(*m, {"knee"}, {"child"}, {"ground"}, {"s.xml", 3, "joint_names"}), InputError);
  EXPECT_THROW(muscle::resolveReactions(*m, {"pin"}, {"child"}, {"tibia"}, {"s.xml", 3, "express_in_frame"}), InputError);
  const auto r = muscle::resolveReactions(*m, {"pin"}, {"parent"}, {"pin/bar_offset"}, {"s.xml", 3, ""});
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(r[0].frame, muscle::ReactionFrame::ChildJointFrame);
  EXPECT_EQ(muscle::reactionLabels(*m, r)[0], "pin_on_ground_in_bar_offset_fx");
}

}  // namespace
