#pragma once
// Narrow phase on one deformed FFD AABB (paper section 6.2): its six face planes and the
// node-in-box test.
//
// Box node k (0..7) is the corner (k & 1, (k >> 1) & 1, (k >> 2) & 1) of the box in the
// cell's local frame; node 8 is the centre of mass. After deformation the faces are no
// longer planar, so each face gets one plane:
//   normal  N = (c - a) x (d - b) over the face's corners a, b, c, d taken counter-clockwise
//           seen from outside: the cross product of the face diagonals (eq. 3). N is
//           perpendicular to both diagonals, so a and c lie at one height along N, b and d at
//           another.
//   anchor  the higher of the two diagonals (eq. 4-6): the plane N . (P - anchor) = 0 then
//           has all four face nodes on or below it — the conservative choice, so the region
//           bounded by the six planes contains every boundary node.
// A node is inside the box when all six signed distances are negative. The contact face is
// the plane of least penetration (eq. 7), or, for a node moving into the box, the face it
// came in through (see the second node_in_box).
//
// Degenerate boxes. A face whose diagonals are parallel or of zero length (a flat or
// collapsed box) has no normal: |N| <= kDegenerateNormal * (face diagonal lengths) marks the
// box degenerate, and a degenerate box contains no node (node_in_box returns false). An
// inverted box (turned inside out by a large deformation) has inward normals, so no point
// is below all six planes and it contains no node either. Neither case produces NaN; both
// boxes still collide as the moving side (their nodes are tested against other boxes and
// planes), and the lattice dynamics restore them.
#include <algorithm>
#include <cmath>

#include "ffd/types.h"

