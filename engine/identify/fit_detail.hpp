#pragma once
// Internal to the identification (identify/fit.hpp): the least-squares problem a fit solves (the
// trials' selected frames as residuals of the free parameters), the state its steps share, and
// the steps, one file each:
//   fit.cpp                  the order of the steps, the solve, the results, the notes; predict()
//   fit_problem.cpp          the request checked, the parameters' values, bounds and free set, the trials
//   fit_identifiability.cpp  which parameters the data determine, fixing those they do not
//   fit_intervals.cpp        asymptotic, profile and bootstrap confidence intervals
// Not part of the public API (not installed).

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/strings.hpp"
#include "identify/fit.hpp"
#include "identify/least_squares.hpp"

namespace kneesim::identify::detail {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

inline std::string fmt(double v, int digits = 6) { return formatSignificant(v, digits); }

// One trial prepared for evaluation: the law's input view, the selected frames and the buffers a
// force/Jacobian evaluation of the whole trial needs (allocated once).
struct TrialData {
  const Trial* trial = nullptr;
  LawInputs inputs;
  std::vector<int> frames;
  std::vector<double> weight;  // per selected frame
  Eigen::VectorXd force;
  Eigen::MatrixXd jac;
  int offset = 0;  // first residual of this trial
};

// Residuals F_law - F_measured of the selected frames of all trials as a function of the free
// parameters; the fixed ones are held at `full`.
class Dataset : public LeastSquaresProblem {
 public:
  Dataset(const ContactLaw& law, std::vector<TrialData> trials, Eigen::VectorXd full)
      : law_(law), trials_(std::move(trials)), full_(std::move(full)) {
    n_res_ = 0;
    for (auto& t : trials_) {
      t.offset = n_res_;
      n_res_ += static_cast<int>(t.frames.size());
      t.force.resize(t.inputs.getNumFrames());
      t.jac.resize(t.inputs.getNumFrames(), law_.getNumParameters());
    }
  }

  void setFree(std::vector<int> free) { free_ = std::move(free); }
  const std::vector<int>& getFree() const { return free_; }
  void setFull(const Eigen::VectorXd& full) { full_ = full; }
  const Eigen::VectorXd& getFull() const { return full_; }
  Eigen::VectorXd withFree(const double* x) const {
    Eigen::VectorXd p = full_;
    for (size_t k = 0; k < free_.size(); ++k) p[free_[k]] = x[k];
    return p;
  }
  std::vector<TrialData>& getTrials() { return trials_; }

  int getNumParameters() const override { return static_cast<int>(free_.size()); }
  int getNumResiduals() const override { return n_res_; }

  void calcResiduals(const double* x, double* r, double* jacobian) override {
    for (size_t k = 0; k < free_.size(); ++k) full_[free_[k]] = x[k];
    for (auto& t : trials_) {
      law_.calcForce(full_.data(), t.inputs, t.force.data(), jacobian ? t.jac.data() : nullptr);
      const auto& meas = t.trial->measured_force;
      for (size_t s = 0; s < t.frames.size(); ++s) {
        const int i = t.frames[s];
        r[t.offset + s] = t.force[i] - meas[i];
        if (jacobian)
          for (size_t k = 0; k < free_.size(); ++k)
            jacobian[k * n_res_ + t.offset + s] = t.jac(i, free_[k]);
      }
    }
  }

  // Jacobian of all residuals with respect to the parameters in `cols` at `full`.
  Eigen::MatrixXd calcJacobian(const Eigen::VectorXd& full, const std::vector<int>& cols) {
    Eigen::MatrixXd j(n_res_, cols.size());
    for (auto& t : trials_) {
      law_.calcForce(full.data(), t.inputs, t.force.data(), t.jac.data());
      for (size_t s = 0; s < t.frames.size(); ++s)
        for (size_t k = 0; k < cols.size(); ++k) j(t.offset + s, k) = t.jac(t.frames[s], cols[k]);
    }
    return j;
  }

  std::vector<double> getBaseWeights() const {
    std::vector<double> w(n_res_);
    for (const auto& t : trials_)
      for (size_t s = 0; s < t.frames.size(); ++s) w[t.offset + s] = t.weight[s];
    return w;
  }

