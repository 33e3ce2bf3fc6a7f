#pragma once
// The IK round trip of a model: poses near its default one (on its constraints), the markers
// they put in the laboratory, and inverse kinematics recovering them. A model that loads and
// passes it is usable for IK; `kneesim model check` and tools/model-corpus.sh run it.

#include <string>

#include "model/model.hpp"

namespace kneesim::ik {

/// What a round trip measured.
struct RoundTripResult {
  int frames = 0;
  int markers = 0;                 ///< Markers tracked.
  bool synthetic_markers = false;  ///< The model has none: three per body were made up.
  double rms_error = 0;            ///< Largest per-frame marker RMS after IK (m).
  double max_error = 0;            ///< Largest marker error after IK (m).
  double max_constraint_error = 0; ///< Largest constraint violation after IK (m or rad).
  bool converged = true;           ///< Every frame's solve converged.
};

/// Runs the round trip over @p frames poses: each coordinate moved from its default by up to
/// 0.2 rad or 0.01 m (within its range; locked ones stay), couplers and constraints applied,
/// markers (the model's, else three per body) computed with Simbody, then IK from the default
/// pose. Throws InputError if Simbody rejects the model.
RoundTripResult runRoundTrip(const model::ModelPtr& model, int frames = 5);

}  // namespace kneesim::ik
