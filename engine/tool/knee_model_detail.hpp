#pragma once
// Internal to the knee model builder (tool/knee_model.hpp): what its setup reading
// (knee_model_setup.cpp) and its build (knee_model.cpp) share.

namespace kneesim::tool::detail {

inline constexpr double kDeg = 3.14159265358979323846 / 180.0;

/// The bodies of the built model, pelvis to toes, in the order of the source model's parts.
inline const char* const kKneeModelBodyNames[9] = {"pelvis", "femur",   "femoral_component", "tibial_component", "tibia",
                                                   "patella", "talus", "calcaneus",         "toes"};

}  // namespace kneesim::tool::detail