 private:
  const ContactLaw& law_;
  std::vector<TrialData> trials_;
  Eigen::VectorXd full_;
  std::vector<int> free_;
  int n_res_ = 0;
};

// Scale of parameter j for sensitivities: |value|, or the typical scale at zero.
inline double sensitivityScale(const ContactLaw& law, const Eigen::VectorXd& full, int j) {
  return full[j] != 0 ? std::abs(full[j]) : law.getParameter(j).typical_scale;
}

// The parameters of a fit before solving: values, bounds, where each value came from, the free set.
struct FitParameters {
  Eigen::VectorXd full;               // every parameter's value (the start for the free ones)
  std::vector<double> lower, upper;   // bounds
  std::vector<std::string> source;    // "law default" or "setup"
  std::vector<int> freed;             // the parameters the setup frees, ascending
  std::vector<std::string> start_notes;
};

// What the steps after the solve share, and those steps.
struct FitState {
  const ContactLaw& law;
  const FitOptions& o;
  Dataset& data;
  Eigen::VectorXd full;             // the optimum
  std::vector<double> lower, upper;
  std::vector<int> free;            // the solved parameters
  std::vector<double> w0;           // base weight per residual
  int n = 0;                        // residuals
  LeastSquaresOptions lso;          // the solve's options
  std::vector<double> xhat;         // the free parameters at the optimum
  double sse_min = 0;               // weighted SSE at the optimum
  double rho = 0;                   // lag-1 correlation of the residuals, clamped to [0, 0.99]
  int n_pos = 0;                    // residuals of positive weight

  // Identifiability at the optimum, the fit's metrics (overall, per trial, per phase), the
  // residuals' serial correlation (rho) and the effective frame count (fit.cpp).
  void calcStatistics(FitReport& rep);
  // Notes in plain language: start values moved, parameters held, what is identified, weak
  // combinations, parameters on their bounds, convergence, serial correlation (fit.cpp).
  void addNotes(const std::vector<std::string>& start_notes, const LeastSquaresResult& sol, FitReport& rep) const;
  // Asymptotic (Gauss-Newton, inflated for serial correlation), profile and bootstrap intervals of
  // the parameters and derived quantities, as the options ask (fit_intervals.cpp).
  void calcIntervals(const std::vector<Trial>& trials, FitReport& rep);

 private:
  Eigen::VectorXd calcAsymptoticIntervals(double z, FitReport& rep);
  double calcProfileSse(int a, double v, Eigen::VectorXd& at);
  void calcProfileIntervals(double z, const Eigen::VectorXd& se, FitReport& rep);
  void calcBootstrapIntervals(const std::vector<Trial>& trials, FitReport& rep);
};

// ---- the problem (fit_problem.cpp)

// Throws InputError for no trials, repeated trial names or a confidence level outside (0, 1).
void checkRequest(const ContactLaw& law, const std::vector<Trial>& trials, const FitOptions& o);
// The values, bounds and free set the options give (start values moved into narrowed bounds).
FitParameters resolveParameters(const ContactLaw& law, const FitOptions& o);
// The trials' selected frames and weights; throws InputError for a non-finite measured force.
std::vector<TrialData> makeTrialData(const ContactLaw& law, const std::vector<Trial>& trials, const FitOptions& o);
// Throws InputError where the law gives a non-finite force on a selected frame at @p full.
void checkStartForces(Dataset& data, const ContactLaw& law, const Eigen::VectorXd& full);
// The free parameters f but f[held] (a solve with that one held): their indices into rest, their
// start values from p into y0, their bounds and scales into lo (replacing lo's).
void holdOneOut(const ContactLaw& law, const std::vector<int>& f, int held, const Eigen::VectorXd& p,
                const std::vector<double>& lower, const std::vector<double>& upper, std::vector<int>& rest,
                std::vector<double>& y0, LeastSquaresOptions& lo);
// Lag-1 autocorrelation of residuals pooled over trials (consecutive selected frames only).
double lag1Correlation(Dataset& data, const Eigen::VectorXd& r);

// ---- identifiability (fit_identifiability.cpp)

// Identifiability of the parameters @p cols at @p full from the weighted, scaled sensitivities.
IdentifiabilityReport analyze(Dataset& data, const ContactLaw& law, const Eigen::VectorXd& full,
                              const std::vector<int>& cols, const std::vector<double>& w, const FitOptions& o,
                              const std::string& label);
// Gradient of every derived quantity with respect to the parameters in `cols`, each column scaled
// like the sensitivities when @p scaled (d derived / d p_j * |p_j|). Central differences inside
// the bounds.
Eigen::MatrixXd derivedGradient(const ContactLaw& law, const Eigen::VectorXd& full, const std::vector<int>& cols,
                                const std::vector<double>& lower, const std::vector<double>& upper, bool scaled);
// Holds parameters until the rest are identifiable at the start (or throws InputError when the
// options do not allow it); records them in rep.fixed_by_identifiability, @p status and
// @p value_source. Returns the parameters left free.
std::vector<int> fixUnidentifiable(Dataset& data, const ContactLaw& law, const FitOptions& o, FitParameters& p,
                                   const std::vector<double>& w0, FitReport& rep, std::vector<ParameterStatus>& status,
                                   std::vector<std::string>& value_source);

}  // namespace kneesim::identify::detail
