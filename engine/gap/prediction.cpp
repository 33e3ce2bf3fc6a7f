// The gap model: a diagnosis's selected law with its fitted parameters as gap_model.json, read back and
// applied to trials (kneesim gap --predict).

#include "gap/prediction.hpp"

#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

#include <nlohmann/json.hpp>

#include "core/error.hpp"
#include "core/json.hpp"
#include "plugin/registry.hpp"

namespace kneesim::gap {

namespace {

using nlohmann::json;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

}  // namespace

GapModel makeGapModel(const GapReport& r) {
  GapModel m;
  m.source = r.setup_file;
  m.plugins = r.plugins;
  m.law = r.law;
  m.trials = r.trials;
  m.synthetic = r.synthetic;
  m.interim_inputs = r.interim_inputs;
  m.emg_peaks = r.emg_peaks;
  for (const auto& d : r.targets) {
    TargetModel t;
    t.target = d.target;
    t.law = d.final_law;
    t.effects = d.selected;
    for (const auto& p : d.final_fit.parameters) t.parameters.emplace_back(p.name, p.value);
    t.verdict_class = d.verdict_class;
    t.verdict = d.verdict;
    t.heldout_rmse = d.shrinkage.empty() ? kNaN : d.shrinkage.front().rmse_final;
    m.targets.push_back(std::move(t));
  }
  return m;
}

std::string formatGapModel(const GapModel& m) {
  json j;
  j["kind"] = "kneesim gap model";
  j["source"] = m.source;
  j["plugins"] = m.plugins;
  j["law"] = m.law;
  j["trials"] = m.trials;
  j["synthetic"] = m.synthetic;
  j["interim_inputs"] = m.interim_inputs;
  json peaks = json::object();
  for (const auto& [k, v] : m.emg_peaks) peaks[k] = jsonNumber(v);
  j["emg_peaks_V"] = peaks;
  json ts = json::array();
  for (const auto& t : m.targets) {
    json ps = json::array();
    for (const auto& [n, v] : t.parameters) ps.push_back({{"name", n}, {"value", jsonNumber(v)}});
    ts.push_back({{"target", t.target},
                  {"law", t.law},
                  {"effects", t.effects},
                  {"parameters", ps},
                  {"verdict_class", t.verdict_class},
                  {"verdict", t.verdict},
                  {"heldout_rmse_N", jsonNumber(t.heldout_rmse)}});
  }
  j["targets"] = ts;
  return j.dump(2) + "\n";
}

GapModel readGapModel(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError({path, 0, ""}, "gap model: expected a readable gap_model.json, got no file");
  json j;
  try {
    j = json::parse(in);
  } catch (const json::exception& e) {
    throw InputError({path, 0, ""}, std::string("gap model: expected JSON, got a parse error (") + e.what() + ")");
  }
  auto need = [&](const json& o, const char* key, const std::string& at) -> const json& {
    if (!o.is_object() || !o.contains(key))
      throw InputError({path, 0, at}, std::string("gap model: expected a '") + key + "' entry, got none");
    return o.at(key);
  };
  GapModel m;
  try {
    if (need(j, "kind", "") != "kneesim gap model")
      throw InputError({path, 0, "kind"}, "gap model: expected kind 'kneesim gap model', got " + j["kind"].dump());
    m.source = j.value("source", "");
    m.plugins = need(j, "plugins", "").get<std::vector<std::string>>();
    m.law = need(j, "law", "").get<std::string>();
    m.trials = j.value("trials", std::vector<std::string>{});
    m.synthetic = j.value("synthetic", false);
    m.interim_inputs = j.value("interim_inputs", false);
    if (j.contains("emg_peaks_V"))
      for (const auto& [k, v] : j["emg_peaks_V"].items())
        if (v.is_number()) m.emg_peaks[k] = v.get<double>();
    const json& ts = need(j, "targets", "");
    if (!ts.is_array() || ts.empty())
      throw InputError({path, 0, "targets"}, "gap model: expected at least one target, got none");
    for (size_t k = 0; k < ts.size(); ++k) {
      const std::string at = "targets[" + std::to_string(k) + "]";
      TargetModel t;
      t.target = need(ts[k], "target", at).get<std::string>();
      if (const std::string why = findTargetProblem(t.target); !why.empty())
        throw InputError({path, 0, at + "/target"}, "gap model: " + why);
      t.law = ts[k].value("law", "");
      t.effects = need(ts[k], "effects", at).get<std::vector<std::string>>();
      for (const auto& p : need(ts[k], "parameters", at)) {
        const json& v = need(p, "value", at + "/parameters");
        if (!v.is_number())
          throw InputError({path, 0, at + "/parameters/" + p.value("name", "?")},
                           "gap model: expected a number, got " + v.dump());
        t.parameters.emplace_back(need(p, "name", at + "/parameters").get<std::string>(), v.get<double>());
      }
      t.verdict_class = ts[k].value("verdict_class", "");
      t.verdict = ts[k].value("verdict", "");
      t.heldout_rmse = ts[k].contains("heldout_rmse_N") && ts[k]["heldout_rmse_N"].is_number()
                           ? ts[k]["heldout_rmse_N"].get<double>()
                           : kNaN;
      m.targets.push_back(std::move(t));
    }
  } catch (const json::exception& e) {
    throw InputError({path, 0, ""}, std::string("gap model: expected the fields gap_model.json has, got ") + e.what());
  }
  return m;
}

std::vector<TrialPrediction> predictTrials(const GapModel& m, const plugin::Registry& registry,
                                           const std::vector<GapTrial>& trials, const std::string& where) {
  const SourceLocation at{where, 0, "gap model"};
  const identify::ContactLaw base = identify::ContactLaw::fromRegistry(registry, m.law, at);
  std::vector<TrialPrediction> out(trials.size());
  for (size_t k = 0; k < trials.size(); ++k) {
    out[k].trial = trials[k].trial.name;
    out[k].activity = trials[k].activity;
    out[k].time = trials[k].trial.time;
    out[k].phase = trials[k].cycle_phase;
  }
  for (const auto& tm : m.targets) {
    std::vector<Effect> effects;
    for (const auto& e : tm.effects) effects.push_back(Effect::fromRegistry(registry, e, at));
    const identify::ContactLaw law = makeExtendedLaw(base, effects);
    Eigen::VectorXd p = law.getDefaultValues();
    for (int i = 0; i < law.getNumParameters(); ++i) {
      const std::string& name = law.getParameter(i).name;
      bool found = false;
      for (const auto& [n, v] : tm.parameters)
        if (n == name) p[i] = v, found = true;
      if (!found)
        throw InputError({where, 0, tm.target + "/parameters"},
                         "gap model: expected a value for parameter '" + name + "' of " + law.getName() + ", got none");
    }
    for (size_t k = 0; k < trials.size(); ++k) {
      const identify::Trial tt = makeTargetTrial(trials[k], tm.target);
      const identify::LawInputs in(law, tt.channels, tt.time, tt.name, trials[k].trial.source);
      Eigen::VectorXd f;
      law.calcForce(p, in, f);
      std::vector<double>& pred = out[k].predicted[tm.target];
      pred.assign(f.data(), f.data() + f.size());
      double ss = 0;
      int n = 0;
      for (size_t i = 0; i < pred.size(); ++i)
        if (std::isfinite(tt.measured_force[i])) ss += std::pow(tt.measured_force[i] - pred[i], 2), ++n;
      if (n > 0) {
        out[k].measured[tm.target] = tt.measured_force;
        out[k].rmse[tm.target] = std::sqrt(ss / n);
      }
    }
  }
  return out;
}

io::Storage toStorage(const TrialPrediction& p) {
  io::Storage s;
  s.name = p.trial + "_predicted";
  s.in_degrees = false;
  s.labels = {"time", "cycle_phase"};
  std::vector<const std::vector<double>*> cols{&p.time, &p.phase};
  for (const auto& [target, v] : p.predicted) {
    s.labels.push_back(target);
    cols.push_back(&v);
    auto it = p.measured.find(target);
    if (it != p.measured.end()) {
      s.labels.push_back(target + "_measured");
      cols.push_back(&it->second);
    }
  }
  s.data.resize(static_cast<Eigen::Index>(p.time.size()), static_cast<Eigen::Index>(cols.size()));
  for (size_t c = 0; c < cols.size(); ++c)
    for (size_t i = 0; i < p.time.size(); ++i) s.data(Eigen::Index(i), Eigen::Index(c)) = (*cols[c])[i];
  s.header.emplace_back("units", "time s, cycle_phase 0-1, forces N (predicted by the gap model's selected law)");
  return s;
}

}  // namespace kneesim::gap
