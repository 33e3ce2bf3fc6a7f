#include "ik/marker_placer.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <limits>
#include <set>
#include <sstream>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/paths.hpp"
#include "core/strings.hpp"
#include "core/xml.hpp"
#include "io/storage.hpp"
#include "model/osim_reader.hpp"
#include "model/osim_writer.hpp"

namespace kneesim::ik {

namespace fs = std::filesystem;
using Eigen::Vector3d;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

std::shared_ptr<model::Model> withMarkers(const model::Model& m, const std::vector<PlacerMarker>& markers,
                                          const std::vector<Vector3d>& p) {
  auto out = std::make_shared<model::Model>(m);
  for (size_t i = 0; i < markers.size(); ++i) out->markers[markers[i].marker].p_BM = p[i];
  return out;
}

// One IK pass over every frame of every trial with the markers of @p current.
struct Pass {
  std::vector<std::vector<Eigen::VectorXd>> poses;        // per trial, frame
  std::vector<std::vector<std::vector<double>>> errors;    // per trial, frame, marker (m, NaN missing)
  std::vector<double> trial_mean_rms;
  double mean_rms = 0;
};

Pass solvePass(const model::ModelPtr& current, const std::vector<PlacerMarker>& markers,
               const std::vector<double>& ik_weights, const std::vector<CoordinateTask>& coordinate_tasks,
               const std::vector<double>& refs, const std::vector<PlacerTrial>& trials,
               const std::vector<std::vector<Eigen::VectorXd>>* start, const SolverOptions& solver_options,
               const sim::System& system, sim::Workspace& ws) {
  std::vector<MarkerTask> tasks;
  for (size_t i = 0; i < markers.size(); ++i) tasks.push_back({markers[i].marker, ik_weights[i]});
  // Zero-weight markers stay in the task list (they do not steer the pose); their distances are
  // computed below since the solver reports only weighted markers.
  Solver solver(system, tasks, coordinate_tasks, solver_options);
  Pass pass;
  pass.poses.resize(trials.size());
  pass.errors.resize(trials.size());
  pass.trial_mean_rms.assign(trials.size(), 0.0);
  int frames_total = 0;
  for (size_t t = 0; t < trials.size(); ++t) {
    const PlacerTrial& trial = trials[t];
    Eigen::VectorXd q = system.getDefaultCoordinates();
    double sum_rms = 0;
    for (size_t f = 0; f < trial.observed.size(); ++f) {
      if (start && !(*start)[t].empty()) q = (*start)[t][f];
      const FrameResult r = solver.solveFrame(ws, trial.observed[f], refs, q);
      system.realizePosition(ws, q);
      std::vector<double> err(markers.size(), std::numeric_limits<double>::quiet_NaN());
      for (size_t i = 0; i < markers.size(); ++i) {
        const Vector3d& x = trial.observed[f][i];
        if (!x.allFinite()) continue;
        const model::Marker& mk = current->markers[markers[i].marker];
        err[i] = (system.findStationLocation(ws, mk.body, mk.p_BM) - x).norm();
      }
      pass.poses[t].push_back(q);
      pass.errors[t].push_back(std::move(err));
      sum_rms += r.rms_error;
    }
    pass.trial_mean_rms[t] = trial.observed.empty() ? 0.0 : sum_rms / double(trial.observed.size());
    pass.mean_rms += sum_rms;
    frames_total += int(trial.observed.size());
  }
  pass.mean_rms = frames_total > 0 ? pass.mean_rms / frames_total : 0.0;
  return pass;
}

}  // namespace

