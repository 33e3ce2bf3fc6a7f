#pragma once
// The trial-inputs seam of the gap diagnosis: one recording's channels (contact areas, flexion and
// its rate, ground reaction force, EMG envelopes), its measured total/medial/lateral knee force,
// and its cycles (gait events from the force plates, the knee force or the flexion), on one time
// base, ready for identify::fit().
//
// The contact-area channels come from the .sto the contact-area tool writes per trial (columns
// time, S, S_medial, S_lateral (m^2), dmin, dmin_medial, dmin_lateral (m), centroids, dS_dt and
// "S@2mm", "S@3mm", "S@5mm", "S@6mm"); every column of that file becomes a channel. Flexion comes
// from that file's knee_flexion column, an IK motion, or the eKnee goniometer (GON, through
// io::calcKneeFlexionDeg). The KneeContactWorkflow writes such files with the flexion and, with
// area_derivatives, the exact dS_dflexion and dS_dap.

#include <map>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "identify/trial.hpp"
#include "io/goniometer.hpp"

namespace kneesim::gap {

/// A named part of an activity's cycle, as fractions of the normalised cycle [0, 1].
struct PhaseDefinition {
  std::string name;
  double begin = 0, end = 1;
};

/// How an activity's cycle is normalised and divided into phases.
struct ActivityDefinition {
  std::string name;  ///< "gait", "stair", "chair" or any other.
  /// Where the cycle's middle event (toe-off, foot off, start of sitting down) sits in the
  /// normalised cycle: start -> mid maps to [0, mid_fraction], mid -> end to [mid_fraction, 1].
  double mid_fraction = 0.5;
  std::vector<PhaseDefinition> phases;
};

/// The built-in definitions: "gait" (Perry: loading response 0-12 %, mid-stance 12-31 %, terminal
/// stance 31-50 %, pre-swing 50-62 %, swing 62-100 %, toe-off at 62 %), "stair" (ascent, McFadyen &
/// Winter 1988: weight acceptance 0-14 %, pull-up 14-32 %, forward continuance 32-64 %, foot
/// clearance 64-82 %, foot placement 82-100 %, foot off at 64 %), "chair" (sit-stand-sit from the
/// start of rising: rise 0-25 %, standing 25-50 %, sit-down 50-80 %, seated 80-100 %, start of
/// sitting down at 50 %); any other name gets quarters with the middle event at 50 %.
ActivityDefinition getActivityDefinition(const std::string& name);

/// One cycle of a recording: a unit of cross-validation and of cycle normalisation.
struct Cycle {
  double start = 0;         ///< s: the event opening the cycle (heel strike, foot contact, start of rising).
  double mid = 0;           ///< s: the middle event (toe-off, foot off, start of sitting); NaN if unknown.
  double end = 0;           ///< s: the next opening event.
  bool start_estimated = false;  ///< The recording starts inside this cycle: start extrapolated.
  bool end_estimated = false;    ///< The recording ends inside this cycle: end extrapolated.
  double begin_time = 0;    ///< s: the first frame of the recording in this cycle.
  double end_time = 0;      ///< s: the last frame of the recording in this cycle.
};

/// One recording prepared for the diagnosis.
struct GapTrial {
  identify::Trial trial;             ///< Channels, time and the measured TOTAL force (N).
  std::string activity;              ///< Activity name (getActivityDefinition).
  std::vector<double> medial, lateral;  ///< Measured compartment forces (Dao & Pouletaut eq. 4), N.
  std::vector<Cycle> cycles;         ///< In time order, covering every frame.
  /// Per frame: normalised cycle position in [0, 1); NaN before an extrapolated cycle start (the
  /// recording's first event comes more than a typical cycle after its start).
  std::vector<double> cycle_phase;
  std::vector<int> cycle_index;      ///< Per frame: index into cycles.
  std::string event_source;          ///< "force plates", "knee force", "flexion" or "setup".
  bool interim_inputs = false;       ///< The area file is marked kneesim_interim=true (a stand-in, not computed areas).
  std::vector<std::string> notes;    ///< Where each channel came from, in plain language.

