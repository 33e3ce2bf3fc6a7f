// Confidence intervals of a fit: asymptotic (the Gauss-Newton covariance inflated for serially
// correlated residuals), profile likelihood (the weighted SSE minimised over the other parameters)
// and block or trial bootstrap, for the parameters and the law's derived quantities.

#include <algorithm>
#include <random>

#include <Eigen/LU>

#include "identify/fit_detail.hpp"
#include "identify/statistics.hpp"

namespace kneesim::identify::detail {

namespace {

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return kNaN;
  std::sort(v.begin(), v.end());
  const double pos = q * (v.size() - 1);
  const size_t i = static_cast<size_t>(std::floor(pos));
  const double f = pos - i;
  return i + 1 < v.size() ? v[i] * (1 - f) + v[i + 1] * f : v[i];
}

}  // namespace

void FitState::calcIntervals(const std::vector<Trial>& trials, FitReport& rep) {
  const int k = static_cast<int>(free.size());
  const double z = normalQuantile(0.5 + o.confidence.level / 2);
  const Eigen::VectorXd se = calcAsymptoticIntervals(z, rep);
  if (k > 0 && o.confidence.profile) calcProfileIntervals(z, se, rep);
  calcBootstrapIntervals(trials, rep);
}

// Asymptotic intervals at level z; returns the standard errors of the free parameters (NaN where
// the covariance is not available).
Eigen::VectorXd FitState::calcAsymptoticIntervals(double z, FitReport& rep) {
  const int k = static_cast<int>(free.size());
  Eigen::VectorXd se = Eigen::VectorXd::Constant(k, kNaN);
  if (k > 0 && o.confidence.asymptotic && n_pos > k) {
    // Gauss-Newton covariance, inflated by n / n_eff for serially correlated residuals.
    Eigen::MatrixXd j = data.calcJacobian(full, free);
    Eigen::MatrixXd jtwj = Eigen::MatrixXd::Zero(k, k);
    for (int i = 0; i < n; ++i) jtwj.noalias() += w0[i] * j.row(i).transpose() * j.row(i);
    const double s2 = sse_min / (n_pos - k) * (1 + rho) / (1 - rho);
    // Invert in scaled parameters (D J^T W J D with D the sensitivity scales): parameters of very
    // different magnitudes (a modulus ~1e7 Pa next to a threshold shift ~1e-4 m) make J^T W J
    // look singular to a pivot threshold although it is well conditioned once scaled.
    Eigen::VectorXd dsc(k);
    for (int a = 0; a < k; ++a) dsc[a] = sensitivityScale(law, full, free[a]);
    const Eigen::MatrixXd scaled = dsc.asDiagonal() * jtwj * dsc.asDiagonal();
    Eigen::FullPivLU<Eigen::MatrixXd> lu(scaled);
    if (lu.isInvertible()) {
      const Eigen::MatrixXd cov = s2 * dsc.asDiagonal() * lu.inverse() * dsc.asDiagonal();
      for (int a = 0; a < k; ++a) {
        se[a] = std::sqrt(std::max(0.0, cov(a, a)));
        rep.parameters[free[a]].ci_asymptotic = {full[free[a]] - z * se[a], full[free[a]] + z * se[a]};
      }
      const Eigen::MatrixXd g = derivedGradient(law, full, free, lower, upper, false);
      for (int q = 0; q < law.getNumDerived(); ++q) {
        const double sd = std::sqrt(std::max(0.0, (g.row(q) * cov * g.row(q).transpose())(0, 0)));
        rep.derived[q].ci_asymptotic = {rep.derived[q].value - z * sd, rep.derived[q].value + z * sd};
      }
    }
  }
  return se;
}

// Minimum of the weighted SSE over the free parameters other than free[a] with free[a] = v,
// starting from the optimum; also returns the parameter vector.
double FitState::calcProfileSse(int a, double v, Eigen::VectorXd& at) {
  Eigen::VectorXd p = full;
  p[free[a]] = v;
  std::vector<int> others;
  std::vector<double> y0;
  LeastSquaresOptions po = lso;
  holdOneOut(law, free, a, full, lower, upper, others, y0, po);
  po.verbose = false;
  po.warm_mu = 1e-6;
  data.setFull(p);
  data.setFree(others);
  const LeastSquaresResult r = solveLeastSquares(data, y0, po);
  at = p;
  for (size_t b = 0; b < others.size(); ++b) at[others[b]] = r.x[b];
  return r.sse;
}