namespace {

/// The markers' positions in their bodies during the alternation: the model's (p0), the current
/// ones (p), which have a position yet (placed) and which sit at the movement limit (clamped).
struct Placement {
  std::vector<Vector3d> p0, p;
  std::vector<char> placed, clamped;
};

/// The p step, G(p): each movable marker at the (prior-weighted) mean of its measured positions
/// in its body frame at @p poses. Fills rec's objective and max_movement; updates placed, clamped.
std::vector<Vector3d> stepMarkers(const model::Model& current, const std::vector<PlacerMarker>& markers,
                                  const std::vector<PlacerTrial>& trials,
                                  const std::vector<std::vector<Eigen::VectorXd>>& poses, const std::vector<double>& w,
                                  const MarkerPlacerOptions& options, const sim::System& system, sim::Workspace& ws,
                                  Placement& s, PlacerIteration& rec) {
  const size_t n = markers.size();
  std::vector<Vector3d> sum(n, Vector3d::Zero());
  std::vector<double> count(n, 0.0);
  for (size_t t = 0; t < trials.size(); ++t)
    for (size_t f = 0; f < trials[t].observed.size(); ++f) {
      system.realizePosition(ws, poses[t][f]);
      for (size_t i = 0; i < n; ++i) {
        const Vector3d& x = trials[t].observed[f][i];
        if (!x.allFinite()) continue;
        const int body = current.markers[markers[i].marker].body;
        const Eigen::Isometry3d X_GB = system.getBodyPose(ws, body);
        const Vector3d y = X_GB.inverse() * x;
        sum[i] += trials[t].weight * y;
        count[i] += trials[t].weight;
        rec.objective += w[i] * trials[t].weight * (y - s.p[i]).squaredNorm();
      }
    }
  std::vector<Vector3d> g = s.p;
  double max_move = 0;
  for (size_t i = 0; i < n; ++i) {
    if (s.placed[i] && !markers[i].unplaced) rec.objective += w[i] * options.prior_weight * (s.p[i] - s.p0[i]).squaredNorm();
    if (!markers[i].move || count[i] <= 0) continue;
    const double mu = markers[i].unplaced ? 0.0 : options.prior_weight;
    Vector3d np = (sum[i] + mu * s.p0[i]) / (count[i] + mu);
    s.clamped[i] = 0;
    if (!markers[i].unplaced) {
      const Vector3d d = np - s.p0[i];
      if (d.norm() > options.max_marker_movement) {
        np = s.p0[i] + d * (options.max_marker_movement / d.norm());
        s.clamped[i] = 1;
      }
    }
    max_move = std::max(max_move, (np - s.p[i]).norm());
    g[i] = np;
    s.placed[i] = 1;
  }
  rec.max_movement = max_move;
  return g;
}

/// Anderson acceleration of the fixed-point map p -> G(p) (one q step and one p step): the plain
/// alternation crawls along directions the data see only weakly (e.g. a hip centre from gait), at
/// a rate near 1 per iteration. History of the last kDepth steps; an accelerated point that raises
/// the objective J is dropped for the plain step from the previous point.
class Anderson {
 public:
  /// The next point after P = p with image G = G(p) and objective J at p. The history starts
  /// again while markers are still being placed (@p all_placed_before false).
  Eigen::VectorXd next(const Eigen::VectorXd& P, const Eigen::VectorXd& G, double J, bool all_placed_before,
                       const std::vector<PlacerMarker>& markers, const MarkerPlacerOptions& options, Placement& s) {
    const int N = int(P.size());
    Eigen::VectorXd next = G;
    if (!all_placed_before) {
      hist_f_.clear();
      hist_g_.clear();
      return next;
    }
    if (J > prev_J_ * (1 + 1e-12) && prev_G_.size() == N) {
      // The accelerated point did worse than the point before it: take the plain step from there.
      s.clamped = prev_clamped_;
      hist_f_.clear();
      hist_g_.clear();
      return prev_G_;
    }
    hist_f_.push_back(G - P);
    hist_g_.push_back(G);
    if (int(hist_f_.size()) > kDepth + 1) {
      hist_f_.erase(hist_f_.begin());
      hist_g_.erase(hist_g_.begin());
    }
    const int depth = int(hist_f_.size()) - 1;
    if (depth > 0) {
      Eigen::MatrixXd dF(N, depth), dG(N, depth);
      for (int k = 0; k < depth; ++k) {
        dF.col(k) = hist_f_[k + 1] - hist_f_[k];
        dG.col(k) = hist_g_[k + 1] - hist_g_[k];
      }
      const Eigen::VectorXd gamma = dF.colPivHouseholderQr().solve(hist_f_.back());
      if (gamma.allFinite()) next = G - dG * gamma;
      for (size_t i = 0; i < markers.size(); ++i) {  // keep fixed markers and the movement limit
        if (!markers[i].move) next.segment<3>(3 * i) = P.segment<3>(3 * i);
        if (markers[i].unplaced || !markers[i].move) continue;
        const Vector3d d = Vector3d(next.segment<3>(3 * i)) - s.p0[i];
        if (d.norm() > options.max_marker_movement)
          next.segment<3>(3 * i) = s.p0[i] + d * (options.max_marker_movement / d.norm());
      }
    }
    prev_J_ = J;
    prev_G_ = G;
    prev_clamped_ = s.clamped;
    return next;
  }

