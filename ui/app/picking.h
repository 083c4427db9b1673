#pragma once
// From a world point on an embedded surface (read back from the depth buffer) to the lattice
// cell and local coordinates a Grab command names.
#include "ffd/model.h"
#include "ffd/physics_loop.h"

namespace ffd::ui {

struct CellPoint {
  Index cell = kNoIndex;      // global cell index
  Vec3 local = Vec3::Zero();  // (s, t, u) in [0, 1]^3
};

// Local coordinates of `point` in the trilinear cell with corners `corners` (eq. 2 inverted by
// Newton's method; exact for undistorted cells after one iteration).
Vec3 inverse_trilinear(const std::array<Vec3, 8>& corners, const Vec3& point);

// The surface cell whose deformed cell holds `point` (tolerance: a quarter of a cell);
// cell == kNoIndex when none does.
CellPoint cell_at(const Model& model, const Frame& frame, const Vec3& point);

// Mean lattice node position of an object in this frame (m).
Vec3 object_centre(const Model& model, const Frame& frame, Index object);

}  // namespace ffd::ui