// Profile-likelihood intervals at level z, searched from the optimum in steps of @p se.
void FitState::calcProfileIntervals(double z, const Eigen::VectorXd& se, FitReport& rep) {
  const int k = static_cast<int>(free.size());
  const double chi2 = z * z;
  const double threshold = sse_min * std::exp(chi2 / rep.effective_frames);
  std::vector<Eigen::VectorXd> ends;
  for (int a = 0; a < k; ++a) {
    const int j = free[a];
    const double v0 = full[j];
    double step = std::isfinite(se[a]) && se[a] > 0 ? se[a] : 1e-3 * sensitivityScale(law, full, j);
    step = std::max(step, 1e-9 * sensitivityScale(law, full, j));
    double bound[2];
    for (int side = 0; side < 2; ++side) {
      const double dir = side == 0 ? -1.0 : 1.0;
      const double limit = side == 0 ? lower[j] : upper[j];
      Eigen::VectorXd at;
      double inside = v0, outside = kNaN;
      double d = step;
      for (int it = 0; it < 60; ++it) {
        double v = v0 + dir * d;
        if ((side == 0 && v <= limit) || (side == 1 && v >= limit)) {
          v = limit;
          if (calcProfileSse(a, v, at) <= threshold) break;  // the interval reaches the bound
          outside = v;
          break;
        }
        if (calcProfileSse(a, v, at) > threshold) {
          outside = v;
          break;
        }
        inside = v;
        d *= 2;
      }
      if (std::isnan(outside)) {
        bound[side] = limit;
        calcProfileSse(a, limit, at);
        ends.push_back(at);
        continue;
      }
      for (int it = 0; it < 60 && std::abs(outside - inside) > 1e-10 * std::max(std::abs(v0), step); ++it) {
        const double mid = 0.5 * (inside + outside);
        (calcProfileSse(a, mid, at) > threshold ? outside : inside) = mid;
      }
      bound[side] = 0.5 * (inside + outside);
      calcProfileSse(a, bound[side], at);
      ends.push_back(at);
    }
    rep.parameters[j].ci_profile = {bound[0], bound[1]};
  }
  for (int q = 0; q < law.getNumDerived(); ++q) {
    double lo = rep.derived[q].value, hi = lo;
    for (const auto& e : ends) {
      const double v = law.calcDerived(e)[q];
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
    rep.derived[q].ci_profile = {lo, hi};
  }
  data.setFull(full);
  data.setFree(free);
}

// Bootstrap intervals: the fit repeated on frames drawn in circular blocks, or on whole trials.
void FitState::calcBootstrapIntervals(const std::vector<Trial>& trials, FitReport& rep) {
  const int k = static_cast<int>(free.size());
  const ConfidenceOptions& co = o.confidence;
  rep.bootstrap.mode = co.bootstrap_mode;
  rep.bootstrap.seed = co.seed;
  if (k > 0 && co.bootstrap_samples > 0) {
    if (co.bootstrap_mode != "frames" && co.bootstrap_mode != "trials")
      throw InputError(o.where, "bootstrap mode: expected 'frames' or 'trials', got '" + co.bootstrap_mode + "'");
    const bool by_trial = co.bootstrap_mode == "trials";
    if (by_trial && trials.size() < 2)
      throw InputError(o.where, "bootstrap mode 'trials': expected at least two trials, got " +
                                    std::to_string(trials.size()));
    int n_min = n;
    for (const auto& t : data.getTrials()) n_min = std::min<int>(n_min, static_cast<int>(t.frames.size()));
    int block = co.block_length;
    if (block <= 0) {
      // Long enough to keep the residuals' correlation inside blocks, at least n^(1/3).
      const double corr_len = (1 + rho) / (1 - rho);
      block = static_cast<int>(std::ceil(std::max(std::cbrt(static_cast<double>(n_min)), corr_len)));
    }
    block = std::clamp(block, 1, std::max(1, n_min / 2));
    rep.bootstrap.samples = co.bootstrap_samples;
    rep.bootstrap.block_length = by_trial ? 0 : block;
    std::mt19937_64 rng(co.seed);
    // Portable draws (std::uniform_int_distribution differs between standard libraries).
    auto draw = [&](int m) { return static_cast<int>(rng() % static_cast<unsigned long long>(m)); };
    std::vector<std::vector<double>> pv(k), dv(law.getNumDerived());
    LeastSquaresOptions bo = lso;
    bo.verbose = false;
    bo.warm_mu = 1e-6;
    std::vector<double> counts(n);
    for (int b = 0; b < co.bootstrap_samples; ++b) {
      std::fill(counts.begin(), counts.end(), 0.0);
      auto& tds2 = data.getTrials();
      if (by_trial) {
        for (size_t t = 0; t < tds2.size(); ++t) {
          const auto& td = tds2[draw(static_cast<int>(tds2.size()))];
          for (size_t s = 0; s < td.frames.size(); ++s) counts[td.offset + s] += 1;
        }
      } else {
        // Circular blocks (Politis & Romano 1992): a block may wrap from the last frame to the
        // first, so every frame is drawn equally often. Blocks that must fit inside the window
        // under-sample its first and last frames and bias the estimate.
        for (const auto& td : tds2) {
          const int m = static_cast<int>(td.frames.size());
          const int len = std::min(block, m);
          int filled = 0;
          while (filled < m) {
            const int start = draw(m);
            for (int s = 0; s < len && filled < m; ++s, ++filled) counts[td.offset + (start + s) % m] += 1;
          }
        }
      }
      for (int i = 0; i < n; ++i) bo.weights[i] = w0[i] * counts[i];
      data.setFull(full);
      data.setFree(free);
      const LeastSquaresResult r = solveLeastSquares(data, xhat, bo);
      if (!r.success) {
        ++rep.bootstrap.failures;
        continue;
      }
      Eigen::VectorXd p = full;
      for (int a = 0; a < k; ++a) {
        p[free[a]] = r.x[a];
        pv[a].push_back(r.x[a]);
      }
      const Eigen::VectorXd d = law.calcDerived(p);
      for (int q = 0; q < law.getNumDerived(); ++q) dv[q].push_back(d[q]);
    }
    const double lo_q = 0.5 - co.level / 2, hi_q = 0.5 + co.level / 2;
    for (int a = 0; a < k; ++a) rep.parameters[free[a]].ci_bootstrap = {percentile(pv[a], lo_q), percentile(pv[a], hi_q)};
    for (int q = 0; q < law.getNumDerived(); ++q) rep.derived[q].ci_bootstrap = {percentile(dv[q], lo_q), percentile(dv[q], hi_q)};
    data.setFull(full);
    data.setFree(free);
  }
}

}  // namespace kneesim::identify::detail
