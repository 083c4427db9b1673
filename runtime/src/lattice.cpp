#include "lattice.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <deque>
#include <stdexcept>
#include <string>

namespace ffd {

namespace {

// More cells than this means a cell size far too small for the mesh: refuse rather than
// exhaust memory.
constexpr double kMaxGridCells = 64.0e6;

struct CellAccumulator {
  bool has_surface = false;
  Vec3 lo = Vec3::Constant(INFINITY), hi = Vec3::Constant(-INFINITY);  // cell-local bounds
  double area = 0.0;
  Vec3 area_centroid = Vec3::Zero();  // sum of area * centroid, local
  Vec3 area_normal = Vec3::Zero();    // sum of area * normal
};

// Keeps the part of `in` on the side coord[axis] * sign <= bound * sign.
int clip_polygon(const std::array<Vec3, 9>& in, int n, int axis, double bound, bool keep_below,
                 std::array<Vec3, 9>& out) {
  int m = 0;
  auto inside = [&](const Vec3& p) { return keep_below ? p[axis] <= bound : p[axis] >= bound; };
  for (int i = 0; i < n; ++i) {
    const Vec3& p = in[i];
    const Vec3& q = in[(i + 1) % n];
    const bool pin = inside(p), qin = inside(q);
    if (pin && m < 9) out[m++] = p;
    if (pin != qin && m < 9) {
      const double t = (bound - p[axis]) / (q[axis] - p[axis]);
      Vec3 x = p + t * (q - p);
      x[axis] = bound;  // exactly on the plane, whatever the rounding
      out[m++] = x;
    }
  }
  return m;
}

// Adds a clipped piece of a triangle (n vertices, cell-local) to `acc`: bounds, area,
// area-weighted centroid and normal. Returns false (and adds nothing) for a piece without
// area.
bool accumulate_piece(CellAccumulator& acc, const std::array<Vec3, 9>& poly, int n, const Vec3& tri_normal) {
  Vec3 weighted = Vec3::Zero();
  double twice_area = 0.0;
  for (int v = 1; v + 1 < n; ++v) {
    const double a2 = (poly[v] - poly[0]).cross(poly[v + 1] - poly[0]).norm();
    twice_area += a2;
    weighted += a2 * (poly[0] + poly[v] + poly[v + 1]) / 3.0;
  }
  if (!(twice_area > 1e-14)) return false;
  acc.has_surface = true;
  for (int v = 0; v < n; ++v) {
    acc.lo = acc.lo.cwiseMin(poly[v]);
    acc.hi = acc.hi.cwiseMax(poly[v]);
  }
  acc.area += twice_area;
  acc.area_centroid += weighted;
  acc.area_normal += tri_normal.normalized() * twice_area;
  return true;
}

// Adds a clipped polygon (cell-local) to the accumulator of every part of the box
// [box_lo, box_hi] split k x k x k that it overlaps; `parts` holds the k^3 accumulators,
// x fastest. An axis along which the box is flat has all its surface in part 0.
void accumulate_parts(const std::array<Vec3, 9>& poly, int n, const Vec3& tri_normal, const Vec3& box_lo,
                      const Vec3& box_hi, int k, CellAccumulator* parts) {
  Vec3 lo = poly[0], hi = poly[0];
  for (int v = 1; v < n; ++v) {
    lo = lo.cwiseMin(poly[v]);
    hi = hi.cwiseMax(poly[v]);
  }
  const Vec3 part_size = (box_hi - box_lo) / k;
  Vec3i first = Vec3i::Zero(), last = Vec3i::Zero();
  for (int a = 0; a < 3; ++a) {
    if (!(part_size[a] > 1e-12)) continue;
    first[a] = std::clamp(static_cast<int>(std::floor((lo[a] - box_lo[a]) / part_size[a])), 0, k - 1);
    last[a] = std::clamp(static_cast<int>(std::floor((hi[a] - box_lo[a]) / part_size[a])), 0, k - 1);
  }
  std::array<Vec3, 9> a_buf, b_buf;
  for (int z = first.z(); z <= last.z(); ++z)
    for (int y = first.y(); y <= last.y(); ++y)
      for (int x = first.x(); x <= last.x(); ++x) {
        const Vec3i part(x, y, z);
        a_buf = poly;
        int m = n;
        for (int axis = 0; axis < 3 && m > 0; ++axis) {
          if (!(part_size[axis] > 1e-12)) continue;
          const double below = part[axis] == 0 ? -INFINITY : box_lo[axis] + part[axis] * part_size[axis];
          const double above = part[axis] == k - 1 ? INFINITY : box_lo[axis] + (part[axis] + 1) * part_size[axis];
          m = clip_polygon(a_buf, m, axis, below, false, b_buf);
          m = clip_polygon(b_buf, m, axis, above, true, a_buf);
        }
        if (m >= 3) accumulate_piece(parts[x + k * (y + k * z)], a_buf, m, tri_normal);
      }
}

// The box [lo, hi] of a piece of surface with mean normal `normal`, grown to at least
// `min_thickness` per axis towards the inside of the surface (against its normal), kept
// within [bound_lo, bound_hi]: 8 corners and the centre node (cell-local).
std::array<Vec3, 9> fitted_box(Vec3 blo, Vec3 bhi, const Vec3& normal, const Vec3& centre, double min_thickness,
                               double bound_lo, double bound_hi) {
  for (int a = 0; a < 3; ++a) {
    const double need = min_thickness - (bhi[a] - blo[a]);
    if (need <= 0.0) continue;
    if (normal[a] > 0.1) blo[a] -= need;
    else if (normal[a] < -0.1) bhi[a] += need;
    else { blo[a] -= 0.5 * need; bhi[a] += 0.5 * need; }
    if (blo[a] < bound_lo) { bhi[a] = std::min(bound_hi, bhi[a] + (bound_lo - blo[a])); blo[a] = bound_lo; }
    if (bhi[a] > bound_hi) { blo[a] = std::max(bound_lo, blo[a] - (bhi[a] - bound_hi)); bhi[a] = bound_hi; }
  }
  std::array<Vec3, 9> box;
  for (int k = 0; k < 8; ++k)
    box[k] = Vec3((k & 1) ? bhi.x() : blo.x(), (k & 2) ? bhi.y() : blo.y(), (k & 4) ? bhi.z() : blo.z());
  box[8] = centre;
  return box;
}

std::int64_t linear_index(const Vec3i& c, const Vec3i& dims) {
  return c.x() + static_cast<std::int64_t>(dims.x()) * (c.y() + static_cast<std::int64_t>(dims.y()) * c.z());
}

}  // namespace

int clip_triangle_to_unit_cell(const Vec3& a, const Vec3& b, const Vec3& c, std::array<Vec3, 9>& out) {
  std::array<Vec3, 9> buf;
  out[0] = a;
  out[1] = b;
  out[2] = c;
  int n = 3;
  for (int axis = 0; axis < 3 && n > 0; ++axis) {
    n = clip_polygon(out, n, axis, 0.0, false, buf);
    n = clip_polygon(buf, n, axis, 1.0, true, out);
  }
  return n;
}

LatticeBuild build_lattice(const SurfaceMesh& mesh, double cell_size, bool fill_interior,
                           double min_box_thickness, int sub_box_split) {
  LatticeBuild out;
  const double h = cell_size;
  out.cell_size = h;
  const auto [lo, hi] = mesh_bounds(mesh);
  const Vec3 extent = hi - lo;
  // floor(extent / h) + 1 cells per axis, centred: the margin (n h - extent) / 2 lies in
  // (0, h/2], so a flat face on the mesh's bounds never sits exactly on a lattice plane.
  double total = 1.0;
  for (int a = 0; a < 3; ++a) {
    const double n = std::floor(extent[a] / h) + 1.0;
    total *= n;
    if (!(total <= kMaxGridCells)) {
      throw std::invalid_argument("cell size " + std::to_string(h) + " m gives more than " +
                                  std::to_string(static_cast<long long>(kMaxGridCells)) +
                                  " grid cells for a mesh of extent " + std::to_string(extent.maxCoeff()) +
                                  " m; use a larger cell_size");
    }
    out.dims[a] = static_cast<int>(n);
  }
  out.origin = 0.5 * (lo + hi) - 0.5 * h * out.dims.cast<double>();
  const Vec3i dims = out.dims;
  const std::size_t grid_cells = static_cast<std::size_t>(total);

  auto to_grid = [&](const Vec3& p) { return Vec3((p - out.origin) / h); };

  // Every piece of a triangle clipped to a grid cell with area: (linear cell index, the
  // piece in cell-local coordinates, its vertex count, the triangle's normal in grid units).
  auto for_each_piece = [&](auto&& visit) {
    std::array<Vec3, 9> poly;
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
      const auto& tri = mesh.triangles[t];
      const Vec3 g0 = to_grid(mesh.vertices[tri[0]]);
      const Vec3 g1 = to_grid(mesh.vertices[tri[1]]);
      const Vec3 g2 = to_grid(mesh.vertices[tri[2]]);
      const Vec3 tri_normal = (g1 - g0).cross(g2 - g0);  // grid units, length = 2 * area
      Vec3i cmin, cmax;
      for (int a = 0; a < 3; ++a) {
        const double mn = std::min({g0[a], g1[a], g2[a]}), mx = std::max({g0[a], g1[a], g2[a]});
        cmin[a] = std::clamp(static_cast<int>(std::floor(mn)), 0, dims[a] - 1);
        cmax[a] = std::clamp(static_cast<int>(std::floor(mx)), 0, dims[a] - 1);
      }
      for (int k = cmin.z(); k <= cmax.z(); ++k)
        for (int j = cmin.y(); j <= cmax.y(); ++j)
          for (int i = cmin.x(); i <= cmax.x(); ++i) {
            const Vec3 base(i, j, k);
            const int n = clip_triangle_to_unit_cell(g0 - base, g1 - base, g2 - base, poly);
            if (n >= 3) visit(linear_index(Vec3i(i, j, k), dims), poly, n, tri_normal, static_cast<Index>(t));
          }
    }
  };