 private:
  static constexpr int kDepth = 5;
  std::vector<Eigen::VectorXd> hist_f_, hist_g_;  // residuals f = G(p) - p and images G(p)
  Eigen::VectorXd prev_G_;
  double prev_J_ = kInf;
  std::vector<char> prev_clamped_;
};

Eigen::VectorXd flatten(const std::vector<Vector3d>& v) {
  Eigen::VectorXd out(3 * Eigen::Index(v.size()));
  for (size_t i = 0; i < v.size(); ++i) out.segment<3>(3 * i) = v[i];
  return out;
}

/// Each marker's report: where it was and is, whether clamped, its RMS error over @p pass.
std::vector<PlacedMarkerReport> reportMarkers(const model::Model& current, const std::vector<PlacerMarker>& markers,
                                              const Placement& s, const Pass& pass) {
  std::vector<PlacedMarkerReport> out;
  for (size_t i = 0; i < markers.size(); ++i) {
    PlacedMarkerReport r;
    const model::Marker& mk = current.markers[markers[i].marker];
    r.name = mk.name;
    r.body = current.bodies[mk.body].name;
    r.initial = s.p0[i];
    r.placed = s.p[i];
    r.clamped = s.clamped[i];
    double sum2 = 0;
    for (const auto& trial : pass.errors)
      for (const auto& frame : trial)
        if (std::isfinite(frame[i])) {
          ++r.frames;
          sum2 += frame[i] * frame[i];
        }
    r.rms_error = r.frames > 0 ? std::sqrt(sum2 / r.frames) : 0.0;
    out.push_back(r);
  }
  return out;
}

}  // namespace

MarkerPlacerResult placeMarkers(const model::ModelPtr& model, const std::vector<PlacerMarker>& markers,
                                const std::vector<CoordinateTask>& coordinate_tasks,
                                const std::vector<double>& coordinate_references,
                                const std::vector<PlacerTrial>& trials, const MarkerPlacerOptions& options) {
  const model::Model& m0 = *model;
  const size_t n = markers.size();
  KNEESIM_CHECK(coordinate_references.size() == coordinate_tasks.size(), "one reference per coordinate task");
  for (const PlacerTrial& t : trials)
    for (const auto& frame : t.observed) KNEESIM_CHECK(frame.size() == n, "one observed position per placer marker");

  Placement s;
  s.p0.resize(n);
  s.p.resize(n);
  s.placed.resize(n);
  s.clamped.assign(n, 0);
  for (size_t i = 0; i < n; ++i) {
    s.p0[i] = s.p[i] = m0.markers[markers[i].marker].p_BM;
    s.placed[i] = !markers[i].unplaced;
  }

  MarkerPlacerResult result;
  std::vector<std::vector<Eigen::VectorXd>> poses;
  std::shared_ptr<model::Model> current = withMarkers(m0, markers, s.p);
  Anderson anderson;
  for (int it = 0; it < options.max_iterations; ++it) {
    // q step: IK of every frame with the markers held.
    sim::System system(current);
    auto ws = system.createWorkspace();
    std::vector<double> w(n);
    for (size_t i = 0; i < n; ++i) w[i] = s.placed[i] ? markers[i].weight : 0.0;
    Pass pass = solvePass(current, markers, w, coordinate_tasks, coordinate_references, trials,
                          poses.empty() ? nullptr : &poses, options.solver, system, *ws);
    poses = pass.poses;

    PlacerIteration rec;
    rec.mean_rms = pass.mean_rms;
    const bool all_placed_before = std::all_of(s.placed.begin(), s.placed.end(), [](char c) { return c != 0; });
    const std::vector<Vector3d> g = stepMarkers(*current, markers, trials, poses, w, options, system, *ws, s, rec);
    result.iterations.push_back(rec);
    if (rec.max_movement < options.tolerance) {
      s.p = g;
      result.converged = true;
      break;
    }
    const Eigen::VectorXd next = anderson.next(flatten(s.p), flatten(g), rec.objective, all_placed_before, markers,
                                               options, s);
    for (size_t i = 0; i < n; ++i) s.p[i] = next.segment<3>(3 * i);
    current = withMarkers(m0, markers, s.p);
  }
  current = withMarkers(m0, markers, s.p);

  // Final pass with the placed markers, for the figures and the poses.
  sim::System system(current);
  auto ws = system.createWorkspace();
  std::vector<double> w(n);
  for (size_t i = 0; i < n; ++i) w[i] = markers[i].weight;
  Pass pass = solvePass(current, markers, w, coordinate_tasks, coordinate_references, trials,
                        poses.empty() ? nullptr : &poses, options.solver, system, *ws);
  result.poses = pass.poses;
  result.trial_mean_rms = pass.trial_mean_rms;
  result.model = current;
  result.markers = reportMarkers(*current, markers, s, pass);
  return result;
}

