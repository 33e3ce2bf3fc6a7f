// The UF model's muscles carried onto JW's 24-DOF knee model: the patella's frame against the one
// the knee model tool wrote (its mass centre), path lengths against the UF model's own paths where
// the two models' bones move alike (hip and ankle muscles), what is left out, one-line errors.
#include "muscle/adopt_muscles.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "model/osim_reader.hpp"
#include "muscle/path.hpp"
#include "sim/system.hpp"
#include "support/input_error.hpp"
#include "support/jw_muscle_model.hpp"
#include "support/test_data.hpp"

using namespace kneesim;

namespace {

using test::JwModels;

JwModels load() { return test::loadJwModels(); }

muscle::AdoptedMuscles adoptJw(const JwModels& m) { return test::adoptJwMuscles(m, {"vaslat_withreallength"}); }

// Every muscle's length at coordinates @p q_by_name (others at their defaults).
std::vector<double> lengths(const model::ModelPtr& m, const std::vector<std::pair<std::string, double>>& q_by_name) {
  const sim::System sys(m);
  auto ws = sys.createWorkspace();
  Eigen::VectorXd q = sys.getDefaultCoordinates();
  for (const auto& [name, v] : q_by_name) q[m->findCoordinate(name)] = v;
  sys.realizePosition(*ws, q);
  const muscle::PathSet paths(sys);
  auto pws = paths.createWorkspace();
  paths.realize(*ws, q, *pws);
  std::vector<double> out;
  for (int i = 0; i < paths.getNumPaths(); ++i) out.push_back(paths.getLength(*pws, i));
  return out;
}

TEST(AdoptMuscles, JwPatellaFrameIsTheKneeModelToolsButtonFrame) {
  KNEESIM_REQUIRE_BUNDLED_DATA(test::kJwUfModel);
  const JwModels m = load();
  const muscle::BodyCorrespondence c = muscle::calcDefaultPoseCorrespondence(*m.knee, *m.uf, "patella", {"test", 0, ""});
  // The knee model tool re-expressed the UF patella's mass centre in the button's frame with its
  // own transform (knee_model.cpp, X_P_patsrc, from its seating of the button): the same one.
  const Eigen::Vector3d uf = m.uf->bodies[m.uf->findBody("patella")].mass_center;
  const Eigen::Vector3d knee = m.knee->bodies[m.knee->findBody("patella")].mass_center;
  EXPECT_LT((c.X_TD * uf - knee).norm(), 1e-12) << (c.X_TD * uf).transpose() << " vs " << knee.transpose();
  // Not the identity: the button frame's origin is 7.1 mm from the UF patella's.
  EXPECT_NEAR(c.X_TD.translation().norm(), 0.0071, 0.0005);
}

TEST(AdoptMuscles, JwHipAndAnkleMuscleLengthsEqualTheUfModels) {
  KNEESIM_REQUIRE_BUNDLED_DATA(test::kJwUfModel);
  const JwModels m = load();
  const muscle::AdoptedMuscles a = adoptJw(m);
  // 54 muscles: 6 trunk muscles (no torso in the knee model) and one excluded by name are left out.
  EXPECT_EQ(a.adopted.size(), 47u);
  ASSERT_EQ(a.left_out.size(), 7u);
  EXPECT_EQ(a.left_out[0], "vaslat_withreallength: excluded by name");
  EXPECT_EQ(a.left_out[1], "ercspn_r: the target has no body 'torso'");
  // At the same hip, ankle and subtalar angles the pelvis-femur and tibia-foot muscles have the
  // UF model's lengths (its own paths and wraps evaluated on its own bodies): the frames agree.
  const std::vector<std::pair<std::string, double>> q = {{"hip_flexion", 0.5},   {"hip_adduction", -0.1},
                                                          {"hip_rotation", 0.2},  {"ankle_angle", -0.3},
                                                          {"subtalar_angle", 0.1}};
  const std::vector<double> l_uf = lengths(m.uf, q), l_knee = lengths(a.model, q);
  int compared = 0;
  for (const char* name : {"addlong", "glmax2", "glmed1", "iliacus", "psoas", "piri", "soleus", "tibant", "perlong", "tibpost"}) {
    const int iu = m.uf->findMuscle(name), ik = a.model->findMuscle(name);
    ASSERT_GE(iu, 0);
    ASSERT_GE(ik, 0);
    EXPECT_NEAR(l_knee[size_t(ik)], l_uf[size_t(iu)], 1e-9) << name;
    ++compared;
  }
  EXPECT_EQ(compared, 10);
  // Knee-crossing muscles follow the knee model's seated path instead: lengths differ (mm), not wildly.
  const int iu = m.uf->findMuscle("vasmed"), ik = a.model->findMuscle("vasmed");
  EXPECT_NEAR(l_knee[size_t(ik)], l_uf[size_t(iu)], 0.03);
}

TEST(AdoptMuscles, BadNamesAreOneLineErrors) {
  KNEESIM_REQUIRE_BUNDLED_DATA(test::kJwUfModel);
  const JwModels m = load();
  const SourceLocation where{"setup.xml", 7, "MuscleChain"};
  const std::string e1 = test::inputErrorOf([&] { muscle::adoptMuscles(*m.knee, *m.uf, {}, {"quadzilla"}, where); });
  EXPECT_NE(e1.find("setup.xml:7: MuscleChain: expected a muscle of"), std::string::npos) << e1;
  EXPECT_NE(e1.find("got 'quadzilla'"), std::string::npos) << e1;
  const std::string e2 = test::inputErrorOf(
      [&] { muscle::adoptMuscles(*m.knee, *m.uf, {{"tibial_tray", "shin", Eigen::Isometry3d::Identity()}}, {}, where); });
  EXPECT_NE(e2.find("expected a body of the target model"), std::string::npos) << e2;
  const std::string e3 =
      test::inputErrorOf([&] { muscle::calcDefaultPoseCorrespondence(*m.knee, *m.uf, "torso", where); });
  EXPECT_NE(e3.find("expected a body of both models, got 'torso'"), std::string::npos) << e3;
}

}  // namespace
