#pragma once
// A bar on a pin about z (and optionally a block sliding along the bar), built in code for the
// closed-form dynamics tests.

#include <memory>

#include "model/model.hpp"

namespace kneesim::test {

/// What the pendulum is made of.
struct PendulumSpec {
  double mass = 2.5;                                    ///< the bar's mass, kg
  model::Vec3 mass_center = model::Vec3(0.4, 0, 0);     ///< in the bar's frame
  model::Vec3 inertia = model::Vec3(0.01, 0.02, 0.03);  ///< central, diagonal
  model::Vec3 pin_in_ground = model::Vec3::Zero();      ///< the pin's place on ground (F)
  model::Vec3 pin_in_bar = model::Vec3::Zero();         ///< the pin's place on the bar (M)
  double gravity = 9.81;                                ///< along -y
  double block_mass = 0;  ///< > 0 adds a block on a slider along the bar's x axis at its origin
};

/// ground -Pin "pin" (coordinate "angle")-> "bar" [-Slider "slider" ("slide")-> "block"].
inline std::shared_ptr<model::Model> makePendulum(const PendulumSpec& s) {
  auto m = std::make_shared<model::Model>();
  m->name = "pendulum";
  m->format_version = 40000;
  m->gravity = model::Vec3(0, -s.gravity, 0);
  auto addBody = [&](const char* name, double mass, const model::Vec3& com, const model::Vec3& inertia) {
    model::Body b;
    b.name = name;
    b.mass = mass;
    b.mass_center = com;
    b.inertia = inertia.asDiagonal();
    m->bodies.push_back(b);
  };
  auto addJoint = [&](const char* name, model::JointType type, const char* coordinate, model::MotionType motion,
                      int parent, int child, const model::Vec3& p_PF, const model::Vec3& p_BM) {
    model::Coordinate c;
    c.name = coordinate;
    c.motion_type = motion;
    c.joint = int(m->joints.size());
    m->coordinates.push_back(c);
    model::Joint j;
    j.name = name;
    j.type = type;
    j.parent_body = parent;
    j.child_body = child;
    j.X_PF = model::poseFromXYZ(model::Vec3::Zero(), p_PF);
    j.X_BM = model::poseFromXYZ(model::Vec3::Zero(), p_BM);
    j.coordinates = {int(m->coordinates.size()) - 1};
    m->joints.push_back(j);
  };
  addBody("ground", 0, model::Vec3::Zero(), model::Vec3::Zero());
  addBody("bar", s.mass, s.mass_center, s.inertia);
  addJoint("pin", model::JointType::Pin, "angle", model::MotionType::Rotational, 0, 1, s.pin_in_ground, s.pin_in_bar);
  if (s.block_mass > 0) {
    addBody("block", s.block_mass, model::Vec3::Zero(), model::Vec3::Constant(1e-3));
    addJoint("slider", model::JointType::Slider, "slide", model::MotionType::Translational, 1, 2, model::Vec3::Zero(),
             model::Vec3::Zero());
  }
  m->finalize();
  return m;
}

}  // namespace kneesim::test
