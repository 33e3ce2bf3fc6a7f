#include "gap_commands.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include "core/error.hpp"
#include "core/strings.hpp"
#include "gap/synth.hpp"
#include "gap/tool.hpp"
#include "io/storage.hpp"
#include "plugin/registry.hpp"

namespace kneesim::cli {

namespace fs = std::filesystem;

void addGapCommands(CLI::App& app, GapCommandState& s) {
  s.gap = app.add_subcommand("gap", "Sim-to-real gap diagnosis from a <GapTool> setup file");
  s.gap->add_option("setup", s.setup, "GapTool setup XML")->required();
  s.gap->add_option("--areas", s.areas, "Folder holding the contact-area .sto files (replaces their folder in the setup)");
  s.gap->add_option("--workflow-results", s.workflow_results,
                    "A KneeContactWorkflow's results folder: each trial reads <dir>/<trial>/<trial>_contact_area.sto");
  s.gap->add_option("-o,--output", s.output, "Results folder (default: the setup's results_directory)");
  s.gap
      ->add_option("--targets", s.targets,
                   "total, medial and/or lateral, comma- or space-separated (default: the setup's)")
      ->delimiter(',');
  s.gap->add_option("--trials", s.trials, "Comma-separated trial names of the setup to use (default: all)");
  s.gap->add_flag("--no-plots", s.no_plots, "Do not run gnuplot");
  s.gap->add_option("--predict", s.predict,
                    "Apply a diagnosis's gap_model.json to the setup's trials (knee forces not needed) and write "
                    "<trial>_predicted.sto (total, medial, lateral) instead of diagnosing");

  s.synth = app.add_subcommand(
      "synth", "Synthetic trials with hidden effects from a GapTool setup's inputs, diagnosed blind");
  s.synth->add_option("setup", s.setup, "GapTool setup XML naming the trials whose inputs drive the synthetic ones")
      ->required();
  s.synth->add_option("--trials", s.trials, "Comma-separated trial names to use (default: all with a C3D)");
  s.synth->add_option("--areas", s.areas, "Folder holding the contact-area .sto files");
  s.synth->add_option("--workflow-results", s.workflow_results,
                      "A KneeContactWorkflow's results folder: each trial reads <dir>/<trial>/<trial>_contact_area.sto");
  s.synth->add_option("--effect", s.effects, "Injected effect, name:param=value (repeatable)");
  s.synth->add_option("--outside", s.outside, "Injected force outside the catalogue, phase_bump:SIZE_N");
  s.synth->add_option("--noise", s.noise, "SD of the smooth between-cycle noise, N (default 100)");
  s.synth->add_option("--replicates", s.replicates, "Synthetic recordings per source trial (default 3)");
  s.synth->add_option("--seed", s.seed, "Seed (default 1)");
  s.synth->add_option("-o,--output", s.output, "Results folder of the synthetic diagnosis");
  s.synth->add_flag("--blind-suite", s.blind_suite, "Run the blind suite and print its confusion matrix");
  s.synth->add_option("--seeds", s.seeds, "Seeds per case of the blind suite (default 20)");
  s.synth->add_option("--folds", s.folds, "Cross-validation folds of the blind suite (default 5)");
  s.synth->add_flag("--details", s.details, "With --blind-suite: print how each blind diagnosis reached its answer");
  s.synth->add_option("--cases", s.cases, "Comma-separated blind cases to run: default case names and/or custom ones, effect:param=value (default: all default cases)");
}

bool isGapCommand(const GapCommandState& s) { return (s.gap && *s.gap) || (s.synth && *s.synth); }

namespace {

void progressBar(int done, int total) {
  static const bool tty = isatty(fileno(stderr));
  if (!tty || total <= 0) return;
  std::fprintf(stderr, "\rblind    %d/%d", done, total);
  if (done == total) std::fprintf(stderr, "\n");
}

gap::InjectedEffect parseEffect(const std::string& text, const std::string& option = "--effect") {
  // name:param=value
  const auto colon = text.find(':'), eq = text.find('=');
  if (colon == std::string::npos || eq == std::string::npos || eq < colon)
    throw InputError({"(command line)", 0, option}, "expected name:param=value, got '" + text + "'");
  gap::InjectedEffect e;
  e.effect = text.substr(0, colon);
  e.values[text.substr(colon + 1, eq - colon - 1)] =
      parseDouble(text.substr(eq + 1), {"(command line)", 0, option});
  return e;
}

// Keeps the trials named in @p list (comma-separated); throws for a name the setup lacks.
void selectTrials(gap::GapSetup& setup, const std::string& list) {
  std::vector<gap::TrialSource> keep;
  for (const auto& name : splitOn(list, ',')) {
    bool found = false;
    for (const auto& t : setup.trials)
      if (t.name == name) keep.push_back(t), found = true;
    if (!found) {
      std::string have;
      for (const auto& t : setup.trials) have += (have.empty() ? "" : ", ") + t.name;
      throw InputError({"(command line)", 0, "--trials"},
                       "expected trial names of the setup (" + have + "), got '" + std::string(name) + "'");
    }
  }
  setup.trials = keep;
}

// The default blind cases named in @p list (comma-separated); throws for an unknown name.
std::vector<gap::BlindCase> selectCases(const std::string& list) {
  const std::vector<gap::BlindCase> all = gap::getDefaultBlindCases();
  std::vector<gap::BlindCase> keep;
  for (const auto& name : splitOn(list, ',')) {
    if (name.find(':') != std::string::npos) {
      // A custom single-effect case, effect:param=value, whose right answer is that effect.
      gap::BlindCase c;
      c.name = std::string(name);
      c.effects = {parseEffect(c.name, "--cases")};
      c.expected = c.effects.front().effect;
      keep.push_back(c);
      continue;
    }
    bool found = false;
    for (const auto& c : all)
      if (c.name == name) keep.push_back(c), found = true;
    if (!found) {
      std::string have;
      for (const auto& c : all) have += (have.empty() ? "" : ", ") + c.name;
      throw InputError({"(command line)", 0, "--cases"},
                       "expected blind case names (" + have + "), got '" + std::string(name) + "'");
    }
  }
  return keep;
}

void runSynth(const GapCommandState& st, bool quiet) {
  // Command-line values first: a typo must not wait for the trials to load.
  auto bad = [](const char* option, const std::string& what) { throw InputError({"(command line)", 0, option}, what); };
  if (!(st.noise >= 0 && std::isfinite(st.noise)))
    bad("--noise", "expected a standard deviation >= 0 N, got " + formatSignificant(st.noise, 6));
  if (st.replicates < 1) bad("--replicates", "expected at least 1, got " + std::to_string(st.replicates));
  if (st.seeds < 1) bad("--seeds", "expected at least 1, got " + std::to_string(st.seeds));
  if (st.folds < 0 || st.folds == 1)
    bad("--folds", "expected 0 (leave one cycle out) or at least 2, got " + std::to_string(st.folds));
  const std::vector<gap::BlindCase> cases = st.cases.empty() ? std::vector<gap::BlindCase>{} : selectCases(st.cases);
  gap::GapSetup setup = gap::readGapSetup(st.setup);
  if (!st.trials.empty()) {
    selectTrials(setup, st.trials);
  } else {
    std::vector<gap::TrialSource> keep;
    for (const auto& t : setup.trials)
      if (!t.c3d.empty()) keep.push_back(t);
    if (!keep.empty()) setup.trials = keep;
  }
  if (!st.workflow_results.empty()) gap::setWorkflowResults(setup, st.workflow_results);
  if (!st.areas.empty()) gap::setContactAreaDirectory(setup, st.areas);
  plugin::Registry reg;
  for (const auto& p : setup.plugins) reg.loadPlugin(p, {st.setup, 0, "GapTool/plugins"});
  const identify::ContactLaw law = identify::ContactLaw::fromRegistry(reg, setup.law, {st.setup, 0, "GapTool/law"});
  std::vector<gap::Effect> catalogue;
  for (const auto& n : setup.effects.empty() ? reg.getEffectNames() : setup.effects)
    catalogue.push_back(gap::Effect::fromRegistry(reg, n));
  std::vector<gap::GapTrial> sources;
  for (const auto& t : setup.trials) sources.push_back(gap::assembleTrial(t));
  gap::normalizeEmg(sources, setup.trials.front().emg_flexors, setup.trials.front().emg_extensors);

  // The synthetic baseline: the law fitted to the sources' measured forces, so the synthetic
  // forces have the real magnitude.
  gap::SynthOptions so;
  so.base_values = gap::fitSyntheticBaseline(law, sources, setup.options.fit);
  so.noise_sd = st.noise;
  so.replicates = st.replicates;
  so.seed = st.seed;
  for (const auto& e : st.effects) so.effects.push_back(parseEffect(e));
  if (!st.outside.empty()) {
    const auto colon = st.outside.find(':');
    so.outside = st.outside.substr(0, colon);
    so.outside_size = colon == std::string::npos ? 400.0 : parseDouble(st.outside.substr(colon + 1), {"(command line)", 0, "--outside"});
  }
  gap::DiagnosisOptions dopt = setup.options;
  dopt.fit.confidence.profile = false;
  dopt.fit.confidence.bootstrap_samples = 0;
  if (st.blind_suite) {
    gap::BlindSuiteOptions bo = gap::getStandardBlindSuiteOptions(setup.options.fit, st.seeds);
    bo.synth.base_values = so.base_values;
    bo.synth.noise_sd = st.noise;
    bo.synth.replicates = st.replicates;
    bo.diagnosis.cv_folds = st.folds;
    bo.cases = cases;
    if (!quiet) bo.progress = progressBar;
    const gap::BlindSuiteResult res = gap::runBlindSuite(law, catalogue, sources, bo);
    if (st.details)
      for (const auto& out : res.outcomes) {
        std::cout << out.case_name << " seed " << out.seed << ": " << out.answer
                  << (out.correct ? " (right)" : " (wrong)") << "\n";
        for (const auto& line : out.trace) std::cout << "  " << line << "\n";
      }
    std::cout << res.formatMarkdown() << "\n"
              << res.outcomes.size() << " blind diagnoses (" << st.seeds << " seeds per case, " << st.replicates
              << " replicates of " << sources.size() << " trial(s), noise " << st.noise << " N, "
              << (st.folds == 0 ? std::string("leave-one-cycle-out") : std::to_string(st.folds) + "-fold")
              << " cross-validation) in " << res.seconds << " s\n";
    return;
  }
  std::vector<gap::GapTrial> trials = gap::makeSyntheticTrials(law, catalogue, sources, so);
  gap::GapReport rep = gap::diagnose(law, catalogue, trials, dopt);
  std::string injected;
  for (const auto& e : so.effects)
    for (const auto& [p, v] : e.values) injected += (injected.empty() ? "" : ", ") + e.effect + "." + p + " = " + std::to_string(v);
  if (!so.outside.empty()) injected += (injected.empty() ? "" : ", ") + so.outside + " " + std::to_string(so.outside_size) + " N";
  rep.synthetic = true;
  rep.notes.insert(rep.notes.begin(), "SYNTHETIC trials (seed " + std::to_string(so.seed) + ", noise " +
                                          std::to_string(so.noise_sd) + " N): injected " +
                                          (injected.empty() ? std::string("nothing") : injected));
  const std::string dir = st.output.empty() ? setup.results_directory + "_synthetic" : st.output;
  gap::GapRunResult res;
  res.report = rep;
  res.directory = dir;
  res.files = gap::writeGapReport(dir, rep, setup.report);
  if (!quiet) gap::printGapSummary(res, std::cout);
}

}  // namespace

void runGapCommand(const GapCommandState& st, bool quiet) {
  if (st.synth && *st.synth) return runSynth(st, quiet);
  for (const auto& target : st.targets)
    if (const std::string why = gap::findTargetProblem(target); !why.empty())
      throw InputError({"(command line)", 0, "--targets"}, why);
  gap::GapSetup setup = gap::readGapSetup(st.setup);
  if (!st.trials.empty()) selectTrials(setup, st.trials);
  if (!st.workflow_results.empty()) gap::setWorkflowResults(setup, st.workflow_results);
  if (!st.areas.empty()) gap::setContactAreaDirectory(setup, st.areas);
  if (!st.output.empty()) setup.results_directory = st.output;
  if (!st.predict.empty()) {
    const gap::PredictRunResult p = gap::runPredict(setup, st.predict, [&](const std::string& m) {
      if (!quiet) std::cerr << m << "\n";
    });
    if (!quiet) gap::printPredictSummary(p, std::cout);
    return;
  }
  if (!st.targets.empty()) setup.options.targets = st.targets;
  if (st.no_plots) setup.report.plots = false;
  const gap::GapRunResult r = gap::runGap(setup, [&](const std::string& m) {
    if (!quiet) std::cerr << m << "\n";
  });
  if (!quiet) gap::printGapSummary(r, std::cout);
}

}  // namespace kneesim::cli
