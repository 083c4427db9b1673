#pragma once
// SIMD kernel of the FFD AABB update (paper section 4, eq. 2): the 9 nodes of every box from
// its cell's 8 lattice nodes, kBoxLanes boxes at a time, and each box's world AABB for the
// broad phase. Each lane computes exactly what trilinear_map() computes for one point, so the
// nodes are bit-identical to it on every SIMD target (see spring_kernels.h).
#include <array>
#include <cstdint>

#include "ffd/model.h"

namespace ffd {

struct BoxOutput {
  std::array<Vec3, 9>* nodes;  // per box: 8 corners, then the centre of mass, m
  double* lo[3];               // per box and axis: the AABB of its 9 nodes, m (null: not wanted)
  double* hi[3];
  std::uint8_t* valid;         // set to 1 for every box written
};

// The boxes of blocks [first_block, last_block) of `set` (BoxSet::kernel_local), from the
// lattice positions `x` (State::x as 3 N doubles).
void update_box_blocks(const BoxSet& set, Index first_block, Index last_block, const double* x, const BoxOutput& out);

// Box b alone, by the same arithmetic as its lane in update_box_blocks.
void update_one_box(const BoxSet& set, Index box, const double* x, const BoxOutput& out);

}  // namespace ffd
