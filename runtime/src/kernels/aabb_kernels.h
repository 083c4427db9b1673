#pragma once
// SIMD kernel of the edge tests' box filter (deepest_edge_crossing): which of a cell's
// candidate triangles have an AABB that meets an edge's. The compares are exact, so every
// SIMD target finds the same triangles, in the same order, as the scalar test.
#include <array>

#include "ffd/model.h"

namespace ffd {

// Axis-aligned boxes as columns, one array per bound and axis (m): the layout the kernel
// loads a vector of boxes from.
struct BoxColumns {
  std::array<const double*, 3> lo;
  std::array<const double*, 3> hi;
};

// Writes to `hits`, in increasing order, every i < count whose box meets [lo, hi]: on no
// axis does it lie wholly below or wholly above (a NaN bound separates nothing, so such a
// box meets). Returns how many; `hits` has room for count.
Index boxes_meeting(const BoxColumns& boxes, Index count, const Vec3& lo, const Vec3& hi, Index* hits);

}  // namespace ffd
