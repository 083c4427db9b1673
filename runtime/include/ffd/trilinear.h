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

// A cell turned inside out: the Jacobian of eq. 2 at the cell's centre has a determinant
// <= 0 (its three mean edge directions no longer form a right-handed frame). `corner(j)` is
// the deformed corner j.
template <class CornerFn>
inline bool cell_inside_out(CornerFn&& corner) {
  const Vec3 ds = corner(1) - corner(0) + corner(3) - corner(2) + corner(5) - corner(4) + corner(7) - corner(6);
  const Vec3 dt = corner(2) - corner(0) + corner(3) - corner(1) + corner(6) - corner(4) + corner(7) - corner(5);
  const Vec3 du = corner(4) - corner(0) + corner(5) - corner(1) + corner(6) - corner(2) + corner(7) - corner(3);
  return !(ds.cross(dt).dot(du) > 0.0);
}

}  // namespace ffd