MarkerPlacerSetup readMarkerPlacerSetup(const std::string& path) {
  auto doc = xml::Document::load(path);
  MarkerPlacerSetup s;
  s.setup_file = path;
  const std::string dir = fs::path(path).parent_path().string();
  xml::Node root = doc->root();
  xml::Node tool = root.name() == "MarkerPlacer" ? root : root.child("MarkerPlacer");
  if (!tool) root.fail("expected a <MarkerPlacer> element, got <" + root.name() + ">");
  s.name = tool.nameAttr();
  static const std::set<std::string> known = {
      "model_file",         "IKTaskSet",        "marker_file",        "time_range",         "frame_stride",
      "MarkerPlacerTrialSet", "unplaced_markers", "fixed_markers",    "prior_weight",       "max_marker_movement",
      "max_iterations",     "tolerance",        "accuracy",           "output_model_file",  "output_marker_file",
      "output_motion_file", "apply"};
  for (const xml::Node& c : tool.children())
    if (!known.count(c.name()))
      c.fail("unknown element <" + c.name() +
             "> in MarkerPlacer (expected one of model_file, IKTaskSet, marker_file, time_range, frame_stride, "
             "MarkerPlacerTrialSet, unplaced_markers, fixed_markers, prior_weight, max_marker_movement, "
             "max_iterations, tolerance, accuracy, output_model_file, output_marker_file, output_motion_file)");
  s.model_file = xml::resolvePath(dir, tool.childText("model_file"));
  if (s.model_file.empty()) tool.fail("missing <model_file>");
  s.output_model_file = xml::resolvePath(dir, tool.childText("output_model_file"));
  if (s.output_model_file.empty()) tool.fail("missing <output_model_file>");
  s.output_marker_file = xml::resolvePath(dir, tool.childText("output_marker_file"));
  s.output_motion_file = xml::resolvePath(dir, tool.childText("output_motion_file"));

  if (xml::Node set = tool.child("IKTaskSet")) s.tasks = readTaskSetElement(set, dir);

  auto readTrial = [&](const xml::Node& n, PlacerTrialSpec& t) {
    t.marker_file = xml::resolvePath(dir, n.childText("marker_file"));
    if (t.marker_file.empty()) n.fail("missing <marker_file>");
    if (xml::Node tr = n.child("time_range"); tr && !tr.text().empty()) {
      const auto v = tr.toDoubles();
      if (v.size() != 2 || v[0] > v[1]) tr.fail("expected 2 numbers start <= end, got '" + tr.text() + "'");
      t.time_start = v[0];
      t.time_end = v[1];
    }
    if (xml::Node st = n.child("frame_stride")) {
      t.frame_stride = st.toIntIn(1);
    }
    t.weight = n.childDouble("weight", 1.0);
    if (!(t.weight > 0) || !std::isfinite(t.weight)) n.child("weight").fail("expected a weight > 0");
    t.where = n.where();
  };
  if (tool.child("marker_file")) {
    PlacerTrialSpec t;
    t.name = fs::path(tool.childText("marker_file")).stem().string();
    readTrial(tool, t);
    s.trials.push_back(t);
  }
  if (xml::Node set = tool.child("MarkerPlacerTrialSet")) {
    xml::Node objects = set.child("objects");
    for (const xml::Node& n : (objects ? objects : set).children()) {
      if (n.name() != "MarkerPlacerTrial") n.fail("expected <MarkerPlacerTrial>, got <" + n.name() + ">");
      PlacerTrialSpec t;
      t.name = n.nameAttr();
      static const std::set<std::string> trial_known = {"marker_file", "time_range", "frame_stride", "weight"};
      for (const xml::Node& c : n.children())
        if (!trial_known.count(c.name()))
          c.fail("unknown element <" + c.name() + "> in MarkerPlacerTrial (expected marker_file, time_range, "
                 "frame_stride, weight)");
      readTrial(n, t);
      if (t.name.empty()) t.name = fs::path(t.marker_file).stem().string();
      s.trials.push_back(t);
    }
  }
  if (s.trials.empty()) tool.fail("expected a <marker_file> or a <MarkerPlacerTrialSet> with trials, got none");

  s.unplaced_markers = tool.child("unplaced_markers") ? tool.child("unplaced_markers").toWords() : std::vector<std::string>{};
  s.fixed_markers = tool.child("fixed_markers") ? tool.child("fixed_markers").toWords() : std::vector<std::string>{};
  s.options.prior_weight = tool.childDouble("prior_weight", 1.0);
  if (!(s.options.prior_weight >= 0)) tool.child("prior_weight").fail("expected a weight >= 0");
  const double mm = tool.childDouble("max_marker_movement", -1.0);  // OpenSim: -1 means unbounded
  s.options.max_marker_movement = mm < 0 ? kInf : mm;
  s.options.max_iterations = tool.child("max_iterations") ? tool.child("max_iterations").toIntIn(1, 100000) : 20;
  if (s.options.max_iterations < 1) tool.child("max_iterations").fail("expected at least 1 iteration");
  s.options.tolerance = tool.childDouble("tolerance", 1e-5);
  const double accuracy = tool.childDouble("accuracy", 1e-5);
  if (!(accuracy > 0)) tool.child("accuracy").fail("expected accuracy > 0");
  s.options.solver.step_tolerance = std::min(1e-9, accuracy * 1e-3);
  return s;
}

