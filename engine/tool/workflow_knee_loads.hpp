#pragma once
// The knee's net loads of a KneeContactWorkflow trial: the trial's InverseDynamicsTool setup (with
// <KneeLoads>) run on the trial's motion, and how each net load follows the measured eKnee forces
// (correlation over the trial and over its window, and the time shift that aligns them best).

#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "io/knee_forces.hpp"
#include "io/storage.hpp"
#include "tool/plot.hpp"

namespace kneesim::tool {

/// How one net knee load follows one measured force of a trial.
struct KneeLoadAgreement {
  std::string load;      ///< A knee load column, e.g. "knee_axial_force".
  std::string measured;  ///< "total", "medial" or "lateral".
  double r_trial = std::numeric_limits<double>::quiet_NaN();   ///< Pearson correlation over the trial's frames.
  double r_window = std::numeric_limits<double>::quiet_NaN();  ///< Over the window's frames.
  /// The shift (s) with measured(t) best correlated (largest |r|) with load(t - lag), within the
  /// largest lag asked for: positive when the measured force follows the load later.
  double lag = std::numeric_limits<double>::quiet_NaN();
  double r_at_lag = std::numeric_limits<double>::quiet_NaN();  ///< The correlation at that shift.
};

/// The knee's net loads of one trial.
struct TrialKneeLoads {
  std::string id_setup_file;
  io::Storage table;  ///< The InverseDynamicsTool's <KneeLoads> table, at the motion's frames.
  /// Each knee load column at the trial's frames (the workflow's time), in the table's order.
  std::vector<std::pair<std::string, std::vector<double>>> at_frames;
  std::vector<KneeLoadAgreement> agreement;
  double seconds = 0;  ///< Inverse dynamics, wall clock.
};

/// Runs the InverseDynamicsTool setup @p id_setup_file on @p motion (in place of its
/// coordinates_file; @p motion_file names it in messages) with its outputs redirected into
/// @p trial_dir as <trial>_id.sto, <trial>_knee_loads.sto, <trial>_joint_loads.sto and <trial>_grf.mot (with its .xml), staged in
/// @p stage; the tool's notes and warnings go to @p notes. Throws InputError at @p where when the
/// file is missing or has no <KneeLoads>, and the tool's own errors for bad input.
TrialKneeLoads runTrialKneeLoads(const std::string& id_setup_file, const io::Storage& motion,
                                 const std::string& motion_file, const std::string& trial,
                                 const std::string& trial_dir, const SourceLocation& where, AtomicFileSet& stage,
                                 std::vector<std::string>& notes);

/// Fills @p loads' at_frames (each knee load interpolated at @p time) and agreement (each load
/// against the total, medial and lateral forces of @p forces, given at @p time; the window is
/// [window_begin, window_end]; shifts up to @p max_lag seconds, by whole frames).
void compareKneeLoads(TrialKneeLoads& loads, const std::vector<double>& time, const io::KneeForces& forces,
                      double window_begin, double window_end, double max_lag = 0.2);

/// The plot of @p loads beside the measured forces of trial @p trial against @p x (its frames as
/// gait-cycle percent or time, @p xlabel): the measured total, medial and lateral forces and the
/// net axial force (N, left axis), the net flexion and adduction moments (N m, right axis). The
/// file name is left to the caller.
Plot makeKneeLoadPlot(const TrialKneeLoads& loads, const io::KneeForces& forces, const std::vector<double>& x,
                      const std::string& xlabel, const std::string& trial);

/// The agreement of @p loads for summary.json: the setup, the knee-load file's columns and units,
/// and one entry per load and measured force (and the seconds taken with @p timings).
nlohmann::json toJson(const TrialKneeLoads& loads, bool timings = true);

}  // namespace kneesim::tool