  // Clip every triangle against the cells its bounding box touches (sections 3-4).
  std::vector<CellAccumulator> acc(grid_cells);
  std::vector<std::pair<std::int64_t, Index>> pieces;  // (grid cell, triangle) with area
  for_each_piece([&](std::int64_t li, const std::array<Vec3, 9>& poly, int n, const Vec3& tri_normal, Index triangle) {
    // A piece without area touches the cell at an edge or a point only.
    if (accumulate_piece(acc[li], poly, n, tri_normal)) pieces.emplace_back(li, triangle);
  });

  // Interior cells: those the outside cannot reach through non-surface cells (6-connected
  // flood fill over the grid padded by one cell). An open mesh leaks and gets none.
  std::vector<bool> interior(grid_cells, false);
  if (fill_interior) {
    const Vec3i pd = dims + Vec3i::Constant(2);
    std::vector<bool> outside(static_cast<std::size_t>(pd.x()) * pd.y() * pd.z(), false);
    auto surface_at = [&](const Vec3i& padded) {
      const Vec3i c = padded - Vec3i::Constant(1);
      if ((c.array() < 0).any() || (c.array() >= dims.array()).any()) return false;
      return acc[linear_index(c, dims)].has_surface;
    };
    std::deque<Vec3i> queue{Vec3i::Zero()};
    outside[0] = true;
    while (!queue.empty()) {
      const Vec3i c = queue.front();
      queue.pop_front();
      for (int a = 0; a < 3; ++a) {
        for (int d = -1; d <= 1; d += 2) {
          Vec3i nb = c;
          nb[a] += d;
          if (nb[a] < 0 || nb[a] >= pd[a]) continue;
          const std::int64_t li = linear_index(nb, pd);
          if (outside[li] || surface_at(nb)) continue;
          outside[li] = true;
          queue.push_back(nb);
        }
      }
    }
    for (int k = 0; k < dims.z(); ++k)
      for (int j = 0; j < dims.y(); ++j)
        for (int i = 0; i < dims.x(); ++i) {
          const Vec3i c(i, j, k);
          const std::int64_t li = linear_index(c, dims);
          if (!acc[li].has_surface && !outside[linear_index(c + Vec3i::Constant(1), pd)]) interior[li] = true;
        }
  }

