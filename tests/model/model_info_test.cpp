// `kneesim model info`'s text and the warning about components that pose a model, on OpenSim's
// knee_patella_ligament model (ranges worked out by hand: -2.0943951 rad is -120 degrees).
#include "model/model_info.hpp"

#include <gtest/gtest.h>

#include <sstream>

#include "model/osim_reader.hpp"
#include "support/test_data.hpp"

namespace kneesim::model {
namespace {

std::string infoOf(const Model& m) {
  std::ostringstream os;
  printModelInfo(m, os);
  return os.str();
}

TEST(ModelInfo, ListsJointsCoordinatesConstraintsAndMarkers) {
  const ModelPtr m = readOsim(test::sourcePath("tests/model/corpus/knee_patella_ligament.osim"));
  const std::string info = infoOf(*m);
  EXPECT_NE(info.find("format: OpenSim document version 30000\n"), std::string::npos) << info;
  EXPECT_NE(info.find("3 bodies besides ground:\n"), std::string::npos) << info;
  EXPECT_NE(info.find("knee_r                   CustomJoint femur_r -> tibia_r: knee_angle_r\n"), std::string::npos) << info;
  EXPECT_NE(info.find("knee_angle_r                rotational  default         0  range -120 to 10, clamped\n"),
            std::string::npos)
      << info;
  EXPECT_NE(info.find("patellar_ligament_r      ConstantDistanceConstraint patella_r - tibia_r, distance 0.0635 m\n"),
            std::string::npos)
      << info;
  EXPECT_NE(info.find("tib_tuberosity           on tibia_r at 0.03789 -0.07142 0.00066\n"), std::string::npos) << info;
  EXPECT_NE(info.find("every component is simulated\n"), std::string::npos) << info;
  EXPECT_EQ(describeIgnoredKinematics(*m), "");
}

TEST(ModelInfo, NamesTheIgnoredComponentsThatPoseTheModel) {
  auto m = std::make_shared<Model>(*readOsim(test::sourcePath("tests/model/corpus/knee_patella_ligament.osim")));
  m->ignored.push_back({"Blankevoort1991Ligament", "mcl", "ligament", true});
  m->ignored.push_back({"Blankevoort1991Ligament", "lcl", "ligament", true});
  m->ignored.push_back({"Smith2018ArticularContactForce", "tf_contact", "contact", true});
  m->ignored.push_back({"Millard2012EquilibriumMuscle", "vasmed", "muscle", false});
  EXPECT_EQ(describeIgnoredKinematics(*m),
            m->source_file + ": 1 contact (Smith2018ArticularContactForce), 2 ligaments (Blankevoort1991Ligament) not "
                             "simulated; in OpenSim they help decide where the bodies go, here the kinematics ignore them");
  const std::string info = infoOf(*m);
  EXPECT_NE(info.find("4 components not simulated: 1 contact (Smith2018ArticularContactForce), 2 ligaments "
                      "(Blankevoort1991Ligament), 1 muscle (Millard2012EquilibriumMuscle)\n"),
            std::string::npos)
      << info;
  EXPECT_NE(info.find("vasmed                   Millard2012EquilibriumMuscle (muscle)\n"), std::string::npos) << info;
  EXPECT_NE(info.find("mcl                      Blankevoort1991Ligament (ligament, poses the model in OpenSim)\n"),
            std::string::npos)
      << info;
}

}  // namespace
}  // namespace kneesim::model
