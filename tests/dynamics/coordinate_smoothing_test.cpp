// Coordinate trajectories: units, missing columns, state-path labels, derivatives of a known
// motion, and bad input.
#include "dynamics/coordinate_smoothing.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "support/input_error.hpp"

namespace kneesim::dynamics {
namespace {

/// A model with a rotational and a translational coordinate (no joints are needed here).
model::Model twoCoordinates() {
  model::Model m;
  model::Coordinate a, b, c;
  a.name = "angle";
  b.name = "shift";
  b.motion_type = model::MotionType::Translational;
  c.name = "unused";
  c.default_value = 0.25;
  m.coordinates = {a, b, c};
  return m;
}

io::Storage motion(const std::vector<std::string>& labels, double rate, int rows) {
  io::Storage s;
  s.labels = labels;
  s.data.resize(rows, 3);
  for (int r = 0; r < rows; ++r) {
    const double t = r / rate;
    s.data(r, 0) = t;
    s.data(r, 1) = 30 * std::sin(2 * t);  // degrees
    s.data(r, 2) = 0.1 * t * t;
  }
  return s;
}

TEST(CoordinateSmoothing, DifferentiatesUnfilteredMotionInSIUnits) {
  const model::Model m = twoCoordinates();
  CoordinateSmoothingOptions o;
  o.in_degrees = true;
  const CoordinateTrajectories traj(m, motion({"time", "angle", "/jointset/j/shift/value"}, 100, 200), "f.mot", o);
  ASSERT_EQ(traj.getMissing().size(), 1u);
  EXPECT_EQ(traj.getMissing()[0], "unused");
  Eigen::VectorXd q(3), qd(3), qdd(3);
  const double t = 0.987, k = M_PI / 180;
  traj.calcAt(t, q, qd, qdd);
  EXPECT_NEAR(q[0], 30 * k * std::sin(2 * t), 1e-9);
  EXPECT_NEAR(qd[0], 60 * k * std::cos(2 * t), 1e-7);
  EXPECT_NEAR(qdd[0], -120 * k * std::sin(2 * t), 1e-5);
  EXPECT_NEAR(q[1], 0.1 * t * t, 1e-12);  // translations are not converted
  EXPECT_NEAR(qd[1], 0.2 * t, 1e-9);
  EXPECT_NEAR(qdd[1], 0.2, 1e-7);
  EXPECT_EQ(q[2], 0.25);  // missing: its default
  EXPECT_EQ(qd[2], 0.0);
}

TEST(CoordinateSmoothing, LowPassKeepsSlowMotionAndPadsTheTimes) {
  const model::Model m = twoCoordinates();
  CoordinateSmoothingOptions o;
  o.cutoff_hz = 6;
  o.in_degrees = true;
  const CoordinateTrajectories traj(m, motion({"time", "angle", "shift"}, 100, 201), "f.mot", o);
  // Padded by half the rows on each side (the steps are uniform: no resampling).
  ASSERT_EQ(traj.getTimes().size(), 201u + 2 * 100);
  EXPECT_NEAR(traj.getTimes().front(), -1.0, 1e-12);
  EXPECT_NEAR(traj.getStartTime(), 0.0, 1e-12);
  EXPECT_NEAR(traj.getEndTime(), 2.0, 1e-12);
  Eigen::VectorXd q(3), qd(3), qdd(3);
  traj.calcAt(1.0, q, qd, qdd);
  // 0.32 Hz passes a 6 Hz Butterworth almost unchanged: (0.32/6)^6 ~ 2e-8.
  EXPECT_NEAR(q[0], 30 * M_PI / 180 * std::sin(2.0), 1e-6);
}

TEST(CoordinateSmoothing, BadInputIsOneLine) {
  const model::Model m = twoCoordinates();
  io::Storage s = motion({"time", "angle", "shift"}, 100, 50);
  s.data(7, 1) = std::nan("");
  EXPECT_NE(test::inputErrorOf([&] { CoordinateTrajectories(m, s, "ik.mot", {}); }).find("ik.mot: angle: expected a finite value"),
            std::string::npos);
  io::Storage u = motion({"time", "angle", "shift"}, 100, 50);
  u.data(9, 0) = u.data(8, 0);
  EXPECT_NE(test::inputErrorOf([&] { CoordinateTrajectories(m, u, "ik.mot", {}); }).find("expected strictly increasing times"),
            std::string::npos);
  EXPECT_NE(test::inputErrorOf([&] { CoordinateTrajectories(m, motion({"t", "angle", "shift"}, 100, 50), "ik.mot", {}); })
                .find("expected a 'time' column"),
            std::string::npos);
}

}  // namespace
}  // namespace kneesim::dynamics