  // Kept cells in linear order.
  std::vector<Index> kept_index(grid_cells, kNoIndex);
  for (int k = 0; k < dims.z(); ++k)
    for (int j = 0; j < dims.y(); ++j)
      for (int i = 0; i < dims.x(); ++i) {
        const Vec3i c(i, j, k);
        const std::int64_t li = linear_index(c, dims);
        if (!acc[li].has_surface && !interior[li]) continue;
        kept_index[li] = static_cast<Index>(out.cells.size());
        out.cells.push_back(c);
        out.cell_has_surface.push_back(acc[li].has_surface);
      }

  // Areas are measured in cell units: a cell vastly larger than the mesh leaves every piece
  // below the area threshold, and then no vertex would have a cell to be bound to.
  if (std::find(out.cell_has_surface.begin(), out.cell_has_surface.end(), true) == out.cell_has_surface.end()) {
    char message[200];
    std::snprintf(message, sizeof message,
                  "no triangle has an area at cell size %g m for a mesh of extent %g m; use a cell_size nearer "
                  "the mesh's size", h, extent.maxCoeff());
    throw std::invalid_argument(message);
  }

  out.cell_triangles.resize(out.cells.size());
  for (const auto& [li, triangle] : pieces) out.cell_triangles[kept_index[li]].push_back(triangle);

