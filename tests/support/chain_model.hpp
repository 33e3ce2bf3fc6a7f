#pragma once
// A small hand-built model shared by the sim and ik tests.

#include <cmath>
#include <memory>

#include "model/model.hpp"

namespace kneesim::test {

using model::Vec3;

// ground -Pin(q0)-> A -Slider(q1)-> B -Custom(q2)-> C, markers on A, B, C.
//  Pin j0:    X_PF = translation (0,1,0); rotates A about z by q0.
//  Slider j1: X_PF = (0.5,0,0) with body-fixed XYZ (0, pi/2, 0): F's x axis is A's -z.
//  Custom j2: rotation1 about z by q2, translation1 along x by 0.1 q2 + 0.05.
inline std::shared_ptr<model::Model> makeChain(bool reverse_custom, int format_version) {
  auto m = std::make_shared<model::Model>();
  m->name = "chain";
  m->format_version = format_version;
  m->bodies.resize(4);
  const char* names[] = {"ground", "A", "B", "C"};
  for (int i = 0; i < 4; ++i) {
    m->bodies[i].name = names[i];
    m->bodies[i].mass = i == 0 ? 0.0 : 1.0;
    m->bodies[i].inertia = model::Mat3::Identity() * (i == 0 ? 0.0 : 0.01);
  }
  auto coord = [&](const char* n, model::MotionType t, int joint) {
    model::Coordinate c;
    c.name = n;
    c.motion_type = t;
    c.joint = joint;
    m->coordinates.push_back(c);
    return int(m->coordinates.size() - 1);
  };
  model::Joint j0;
  j0.name = "pin";
  j0.type = model::JointType::Pin;
  j0.parent_body = 0;
  j0.child_body = 1;
  j0.X_PF = model::poseFromXYZ(Vec3::Zero(), Vec3(0, 1, 0));
  j0.coordinates = {coord("q0", model::MotionType::Rotational, 0)};
  model::Joint j1;
  j1.name = "slider";
  j1.type = model::JointType::Slider;
  j1.parent_body = 1;
  j1.child_body = 2;
  j1.X_PF = model::poseFromXYZ(Vec3(0, M_PI / 2, 0), Vec3(0.5, 0, 0));
  j1.coordinates = {coord("q1", model::MotionType::Translational, 1)};
  model::Joint j2;
  j2.name = "custom";
  j2.type = model::JointType::Custom;
  j2.parent_body = 2;
  j2.child_body = 3;
  j2.reverse = reverse_custom;
  const int q2 = coord("q2", model::MotionType::Coupled, 2);
  j2.coordinates = {q2};
  j2.spatial[0].axis = Vec3::UnitZ();
  j2.spatial[0].coordinates = {q2};
  j2.spatial[0].function = model::makeLinear(1.0, 0.0);
  j2.spatial[1].axis = Vec3::UnitX();
  j2.spatial[2].axis = Vec3::UnitY();
  j2.spatial[3].axis = Vec3::UnitX();
  j2.spatial[3].coordinates = {q2};
  j2.spatial[3].function = model::makeLinear(0.1, 0.05);
  j2.spatial[4].axis = Vec3::UnitY();
  j2.spatial[5].axis = Vec3::UnitZ();
  m->joints = {j0, j1, j2};
  m->markers = {{"mA", 1, Vec3(0.5, 0, 0), false}, {"mB", 2, Vec3(0, 0, 0.2), false},
                {"mC", 3, Vec3(0.1, 0, 0), false}, {"mC0", 3, Vec3::Zero(), false}};
  m->finalize();
  return m;
}

}  // namespace kneesim::test
