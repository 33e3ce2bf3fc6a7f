#include "gap/signals.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include <Eigen/Dense>

#include "core/error.hpp"

namespace kneesim::gap {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// One pass of a second-order Butterworth section (bilinear transform, pre-warped).
void biquad(std::vector<double>& x, double b0, double b1, double b2, double a1, double a2) {
  if (x.empty()) return;
  // Start in the steady state of the first value so the pad does not ring.
  const double x0 = x[0];
  double y1 = x0, y2 = x0, x1 = x0, x2 = x0;
  for (double& v : x) {
    const double y = b0 * v + b1 * x1 + b2 * x2 - a1 * y1 - a2 * y2;
    x2 = x1;
    x1 = v;
    y2 = y1;
    y1 = y;
    v = y;
  }
}
}  // namespace

std::vector<double> lowPass(const std::vector<double>& x, double rate, double cutoff) {
  KNEESIM_CHECK(rate > 0 && cutoff > 0 && cutoff < rate / 2, "low-pass cut-off must lie in (0, rate / 2)");
  const int n = static_cast<int>(x.size());
  if (n < 3) return x;
  const double k = std::tan(M_PI * cutoff / rate), q = std::sqrt(2.0);
  const double norm = 1 / (1 + q * k + k * k);
  const double b0 = k * k * norm, b1 = 2 * b0, b2 = b0, a1 = 2 * (k * k - 1) * norm, a2 = (1 - q * k + k * k) * norm;
  const int pad = std::min(n - 1, static_cast<int>(3 * rate / cutoff));
  std::vector<double> y;
  y.reserve(n + 2 * pad);
  for (int i = pad; i >= 1; --i) y.push_back(2 * x[0] - x[i]);
  y.insert(y.end(), x.begin(), x.end());
  for (int i = 1; i <= pad; ++i) y.push_back(2 * x[n - 1] - x[n - 1 - i]);
  biquad(y, b0, b1, b2, a1, a2);
  std::reverse(y.begin(), y.end());
  biquad(y, b0, b1, b2, a1, a2);
  std::reverse(y.begin(), y.end());
  return std::vector<double>(y.begin() + pad, y.begin() + pad + n);
}

std::vector<double> emgEnvelope(const std::vector<double>& raw, double rate, double cutoff) {
  if (raw.empty()) return {};
  const double mean = std::accumulate(raw.begin(), raw.end(), 0.0) / raw.size();
  std::vector<double> r(raw.size());
  for (size_t i = 0; i < raw.size(); ++i) r[i] = std::abs(raw[i] - mean);
  std::vector<double> env = lowPass(r, rate, cutoff);
  for (double& v : env) v = std::max(v, 0.0);
  return env;
}

std::vector<double> derivative(const std::vector<double>& t, const std::vector<double>& x) {
  const size_t n = x.size();
  std::vector<double> d(n, 0.0);
  if (n < 2) return d;
  d[0] = (x[1] - x[0]) / (t[1] - t[0]);
  d[n - 1] = (x[n - 1] - x[n - 2]) / (t[n - 1] - t[n - 2]);
  for (size_t i = 1; i + 1 < n; ++i) d[i] = (x[i + 1] - x[i - 1]) / (t[i + 1] - t[i - 1]);
  return d;
}

std::vector<double> interpolate(const std::vector<double>& t, const std::vector<double>& x,
                                const std::vector<double>& at, double tolerance) {
  std::vector<double> out(at.size(), kNaN);
  if (t.empty()) return out;
  size_t j = 0;
  for (size_t i = 0; i < at.size(); ++i) {
    const double v = at[i];
    if (v < t.front()) {
      if (t.front() - v <= tolerance) out[i] = x.front();
      continue;
    }
    if (v > t.back()) {
      if (v - t.back() <= tolerance) out[i] = x.back();
      continue;
    }
    if (j > 0 && t[j] > v) j = 0;  // targets not sorted: restart the walk
    while (j + 1 < t.size() && t[j + 1] < v) ++j;
    if (j + 1 >= t.size()) {
      out[i] = x.back();
      continue;
    }
    const double f = t[j + 1] > t[j] ? (v - t[j]) / (t[j + 1] - t[j]) : 0.0;
    out[i] = x[j] + f * (x[j + 1] - x[j]);
  }
  return out;
}

double IsotonicFit::evaluate(double v) const {
  if (x.empty()) return kNaN;
  if (v <= x.front()) return y.front();
  if (v >= x.back()) return y.back();
  const size_t j = std::upper_bound(x.begin(), x.end(), v) - x.begin();
  if (x[j] == x[j - 1]) return y[j];
  const double f = (v - x[j - 1]) / (x[j] - x[j - 1]);
  return y[j - 1] + f * (y[j] - y[j - 1]);
}

