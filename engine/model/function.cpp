#include "model/function.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace kneesim::model {

namespace {

// OpenSim/Common/SimmMacros.h. Knot spacings are floored at TINY_NUMBER and abscissae this close
// to an end knot take the end knot's value, exactly as OpenSim evaluates them.
constexpr double kTinyNumber = 0.0000001;
constexpr double kRoundoffError = 0.0000000000002;

bool equalWithinError(double a, double b) { return std::abs(a - b) <= kRoundoffError; }

std::string fmt(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

void requireKnots(const std::vector<double>& x, const std::vector<double>& y) {
  const std::string msg = checkKnots(x, y);
  if (!msg.empty()) throw std::invalid_argument(msg);
}

// OpenSim's binary search for the interval [x_k, x_k+1] holding xv, for x0 < xv < xn-1. The
// bounds guard only matters for a NaN argument, which OpenSim also lets through to the formula.
int searchInterval(const std::vector<double>& x, double xv) {
  const int n = int(x.size());
  if (n < 3) return 0;
  int i = 0, j = n, k = 0;
  for (int guard = 0; guard < 64; ++guard) {
    k = (i + j) / 2;
    if (k > n - 2) k = n - 2;
    if (xv < x[k])
      j = k;
    else if (xv > x[k + 1])
      i = k;
    else
      break;
  }
  return k;
}

// OpenSim's rule outside and on the ends of the knots x: linear extrapolation with the end
// slopes b, and the end values on the ends (within rounding). Sets v and returns true there;
// false inside, where the function's own interval formula applies.
bool findEndValue(const std::vector<double>& x, const std::vector<double>& y, const std::vector<double>& b, double xv,
                  double& v) {
  const size_t n = x.size();
  if (xv < x[0])
    v = y[0] + (xv - x[0]) * b[0];
  else if (xv > x[n - 1])
    v = y[n - 1] + (xv - x[n - 1]) * b[n - 1];
  else if (equalWithinError(xv, x[0]))
    v = y[0];
  else if (equalWithinError(xv, x[n - 1]))
    v = y[n - 1];
  else
    return false;
  return true;
}

}  // namespace

std::string checkKnots(const std::vector<double>& x, const std::vector<double>& y) {
  if (x.size() != y.size())
    return "expected as many y values as x values (" + std::to_string(x.size()) + "), got " +
           std::to_string(y.size());
  if (x.size() < 2) return "expected at least 2 knots, got " + std::to_string(x.size());
  for (size_t i = 0; i < x.size(); ++i)
    if (!std::isfinite(x[i]) || !std::isfinite(y[i]))
      return "expected finite knots, got x=" + fmt(x[i]) + " y=" + fmt(y[i]) + " at knot " + std::to_string(i);
  for (size_t i = 1; i < x.size(); ++i)
    if (!(x[i] > x[i - 1]))
      return "expected strictly increasing x, got " + fmt(x[i - 1]) + " then " + fmt(x[i]) + " at knot " +
             std::to_string(i);
  return "";
}

// ---------------------------------------------------------------------------------------------
PolynomialFunction::PolynomialFunction(std::vector<double> coefficients) : c_(std::move(coefficients)) {}

double PolynomialFunction::calcValue(const double* x) const {
  double v = 0.0;
  for (double c : c_) v = v * x[0] + c;
  return v;
}

double PolynomialFunction::calcDerivative(const double* x, const int*, int order) const {
  // c_[i] multiplies x^p with p = n-1-i; its order-th derivative is c p!/(p-order)! x^(p-order).
  const int n = int(c_.size());
  double v = 0.0;
  for (int i = 0; i < n; ++i) {
    const int p = n - 1 - i;
    if (p < order) break;
    double f = c_[i];
    for (int k = 0; k < order; ++k) f *= double(p - k);
    v = v * x[0] + f;
  }
  return v;
}

// ---------------------------------------------------------------------------------------------
SimmSpline::SimmSpline(std::vector<double> x, std::vector<double> y, std::string type_name)
    : x_(std::move(x)), y_(std::move(y)), type_name_(std::move(type_name)) {
  requireKnots(x_, y_);
  // SimmSpline::calcCoefficients, statement for statement.
  const int n = int(x_.size());
  b_.assign(n, 0.0);
  c_.assign(n, 0.0);
  d_.assign(n, 0.0);
  std::vector<double>& b = b_;
  std::vector<double>& c = c_;
  std::vector<double>& d = d_;
  if (n == 2) {
    const double t = std::max(kTinyNumber, x_[1] - x_[0]);
    b[0] = b[1] = (y_[1] - y_[0]) / t;
    return;
  }
  const int nm1 = n - 1, nm2 = n - 2;
  // Tridiagonal system: b = diagonal, d = off-diagonal, c = right-hand side.
  d[0] = std::max(kTinyNumber, x_[1] - x_[0]);
  c[1] = (y_[1] - y_[0]) / d[0];
  for (int i = 1; i < nm1; ++i) {
    d[i] = std::max(kTinyNumber, x_[i + 1] - x_[i]);
    b[i] = 2.0 * (d[i - 1] + d[i]);
    c[i + 1] = (y_[i + 1] - y_[i]) / d[i];
    c[i] = c[i + 1] - c[i];
  }
  // End conditions: third derivatives at the ends from divided differences (n > 3).
  b[0] = -d[0];
  b[nm1] = -d[nm2];
  c[0] = 0.0;
  c[nm1] = 0.0;
  if (n > 3) {
    const double d31 = std::max(kTinyNumber, x_[3] - x_[1]);
    const double d20 = std::max(kTinyNumber, x_[2] - x_[0]);
    const double d1 = std::max(kTinyNumber, x_[nm1] - x_[n - 3]);
    const double d2 = std::max(kTinyNumber, x_[nm2] - x_[n - 4]);
    const double d30 = std::max(kTinyNumber, x_[3] - x_[0]);
    const double d3 = std::max(kTinyNumber, x_[nm1] - x_[n - 4]);
    c[0] = c[2] / d31 - c[1] / d20;
    c[nm1] = c[nm2] / d1 - c[n - 3] / d2;
    c[0] = c[0] * d[0] * d[0] / d30;
    c[nm1] = -c[nm1] * d[nm2] * d[nm2] / d3;
  }
  for (int i = 1; i < n; ++i) {  // forward elimination
    const double t = d[i - 1] / b[i - 1];
    b[i] -= t * d[i - 1];
    c[i] -= t * c[i - 1];
  }
  c[nm1] /= b[nm1];  // back substitution
  for (int j = 0; j < nm1; ++j) {
    const int i = nm2 - j;
    c[i] = (c[i] - d[i] * c[i + 1]) / b[i];
  }
  // Polynomial coefficients.
  b[nm1] = (y_[nm1] - y_[nm2]) / d[nm2] + d[nm2] * (c[nm2] + 2.0 * c[nm1]);
  for (int i = 0; i < nm1; ++i) {
    b[i] = (y_[i + 1] - y_[i]) / d[i] - d[i] * (c[i + 1] + 2.0 * c[i]);
    d[i] = (c[i + 1] - c[i]) / d[i];
    c[i] *= 3.0;
  }
  c[nm1] *= 3.0;
  d[nm1] = d[nm2];
}

int SimmSpline::findInterval(double x) const { return searchInterval(x_, x); }

double SimmSpline::calcValue(const double* xp) const {
  const double x = xp[0];
  double v;
  if (findEndValue(x_, y_, b_, x, v)) return v;
  const int k = findInterval(x);
  const double dx = x - x_[k];
  return y_[k] + dx * (b_[k] + dx * (c_[k] + dx * d_[k]));
}

double SimmSpline::calcDerivative(const double* xp, const int*, int order) const {
  if (order < 1 || order > 2) return 0.0;  // OpenSim throws; the third derivative is unused
  const double x = xp[0];
  const int n = int(x_.size());
  if (x < x_[0]) return order == 1 ? b_[0] : 0.0;
  if (x > x_[n - 1]) return order == 1 ? b_[n - 1] : 0.0;
  if (equalWithinError(x, x_[0])) return order == 1 ? b_[0] : 2.0 * c_[0];
  if (equalWithinError(x, x_[n - 1])) return order == 1 ? b_[n - 1] : 2.0 * c_[n - 1];
  const int k = findInterval(x);
  const double dx = x - x_[k];
  if (order == 1) return b_[k] + dx * (2.0 * c_[k] + 3.0 * dx * d_[k]);
  return 2.0 * c_[k] + 6.0 * dx * d_[k];
}

// ---------------------------------------------------------------------------------------------
PiecewiseLinearFunction::PiecewiseLinearFunction(std::vector<double> x, std::vector<double> y)
    : x_(std::move(x)), y_(std::move(y)) {
  requireKnots(x_, y_);
  const int n = int(x_.size());
  b_.assign(n, 0.0);
  for (int i = 0; i < n - 1; ++i) b_[i] = (y_[i + 1] - y_[i]) / std::max(kTinyNumber, x_[i + 1] - x_[i]);
  b_[n - 1] = b_[n - 2];
}

int PiecewiseLinearFunction::findInterval(double x) const { return searchInterval(x_, x); }

double PiecewiseLinearFunction::calcValue(const double* xp) const {
  const double x = xp[0];
  double v;
  if (findEndValue(x_, y_, b_, x, v)) return v;
  const int k = findInterval(x);
  return y_[k] + (x - x_[k]) * b_[k];
}

double PiecewiseLinearFunction::calcDerivative(const double* xp, const int*, int order) const {
  if (order != 1) return 0.0;
  const double x = xp[0];
  const int n = int(x_.size());
  if (x < x_[0]) return b_[0];
  if (x > x_[n - 1]) return b_[n - 1];
  if (equalWithinError(x, x_[0])) return b_[0];
  if (equalWithinError(x, x_[n - 1])) return b_[n - 1];
  return b_[findInterval(x)];
}

// ---------------------------------------------------------------------------------------------
MultiplierFunction::MultiplierFunction(FunctionPtr g, double scale) : g_(std::move(g)), scale_(scale) {
  if (!g_) throw std::invalid_argument("MultiplierFunction needs a function to scale");
}

// ---------------------------------------------------------------------------------------------
FunctionPtr makeConstant(double value) { return std::make_shared<Constant>(value); }
FunctionPtr makeLinear(double slope, double intercept) { return std::make_shared<LinearFunction>(slope, intercept); }
FunctionPtr makePolynomial(std::vector<double> coefficients) {
  return std::make_shared<PolynomialFunction>(std::move(coefficients));
}
FunctionPtr makeSimmSpline(std::vector<double> x, std::vector<double> y) {
  return std::make_shared<SimmSpline>(std::move(x), std::move(y), "SimmSpline");
}
FunctionPtr makeNaturalCubicSpline(std::vector<double> x, std::vector<double> y) {
  return std::make_shared<SimmSpline>(std::move(x), std::move(y), "NaturalCubicSpline");
}
FunctionPtr makePiecewiseLinear(std::vector<double> x, std::vector<double> y) {
  return std::make_shared<PiecewiseLinearFunction>(std::move(x), std::move(y));
}
FunctionPtr makeMultiplier(FunctionPtr g, double scale) {
  return std::make_shared<MultiplierFunction>(std::move(g), scale);
}

bool findLinearForm(const Function& f, double& slope, double& intercept) {
  if (f.getArgumentSize() != 1) return false;
  if (auto* c = dynamic_cast<const Constant*>(&f)) {
    slope = 0.0;
    intercept = c->getValue();
    return true;
  }
  if (auto* l = dynamic_cast<const LinearFunction*>(&f)) {
    slope = l->getSlope();
    intercept = l->getIntercept();
    return true;
  }
  if (auto* p = dynamic_cast<const PolynomialFunction*>(&f)) {
    const auto& c = p->getCoefficients();
    if (c.size() > 2) {
      // Leading zero coefficients still make a line.
      for (size_t i = 0; i + 2 < c.size(); ++i)
        if (c[i] != 0.0) return false;
    }
    const size_t n = c.size();
    slope = n >= 2 ? c[n - 2] : 0.0;
    intercept = n >= 1 ? c[n - 1] : 0.0;
    return true;
  }
  if (auto* m = dynamic_cast<const MultiplierFunction*>(&f)) {
    double s, i;
    if (!findLinearForm(*m->getFunction(), s, i)) return false;
    slope = m->getScale() * s;
    intercept = m->getScale() * i;
    return true;
  }
  return false;
}

}  // namespace kneesim::model
