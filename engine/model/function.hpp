#pragma once
// Scalar functions used by CustomJoint transform axes and coordinate couplers: OpenSim's
// Constant, LinearFunction, PolynomialFunction, SimmSpline, NaturalCubicSpline,
// PiecewiseLinearFunction and MultiplierFunction.
//
// The evaluation reproduces OpenSim (opensim-core OpenSim/Common/*.cpp) exactly, including
// SIMM's spline end conditions, its linear extrapolation outside the knots and its treatment of
// abscissae within 2e-13 of an end knot. OpenSim maps the type name NaturalCubicSpline (and the
// older natCubicSpline) onto SimmSpline, so both names evaluate identically here too.

#include <memory>
#include <string>
#include <vector>

namespace kneesim::model {

/// A smooth function f: R^n -> R with derivatives up to order 2. Immutable once built.
class Function {
 public:
  virtual ~Function() = default;
  /// Number of arguments n (1 for every spline; couplers may use more).
  virtual int getArgumentSize() const { return 1; }
  /// f(x); @p x has getArgumentSize() entries.
  virtual double calcValue(const double* x) const = 0;
  /// Partial derivative of f. @p components lists the argument index of each differentiation
  /// (size 1 or 2): {0} is df/dx0, {0,0} is d2f/dx0^2.
  virtual double calcDerivative(const double* x, const int* components, int order) const = 0;
  /// OpenSim's XML tag for this type, e.g. "SimmSpline".
  virtual std::string getTypeName() const = 0;

  /// One-argument conveniences.
  double calcValue(double x) const { return calcValue(&x); }
  double calcDerivative1(double x) const { static const int c[1] = {0}; return calcDerivative(&x, c, 1); }
  double calcDerivative2(double x) const { static const int c[2] = {0, 0}; return calcDerivative(&x, c, 2); }
};

using FunctionPtr = std::shared_ptr<const Function>;

/// f(x) = value.
FunctionPtr makeConstant(double value);
/// f(x) = slope*x + intercept.
FunctionPtr makeLinear(double slope, double intercept);
/// f(x) = c[0] x^(n-1) + ... + c[n-1] (coefficients from highest order down, as OpenSim).
FunctionPtr makePolynomial(std::vector<double> coefficients);
/// SIMM's cubic spline (OpenSim SimmSpline), linear extrapolation outside the knots.
FunctionPtr makeSimmSpline(std::vector<double> x, std::vector<double> y);
/// Natural cubic spline (OpenSim NaturalCubicSpline). OpenSim evaluates this type with the
/// SimmSpline algorithm (RegisterTypes_osimCommon renames it), so this is a SimmSpline whose
/// getTypeName() is "NaturalCubicSpline".
FunctionPtr makeNaturalCubicSpline(std::vector<double> x, std::vector<double> y);
/// Piecewise linear interpolation (OpenSim PiecewiseLinearFunction).
FunctionPtr makePiecewiseLinear(std::vector<double> x, std::vector<double> y);
/// f(x) = scale * g(x) (OpenSim MultiplierFunction).
FunctionPtr makeMultiplier(FunctionPtr g, double scale);

/// Checks knots for the tabulated functions: equal sizes, at least two points, finite values
/// and strictly increasing x. Returns "" when valid, else a message "expected ..., got ...".
std::string checkKnots(const std::vector<double>& x, const std::vector<double>& y);

/// If @p f is exactly slope*x + intercept of its single argument (Constant, LinearFunction,
/// PolynomialFunction of degree <= 1, or a MultiplierFunction of one of these), stores the two
/// numbers and returns true; otherwise returns false and leaves them unchanged.
bool findLinearForm(const Function& f, double& slope, double& intercept);

/// OpenSim Constant: f(x) = value for any number of arguments.
class Constant final : public Function {
 public:
  /// Creates f = @p value taking @p argument_size arguments.
  explicit Constant(double value, int argument_size = 1) : value_(value), n_(argument_size) {}
  int getArgumentSize() const override { return n_; }
  double calcValue(const double*) const override { return value_; }
  double calcDerivative(const double*, const int*, int) const override { return 0.0; }
  std::string getTypeName() const override { return "Constant"; }
  /// The constant value.
  double getValue() const { return value_; }