namespace {

/// The markers and coordinate tasks a placement uses, with each marker's column in each trial.
struct PlacerPlan {
  std::vector<CoordinateTask> coord_tasks;
  std::vector<double> refs;
  std::vector<PlacerMarker> markers;
  std::vector<std::vector<int>> columns;  // per marker, per trial
};

/// Each model marker's IK weight from the task set (weight 0 for markers it leaves out; without a
/// task set every marker weighs 1); the applied coordinate tasks with their references go to @p plan.
std::vector<double> readPlacerTasks(const MarkerPlacerSetup& setup, const model::Model& m, PlacerPlan& plan) {
  std::vector<double> weight(m.markers.size(), setup.tasks.empty() ? 1.0 : 0.0);
  for (const TaskSpec& t : setup.tasks) {
    if (t.kind == TaskSpec::Kind::Marker) {
      const int mi = m.findMarker(t.name);
      if (mi < 0) throw InputError(t.where, "task names marker '" + t.name + "' which the model does not have");
      weight[mi] = t.apply ? t.weight : 0.0;
    } else {
      const int ci = m.findCoordinate(t.name);
      if (ci < 0) throw InputError(t.where, "task names coordinate '" + t.name + "' which the model does not have");
      if (!t.apply || t.weight == 0) continue;
      if (t.value_type == "from_file")
        throw InputError(t.where, "expected default_value or manual_value for a marker placer coordinate task, got from_file");
      plan.coord_tasks.push_back({ci, t.weight});
      plan.refs.push_back(t.value_type == "manual_value" ? t.value : m.coordinates[ci].default_value);
    }
  }
  return weight;
}

/// Markers: every model marker found in some trial, with its IK weight and whether it may move.
PlacerPlan planPlacement(const MarkerPlacerSetup& setup, const model::Model& m, const std::vector<io::MarkerTable>& tables) {
  std::set<std::string> unplaced(setup.unplaced_markers.begin(), setup.unplaced_markers.end());
  std::set<std::string> fixed(setup.fixed_markers.begin(), setup.fixed_markers.end());
  for (const std::string& nm : unplaced)
    if (m.findMarker(nm) < 0)
      throw InputError({setup.setup_file, 0, "unplaced_markers"}, "unknown marker '" + nm + "' (not in " + setup.model_file + ")");
  for (const std::string& nm : fixed)
    if (m.findMarker(nm) < 0)
      throw InputError({setup.setup_file, 0, "fixed_markers"}, "unknown marker '" + nm + "' (not in " + setup.model_file + ")");
  PlacerPlan plan;
  const std::vector<double> weight = readPlacerTasks(setup, m, plan);
  for (size_t i = 0; i < m.markers.size(); ++i) {
    std::vector<int> cols;
    bool any = false;
    for (const io::MarkerTable& tab : tables) {
      cols.push_back(tab.findMarker(m.markers[i].name));
      any = any || cols.back() >= 0;
    }
    if (!any) continue;
    PlacerMarker pm;
    pm.marker = int(i);
    pm.weight = weight[i];
    pm.move = !m.markers[i].fixed && !fixed.count(m.markers[i].name);
    pm.unplaced = unplaced.count(m.markers[i].name) > 0;
    plan.markers.push_back(pm);
    plan.columns.push_back(cols);
  }
  if (plan.markers.empty())
    throw InputError({setup.setup_file, 0, ""}, "no model marker is found in the trials' marker files");
  return plan;
}

/// Each trial's frames in its time range, every frame_stride-th, that hold a tracked marker.
std::vector<PlacerTrial> makeTrials(const MarkerPlacerSetup& setup, const std::vector<io::MarkerTable>& tables,
                                    const PlacerPlan& plan) {
  std::vector<PlacerTrial> trials;
  for (size_t t = 0; t < setup.trials.size(); ++t) {
    const PlacerTrialSpec& spec = setup.trials[t];
    const io::MarkerTable& tab = tables[t];
    PlacerTrial trial;
    trial.name = spec.name;
    trial.weight = spec.weight;
    int k = 0;
    for (int f = 0; f < tab.getNumFrames(); ++f) {
      if (tab.time[f] < spec.time_start - 1e-9 || tab.time[f] > spec.time_end + 1e-9) continue;
      if (k++ % spec.frame_stride != 0) continue;
      std::vector<Vector3d> obs(plan.markers.size(), Vector3d::Constant(std::numeric_limits<double>::quiet_NaN()));
      int present = 0;
      for (size_t i = 0; i < plan.markers.size(); ++i)
        if (plan.columns[i][t] >= 0) {
          obs[i] = tab.getPosition(f, plan.columns[i][t]);
          present += obs[i].allFinite() && plan.markers[i].weight > 0 ? 1 : 0;
        }
      if (present == 0) continue;
      trial.time.push_back(tab.time[f]);
      trial.observed.push_back(std::move(obs));
    }
    if (trial.observed.empty()) {
      std::ostringstream os;
      os << "time range " << spec.time_start << " to " << spec.time_end << " s of " << spec.marker_file
         << " holds no frame with a tracked marker";
      throw InputError(spec.where, os.str());
    }
    trials.push_back(std::move(trial));
  }
  return trials;
}

/// The placed model as an .osim file whose comment says how it was made.
std::string formatPlacedModel(const MarkerPlacerSetup& setup, const model::Model& placed) {
  model::OsimWriteOptions wo;
  wo.comment = {"Markers registered by kneesim's marker placer: `kneesim run " + fs::path(setup.setup_file).filename().string() +
                "` from " + fs::path(setup.model_file).filename().string() + " and the trials:"};
  for (const PlacerTrialSpec& t : setup.trials) {
    std::ostringstream os;
    os << "  " << t.name << ": " << fs::path(t.marker_file).filename().string() << ", " << t.time_start << " to "
       << t.time_end << " s, every " << t.frame_stride << " frame(s), weight " << t.weight;
    wo.comment.push_back(os.str());
  }
  return model::formatOsim(placed, wo);
}

/// One row per marker: where it is, where it was, how far it moved, its error, whether clamped.
std::string formatMarkerTable(const MarkerPlacerResult& result) {
  std::ostringstream os;
  os << std::setprecision(10);
  os << "marker,body,x_m,y_m,z_m,initial_x_m,initial_y_m,initial_z_m,moved_m,frames,rms_error_m,clamped\n";
  for (const PlacedMarkerReport& r : result.markers)
    os << r.name << "," << r.body << "," << r.placed.x() << "," << r.placed.y() << "," << r.placed.z() << ","
       << r.initial.x() << "," << r.initial.y() << "," << r.initial.z() << "," << (r.placed - r.initial).norm()
       << "," << r.frames << "," << r.rms_error << "," << (r.clamped ? 1 : 0) << "\n";
  return os.str();
}

}  // namespace