IsotonicFit fitIsotonic(const std::vector<double>& x, const std::vector<double>& y, const std::vector<double>& w) {
  std::vector<size_t> order;
  for (size_t i = 0; i < x.size(); ++i)
    if (std::isfinite(x[i]) && std::isfinite(y[i]) && (w.empty() || w[i] > 0)) order.push_back(i);
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return x[a] < x[b]; });
  // Blocks: weighted sums of y and y^2 (for the SSE) over an x range, pooled while they violate
  // monotonicity. Equal x values start in one block (a function cannot step within a tie).
  struct Block {
    double w, sy, syy, xmin, xmax;
  };
  std::vector<Block> blocks;
  for (size_t i : order) {
    const double wi = w.empty() ? 1.0 : w[i];
    const Block b{wi, wi * y[i], wi * y[i] * y[i], x[i], x[i]};
    if (!blocks.empty() && blocks.back().xmax == x[i]) {
      Block& l = blocks.back();
      l.w += b.w, l.sy += b.sy, l.syy += b.syy;
    } else {
      blocks.push_back(b);
    }
    while (blocks.size() > 1) {
      const Block& r = blocks.back();
      const Block& l = blocks[blocks.size() - 2];
      if (l.sy / l.w <= r.sy / r.w) break;
      const Block m{l.w + r.w, l.sy + r.sy, l.syy + r.syy, l.xmin, r.xmax};
      blocks.pop_back();
      blocks.back() = m;
    }
  }
  IsotonicFit f;
  for (const Block& b : blocks) {
    const double my = b.sy / b.w;
    f.sse += b.syy - b.w * my * my;
    // Knots at both ends of the block's x range: the fit is the block's value across it and
    // linear between blocks.
    f.x.push_back(b.xmin);
    f.y.push_back(my);
    if (b.xmax > b.xmin) {
      f.x.push_back(b.xmax);
      f.y.push_back(my);
    }
  }
  f.sse = std::max(0.0, f.sse);
  return f;
}

double pearson(const std::vector<double>& x, const std::vector<double>& y) {
  double sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
  int n = 0;
  for (size_t i = 0; i < std::min(x.size(), y.size()); ++i) {
    if (!std::isfinite(x[i]) || !std::isfinite(y[i])) continue;
    sx += x[i];
    sy += y[i];
    ++n;
  }
  if (n < 3) return kNaN;
  const double mx = sx / n, my = sy / n;
  for (size_t i = 0; i < std::min(x.size(), y.size()); ++i) {
    if (!std::isfinite(x[i]) || !std::isfinite(y[i])) continue;
    sxx += (x[i] - mx) * (x[i] - mx);
    syy += (y[i] - my) * (y[i] - my);
    sxy += (x[i] - mx) * (y[i] - my);
  }
  if (!(sxx > 0) || !(syy > 0)) return kNaN;
  return sxy / std::sqrt(sxx * syy);
}

double lag1Autocorrelation(const std::vector<double>& x) {
  double s = 0;
  int n = 0;
  for (double v : x)
    if (std::isfinite(v)) s += v, ++n;
  if (n < 3) return 0.0;
  const double m = s / n;
  double num = 0, den = 0;
  for (size_t i = 0; i < x.size(); ++i) {
    if (!std::isfinite(x[i])) continue;
    den += (x[i] - m) * (x[i] - m);
    if (i + 1 < x.size() && std::isfinite(x[i + 1])) num += (x[i] - m) * (x[i + 1] - m);
  }
  return den > 0 ? num / den : 0.0;
}

double effectiveSampleSize(int n, double rx, double ry) {
  const double p = std::clamp(rx * ry, -0.99, 0.99);
  return std::max(3.0, n * (1 - p) / (1 + p));
}

std::pair<double, double> correlationInterval(double r, double n_eff, double level) {
  if (!std::isfinite(r) || n_eff <= 3) return {kNaN, kNaN};
  const double z = std::atanh(std::clamp(r, -0.999999, 0.999999));
  const double h = normalQuantile(0.5 + level / 2) / std::sqrt(n_eff - 3);
  return {std::tanh(z - h), std::tanh(z + h)};
}

