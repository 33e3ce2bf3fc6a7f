#pragma once
// JW's 24-DOF knee model with the UF model's muscles carried onto it, as models/jw-knee24's
// <MuscleChain> does (tibial_tray on tibial_component, the patella re-framed), for the muscle tests.

#include <string>
#include <vector>

#include "model/osim_forces.hpp"
#include "model/osim_reader.hpp"
#include "muscle/adopt_muscles.hpp"
#include "support/test_data.hpp"

namespace kneesim::test {

inline const char* kJwUfModel = "kgc4-jw/model/jw_all_body_scaled.osim";

/// The UF model and the 24-DOF knee model.
struct JwModels {
  model::ModelPtr uf, knee;
};

inline JwModels loadJwModels() {
  return {model::readOsim(bundledDataPath(kJwUfModel)), model::readOsim(sourcePath("models/jw-knee24/jw_knee24.osim"))};
}

/// The UF muscles on the knee model, @p exclude left out by name.
inline muscle::AdoptedMuscles adoptJwMuscles(const JwModels& m, const std::vector<std::string>& exclude) {
  std::vector<muscle::BodyCorrespondence> map = {{"tibial_tray", "tibial_component", Eigen::Isometry3d::Identity()}};
  map.push_back(muscle::calcDefaultPoseCorrespondence(*m.knee, *m.uf, "patella", {"test", 0, ""}));
  return muscle::adoptMuscles(*m.knee, *m.uf, map, exclude, {"test", 0, ""});
}

/// adoptJwMuscles() with the reserves of models/jw-knee24/jw_muscle_reserves.xml.
inline model::ModelPtr makeJwMuscleModel() {
  const JwModels m = loadJwModels();
  return model::readOsimActuatorSet(sourcePath("models/jw-knee24/jw_muscle_reserves.xml"),
                                    adoptJwMuscles(m, {}).model, false);
}

}  // namespace kneesim::test
