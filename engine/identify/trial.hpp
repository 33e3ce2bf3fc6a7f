#pragma once
// Trials for identification: per-frame inputs and measured force, time windows and phases.

#include <limits>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "identify/contact_law.hpp"

namespace kneesim::identify {

/// A closed time interval [begin, end] in seconds.
struct TimeWindow {
  double begin = -std::numeric_limits<double>::infinity();
  double end = std::numeric_limits<double>::infinity();
};

/// One recorded trial: the law's input channels and the measured knee force per frame.
struct Trial {
  std::string name;                  ///< E.g. "ngait_og3"; used in reports and messages.
  std::vector<double> time;          ///< Frame times, s, strictly increasing.
  ChannelMap channels;               ///< Input channels ("S", "S_medial", ...), one value per frame, SI.
  std::vector<double> measured_force;  ///< Measured force per frame, N (e.g. eKnee medial + lateral).
  std::vector<double> weight;        ///< Optional per-frame weight (>= 0) in the fit; empty means 1.
  std::vector<TimeWindow> windows;   ///< Frames used; empty means every frame.
  SourceLocation source;             ///< Where the trial was defined (setup file), for messages.
};

/// A named part of a trial (e.g. "stance") for reporting errors separately.
struct Phase {
  std::string name;
  double begin = 0;  ///< Seconds, or a fraction of the trial's duration if fraction_of_trial.
  double end = 1;
  bool fraction_of_trial = false;  ///< begin/end are fractions: t = t0 + f (t_last - t0).
};

/// Where messages about @p trial point: its source, or @p fallback when the source is empty.
const SourceLocation& locate(const Trial& trial, const SourceLocation& fallback);

/// Throws InputError at locate(trial, fallback) if the trial is malformed: no frames, time not
/// strictly increasing or not finite, measured_force/weight/channels of the wrong length, negative
/// or non-finite weights, a window with begin > end.
void checkTrial(const Trial& trial, const SourceLocation& fallback = {});

/// Indices of the frames inside any of the trial's windows (all frames if it has none), in order.
/// Throws InputError at locate(trial, fallback) naming the trial, its windows and its time range
/// if none is selected.
std::vector<int> selectFrames(const Trial& trial, const SourceLocation& fallback = {});

/// Indices of @p frames (a selection, e.g. from selectFrames) that fall inside @p phase. May be empty.
std::vector<int> selectPhase(const Trial& trial, const std::vector<int>& frames, const Phase& phase);

/// The phase's interval in seconds for @p trial.
TimeWindow resolvePhase(const Trial& trial, const Phase& phase);

}  // namespace kneesim::identify
