#pragma once
// Trilinear free-form deformation of one regular lattice cell (paper section 3).
// Corner j of a cell is (j & 1, (j >> 1) & 1, (j >> 2) & 1) in local coordinates: x fastest.
#include "ffd/types.h"

namespace ffd {

// Eq. 1, divided by the cell size h so that (s, t, u) is in [0, 1]^3 inside the cell:
// s = (x - x0) / h, t = (y - y0) / h, u = (z - z0) / h.
inline Vec3 local_coordinates(const Vec3& p, const Vec3& cell_origin, double h) {
  return (p - cell_origin) / h;
}

// The eight products B_j(s) B_j(t) B_j(u) of the linear Bernstein functions (eq. 2).
inline std::array<double, 8> trilinear_weights(const Vec3& stu) {
  const double s = stu.x(), t = stu.y(), u = stu.z();
  const double s0 = 1.0 - s, t0 = 1.0 - t, u0 = 1.0 - u;
  return {s0 * t0 * u0, s * t0 * u0, s0 * t * u0, s * t * u0,
          s0 * t0 * u,  s * t0 * u,  s0 * t * u,  s * t * u};
}

// Eq. 2: p' = sum_j B_j(s) B_j(t) B_j(u) C'_j over the cell's 8 deformed corners.
template <class CornerFn>
inline Vec3 trilinear_map(const Vec3& stu, CornerFn&& corner) {
  const std::array<double, 8> w = trilinear_weights(stu);
  Vec3 p = w[0] * corner(0);
  for (int j = 1; j < 8; ++j) p += w[j] * corner(j);
  return p;
}

}  // namespace ffd