MarkerPlacerResult runMarkerPlacer(const MarkerPlacerSetup& setup) {
  if (!pathExists(setup.model_file))
    throw InputError({setup.setup_file, 0, "model_file"}, "model file not found: " + setup.model_file);
  model::ModelPtr model = model::readOsim(setup.model_file);
  const model::Model& m = *model;

  std::vector<io::MarkerTable> tables;
  for (const PlacerTrialSpec& t : setup.trials) {
    if (!pathExists(t.marker_file)) throw InputError(t.where, "marker file not found: " + t.marker_file);
    tables.push_back(io::readMarkerFile(t.marker_file));
  }
  const PlacerPlan plan = planPlacement(setup, m, tables);
  const std::vector<PlacerTrial> trials = makeTrials(setup, tables, plan);
  MarkerPlacerResult result = placeMarkers(model, plan.markers, plan.coord_tasks, plan.refs, trials, setup.options);

  // Outputs, prepared before any is written.
  const std::string model_text = formatPlacedModel(setup, *result.model);
  const std::string csv = setup.output_marker_file.empty() ? std::string() : formatMarkerTable(result);
  io::Storage motion;
  if (!setup.output_motion_file.empty()) motion = makeMotion(m, setup.trials[0].name, trials[0].time, result.poses[0]);
  writeFileAtomically(setup.output_model_file, [&](std::ostream& os) { os << model_text; });
  if (!csv.empty()) writeFileAtomically(setup.output_marker_file, [&](std::ostream& os) { os << csv; });
  if (!setup.output_motion_file.empty()) io::writeStorage(setup.output_motion_file, motion);
  return result;
}

