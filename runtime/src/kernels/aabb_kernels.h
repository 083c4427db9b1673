#pragma once
// SIMD kernels of the edge tests' filters (deepest_edge_crossing): which of a cell's edges
// and triangles have an AABB that meets a region, and which candidate triangles have an AABB
// that meets an edge's and a plane the edge passes through. Each lane does the scalar test's
// operations in the scalar test's order (no fused multiply-add: -ffp-contract=off, and no
// MulAdd here), so every SIMD target keeps the same ones, in the same order, as the scalar
// test.
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

// Triangles as columns: their AABBs, their faces (triangle_face: the unnormalised normal) and
// a corner each, the one plane_height measures from.
struct TriangleColumns {
  BoxColumns boxes;
  std::array<const double*, 3> face;
  std::array<const double*, 3> corner;
};

// How far p lies in front of the plane through `corner` with normal `face`, times |face|
// (m^3 for a triangle_face): > 0 in front, < 0 behind. Written out, so that the kernel's
// lanes compute it with the same operations in the same order.
inline double plane_height(const Vec3& face, const Vec3& corner, const Vec3& p) {
  const Vec3 d = p - corner;
  return (face.x() * d.x() + face.y() * d.y()) + face.z() * d.z();
}

// Writes to `hits`, in increasing order, every i < count whose triangle the segment pq may
// cross: its box meets [lo, hi] (pq's bounds), on no axis lying wholly below or wholly
// above, and p and q lie strictly on opposite sides of its plane (plane_height, > 0 and < 0).
// A NaN anywhere is no crossing, as in segment_crosses_triangle. Returns how many; `hits` has
// room for count.
Index triangles_straddled(const TriangleColumns& triangles, Index count, const Vec3& p, const Vec3& q, const Vec3& lo,
                          const Vec3& hi, Index* hits);

}  // namespace ffd