namespace {

// Continued fraction of the regularised incomplete beta function (modified Lentz).
double betaFraction(double a, double b, double x) {
  const double tiny = 1e-300;
  double c = 1, d = 1 - (a + b) * x / (a + 1);
  if (std::abs(d) < tiny) d = tiny;
  d = 1 / d;
  double h = d;
  for (int m = 1; m <= 300; ++m) {
    const double m2 = 2 * m;
    double aa = m * (b - m) * x / ((a + m2 - 1) * (a + m2));
    d = 1 + aa * d;
    if (std::abs(d) < tiny) d = tiny;
    c = 1 + aa / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1 / d;
    h *= d * c;
    aa = -(a + m) * (a + b + m) * x / ((a + m2) * (a + m2 + 1));
    d = 1 + aa * d;
    if (std::abs(d) < tiny) d = tiny;
    c = 1 + aa / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1 / d;
    const double del = d * c;
    h *= del;
    if (std::abs(del - 1) < 1e-15) break;
  }
  return h;
}

// Regularised incomplete beta I_x(a, b).
double incompleteBeta(double a, double b, double x) {
  if (x <= 0) return 0;
  if (x >= 1) return 1;
  const double lbt = std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) + a * std::log(x) + b * std::log(1 - x);
  if (x < (a + 1) / (a + b + 2)) return std::exp(lbt) * betaFraction(a, b, x) / a;
  return 1 - std::exp(lbt) * betaFraction(b, a, 1 - x) / b;
}

// Regularised upper incomplete gamma Q(a, x).
double upperGamma(double a, double x) {
  if (x <= 0) return 1;
  const double lg = std::lgamma(a);
  if (x < a + 1) {  // series for P
    double sum = 1 / a, term = sum;
    for (int n = 1; n < 1000; ++n) {
      term *= x / (a + n);
      sum += term;
      if (std::abs(term) < std::abs(sum) * 1e-16) break;
    }
    return 1 - sum * std::exp(-x + a * std::log(x) - lg);
  }
  const double tiny = 1e-300;  // continued fraction for Q
  double b = x + 1 - a, c = 1 / tiny, d = 1 / b, h = d;
  for (int i = 1; i < 1000; ++i) {
    const double an = -i * (i - a);
    b += 2;
    d = an * d + b;
    if (std::abs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1 / d;
    const double del = d * c;
    h *= del;
    if (std::abs(del - 1) < 1e-16) break;
  }
  return std::exp(-x + a * std::log(x) - lg) * h;
}

}  // namespace

double studentCdf(double t, double dof) {
  if (!(dof > 0)) return kNaN;
  const double x = dof / (dof + t * t);
  const double tail = 0.5 * incompleteBeta(dof / 2, 0.5, x);
  return t >= 0 ? 1 - tail : tail;
}

double fisherSurvival(double f, double dof1, double dof2) {
  if (!(dof1 > 0) || !(dof2 > 0) || std::isnan(f)) return kNaN;
  if (f <= 0) return 1;
  return incompleteBeta(dof2 / 2, dof1 / 2, dof2 / (dof2 + dof1 * f));
}

