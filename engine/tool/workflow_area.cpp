// Contact areas of the knee contact workflow: a trial's areas computed in parallel over frames,
// and their derivatives along flexion and along an anterior shift of the femoral component.

#include <algorithm>
#include <exception>
#include <thread>

#include "tool/workflow_detail.hpp"

namespace kneesim::tool::detail {

namespace {

// Poses at arbitrary flexion angles (rad), every other coordinate at its default or coupler.
std::vector<Eigen::Isometry3d> calcFlexionPoses(const WorkflowSetup& setup, const WorkflowTrialSpec& spec,
                                                const model::ModelPtr& model, const ImplantMeshes& meshes,
                                                const ContactAreaSetup& cs, const std::vector<double>& flexion) {
  ContactAreaSetup any_time = cs;
  any_time.time_start = -HUGE_VAL;
  any_time.time_end = HUGE_VAL;
  std::vector<double> t(flexion.size());
  for (size_t i = 0; i < t.size(); ++i) t[i] = double(i);
  if (setup.kinematics != "model") return calcHingeKinematics(any_time, meshes, t, flexion).X_IF;
  io::Storage m;
  m.name = spec.name + " flexion only";
  m.in_degrees = false;
  m.labels = {"time", setup.flexion_coordinate};
  m.data.resize(Eigen::Index(t.size()), 2);
  for (size_t i = 0; i < t.size(); ++i) {
    m.data(Eigen::Index(i), 0) = t[i];
    m.data(Eigen::Index(i), 1) = flexion[i];
  }
  return calcModelKinematics(any_time, model, m, m.name).X_IF;
}

// Whether the model's poses @p k are those at their flexion @p theta alone (posesAt(theta)).
template <class PosesAt>
bool followsFlexion(const std::vector<double>& theta, const ContactKinematics& k, const PosesAt& posesAt) {
  try {
    const std::vector<Eigen::Isometry3d> X = posesAt(theta);
    double worst = 0;
    for (size_t i = 0; i < X.size(); ++i)
      worst = std::max({worst, (X[i].translation() - k.X_IF[i].translation()).norm(),
                        (X[i].linear() - k.X_IF[i].linear()).norm() * 0.05});
    return worst < 1e-9;
  } catch (const InputError&) {
    return false;  // an uncoupled coordinate between the components: not a function of flexion
  }
}

}  // namespace

contact::ContactSeries calcSeriesInParallel(const contact::ContactAreaCalculator& calculator,
                                            std::vector<std::unique_ptr<contact::ContactAreaWorkspace>>& wss,
                                            const std::vector<double>& time,
                                            const std::vector<Eigen::Isometry3d>& X_IF,
                                            const std::function<void(int, int)>& progress) {
  contact::ContactSeries series;
  series.time = time;
  series.extra_thresholds = calculator.getOptions().extra_thresholds;
  const size_t n = X_IF.size();
  series.frames.resize(n);
  for (auto& f : series.frames) f.S_extra.resize(series.extra_thresholds.size());
  const size_t threads = std::max<size_t>(1, std::min(wss.size(), n / 16));
  const size_t block = (n + threads - 1) / threads;
  std::vector<std::exception_ptr> errors(threads);
  const auto work = [&](size_t j) {
    try {
      const size_t begin = j * block, end = std::min(n, begin + block);
      for (size_t k = begin; k < end; ++k) {
        calculator.calcFrame(*wss[j], X_IF[k], series.frames[k]);
        // Only the first thread reports, scaled to the whole.
        if (j == 0 && progress && ((k - begin) % 10 == 9 || k + 1 == end))
          progress(int(std::min(n, (k - begin + 1) * threads)), int(n));
      }
    } catch (...) {
      errors[j] = std::current_exception();
    }
  };
  std::vector<std::thread> pool;
  for (size_t j = 1; j < threads; ++j) pool.emplace_back(work, j);
  work(0);
  for (auto& t : pool) t.join();
  for (const auto& e : errors)
    if (e) std::rethrow_exception(e);
  if (progress) progress(int(n), int(n));
  contact::calcAreaDerivatives(series);
  return series;
}

std::vector<double> areaSeries(const contact::ContactSeries& s, int extra) {
  std::vector<double> v;
  for (const auto& f : s.frames) v.push_back(extra < 0 ? f.S : f.S_extra[size_t(extra)]);
  return v;
}

bool isRotational(const model::ModelPtr& model, const WorkflowSetup& setup) {
  const int c = model->findCoordinate(setup.flexion_coordinate);
  return c >= 0 && model->coordinates[size_t(c)].motion_type == model::MotionType::Rotational;
}

// The step of the area's flexion derivative in the coordinate's SI unit.
double getFlexionStep(const WorkflowSetup& setup, bool rotational) {
  return std::isfinite(setup.flexion_step) ? setup.flexion_step : rotational ? 0.5 * kDeg : 1e-4;
}

// The area derivatives of one trial (WorkflowSetup::area_derivatives): dS/d(flexion) and
// dS/d(anterior shift of the femur), total and per compartment, at the main threshold, by central
// differences of areas at shifted poses. When every pose of the trial is a function of the flexion
// alone (always for the hinge; for the model when its other coordinates between the components
// follow couplers, checked pose by pose), the derivatives are computed on a flexion grid of the
// step's spacing covering the trial and interpolated linearly to the frames (3 area evaluations
// per grid knot instead of 4 per frame); otherwise at every frame.
std::vector<std::pair<std::string, std::vector<double>>> calcAreaDerivatives(
    const WorkflowSetup& setup, const WorkflowTrialSpec& spec, const model::ModelPtr& model, const ImplantMeshes& meshes,
    const io::Storage& motion, int motion_flex, double flex_unit, const ContactAreaSetup& cs, const ContactKinematics& k,
    const std::vector<int>& keep, const contact::ContactAreaCalculator& calculator,
    std::vector<std::unique_ptr<contact::ContactAreaWorkspace>>& wss, std::vector<std::string>& notes,
    const std::function<void(int, int)>& progress) {
  const double h = getFlexionStep(setup, isRotational(model, setup)), a = setup.ap_step;
  const std::string step_text = isRotational(model, setup) ? fmt(h / kDeg, 3) + " deg" : fmt(h, 3) + " m";
  const Eigen::Vector3d anterior = -setup.contact.options.insert_directions.posterior.normalized();
  const auto shift = [&](const std::vector<Eigen::Isometry3d>& X, double s) {
    std::vector<Eigen::Isometry3d> out(X.size());
    for (size_t i = 0; i < X.size(); ++i) out[i] = Eigen::Translation3d(s * anterior) * X[i];
    return out;
  };
  const auto posesAt = [&](const std::vector<double>& flexion) {
    return calcFlexionPoses(setup, spec, model, meshes, cs, flexion);
  };
  // The frames' flexion (rad) in the order of k.
  std::vector<double> theta;
  for (int row = 0; row < motion.getNumRows(); ++row) {
    const double t = motion.data(row, 0);
    if (t < cs.time_start - 1e-9 || t > cs.time_end + 1e-9) continue;
    theta.push_back(motion.data(row, motion_flex) * flex_unit);
  }
  const bool on_path = setup.kinematics != "model" || (theta.size() == k.X_IF.size() && followsFlexion(theta, k, posesAt));
  const auto S = [](const contact::ContactFrame& f, int c) { return c == 0 ? f.S : c == 1 ? f.S_medial : f.S_lateral; };
  std::vector<std::vector<double>> dflex(3, std::vector<double>(keep.size())), dap = dflex;
  if (on_path) {
    double lo = HUGE_VAL, hi = -HUGE_VAL;
    for (int i : keep) lo = std::min(lo, theta[size_t(i)]), hi = std::max(hi, theta[size_t(i)]);
    const int k0 = int(std::floor(lo / h)) - 1, k1 = int(std::ceil(hi / h)) + 1;
    std::vector<double> grid;
    for (int j = k0; j <= k1; ++j) grid.push_back(j * h);
    const std::vector<Eigen::Isometry3d> X = posesAt(grid);
    std::vector<double> gt(grid.size());
    for (size_t i = 0; i < gt.size(); ++i) gt[i] = double(i);
    const contact::ContactSeries s0 = calcSeriesInParallel(calculator, wss, gt, X, progress);
    const contact::ContactSeries sp = calcSeriesInParallel(calculator, wss, gt, shift(X, +a), progress);
    const contact::ContactSeries sm = calcSeriesInParallel(calculator, wss, gt, shift(X, -a), progress);
    const size_t n = grid.size();
    for (size_t f = 0; f < keep.size(); ++f) {
      const double x = (theta[size_t(keep[f])] - grid[0]) / h;
      const size_t j = std::clamp<size_t>(size_t(std::floor(x)), 1, n - 3);
      const double w = std::clamp(x - double(j), 0.0, 1.0);
      for (int c = 0; c < 3; ++c) {
        const auto df = [&](size_t q) { return (S(s0.frames[q + 1], c) - S(s0.frames[q - 1], c)) / (2 * h); };
        const auto da = [&](size_t q) { return (S(sp.frames[q], c) - S(sm.frames[q], c)) / (2 * a); };
        dflex[size_t(c)][f] = (1 - w) * df(j) + w * df(j + 1);
        dap[size_t(c)][f] = (1 - w) * da(j) + w * da(j + 1);
      }
    }
    notes.push_back("area derivatives on a " + step_text + " grid of " + setup.flexion_coordinate + " (" + std::to_string(n) +
                    " knots): every pose of the trial is a function of it alone");
  } else {
    std::vector<double> tp, tm;
    for (double v : theta) tp.push_back(v + h), tm.push_back(v - h);
    const std::vector<Eigen::Isometry3d> X = subset(k.X_IF, keep);
    std::vector<Eigen::Isometry3d> Xp, Xm;
    if (setup.kinematics == "model") {
      io::Storage plus = motion, minus = motion;
      plus.data.col(motion_flex).array() += h / flex_unit;
      minus.data.col(motion_flex).array() -= h / flex_unit;
      Xp = subset(calcModelKinematics(cs, model, plus, spec.name + " flexion + step").X_IF, keep);
      Xm = subset(calcModelKinematics(cs, model, minus, spec.name + " flexion - step").X_IF, keep);
    }
    std::vector<double> time(keep.size());
    for (size_t i = 0; i < time.size(); ++i) time[i] = k.time[size_t(keep[i])];
    const contact::ContactSeries fp = calcSeriesInParallel(calculator, wss, time, Xp, progress);
    const contact::ContactSeries fm = calcSeriesInParallel(calculator, wss, time, Xm, progress);
    const contact::ContactSeries ap = calcSeriesInParallel(calculator, wss, time, shift(X, +a), progress);
    const contact::ContactSeries am = calcSeriesInParallel(calculator, wss, time, shift(X, -a), progress);
    for (size_t f = 0; f < keep.size(); ++f)
      for (int c = 0; c < 3; ++c) {
        dflex[size_t(c)][f] = (S(fp.frames[f], c) - S(fm.frames[f], c)) / (2 * h);
        dap[size_t(c)][f] = (S(ap.frames[f], c) - S(am.frames[f], c)) / (2 * a);
      }
    notes.push_back("area derivatives at every frame (the poses depend on more than " + setup.flexion_coordinate + ")");
  }
  return {{"dS_dflexion", dflex[0]}, {"dS_medial_dflexion", dflex[1]}, {"dS_lateral_dflexion", dflex[2]},
          {"dS_dap", dap[0]},        {"dS_medial_dap", dap[1]},        {"dS_lateral_dap", dap[2]}};
}

}  // namespace kneesim::tool::detail
