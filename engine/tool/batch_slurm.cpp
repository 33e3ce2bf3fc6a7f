// Writes the sbatch scripts of a batch: a job array with one task per trial and a dependent summary.
#include "tool/batch_slurm.hpp"

#include <filesystem>
#include <sstream>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/paths.hpp"
#include "core/strings.hpp"

namespace kneesim::tool {

namespace fs = std::filesystem;

namespace {

void checkOption(const std::string& value, const std::string& what) {
  if (value.find_first_of("\n\r") != std::string::npos)
    throw InputError({"kneesim batch", 0, what}, "expected one line, got a line break");
}

// The #SBATCH lines both jobs share: where they run.
std::string placement(const SlurmOptions& o) {
  std::string s;
  if (!o.partition.empty()) s += "#SBATCH --partition=" + o.partition + "\n";
  if (!o.account.empty()) s += "#SBATCH --account=" + o.account + "\n";
  for (const std::string& e : o.extra) s += "#SBATCH " + e + "\n";
  return s;
}

void writeScript(const std::string& path, const std::string& text) {
  writeFileAtomically(path, [&](std::ostream& os) { os << text; });
  fs::permissions(path, fs::perms::owner_exec | fs::perms::group_exec | fs::perms::others_exec, fs::perm_options::add);
}

}  // namespace

SlurmJobFiles writeSlurmJob(const std::string& dir, const std::vector<const BatchTrialPlan*>& trials,
                            const std::string& manifest, const std::string& output_dir, const SlurmOptions& o) {
  if (trials.empty()) throw InputError({manifest, 0, ""}, "expected trials to submit, got none (all finished?)");
  for (const std::string* v : {&o.job_name, &o.partition, &o.account, &o.time, &o.mem, &o.kneesim}) checkOption(*v, "slurm option");
  for (const std::string& e : o.extra) checkOption(e, "slurm option");
  const fs::path d = fs::absolute(fs::path(dir)).lexically_normal();
  createFolder(d / "logs");
  SlurmJobFiles f;
  f.tasks = int(trials.size());
  f.trial_list = (d / "kneesim_trials.txt").string();
  f.array_script = (d / "kneesim_array.sbatch").string();
  f.summary_script = (d / "kneesim_summary.sbatch").string();
  f.submit_script = (d / "submit.sh").string();
  const std::string logs = (d / "logs").string();
  const std::string kneesim = "KNEESIM=\"${KNEESIM:-" + o.kneesim + "}\"\n";

  std::ostringstream list;
  for (const BatchTrialPlan* p : trials) list << p->setup_file << "\n";
  writeFileAtomically(f.trial_list, [&](std::ostream& os) { os << list.str(); });

  std::ostringstream a;
  a << "#!/bin/bash\n"
    << "# One Slurm array task per trial: task i runs `kneesim run` on line i of kneesim_trials.txt from the\n"
    << "# trial's folder, its output in the trial's log, as `kneesim batch` does. Written by\n"
    << "# `kneesim batch " << manifest << " --emit-slurm`; submit with submit.sh, which also queues the summary.\n"
    << "#SBATCH --job-name=" << o.job_name << "\n"
    << "#SBATCH --array=1-" << f.tasks << (o.max_running > 0 ? "%" + std::to_string(o.max_running) : "") << "\n"
    << "#SBATCH --ntasks=1\n#SBATCH --cpus-per-task=" << o.cpus_per_task << "\n"
    << "#SBATCH --mem=" << o.mem << "\n#SBATCH --time=" << o.time << "\n"
    << placement(o) << "#SBATCH --output=" << logs << "/%x_%A_%a.out\n"
    << "set -u\n" << kneesim
    << "setup=\"$(sed -n \"${SLURM_ARRAY_TASK_ID}p\" " << shellQuote(f.trial_list) << ")\"\n"
    << "if [ -z \"$setup\" ]; then echo \"no trial for array task ${SLURM_ARRAY_TASK_ID}\" >&2; exit 1; fi\n"
    << "cd \"$(dirname \"$setup\")\" || exit 1\n"
    << "name=\"$(basename \"$setup\" _batch.xml)\"\n"
    << "echo \"kneesim: trial $name in $(pwd), log $name.log\"\n"
    << "exec \"$KNEESIM\" run \"$(basename \"$setup\")\" > \"$name.log\" 2>&1\n";
  writeScript(f.array_script, a.str());

  std::ostringstream s;
  s << "#!/bin/bash\n"
    << "# The summary of the batch once every array task has ended, however it ended (afterany):\n"
    << "# batch_summary.csv in the output folder. Submitted by submit.sh.\n"
    << "#SBATCH --job-name=" << o.job_name << "-summary\n#SBATCH --ntasks=1\n#SBATCH --mem=1G\n#SBATCH --time=00:10:00\n"
    << placement(o) << "#SBATCH --output=" << logs << "/%x_%j.out\n"
    << "set -u\n" << kneesim
    << "exec \"$KNEESIM\" batch " << shellQuote(manifest) << " --output " << shellQuote(output_dir) << " --summary-only\n";
  writeScript(f.summary_script, s.str());

  std::ostringstream sub;
  sub << "#!/bin/sh\n"
      << "# Submits the trials' job array, then the summary job to run after it (whatever its tasks' exit).\n"
      << "set -eu\n"
      << "array=$(sbatch --parsable " << shellQuote(f.array_script) << ")\n"
      << "array=${array%%;*}\n"
      << "summary=$(sbatch --parsable --dependency=afterany:$array " << shellQuote(f.summary_script) << ")\n"
      << "echo \"submitted array job $array (" << f.tasks << " tasks) and summary job ${summary%%;*}\"\n";
  writeScript(f.submit_script, sub.str());
  return f;
}

}  // namespace kneesim::tool