namespace ffd {

inline constexpr double kDegenerateNormal = 1e-9;

// Corners of each face, counter-clockwise seen from outside: -x, +x, -y, +y, -z, +z.
inline constexpr int kBoxFaces[6][4] = {
    {0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};

struct BoxPlanes {
  std::array<Vec3, 6> normal;   // unit outward normals
  std::array<double, 6> offset; // plane i: normal[i] . x = offset[i]
  bool degenerate = false;      // some face has no normal: the box contains nothing
};

template <class Nodes>
inline BoxPlanes box_planes(const Nodes& node) {
  BoxPlanes planes;
  for (int f = 0; f < 6; ++f) {
    const Vec3& a = node[kBoxFaces[f][0]];
    const Vec3& b = node[kBoxFaces[f][1]];
    const Vec3& c = node[kBoxFaces[f][2]];
    const Vec3& d = node[kBoxFaces[f][3]];
    const Vec3 diag1 = c - a, diag2 = d - b;
    const Vec3 n = diag1.cross(diag2);  // eq. 3
    const double len = n.norm();
    if (!(len > kDegenerateNormal * diag1.norm() * diag2.norm()) || !std::isfinite(len)) {
      planes.degenerate = true;
      planes.normal[f] = Vec3::Zero();
      planes.offset[f] = 0.0;
      continue;
    }
    planes.normal[f] = n / len;
    // Eq. 4-6: anchor on the diagonal that lies higher along N, so all four nodes are inside.
    planes.offset[f] = std::max(planes.normal[f].dot(a), planes.normal[f].dot(b));
  }
  return planes;
}

struct NodeInBox {
  bool inside = false;
  int face = -1;      // plane of least penetration (eq. 7)
  double depth = 0;   // r = min over the six penetration depths, m (> 0 when inside)
};

inline NodeInBox node_in_box(const BoxPlanes& planes, const Vec3& p) {
  NodeInBox result;
  if (planes.degenerate) return result;
  double least = INFINITY;
  for (int f = 0; f < 6; ++f) {
    const double depth = planes.offset[f] - planes.normal[f].dot(p);  // -(signed distance)
    if (!(depth > 0.0)) return result;  // on or outside this plane (also rejects NaN)
    if (depth < least) {
      least = depth;
      result.face = f;
    }
  }
  result.inside = true;
  result.depth = least;
  return result;
}

// The face of the box a node at p is nearest to leaving through, and how far out of its plane
// the node lies (< 0: inside, by eq. 7's least depth), when the node lies within `margin` of
// every plane: inside the box grown by margin. With margin 0 that is node_in_box's inside
// (height = -depth, exactly). Otherwise face -1.
struct NearFace {
  int face = -1;
  double height = INFINITY;  // signed distance out of the face's plane, m
};

inline NearFace near_face(const BoxPlanes& planes, const Vec3& p, double margin) {
  NearFace near;
  if (planes.degenerate) return near;
  double outmost = -INFINITY;
  for (int f = 0; f < 6; ++f) {
    const double height = planes.normal[f].dot(p) - planes.offset[f];
    if (!(height < margin)) return NearFace{};  // beyond the margin (also rejects NaN)
    if (height > outmost) {
      outmost = height;
      near.face = f;
    }
  }
  near.height = outmost;
  return near;
}

// Relative speeds below this (m/s) do not tell which face a node came through.
inline constexpr double kMinApproachSpeed = 1e-4;

// Node-in-box with the face chosen by how the node got in. `relative_velocity` is the
// node's velocity relative to the box (m/s). Among the faces the node is moving in
// through, the one it crossed last — least depth / approach speed — is the contact face,
// and its depth is r. A node at rest relative to the box falls back to eq. 7 (least depth).
// Why: a node entering a thin box through its broad face can be closer to a side face; eq. 7
// alone then pushes it sideways, the approach is never stopped and thin shells tunnel.
//
// Only entries within the last `recent` seconds (a few steps) count: a node that has been
// inside for longer says nothing reliable about its way in, and the far face's large depth
// would make a large, energy-injecting correction. Then eq. 7 decides.
inline NodeInBox node_in_box(const BoxPlanes& planes, const Vec3& p, const Vec3& relative_velocity, double recent) {
  NodeInBox result = node_in_box(planes, p);
  if (!result.inside) return result;
  double best_time = recent;
  for (int f = 0; f < 6; ++f) {
    const double approach = -planes.normal[f].dot(relative_velocity);  // > 0: moving in through f
    if (!(approach > kMinApproachSpeed)) continue;
    const double depth = planes.offset[f] - planes.normal[f].dot(p);
    const double since_entry = depth / approach;  // s
    if (since_entry < best_time) {
      best_time = since_entry;
      result.face = f;
      result.depth = depth;
    }
  }
  return result;
}

// How far the hulls of two boxes' corners overlap along the twelve face normals of the two
// (the separating-axis test on those axes), with `skin` counted as overlap. `normal` points
// from a towards b, and moving b by depth along it (or a by depth against it) parts them
// along that axis, `skin` apart. The axis is the one b came in along within `recent`
// seconds, at `relative_velocity` (b's velocity less a's, m/s), as node_in_box picks a face;
// without one, the shortest way out.
struct BoxOverlap {
  bool overlapping = false;
  Vec3 normal = Vec3::Zero();
  double depth = 0.0;  // m
};

inline BoxOverlap box_overlap(const BoxPlanes& planes_a, const Vec3* a, int count_a, const BoxPlanes& planes_b,
                              const Vec3* b, int count_b, double skin = 0.0, const Vec3& relative_velocity = Vec3::Zero(),
                              double recent = 0.0) {
  BoxOverlap result;
  double least = INFINITY;
  double best_time = recent;  // the axis b came in along last, as node_in_box chooses a face
  Vec3 entered = Vec3::Zero();
  double entered_depth = 0.0;
  for (int axis = 0; axis < 12; ++axis) {
    const Vec3& n = axis < 6 ? planes_a.normal[axis] : planes_b.normal[axis - 6];
    if (n.squaredNorm() == 0.0) continue;  // a degenerate face
    double lo_a = INFINITY, hi_a = -INFINITY, lo_b = INFINITY, hi_b = -INFINITY;
    for (int k = 0; k < count_a; ++k) {
      const double p = n.dot(a[k]);
      if (std::isnan(p)) return BoxOverlap{};  // min and max would pass over it
      lo_a = std::min(lo_a, p);
      hi_a = std::max(hi_a, p);
    }
    for (int k = 0; k < count_b; ++k) {
      const double p = n.dot(b[k]);
      if (std::isnan(p)) return BoxOverlap{};
      lo_b = std::min(lo_b, p);
      hi_b = std::max(hi_b, p);
    }
    const double b_along = hi_a + skin - lo_b, b_against = hi_b + skin - lo_a;  // b's move along +n, -n
    if (!(b_along > 0.0) || !(b_against > 0.0)) return BoxOverlap{};  // a separating axis
    if (b_along < least) {
      least = b_along;
      result.normal = n;
    }
    if (b_against < least) {
      least = b_against;
      result.normal = -n;
    }
    const double approach = n.dot(relative_velocity);  // > 0: b moving along +n into a
    if (approach < -kMinApproachSpeed && b_along / -approach < best_time) {
      best_time = b_along / -approach;
      entered = n;
      entered_depth = b_along;
    } else if (approach > kMinApproachSpeed && b_against / approach < best_time) {
      best_time = b_against / approach;
      entered = -n;
      entered_depth = b_against;
    }
  }
  if (least == INFINITY) return BoxOverlap{};
  result.overlapping = true;
  result.depth = least;
  if (entered.squaredNorm() > 0.0) {
    result.normal = entered;
    result.depth = entered_depth;
  }
  return result;
}

}  // namespace ffd
