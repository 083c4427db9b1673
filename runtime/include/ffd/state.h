#pragma once
// State: everything that changes while a scene runs. The step index is the only clock.
// Two States built from the same Model and advanced by the same commands are bit-identical.
#include <cstdint>
#include <vector>

#include "ffd/types.h"

namespace ffd {

// Parameters a user may tune while the scene runs (they start from the scene's settings).
struct TunableParams {
  Vec3 gravity = Vec3::Zero();  // m/s^2
  double alpha = 0.0;           // collision damping, eq. 8
  double beta = 0.0;            // friction, eq. 8
};

struct State {
  std::uint64_t step = 0;  // steps taken since time zero
  TunableParams params;
  std::vector<Vec3> x;  // (N) lattice node positions, m
  std::vector<Vec3> v;  // (N) lattice node velocities, m/s
  std::vector<Quat> region_rotation;  // (R) shape-matching rotations, warm start of the next step
};

// FNV-1a (64 bit) over the raw bits of every x, then every v, in node order.
std::uint64_t state_hash(const State& state);

}  // namespace ffd
