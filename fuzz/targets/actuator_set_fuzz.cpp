// Fuzz target: actuator (force set) files added to a model, as the analyze tool's
// <force_set_files> and the workflow's muscle chain name them (model::readOsimActuatorSet), on
// OpenSim's arm26 model (muscles, coordinates to actuate).
#include "harness.hpp"
#include "model/osim_forces.hpp"
#include "model/osim_reader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const kneesim::model::ModelPtr model =
      kneesim::model::readOsim(KNEESIM_DATA_DIR "/opensim-dynamics-tests/so/arm26.osim");
  return kneesim::fuzz::runReader(data, size, ".xml", [](const std::string& path) {
    kneesim::model::readOsimActuatorSet(path, model, false);
  });
}
