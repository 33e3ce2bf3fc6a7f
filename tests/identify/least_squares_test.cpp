#include "identify/least_squares.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <thread>

namespace kneesim::identify {
namespace {

// Rosenbrock as least squares: r = (10 (x2 - x1^2), 1 - x1); minimum (1, 1).
struct Rosenbrock : LeastSquaresProblem {
  int getNumParameters() const override { return 2; }
  int getNumResiduals() const override { return 2; }
  void calcResiduals(const double* x, double* r, double* j) override {
    r[0] = 10 * (x[1] - x[0] * x[0]);
    r[1] = 1 - x[0];
    if (j) {
      j[0] = -20 * x[0];  // dr0/dx0
      j[1] = -1;          // dr1/dx0
      j[2] = 10;          // dr0/dx1
      j[3] = 0;           // dr1/dx1
    }
  }
};

// y = a exp(b t) sampled at 30 points; a and b of very different magnitudes.
struct Exponential : LeastSquaresProblem {
  double a = 2500, b = -3.5e-3;
  int getNumParameters() const override { return 2; }
  int getNumResiduals() const override { return 30; }
  void calcResiduals(const double* x, double* r, double* j) override {
    for (int i = 0; i < 30; ++i) {
      const double t = 10.0 * i;
      const double e = std::exp(x[1] * t);
      r[i] = x[0] * e - a * std::exp(b * t);
      if (j) {
        j[i] = e;
        j[30 + i] = x[0] * t * e;
      }
    }
  }
};

TEST(LeastSquares, SolvesRosenbrock) {
  Rosenbrock p;
  const LeastSquaresResult r = solveLeastSquares(p, {-1.2, 1.0}, {});
  EXPECT_TRUE(r.success) << r.status;
  EXPECT_EQ(r.status, "Solve_Succeeded");
  EXPECT_NEAR(r.x[0], 1.0, 1e-8);
  EXPECT_NEAR(r.x[1], 1.0, 1e-8);
  EXPECT_LT(r.sse, 1e-16);
  EXPECT_NEAR(r.start_sse, 24.2, 1e-9);  // 10^2 (1 - 1.44)^2 + 2.2^2 = 19.36 + 4.84
  EXPECT_GT(r.iterations, 3);
}

TEST(LeastSquares, RespectsBounds) {
  // With x1 <= 0.5 the minimum is on the bound: x1 = 0.5, x2 = x1^2 = 0.25 (r0 = 0, r1 = 0.5).
  Rosenbrock p;
  LeastSquaresOptions o;
  o.lower = {-2, -2};
  o.upper = {0.5, 2};
  const LeastSquaresResult r = solveLeastSquares(p, {-1.2, 1.0}, o);
  EXPECT_TRUE(r.success) << r.status;
  EXPECT_LE(r.x[0], 0.5);
  EXPECT_NEAR(r.x[0], 0.5, 1e-7);
  EXPECT_NEAR(r.x[1], 0.25, 1e-6);
  EXPECT_TRUE(r.at_upper[0]);
  EXPECT_FALSE(r.at_lower[0] || r.at_upper[1] || r.at_lower[1]);
  EXPECT_NEAR(r.sse, 0.25, 1e-7);
}

TEST(LeastSquares, ScalingHandlesDisparateMagnitudes) {
  Exponential p;
  LeastSquaresOptions o;
  o.scale = {1000, 1e-3};
  o.lower = {0, -1};
  o.upper = {1e5, 1};
  for (bool gn : {true, false}) {
    o.gauss_newton = gn;
    const LeastSquaresResult r = solveLeastSquares(p, {1000, -1e-3}, o);
    EXPECT_TRUE(r.success) << r.status << (gn ? " gauss-newton" : " l-bfgs");
    EXPECT_NEAR(r.x[0], 2500, 1e-5 * 2500);
    EXPECT_NEAR(r.x[1], -3.5e-3, 1e-5 * 3.5e-3);
  }
}

TEST(LeastSquares, WeightsSelectResiduals) {
  // Weight only the second residual: any x1 = 1 minimises, x2 stays free (Gauss-Newton singular in
  // x2, Ipopt regularises) -- check x1 only.
  Rosenbrock p;
  LeastSquaresOptions o;
  o.weights = {0.0, 1.0};
  const LeastSquaresResult r = solveLeastSquares(p, {-1.2, 1.0}, o);
  EXPECT_NEAR(r.x[0], 1.0, 1e-7);
  EXPECT_LT(r.sse, 1e-14);
}

// r = |x|^0.6: f = |x|^1.2 has its minimum at 0, where its curvature is infinite. The Gauss-Newton
// Hessian (p^2 / 2 |x|^(p - 2) for f = |x|^p) is too small there: each step lands at -2/3 x, so the
// objective converges linearly, to 1e-10 in about 50 steps, while the scaled gradient 1.2 |x|^0.2
// would need |x| < 1e-50 to reach tol 1e-10 -- hundreds of iterations past convergence.
struct SlowPower : LeastSquaresProblem {
  int getNumParameters() const override { return 1; }
  int getNumResiduals() const override { return 1; }
  void calcResiduals(const double* x, double* r, double* j) override {
    const double a = std::abs(x[0]);
    r[0] = std::pow(a, 0.6);
    if (j) j[0] = a > 0 ? 0.6 * std::pow(a, -0.4) * (x[0] > 0 ? 1 : -1) : 0.0;
  }
};

TEST(LeastSquares, AStalledObjectiveEndsTheSolve) {
  SlowPower p;
  const LeastSquaresResult r = solveLeastSquares(p, {1.0}, {});
  EXPECT_TRUE(r.success) << r.status;
  EXPECT_EQ(r.status, "Objective_Stalled");
  EXPECT_LT(std::abs(r.x[0]), 1e-8);
  EXPECT_LT(r.sse, 1e-10);
  EXPECT_LT(r.iterations, 150);  // max_iterations is 200: it did not run out
}

// r = x - 1.2e-3 with x >= 1e-3: the optimum lies 2e-4 above the bound, well inside Ipopt's default
// bound push (1e-2), which would move a warm start there 50 times its distance from the bound (and,
// in a fit with a modulus near its floor, multiplied the objective by 1000 before the first step).
struct NearBound : LeastSquaresProblem {
  double farthest = 0;  // largest distance from 1.2e-3 of any point evaluated
  int getNumParameters() const override { return 1; }
  int getNumResiduals() const override { return 2; }
  void calcResiduals(const double* x, double* r, double* j) override {
    farthest = std::max(farthest, std::abs(x[0] - 1.2e-3));
    r[0] = 1e3 * (x[0] - 1.2e-3);
    r[1] = 1.0;  // a residual the parameter cannot change: the optimum's SSE is 1
    if (j) j[0] = 1e3, j[1] = 0;
  }
};

TEST(LeastSquares, AWarmStartStaysWhereItIs) {
  NearBound p;
  LeastSquaresOptions o;
  o.lower = {1e-3};
  o.upper = {1.0};
  o.warm_mu = 1e-6;
  const LeastSquaresResult r = solveLeastSquares(p, {1.2e-3}, o);
  EXPECT_TRUE(r.success) << r.status;
  EXPECT_NEAR(r.x[0], 1.2e-3, 1e-9);
  EXPECT_LT(p.farthest, 1e-6);
  // A cold start is pushed into the interior as usual (and still finds the optimum).
  NearBound cold;
  o.warm_mu = 0;
  const LeastSquaresResult c = solveLeastSquares(cold, {1.2e-3}, o);
  EXPECT_TRUE(c.success) << c.status;
  EXPECT_NEAR(c.x[0], 1.2e-3, 1e-8);
  EXPECT_GT(cold.farthest, 1e-3);
}

struct Throwing : Rosenbrock {
  int calls = 0;
  void calcResiduals(const double* x, double* r, double* j) override {
    if (++calls > 3) throw std::runtime_error("law failed");
    Rosenbrock::calcResiduals(x, r, j);
  }
};

TEST(LeastSquares, ExceptionsFromTheProblemPropagate) {
  Throwing p;
  EXPECT_THROW(solveLeastSquares(p, {-1.2, 1.0}, {}), std::runtime_error);
}

TEST(LeastSquares, ConcurrentSolvesAreSerialisedAndCorrect) {
  // MUMPS is not thread-safe; the mutex makes parallel callers safe.
  std::vector<std::vector<double>> out(4);
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t)
    threads.emplace_back([&out, t] {
      Exponential p;
      p.a = 1000 + 100 * t;
      LeastSquaresOptions o;
      o.scale = {1000, 1e-3};
      out[t] = solveLeastSquares(p, {500, -1e-3}, o).x;
    });
  for (auto& th : threads) th.join();
  for (int t = 0; t < 4; ++t) {
    EXPECT_NEAR(out[t][0], 1000 + 100 * t, 1e-4 * (1000 + 100 * t));
    EXPECT_NEAR(out[t][1], -3.5e-3, 1e-6);
  }
}

TEST(LeastSquares, NothingFreeJustEvaluates) {
  struct Empty : LeastSquaresProblem {
    int getNumParameters() const override { return 0; }
    int getNumResiduals() const override { return 1; }
    void calcResiduals(const double*, double* r, double*) override { r[0] = 3; }
  } p;
  const LeastSquaresResult r = solveLeastSquares(p, {}, {});
  EXPECT_TRUE(r.success);
  EXPECT_EQ(r.sse, 9);
}

}  // namespace
}  // namespace kneesim::identify