  /// Number of frames.
  int getNumFrames() const { return static_cast<int>(trial.time.size()); }
};

/// Where one trial's inputs come from (a <Trial> of the gap setup file).
struct TrialSource {
  std::string name;                ///< E.g. "ngait_og3".
  std::string activity = "gait";
  std::string knee_forces;         ///< eKnee CSV (PM, AM, AL, PL in lbf; GON); empty: no measured force.
  std::string contact_area;        ///< The contact-area tool's .sto for this trial.
  std::string c3d;                 ///< Optional: force plates and EMG (and the C3D clock).
  std::string kinematics;          ///< Optional IK motion (.mot) with the flexion column.
  /// Optional: the knee's net loads from inverse dynamics (the InverseDynamicsTool's
  /// <KneeLoads> file); its knee_* columns become channels of the same names.
  std::string knee_loads;
  std::string flexion_column = "knee_flexion";
  /// "auto" (the area file's knee_flexion column, else the kinematics, else GON), "area",
  /// "kinematics" or "gon".
  std::string flexion_source = "auto";
  /// Flexion from GON (flexion source "gon"): io::calcKneeFlexionDeg with this calibration, the
  /// same the workflow uses (volts -> goniometer degrees when the CSV is in volts, then the line to
  /// the model's knee flexion). Default: JW's (io/goniometer.hpp).
  io::GoniometerCalibration goniometer;
  /// N per unit of the knee-force CSV's GRFz column, used as GRF:vertical when the trial has no
  /// C3D (0: not used). JW: io::kJwCsvGrfNewtonsPerUnit; the column is force plate 1, so this
  /// assumes plate 1 was under the instrumented (right) foot (true in stairupf1, not in ngait_og3).
  double knee_forces_grf_scale = 0;
  /// "auto" (plates for gait and stair with a C3D, flexion for chair, else the knee force),
  /// "plates", "force", "flexion" or "times" (event_times).
  std::string events = "auto";
  std::vector<double> event_times;  ///< Cycle starts in s, for events = "times".
  identify::TimeWindow time_range;  ///< Frames kept (intersected with the data's overlap).
  /// EMG channels (C3D labels) averaged into the flexor and extensor envelopes of
  /// EMG:cocontraction = min(flexors, extensors).
  std::vector<std::string> emg_flexors{"bifeml", "semimem", "medgas", "latgas"};
  std::vector<std::string> emg_extensors{"vasmed", "vaslat", "rf"};
  SourceLocation where;            ///< The setup element, for messages.
};

/// Reads and aligns one trial's inputs. Without a knee-force file (source.knee_forces empty) the frames
/// are the contact-area file's and the measured forces NaN: such a trial can be predicted
/// (gap/prediction.hpp), not diagnosed. Throws InputError (at source.where or naming the file) for
/// a missing file or column, areas that are not in m^2 (a peak above 0.1 m^2), sources whose
/// times do not overlap, or no cycle found. EMG envelopes stay in volts until normalizeEmg.
GapTrial assembleTrial(const TrialSource& source);

/// Normalises every EMG:<label> channel by its largest envelope over all @p trials (so the
/// channels are 0..1 and comparable between trials), drops channels that are dead in any trial
/// (raw peak-to-peak below 0.1 V; their labels are returned), and adds EMG:cocontraction =
/// min(mean flexor envelope, mean extensor envelope) to the trials that have EMG.
/// With @p given_peaks (label -> envelope peak, in volts) the channels are normalised by those instead
/// (how a gap model fitted on other trials is applied; channels it lacks are dropped); @p peaks_used,
/// when given, receives the peaks used.
std::vector<std::string> normalizeEmg(std::vector<GapTrial>& trials, const std::vector<std::string>& flexors,
                                      const std::vector<std::string>& extensors,
                                      const std::map<std::string, double>* given_peaks = nullptr,
                                      std::map<std::string, double>* peaks_used = nullptr);

/// Cycles of a recording from opening events @p starts (s, increasing) and middle events @p mids
/// (any order, matched to the cycle they fall in) over frames @p time; the frames before the first
/// and after the last event form cycles with extrapolated ends (duration of the neighbouring
/// complete cycle, else the recording's). Fills trial.cycles, cycle_phase and cycle_index.
void setCycles(GapTrial& trial, const std::vector<double>& starts, const std::vector<double>& mids);

/// Rising (up = true) or falling crossings of @p level by @p x over @p t, with hysteresis
/// @p hysteresis (the signal must return past level -/+ hysteresis between crossings) and at least
/// @p min_separation s between crossings of the same sense. Times are interpolated between frames.
std::vector<double> findCrossings(const std::vector<double>& t, const std::vector<double>& x, double level,
                                  double hysteresis, bool up, double min_separation);

/// The channel @p name of a trial, or throws InternalError naming it.
const std::vector<double>& getChannel(const GapTrial& trial, const std::string& name);

}  // namespace kneesim::gap
