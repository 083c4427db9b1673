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

// The rebound that follows eq. 8: the pair's approach u (< 0, m/s, relative normal velocity
// of the two sides' mean velocities) is reversed to -(1 - alpha) u, so alpha = 1 stops it
// (as eq. 8 alone does), alpha = 0 is an elastic bounce and values between are a
// coefficient of restitution 1 - alpha. Returns the change of relative normal velocity
// (m/s, >= 0) to split between the two sides by position_shares (momentum is kept).
// Why: eq. 8 alone keeps (1 - alpha) of the approach and eq. 9 moves the nodes without
// touching it, so at small alpha a resting contact keeps the approach gravity adds every
// step (g dt / alpha at rest; without bound at alpha = 0) and a pair meeting head on passes
// through. Only a fresh contact rebounds: one whose depth r this approach made within the
// last `recent` seconds. A node lodged deeper says nothing reliable about the contact's
// normal, and reversing along a wrong one would throw it through the wall it is stuck in.
inline double rebound(double u, double depth, double alpha, double recent) {
  if (!(u < 0.0) || !(depth <= -u * recent)) return 0.0;
  return -2.0 * (1.0 - alpha) * u;
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