void printMarkerPlacerSummary(const MarkerPlacerResult& result, std::ostream& os) {
  os << std::fixed << std::setprecision(2);
  os << "marker placer: " << result.iterations.size() << " iteration(s), "
     << (result.converged ? "converged" : "stopped at the iteration limit") << "\n";
  for (size_t k = 0; k < result.iterations.size(); ++k)
    os << "  iteration " << k + 1 << ": mean frame RMS " << result.iterations[k].mean_rms * 1e3
       << " mm, largest marker move " << result.iterations[k].max_movement * 1e3 << " mm\n";
  for (size_t t = 0; t < result.trial_mean_rms.size(); ++t)
    os << "  trial " << t + 1 << ": mean frame RMS with the placed markers " << result.trial_mean_rms[t] * 1e3 << " mm\n";
  os << "  " << std::left << std::setw(20) << "marker" << std::setw(18) << "body" << std::right << std::setw(9)
     << "moved" << std::setw(8) << "frames" << std::setw(9) << "rms" << "  (mm)\n";
  for (const PlacedMarkerReport& r : result.markers)
    os << "  " << std::left << std::setw(20) << r.name << std::setw(18) << r.body << std::right << std::setw(9)
       << (r.placed - r.initial).norm() * 1e3 << std::setw(8) << r.frames << std::setw(9) << r.rms_error * 1e3
       << (r.clamped ? "  clamped" : "") << "\n";
  os.unsetf(std::ios::floatfield);
}

}  // namespace kneesim::ik
