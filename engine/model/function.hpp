#pragma once
// Scalar functions used by CustomJoint transform axes and coordinate couplers: OpenSim's
// Constant, LinearFunction, PolynomialFunction, SimmSpline, NaturalCubicSpline,
// PiecewiseLinearFunction and MultiplierFunction.

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
/// Natural cubic spline (OpenSim NaturalCubicSpline).
FunctionPtr makeNaturalCubicSpline(std::vector<double> x, std::vector<double> y);
/// Piecewise linear interpolation (OpenSim PiecewiseLinearFunction).
FunctionPtr makePiecewiseLinear(std::vector<double> x, std::vector<double> y);
/// f(x) = scale * g(x) (OpenSim MultiplierFunction).
FunctionPtr makeMultiplier(FunctionPtr g, double scale);

}  // namespace kneesim::model