  // Accuracy level 3: the extreme surface points of every surface cell along 26 directions,
  // from the clipped pieces' corners (a piece's extreme along a direction is one of them).
  out.support_local.resize(out.cells.size());
  {
    std::array<Vec3, kSupportDirectionCount> directions;
    for (int d = 0; d < kSupportDirectionCount; ++d) directions[d] = support_direction(d);
    std::vector<std::array<double, kSupportDirectionCount>> reach(
        out.cells.size(), [] { std::array<double, kSupportDirectionCount> r; r.fill(-INFINITY); return r; }());
    for_each_piece([&](std::int64_t li, const std::array<Vec3, 9>& poly, int n, const Vec3&, Index) {
      const Index c = kept_index[li];
      if (c == kNoIndex || !acc[li].has_surface) return;
      for (int v = 0; v < n; ++v)
        for (int d = 0; d < kSupportDirectionCount; ++d) {
          const double along = directions[d].dot(poly[v]);
          if (along > reach[c][d]) {
            reach[c][d] = along;
            out.support_local[c][d] = poly[v];
          }
        }
    });
  }

  // Bind every vertex to a surface cell whose closed box contains it (eq. 1). A vertex on a
  // cell face belongs to several cells; the first surface one in (-1, 0) offset order wins.
  out.vertex_cell.resize(mesh.vertices.size());
  out.vertex_local.resize(mesh.vertices.size());
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
    const Vec3 g = to_grid(mesh.vertices[v]);
    Index chosen = kNoIndex;
    Vec3i chosen_cell = Vec3i::Zero();
    for (int dz = -1; dz <= 0 && chosen == kNoIndex; ++dz)
      for (int dy = -1; dy <= 0 && chosen == kNoIndex; ++dy)
        for (int dx = -1; dx <= 0 && chosen == kNoIndex; ++dx) {
          Vec3i c;
          bool ok = true;
          for (int a = 0; a < 3; ++a) {
            const int d = a == 0 ? dx : (a == 1 ? dy : dz);
            const int base = std::clamp(static_cast<int>(std::floor(g[a])), 0, dims[a] - 1);
            c[a] = base + d;
            // Offset -1 only when the vertex sits on that cell's upper face.
            if (d == -1 && !(c[a] >= 0 && g[a] <= c[a] + 1.0)) ok = false;
          }
          if (!ok) continue;
          const Index idx = kept_index[linear_index(c, dims)];
          if (idx != kNoIndex && out.cell_has_surface[idx]) {
            chosen = idx;
            chosen_cell = c;
          }
        }
    if (chosen == kNoIndex) {
      // Only a vertex no kept triangle touches with area (cleaned meshes have none); bind it
      // to the nearest surface cell: trilinear extrapolation still reproduces it at rest.
      double best = INFINITY;
      for (std::size_t c = 0; c < out.cells.size(); ++c) {
        if (!out.cell_has_surface[c]) continue;
        const double d = (g - (out.cells[c].cast<double>() + Vec3::Constant(0.5))).squaredNorm();
        if (d < best) {
          best = d;
          chosen = static_cast<Index>(c);
          chosen_cell = out.cells[c];
        }
      }
    }
    out.vertex_cell[v] = chosen;
    out.vertex_local[v] = g - chosen_cell.cast<double>();
    // The vertex is part of the surface in its cell even if it only touches it.
    CellAccumulator& cell = acc[linear_index(chosen_cell, dims)];
    cell.lo = cell.lo.cwiseMin(out.vertex_local[v]);
    cell.hi = cell.hi.cwiseMax(out.vertex_local[v]);
  }

  // FFD AABBs of the surface cells (section 4), thickened where flat.
  out.box_local.resize(out.cells.size());
  for (std::size_t c = 0; c < out.cells.size(); ++c) {
    if (!out.cell_has_surface[c]) continue;
    const CellAccumulator& cell = acc[linear_index(out.cells[c], dims)];
    const Vec3 blo = cell.lo.cwiseMax(0.0), bhi = cell.hi.cwiseMin(1.0);
    const Vec3 normal = cell.area_normal.norm() > 0.0 ? Vec3(cell.area_normal.normalized()) : Vec3::Zero();
    const Vec3 centre = cell.area > 0.0 ? Vec3(cell.area_centroid / cell.area) : Vec3(0.5 * (blo + bhi));
    out.box_local[c] = fitted_box(blo, bhi, normal, centre, min_box_thickness, 0.0, 1.0);
  }

  // Accuracy level 4: every FFD AABB (its tight bounds, before thickening) split k x k x k;
  // each part the surface passes through gets its own box fitted to the surface in it.
  out.sub_box_local.resize(out.cells.size());
  if (sub_box_split > 0) {
    const int k = sub_box_split, parts_per_box = k * k * k;
    std::vector<std::int64_t> first_part(grid_cells, -1);
    for (std::size_t c = 0; c < out.cells.size(); ++c)
      if (out.cell_has_surface[c]) first_part[linear_index(out.cells[c], dims)] = static_cast<std::int64_t>(c) * parts_per_box;
    std::vector<CellAccumulator> parts(out.cells.size() * parts_per_box);
    for_each_piece([&](std::int64_t li, const std::array<Vec3, 9>& poly, int n, const Vec3& tri_normal, Index) {
      if (first_part[li] < 0) return;
      const CellAccumulator& cell = acc[li];
      accumulate_parts(poly, n, tri_normal, cell.lo.cwiseMax(0.0), cell.hi.cwiseMin(1.0), k, &parts[first_part[li]]);
    });
    for (std::size_t c = 0; c < out.cells.size(); ++c) {
      if (!out.cell_has_surface[c]) continue;
      for (int p = 0; p < parts_per_box; ++p) {
        const CellAccumulator& part = parts[c * parts_per_box + p];
        if (!part.has_surface) continue;
        const Vec3 normal = part.area_normal.norm() > 0.0 ? Vec3(part.area_normal.normalized()) : Vec3::Zero();
        // Tight on the outside of the surface, as deep as the FFD AABB on the inside: a part
        // as thin as the surface piece would let a node that crossed more than half of it in
        // one step leave by the far face (eq. 7 picks the nearest), into the object.
        Vec3 lo = part.lo.cwiseMax(0.0), hi = part.hi.cwiseMin(1.0);
        const Vec3& parent_lo = out.box_local[c][0];
        const Vec3& parent_hi = out.box_local[c][7];
        for (int a = 0; a < 3; ++a) {
          if (normal[a] > 0.5) lo[a] = std::min(lo[a], parent_lo[a]);
          else if (normal[a] < -0.5) hi[a] = std::max(hi[a], parent_hi[a]);
        }
        out.sub_box_local[c].push_back(
            fitted_box(lo, hi, normal, Vec3(part.area_centroid / part.area), min_box_thickness, 0.0, 1.0));
      }
      // A cell whose surface is only vertices touching it has no part with area: its
      // whole FFD AABB stands in.
      if (out.sub_box_local[c].empty()) out.sub_box_local[c].push_back(out.box_local[c]);
    }
  }
  return out;
}

}  // namespace ffd
