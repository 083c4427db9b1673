#pragma once
// SIMD kernel of the mass-spring solve (Highway: the best target this CPU has, chosen at run
// time). Each lane does exactly the scalar XPBD update of one spring, the same IEEE operations
// in the same order (no fused multiply-add), so the result is bit-identical to solving the
// springs one after the other, whichever target runs and however many lanes it has.
#include <cstddef>
#include <cstdint>

#include "ffd/model.h"

namespace ffd {

// A node as the kernel reads it: a 32-byte record, so that one aligned load brings a lane's
// node and four records transpose into four lanes in registers.
inline constexpr std::size_t kNodeRecord = 4;  // doubles: x, y, z (m), then 1/m (1/kg) or unused

struct SpringSolve {
  double* node;                    // per node x, y, z, 1/m: 4 N doubles, 32-byte aligned
  const double* start;             // per node x, y, z at the start of the step, then unused: 4 N doubles
  const Index* node_a;             // per spring: its two nodes
  const Index* node_b;
  const double* rest_length;       // per spring, m
  double* lambda;                  // per spring: XPBD multiplier of this step
  const double* inv_denominator;   // per spring: 1 / ((1 + gamma)(wa + wb) + alpha~)
  double alpha_tilde;              // compliance / dt^2
  double gamma;                    // compliance * damping / dt
};

// One XPBD projection of springs [begin, end). `independent`: no two of them share a node,
// so they are solved several at a time; else one after the other.
void project_springs(const SpringSolve& solve, Index begin, Index end, bool independent);

// The target the kernels run on ("AVX3", "AVX2", "SSE4", ..., "SCALAR").
const char* simd_target_name();

}  // namespace ffd
