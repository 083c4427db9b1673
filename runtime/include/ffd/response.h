#pragma once
// Collision response kernels (paper section 7), shared by box-box contacts and static planes.
//
// Conventions. A node of box B was found inside box A; n is the unit outward normal of A's
// plane of least penetration and r > 0 the depth along it (eq. 7). The paper writes R = r N
// and projects velocities on R; projections here use the unit normal n and corrections use r,
// which is what eq. 8 and eq. 9 mean dimensionally.
#include "ffd/types.h"

namespace ffd {

// Eq. 8 for one lattice-node velocity V: the normal part is scaled by (1 - alpha) (damping)
// and the tangential part by (1 - beta) (friction), both taken relative to v_ref. For a pair
// of cells v_ref is their mass-weighted mean velocity, so alpha = 1 stops the approach and
// keeps the pair's momentum; for a static plane v_ref = 0 and this is the paper's formula.
// (V . (-n)) (-n) = (V . n) n, so the same expression serves A and B.
inline Vec3 respond_velocity(const Vec3& V, const Vec3& v_ref, const Vec3& n, double alpha,
                             double beta) {
  const Vec3 relative = V - v_ref;
  const Vec3 normal_part = relative.dot(n) * n;
  return v_ref + (1.0 - alpha) * normal_part + (1.0 - beta) * (relative - normal_part);
}

// Eq. 9, generalised to unequal masses: A moves by -share_a * r * n, B by +share_b * r * n,
// share = inverse mass / sum of inverse masses. Equal masses give the paper's r/2 each; a
// static plane (inverse mass 0) puts the whole correction on the moving side.
struct PositionShares {
  double a, b;
};
inline PositionShares position_shares(double inv_mass_a, double inv_mass_b) {
  const double sum = inv_mass_a + inv_mass_b;
  if (!(sum > 0.0)) return {0.0, 0.0};
  return {inv_mass_a / sum, inv_mass_b / sum};
}

}  // namespace ffd