double studentQuantile(double p, double dof) {
  if (!(p > 0 && p < 1) || !(dof > 0)) return kNaN;
  // Bracket from the normal quantile, then bisect (monotone, cheap enough for reports).
  double lo = -1, hi = 1;
  const double z = normalQuantile(p);
  lo = std::min(lo, 4 * z - 1);
  hi = std::max(hi, 4 * z + 1);
  while (studentCdf(lo, dof) > p) lo *= 2;
  while (studentCdf(hi, dof) < p) hi *= 2;
  for (int i = 0; i < 200 && hi - lo > 1e-12 * std::max(1.0, std::abs(lo)); ++i) {
    const double mid = 0.5 * (lo + hi);
    (studentCdf(mid, dof) < p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

double chiSquareSurvival(double x, double dof) {
  if (!(dof > 0)) return kNaN;
  return upperGamma(dof / 2, x / 2);
}

MeanInterval meanInterval(const std::vector<double>& v, double level) {
  MeanInterval m;
  m.n = static_cast<int>(v.size());
  if (m.n == 0) {
    m.mean = m.lower = m.upper = m.sd = kNaN;
    return m;
  }
  m.mean = std::accumulate(v.begin(), v.end(), 0.0) / m.n;
  if (m.n < 2) {
    m.lower = m.upper = m.sd = kNaN;
    return m;
  }
  double ss = 0;
  for (double x : v) ss += (x - m.mean) * (x - m.mean);
  m.sd = std::sqrt(ss / (m.n - 1));
  const double h = studentQuantile(0.5 + level / 2, m.n - 1) * m.sd / std::sqrt(m.n);
  m.lower = m.mean - h;
  m.upper = m.mean + h;
  return m;
}

std::vector<double> fitAutoregression(const std::vector<std::vector<double>>& runs, int order) {
  KNEESIM_CHECK(order == -1 || order > 0, "fitAutoregression: order must be -1 or positive");
  const int lo = order > 0 ? order : 1, hi = order > 0 ? order : 10;
  std::vector<double> best;
  double best_bic = std::numeric_limits<double>::infinity();
  for (int p = lo; p <= hi; ++p) {
    int n = 0;
    for (const auto& x : runs)
      for (size_t t = p; t < x.size(); ++t) {
        bool ok = std::isfinite(x[t]);
        for (int k = 1; k <= p && ok; ++k) ok = std::isfinite(x[t - k]);
        n += ok;
      }
    if (n < 10 * p + 20) break;
    Eigen::MatrixXd a(n, p);
    Eigen::VectorXd b(n);
    int row = 0;
    for (const auto& x : runs)
      for (size_t t = p; t < x.size(); ++t) {
        bool ok = std::isfinite(x[t]);
        for (int k = 1; k <= p && ok; ++k) ok = std::isfinite(x[t - k]);
        if (!ok) continue;
        for (int k = 1; k <= p; ++k) a(row, k - 1) = x[t - k];
        b[row++] = x[t];
      }
    const Eigen::VectorXd phi = a.colPivHouseholderQr().solve(b);
    const double sse = (b - a * phi).squaredNorm();
    const double bic = n * std::log(std::max(sse / n, 1e-300)) + p * std::log(static_cast<double>(n));
    if (bic < best_bic) best_bic = bic, best.assign(phi.data(), phi.data() + p);
  }
  return best;
}

double whitenedSumOfSquares(const std::vector<double>& phi, const std::vector<double>& x) {
  const size_t p = phi.size();
  double s = 0;
  for (size_t t = p; t < x.size(); ++t) {
    double e = x[t];
    for (size_t k = 1; k <= p && std::isfinite(e); ++k) e -= phi[k - 1] * x[t - k];
    if (std::isfinite(e)) s += e * e;
  }
  return s;
}

MeanInterval relativeReductionInterval(const std::vector<double>& a, const std::vector<double>& b, double level) {
  KNEESIM_CHECK(a.size() == b.size(), "relativeReductionInterval: paired totals of different lengths");
  MeanInterval m;
  m.n = static_cast<int>(a.size());
  const double sa = std::accumulate(a.begin(), a.end(), 0.0), sb = std::accumulate(b.begin(), b.end(), 0.0);
  if (m.n == 0 || !(sa > 0)) {
    m.mean = m.lower = m.upper = m.sd = kNaN;
    return m;
  }
  m.mean = 1 - sb / sa;
  if (m.n < 2) {
    m.lower = m.upper = m.sd = kNaN;
    return m;
  }
  double ss = 0;
  for (int u = 0; u < m.n; ++u) {
    const double e = (a[u] - b[u]) - m.mean * a[u];
    ss += e * e;
  }
  const double se = std::sqrt(m.n / (m.n - 1.0) * ss) / sa;
  m.sd = se * std::sqrt(m.n);
  const double h = studentQuantile(0.5 + level / 2, m.n - 1) * se;
  m.lower = m.mean - h;
  m.upper = m.mean + h;
  return m;
}

double effectiveCount(const std::vector<double>& w) {
  double s = 0, s2 = 0;
  for (double x : w) s += x, s2 += x * x;
  return s2 > 0 ? s * s / s2 : 0.0;
}

MeanInterval weightedMeanInterval(const std::vector<double>& v, const std::vector<double>& w, double level) {
  MeanInterval m;
  m.n = static_cast<int>(v.size());
  double sw = 0, sw2 = 0, swx = 0;
  for (size_t i = 0; i < v.size(); ++i) sw += w[i], sw2 += w[i] * w[i], swx += w[i] * v[i];
  if (m.n == 0 || !(sw > 0)) {
    m.mean = m.lower = m.upper = m.sd = kNaN;
    return m;
  }
  m.mean = swx / sw;
  if (m.n < 2) {
    m.lower = m.upper = m.sd = kNaN;
    return m;
  }
  double ss = 0;
  for (size_t i = 0; i < v.size(); ++i) ss += w[i] * (v[i] - m.mean) * (v[i] - m.mean);
  const double var = ss / (sw - sw2 / sw);  // reliability weights: unbiased
  m.sd = std::sqrt(var);
  const double n_eff = sw * sw / sw2;
  const double se = std::sqrt(var * sw2) / sw;
  const double h = studentQuantile(0.5 + level / 2, std::max(1.0, n_eff - 1)) * se;
  m.lower = m.mean - h;
  m.upper = m.mean + h;
  return m;
}

}  // namespace kneesim::gap