 private:
  double value_;
  int n_;
};

/// OpenSim LinearFunction: f(x) = slope*x + intercept (XML `<coefficients>slope intercept`).
class LinearFunction final : public Function {
 public:
  /// Creates f(x) = @p slope x + @p intercept.
  LinearFunction(double slope, double intercept) : slope_(slope), intercept_(intercept) {}
  double calcValue(const double* x) const override { return slope_ * x[0] + intercept_; }
  double calcDerivative(const double*, const int*, int order) const override { return order == 1 ? slope_ : 0.0; }
  std::string getTypeName() const override { return "LinearFunction"; }
  /// The slope.
  double getSlope() const { return slope_; }
  /// The value at x = 0.
  double getIntercept() const { return intercept_; }

 private:
  double slope_, intercept_;
};

/// OpenSim PolynomialFunction: coefficients from the highest power down.
class PolynomialFunction final : public Function {
 public:
  /// Creates the polynomial; an empty list is the zero polynomial.
  explicit PolynomialFunction(std::vector<double> coefficients);
  double calcValue(const double* x) const override;
  double calcDerivative(const double* x, const int* components, int order) const override;
  std::string getTypeName() const override { return "PolynomialFunction"; }
  /// Coefficients, highest power first.
  const std::vector<double>& getCoefficients() const { return c_; }

 private:
  std::vector<double> c_;
};

/// OpenSim SimmSpline (and NaturalCubicSpline, which OpenSim evaluates with the same code):
/// the Forsythe-Malcolm-Moler cubic spline with third-derivative end conditions from divided
/// differences (n >= 4), zero-rhs end conditions for n = 3, a straight line for n = 2, and
/// linear extrapolation with the end slopes outside [x0, xn-1].
class SimmSpline final : public Function {
 public:
  /// Fits the spline; throws std::invalid_argument if checkKnots() rejects the knots.
  SimmSpline(std::vector<double> x, std::vector<double> y, std::string type_name = "SimmSpline");
  double calcValue(const double* x) const override;
  double calcDerivative(const double* x, const int* components, int order) const override;
  std::string getTypeName() const override { return type_name_; }
  /// The knots' abscissae, strictly increasing.
  const std::vector<double>& getX() const { return x_; }
  /// The knots' values.
  const std::vector<double>& getY() const { return y_; }
  /// Coefficients b, c, d of interval k: f = y_k + b_k dx + c_k dx^2 + d_k dx^3 with dx = x - x_k.
  const std::vector<double>& getB() const { return b_; }
  /// See getB().
  const std::vector<double>& getC() const { return c_; }
  /// See getB().
  const std::vector<double>& getD() const { return d_; }

 private:
  int findInterval(double x) const;
  std::vector<double> x_, y_, b_, c_, d_;
  std::string type_name_;
};

/// OpenSim PiecewiseLinearFunction: straight segments between knots, end-segment slopes outside.
class PiecewiseLinearFunction final : public Function {
 public:
  /// Builds the function; throws std::invalid_argument if checkKnots() rejects the knots.
  PiecewiseLinearFunction(std::vector<double> x, std::vector<double> y);
  double calcValue(const double* x) const override;
  double calcDerivative(const double* x, const int* components, int order) const override;
  std::string getTypeName() const override { return "PiecewiseLinearFunction"; }
  /// The knots' abscissae, strictly increasing.
  const std::vector<double>& getX() const { return x_; }
  /// The knots' values.
  const std::vector<double>& getY() const { return y_; }

 private:
  int findInterval(double x) const;
  std::vector<double> x_, y_, b_;
};

/// OpenSim MultiplierFunction: f(x) = scale * g(x).
class MultiplierFunction final : public Function {
 public:
  /// Wraps @p g (not null) scaled by @p scale.
  MultiplierFunction(FunctionPtr g, double scale);
  int getArgumentSize() const override { return g_->getArgumentSize(); }
  double calcValue(const double* x) const override { return scale_ * g_->calcValue(x); }
  double calcDerivative(const double* x, const int* components, int order) const override {
    return scale_ * g_->calcDerivative(x, components, order);
  }
  std::string getTypeName() const override { return "MultiplierFunction"; }
  /// The scaled function g.
  const FunctionPtr& getFunction() const { return g_; }
  /// The factor applied to g.
  double getScale() const { return scale_; }

 private:
  FunctionPtr g_;
  double scale_;
};

}  // namespace kneesim::model
