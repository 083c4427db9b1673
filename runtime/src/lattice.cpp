#include "lattice.h"

#include <algorithm>
#include <cmath>
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
                           double min_box_thickness) {
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

  // Clip every triangle against the cells its bounding box touches (sections 3-4).
  std::vector<CellAccumulator> acc(grid_cells);
  std::array<Vec3, 9> poly;
  for (const auto& tri : mesh.triangles) {
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
    for (int k = cmin.z(); k <= cmax.z(); ++k) {
      for (int j = cmin.y(); j <= cmax.y(); ++j) {
        for (int i = cmin.x(); i <= cmax.x(); ++i) {
          const Vec3 base(i, j, k);
          const int n = clip_triangle_to_unit_cell(g0 - base, g1 - base, g2 - base, poly);
          if (n < 3) continue;
          Vec3 twice_area_normal = Vec3::Zero();
          Vec3 weighted = Vec3::Zero();
          double twice_area = 0.0;
          for (int v = 1; v + 1 < n; ++v) {
            const Vec3 cr = (poly[v] - poly[0]).cross(poly[v + 1] - poly[0]);
            const double a2 = cr.norm();
            twice_area_normal += cr;
            twice_area += a2;
            weighted += a2 * (poly[0] + poly[v] + poly[v + 1]) / 3.0;
          }
          if (!(twice_area > 1e-14)) continue;  // touches the cell at an edge or a point only
          CellAccumulator& cell = acc[linear_index(Vec3i(i, j, k), dims)];
          cell.has_surface = true;
          for (int v = 0; v < n; ++v) {
            cell.lo = cell.lo.cwiseMin(poly[v]);
            cell.hi = cell.hi.cwiseMax(poly[v]);
          }
          cell.area += twice_area;
          cell.area_centroid += weighted;
          cell.area_normal += tri_normal.normalized() * twice_area;
        }
      }
    }
  }

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
    Vec3 blo = cell.lo.cwiseMax(0.0), bhi = cell.hi.cwiseMin(1.0);
    const Vec3 normal = cell.area_normal.norm() > 0.0 ? Vec3(cell.area_normal.normalized()) : Vec3::Zero();
    for (int a = 0; a < 3; ++a) {
      const double need = min_box_thickness - (bhi[a] - blo[a]);
      if (need <= 0.0) continue;
      // Grow towards the inside of the surface (against its normal), within the cell.
      if (normal[a] > 0.1) blo[a] -= need;
      else if (normal[a] < -0.1) bhi[a] += need;
      else { blo[a] -= 0.5 * need; bhi[a] += 0.5 * need; }
      if (blo[a] < 0.0) { bhi[a] = std::min(1.0, bhi[a] - blo[a]); blo[a] = 0.0; }
      if (bhi[a] > 1.0) { blo[a] = std::max(0.0, blo[a] - (bhi[a] - 1.0)); bhi[a] = 1.0; }
    }
    for (int k = 0; k < 8; ++k) {
      out.box_local[c][k] = Vec3((k & 1) ? bhi.x() : blo.x(), (k & 2) ? bhi.y() : blo.y(),
                                 (k & 4) ? bhi.z() : blo.z());
    }
    out.box_local[c][8] = cell.area > 0.0 ? Vec3(cell.area_centroid / cell.area) : Vec3(0.5 * (blo + bhi));
  }
  return out;
}

}  // namespace ffd
