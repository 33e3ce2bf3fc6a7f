// The knee's net loads of a KneeContactWorkflow trial (inverse dynamics) beside its measured forces.
#include "tool/workflow_knee_loads.hpp"

#include <chrono>
#include <cmath>
#include <filesystem>

#include "core/json.hpp"
#include "core/paths.hpp"
#include "core/strings.hpp"
#include "dynamics/tool.hpp"
#include "gap/signals.hpp"

namespace kneesim::tool {

namespace fs = std::filesystem;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// @p x shifted later by @p k frames: out[i] = x[i - k] (NaN where that is outside).
std::vector<double> shifted(const std::vector<double>& x, int k) {
  std::vector<double> out(x.size(), kNaN);
  for (size_t i = 0; i < x.size(); ++i) {
    const long j = long(i) - k;
    if (j >= 0 && j < long(x.size())) out[i] = x[size_t(j)];
  }
  return out;
}

}  // namespace

TrialKneeLoads runTrialKneeLoads(const std::string& id_setup_file, const io::Storage& motion,
                                 const std::string& motion_file, const std::string& trial,
                                 const std::string& trial_dir, const SourceLocation& where, AtomicFileSet& stage,
                                 std::vector<std::string>& notes) {
  if (!pathExists(id_setup_file)) throw InputError(where, "inverse dynamics setup file not found: " + id_setup_file);
  const auto t0 = std::chrono::steady_clock::now();
  dynamics::IdSetup id = dynamics::readIdSetup(id_setup_file);
  if (id.knee_joint.empty())
    throw InputError(id.locate("KneeLoads"),
                     "expected <KneeLoads> (the knee joint whose net load is compared with the measured forces), got none");
  const fs::path d(trial_dir);
  id.coordinates_file = motion_file;  // the trial's own motion (IK's is staged, not yet written)
  id.results_directory = trial_dir;
  id.output_gen_force_file = (d / (trial + "_id.sto")).string();
  id.output_knee_loads_file = (d / (trial + "_knee_loads.sto")).string();
  if (!id.output_joint_loads_file.empty()) id.output_joint_loads_file = (d / (trial + "_joint_loads.sto")).string();
  if (!id.output_grf_file.empty()) id.output_grf_file = (d / (trial + "_grf.mot")).string();
  dynamics::IdRunOptions o;
  o.stage = &stage;
  o.coordinates = &motion;
  const dynamics::IdReport rep = dynamics::runInverseDynamicsTool(id, o);
  for (const std::string& n : rep.notes) notes.push_back("inverse dynamics: " + n);
  for (const std::string& w : rep.warnings) notes.push_back("inverse dynamics warning: " + w);
  TrialKneeLoads out;
  out.id_setup_file = id_setup_file;
  out.table = rep.knee_loads;
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

void compareKneeLoads(TrialKneeLoads& loads, const std::vector<double>& time, const io::KneeForces& forces,
                      double window_begin, double window_end, double max_lag) {
  const io::Storage& t = loads.table;
  std::vector<double> tt(size_t(t.getNumRows()));
  for (size_t r = 0; r < tt.size(); ++r) tt[r] = t.data(Eigen::Index(r), 0);
  const double dt = time.size() > 1 ? (time.back() - time.front()) / double(time.size() - 1) : 1.0;
  const int steps = int(std::round(max_lag / dt));
  std::vector<double> in_window(time.size(), kNaN);  // 1 inside the window, NaN outside (pearson skips it)
  for (size_t i = 0; i < time.size(); ++i)
    if (time[i] >= window_begin - 1e-9 && time[i] <= window_end + 1e-9) in_window[i] = 1;
  const std::vector<std::pair<std::string, const std::vector<double>*>> measured = {
      {"total", &forces.total}, {"medial", &forces.medial}, {"lateral", &forces.lateral}};
  loads.at_frames.clear();
  loads.agreement.clear();
  for (size_t c = 1; c < t.labels.size(); ++c) {
    std::vector<double> col(tt.size());
    for (size_t r = 0; r < tt.size(); ++r) col[r] = t.data(Eigen::Index(r), Eigen::Index(c));
    const std::vector<double> v = gap::interpolate(tt, col, time);
    std::vector<double> v_window(v.size());
    for (size_t i = 0; i < v.size(); ++i) v_window[i] = v[i] * in_window[i];
    for (const auto& [name, m] : measured) {
      KneeLoadAgreement a;
      a.load = t.labels[c];
      a.measured = name;
      a.r_trial = gap::pearson(v, *m);
      a.r_window = gap::pearson(v_window, *m);
      double best = -1;
      for (int k = -steps; k <= steps; ++k) {
        const double r = gap::pearson(shifted(v, k), *m);
        if (std::isfinite(r) && std::abs(r) > best) best = std::abs(r), a.lag = k * dt, a.r_at_lag = r;
      }
      loads.agreement.push_back(a);
    }
    loads.at_frames.emplace_back(t.labels[c], v);
  }
}

Plot makeKneeLoadPlot(const TrialKneeLoads& loads, const io::KneeForces& forces, const std::vector<double>& x,
                      const std::string& xlabel, const std::string& trial) {
  Plot p;
  p.title = "Knee net loads (inverse dynamics, no muscles) and measured forces, " + trial;
  for (const KneeLoadAgreement& a : loads.agreement)
    if (a.load == "knee_axial_force" && a.measured == "total")
      p.title += ": axial vs total r = " + formatSignificant(a.r_trial, 3) + ", best lag " +
                 formatSignificant(1e3 * a.lag, 3) + " ms";
  p.xlabel = xlabel;
  p.ylabel = "force (N)";
  p.y2label = "net moment (N m)";
  p.series.push_back({"measured total (eKnee)", x, forces.total, "lines", "#000000"});
  p.series.push_back({"measured medial", x, forces.medial, "lines", "#1f77b4", 2, 1.5});
  p.series.push_back({"measured lateral", x, forces.lateral, "lines", "#2ca02c", 2, 1.5});
  const std::vector<std::pair<std::string, std::string>> drawn = {{"knee_axial_force", "#d62728"},
                                                                  {"knee_flexion_moment", "#9467bd"},
                                                                  {"knee_adduction_moment", "#ff7f0e"}};
  for (const auto& [name, color] : drawn)
    for (const auto& [label, v] : loads.at_frames)
      if (label == name) {
        PlotSeries s{"net " + label.substr(5), x, v, "lines", color};
        s.right_axis = label != "knee_axial_force";
        if (s.right_axis) s.title += " (right axis)";
        p.series.push_back(s);
      }
  return p;
}

nlohmann::json toJson(const TrialKneeLoads& loads, bool timings) {
  nlohmann::json j;
  j["id_setup_file"] = loads.id_setup_file;
  j["columns"] = std::vector<std::string>(loads.table.labels.begin() + (loads.table.labels.empty() ? 0 : 1),
                                          loads.table.labels.end());
  j["units"] = "forces N (axial: compression positive; ap: anterior, ml: medial on the tibia), moments N m (net "
               "internal: flexion, adduction, internal rotation positive); no muscles";
  if (timings) j["seconds"] = loads.seconds;
  nlohmann::json a = nlohmann::json::array();
  for (const KneeLoadAgreement& g : loads.agreement)
    a.push_back({{"load", g.load},
                 {"measured", g.measured},
                 {"r_trial", jsonNumber(g.r_trial)},
                 {"r_window", jsonNumber(g.r_window)},
                 {"best_lag_s", jsonNumber(g.lag)},
                 {"r_at_best_lag", jsonNumber(g.r_at_lag)}});
  j["agreement"] = a;
  return j;
}

}  // namespace kneesim::tool
