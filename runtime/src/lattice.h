#pragma once
// Building the FFD lattice of one object from its surface mesh (paper sections 3 and 4):
// the regular grid over the mesh, the cells the surface passes through (plus, on request,
// the interior cells), every vertex bound to a cell with local coordinates (eq. 1), and the
// FFD AABB of every surface cell in that cell's local coordinates.
#include <vector>

#include "ffd/mesh.h"

namespace ffd {

// Accuracy level 3's nodes: for each of the 26 directions (dx, dy, dz) in {-1, 0, 1}^3 but
// 0, the point of the surface inside a cell that reaches furthest along it.
inline constexpr int kSupportDirectionCount = 26;
// Direction d of the 26 (not normalised): the 27 offsets in x-fastest order, (0, 0, 0) skipped.
inline Vec3 support_direction(int d) {
  const int k = d < 13 ? d : d + 1;
  return Vec3(k % 3 - 1, (k / 3) % 3 - 1, k / 9 - 1);
}

struct LatticeBuild {
  double cell_size = 0.0;  // h, m
  Vec3 origin;             // corner of grid cell (0,0,0), m
  Vec3i dims;              // cells per axis of the whole regular grid
  // Kept cells in increasing linear grid order (x fastest), and whether each one holds
  // surface (interior cells come from the flood fill and hold none).
  std::vector<Vec3i> cells;
  std::vector<bool> cell_has_surface;
  // FFD AABB of each kept surface cell, same order as `cells` (unused for interior cells):
  // 8 corners (corner k = (k & 1, k >> 1 & 1, k >> 2 & 1) of [lo, hi]) and the area-weighted
  // centre of mass of the surface in the cell, all in cell-local coordinates.
  std::vector<std::array<Vec3, 9>> box_local;
  // Accuracy level 4: the surface cell split into k x k x k parts, one box per part the
  // surface passes through, fitted to the surface in it (same layout as box_local).
  std::vector<std::vector<std::array<Vec3, 9>>> sub_box_local;
  // Accuracy level 3: per kept surface cell, its surface's extreme points along the 26
  // directions (cell-local; unused for interior cells). Points of the surface itself, so
  // unlike a box corner they never stand off it.
  std::vector<std::array<Vec3, kSupportDirectionCount>> support_local;
  std::vector<std::vector<Index>> cell_triangles;  // per kept cell: triangles crossing it with area
  std::vector<Index> vertex_cell;   // index into `cells`
  std::vector<Vec3> vertex_local;   // (s, t, u) of eq. 1, divided by h
};

// `min_box_thickness` is a fraction of h: a box thinner than that along an axis (a flat
// piece of surface gives a flat box) is thickened towards the inside of the surface, so
// the surface stays on the box's outer face and the box keeps a volume to detect nodes in.
// Throws CompileError-like std::invalid_argument when the grid would be unreasonably large.
// `sub_box_split` is k of accuracy level 4 (0: no sub-boxes).
LatticeBuild build_lattice(const SurfaceMesh& mesh, double cell_size, bool fill_interior,
                           double min_box_thickness, int sub_box_split);

// Clips a triangle to the unit cell [0,1]^3 given in that cell's local coordinates
// (Sutherland-Hodgman); returns the number of polygon vertices written to `out` (0 when
// they do not overlap). A triangle clipped by six planes has at most 9 vertices.
int clip_triangle_to_unit_cell(const Vec3& a, const Vec3& b, const Vec3& c, std::array<Vec3, 9>& out);

}  // namespace ffd
