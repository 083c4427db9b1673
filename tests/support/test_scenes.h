#pragma once
// Scenes built in code for the tests: small, fast, and each exercising one mechanism.
#include <string>

#include "ffd/model.h"
#include "ffd/spec.h"

namespace ffd::test {

inline ObjectSpec box_object(const std::string& name, const Vec3& size, double cell_size, const Vec3& position) {
  ObjectSpec o;
  o.name = name;
  o.source = "box";
  o.mesh = make_box_mesh(size);
  o.position = position;
  o.cell_size = cell_size;
  o.mass = 1.0;
  o.dynamics = DynamicsKind::MassSpring;
  o.mass_spring.stiffness = 2.0e4;
  o.mass_spring.damping = 1.0;
  o.mass_spring.iterations = 4;
  return o;
}

inline ObjectSpec sphere_object(const std::string& name, double radius, double cell_size, const Vec3& position) {
  ObjectSpec o = box_object(name, Vec3::Ones(), cell_size, position);
  o.source = "sphere";
  o.mesh = make_sphere_mesh(radius, 3);
  return o;
}

inline PlaneSpec floor_plane() {
  PlaneSpec p;
  p.name = "floor";
  p.normal = Vec3::UnitY();
  p.offset = 0.0;
  return p;
}

inline Model compile_quietly(const SceneSpec& spec) {
  std::vector<std::string> log;
  return compile(spec, log);
}

}  // namespace ffd::test
