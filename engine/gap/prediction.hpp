#pragma once
// The gap model: what a diagnosis selected -- per target, the baseline law extended by the selected
// effects with every parameter as fitted on all cycles -- saved as gap_model.json next to the report,
// and its prediction on trials without force data (`kneesim gap SETUP --predict gap_model.json`),
// written as <trial>_predicted.sto (total, medial, lateral force).

#include <map>
#include <string>
#include <utility>
#include <vector>

#include "gap/diagnosis.hpp"
#include "io/storage.hpp"

namespace kneesim::plugin {
class Registry;
}

namespace kneesim::gap {

/// The selected model of one target.
struct TargetModel {
  std::string target;                ///< "total", "medial" or "lateral".
  std::string law;                   ///< The extended law's name ("hertz+grf_load").
  std::vector<std::string> effects;  ///< The selected effects, in order (empty: the baseline).
  /// Every parameter of the extended law (table order) with its value fitted on all cycles.
  std::vector<std::pair<std::string, double>> parameters;
  std::string verdict_class, verdict;
  double heldout_rmse = 0;           ///< Withheld RMSE of this model in the diagnosis, N.
};

/// What gap_model.json holds.
struct GapModel {
  std::string source;                    ///< The setup file of the diagnosis.
  std::vector<std::string> plugins;      ///< Plugins to load (the law's and the effects').
  std::string law;                       ///< The baseline law.
  std::vector<std::string> trials;       ///< Trials it was fitted on.
  bool synthetic = false, interim_inputs = false;
  /// EMG envelope peaks (V) it normalised EMG channels by: prediction uses the same (normalizeEmg).
  std::map<std::string, double> emg_peaks;
  std::vector<TargetModel> targets;
};

/// The model a diagnosis selected (GapReport::plugins and emg_peaks filled by the gap tool).
GapModel makeGapModel(const GapReport& report);
/// gap_model.json's text.
std::string formatGapModel(const GapModel& model);
/// Reads gap_model.json; a one-line InputError for a malformed or incomplete file.
GapModel readGapModel(const std::string& path);

/// One trial's predicted forces.
struct TrialPrediction {
  std::string trial, activity;
  std::vector<double> time, phase;
  std::map<std::string, std::vector<double>> predicted;  ///< Per target, N.
  std::map<std::string, std::vector<double>> measured;   ///< Per target where the trial has forces, N.
  /// Per target with a measured force: RMSE of the prediction against it, N.
  std::map<std::string, double> rmse;
};

/// Predicts every target of @p model on @p trials (EMG already normalised by model.emg_peaks), the
/// effects taken from @p registry. Throws InputError naming the parameter or channel a model or trial
/// lacks.
std::vector<TrialPrediction> predictTrials(const GapModel& model, const plugin::Registry& registry,
                                           const std::vector<GapTrial>& trials, const std::string& where = "");

/// A prediction as a storage: time, cycle_phase, then per target "<target>" (predicted) and, where the
/// trial has forces, "<target>_measured".
io::Storage toStorage(const TrialPrediction& prediction);

}  // namespace kneesim::gap
