#pragma once
// Expanding a batch manifest into per-trial setup files: what each row means (batch_manifest.hpp
// reads the table), where the trial's outputs go, and the kneesim setup files that run it.
//
// Every trial gets its own folder <output>/<subject>/<trial>/ and every file in it starts with
// <subject>_<trial>, so parallel runs never write the same file (OpenSim's tools write fixed names
// such as `_ik_marker_errors.sto` into a shared folder: opensim-core#2564). The folder holds:
//   <name>_batch.xml      the BatchTrial setup (batch_trial.hpp): `kneesim run` on it runs the trial
//   <name>_ik.xml, <name>_contact.xml, <name>_workflow.xml   one setup per tool, runnable alone
//   <name>.log            what the trial's run printed
//   <name>_summary.json   the trial's figures, <name>.done its completion marker, <name>.failed
// Setup files name inputs by absolute paths and outputs relative to the folder, so a trial run
// from its folder writes the same bytes wherever the output tree lies.

#include <string>
#include <utility>
#include <vector>

#include "core/error.hpp"
#include "tool/batch_manifest.hpp"

namespace kneesim::tool {

/// One manifest row, checked: absolute input paths, defaults applied.
struct BatchTrialSpec {
  std::string subject, trial;
  std::string name;  ///< <subject>_<trial>: the prefix of every file of the trial.
  std::vector<std::string> tools;  ///< In the order they run: ik, contact, workflow.
  std::string activity;
  std::string model, markers, ik_tasks, motion, knee_forces, c3d;
  std::string time_range, marker_rotation;  ///< As written ("" : none).
  double accuracy = 1e-5;
  std::string window;  ///< stance, cycle, trial or "begin end".
  std::string femoral_component, insert;
  std::string femoral_body = "femoral_component", insert_body = "tibial_component";
  std::string femoral_mesh, insert_mesh;
  double threshold = 0.004;
  std::string distance_provider = "fcl";
  double body_mass = 0;  ///< kg (0: unknown).
  bool plots = false;
  SourceLocation where;  ///< The manifest row.
};

/// One trial of a batch: where its files go and the setup files that run it.
struct BatchTrialPlan {
  BatchTrialSpec spec;
  std::string folder;      ///< <output>/<subject>/<trial> (absolute).
  std::string setup_file;  ///< The BatchTrial setup in the folder.
  /// The setup files to write: (path, contents); the BatchTrial setup first, then one per tool.
  std::vector<std::pair<std::string, std::string>> setup_files;
  std::string setup_hash;  ///< calcSetupHash of the setup files' contents.
  std::string log_file, summary_file, completion_file, failure_file;
  /// "subject/trial", for messages.
  std::string label() const { return spec.subject + "/" + spec.trial; }
};

/// Checks a manifest row and gives it meaning: paths resolved against the manifest's folder and
/// made absolute, defaults applied. Throws InputError at the cell for a missing required column,
/// an unknown tool, a tool without its inputs (ik without markers, contact or workflow without a
/// motion, implant meshes or knee forces), a bad number, a name with characters other than
/// letters, digits and . _ -, or an input file that does not exist.
BatchTrialSpec readBatchTrialSpec(const ManifestRow& row, const std::string& manifest_dir);

/// Plans every row of @p manifest under @p output_dir (made absolute). Throws InputError for a
/// bad row (readBatchTrialSpec) or two rows with the same subject and trial (at the second).
std::vector<BatchTrialPlan> planBatch(const Manifest& manifest, const std::string& output_dir);

/// A hash (64-bit FNV-1a, hexadecimal) of the contents of a trial's setup files, in order: the
/// completion marker records it so that a finished trial whose row changed is run again.
std::string calcSetupHash(const std::vector<std::string>& contents);

/// Writes the plan's setup files (atomically; a file whose contents are already those is left
/// untouched) and creates its folder.
void writeTrialSetups(const BatchTrialPlan& plan);

}  // namespace kneesim::tool
