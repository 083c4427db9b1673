#include "ffd/surface_metrics.h"

#include "ffd/closest_point.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace ffd {

namespace {

using Triangle = std::array<Index, 3>;

// Squared distance from p to the box [lo, hi] (0 inside), m^2.
double box_distance_sq(const Vec3& p, const Vec3& lo, const Vec3& hi) {
  return (lo - p).cwiseMax(p - hi).cwiseMax(0.0).squaredNorm();
}

Vec3 normalized_or_zero(const Vec3& v) {
  const double length = v.norm();
  return length > 0.0 ? Vec3(v / length) : Vec3::Zero();
}

}  // namespace

struct SurfaceDistance::Impl {
  double search_radius = 0.0;
  double search_radius_sq = 0.0;

  std::vector<Vec3> vertices;
  std::vector<Triangle> triangles;                           // the mesh's triangles with non-zero area
  std::vector<Vec3> face_normals;                            // unit
  std::vector<Vec3> triangle_min, triangle_max;              // bounding boxes, m
  std::vector<std::array<std::uint32_t, 3>> triangle_edges;  // edge ids of ab, bc, ca
  std::vector<Vec3> edge_normals;                            // unit sums of the incident face normals
  std::vector<Vec3> vertex_normals;                          // unit angle-weighted sums of the incident face normals

  // Uniform grid over the triangles' bounding boxes, compressed rows: the triangles of cell
  // (i, j, k) are cell_triangles[cell_start[c] .. cell_start[c + 1]), c = i + nx (j + ny k).
  Vec3 grid_min = Vec3::Zero();
  Vec3 grid_max = Vec3::Zero();
  double cell_size = 1.0;
  std::array<std::int64_t, 3> dims{1, 1, 1};
  std::vector<std::uint32_t> cell_start;
  std::vector<Index> cell_triangles;

  std::int64_t cell_coordinate(double value, int axis) const {
    const double c = std::floor((value - grid_min[axis]) / cell_size);
    return std::clamp(static_cast<std::int64_t>(std::clamp(c, -1.0, static_cast<double>(dims[axis]))), std::int64_t{0},
                      dims[axis] - 1);
  }

  Vec3 pseudo_normal(std::size_t triangle, Feature feature) const {
    const Triangle& t = triangles[triangle];
    switch (feature) {
      case Feature::kVertexA:
        return vertex_normals[t[0]];
      case Feature::kVertexB:
        return vertex_normals[t[1]];
      case Feature::kVertexC:
        return vertex_normals[t[2]];
      case Feature::kEdgeAB:
        return edge_normals[triangle_edges[triangle][0]];
      case Feature::kEdgeBC:
        return edge_normals[triangle_edges[triangle][1]];
      case Feature::kEdgeCA:
        return edge_normals[triangle_edges[triangle][2]];
      case Feature::kFace:
        break;
    }
    return face_normals[triangle];
  }
};

SurfaceDistance::SurfaceDistance(const SurfaceMesh& mesh, double search_radius) : impl_(new Impl) {
  try {
    Impl& d = *impl_;
    if (!std::isfinite(search_radius) || search_radius <= 0.0)
      throw std::invalid_argument("SurfaceDistance: search_radius must be finite and > 0");
    d.search_radius = search_radius;
    // Past 1e150 m the square would overflow; every distance is within an infinite bound.
    d.search_radius_sq =
        search_radius < 1e150 ? search_radius * search_radius : std::numeric_limits<double>::infinity();

    for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
      if (!is_finite(mesh.vertices[i]))
        throw std::invalid_argument("SurfaceDistance: vertex " + std::to_string(i) + " is not finite");
    }
    d.vertices = mesh.vertices;
    d.vertex_normals.assign(d.vertices.size(), Vec3::Zero());

    // Faces with area; zero-area ones have no normal and are covered by their neighbours.
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
      const Triangle& tri = mesh.triangles[t];
      for (Index v : tri) {
        if (v >= d.vertices.size())
          throw std::invalid_argument("SurfaceDistance: triangle " + std::to_string(t) + " uses vertex index " +
                                      std::to_string(v) + ", but the mesh has " + std::to_string(d.vertices.size()) +
                                      " vertices");
      }
      const Vec3 normal = (d.vertices[tri[1]] - d.vertices[tri[0]]).cross(d.vertices[tri[2]] - d.vertices[tri[0]]);
      const double length = normal.norm();
      if (!(length > 0.0)) continue;
      d.triangles.push_back(tri);
      d.face_normals.push_back(normal / length);
      d.triangle_min.push_back(d.vertices[tri[0]].cwiseMin(d.vertices[tri[1]]).cwiseMin(d.vertices[tri[2]]));
      d.triangle_max.push_back(d.vertices[tri[0]].cwiseMax(d.vertices[tri[1]]).cwiseMax(d.vertices[tri[2]]));
    }
    if (d.triangles.empty())
      throw std::invalid_argument("SurfaceDistance: the mesh has no triangle with non-zero area");

    // Vertex pseudo-normals: face normals weighted by the face's angle at the vertex.
    for (std::size_t t = 0; t < d.triangles.size(); ++t) {
      const Triangle& tri = d.triangles[t];
      for (int k = 0; k < 3; ++k) {
        const Vec3& corner = d.vertices[tri[k]];
        const Vec3 to_next = d.vertices[tri[(k + 1) % 3]] - corner;
        const Vec3 to_prev = d.vertices[tri[(k + 2) % 3]] - corner;
        const double angle = std::atan2(to_next.cross(to_prev).norm(), to_next.dot(to_prev));  // rad
        d.vertex_normals[tri[k]] += angle * d.face_normals[t];
      }
    }
    for (Vec3& n : d.vertex_normals) n = normalized_or_zero(n);

    // Edge pseudo-normals: sorting (edge, triangle, side) groups each edge's incident faces,
    // and the stable order makes the sums independent of anything but the input order.
    struct EdgeUse {
      std::pair<Index, Index> edge;
      std::uint32_t triangle;
      int side;
    };
    std::vector<EdgeUse> uses;
    uses.reserve(3 * d.triangles.size());
    for (std::size_t t = 0; t < d.triangles.size(); ++t) {
      for (int k = 0; k < 3; ++k) {
        const Index a = d.triangles[t][k], b = d.triangles[t][(k + 1) % 3];
        uses.push_back({{std::min(a, b), std::max(a, b)}, static_cast<std::uint32_t>(t), k});
      }
    }
    std::stable_sort(uses.begin(), uses.end(), [](const EdgeUse& x, const EdgeUse& y) { return x.edge < y.edge; });
    d.triangle_edges.assign(d.triangles.size(), {0, 0, 0});
    for (std::size_t i = 0; i < uses.size(); ++i) {
      if (i == 0 || uses[i].edge != uses[i - 1].edge) d.edge_normals.push_back(Vec3::Zero());
      const auto edge_id = static_cast<std::uint32_t>(d.edge_normals.size() - 1);
      d.edge_normals.back() += d.face_normals[uses[i].triangle];
      d.triangle_edges[uses[i].triangle][static_cast<std::size_t>(uses[i].side)] = edge_id;
    }
    for (Vec3& n : d.edge_normals) n = normalized_or_zero(n);

    // Grid: cells of about search_radius, coarsened while there would be far more cells
    // than triangles (a tiny radius on a large mesh).
    d.grid_min = d.grid_max = d.vertices[d.triangles[0][0]];
    for (const Triangle& tri : d.triangles) {
      for (Index v : tri) {
        d.grid_min = d.grid_min.cwiseMin(d.vertices[v]);
        d.grid_max = d.grid_max.cwiseMax(d.vertices[v]);
      }
    }
    const Vec3 extent = d.grid_max - d.grid_min;
    const double max_cells = std::max(4096.0, 8.0 * static_cast<double>(d.triangles.size()));
    // Starting no finer than extent / max_cells keeps every count below max_cells + 1.
    d.cell_size = std::max(search_radius, extent.maxCoeff() / max_cells);
    for (;;) {
      double cells = 1.0;
      for (int axis = 0; axis < 3; ++axis) cells *= std::floor(extent[axis] / d.cell_size) + 1.0;
      if (cells <= max_cells) break;
      d.cell_size *= 2.0;
    }
    for (int axis = 0; axis < 3; ++axis)
      d.dims[axis] = static_cast<std::int64_t>(std::floor(extent[axis] / d.cell_size)) + 1;

    auto for_each_cell = [&d](std::size_t triangle, auto&& visit) {
      std::array<std::int64_t, 3> first{}, last{};
      for (int axis = 0; axis < 3; ++axis) {
        first[axis] = d.cell_coordinate(d.triangle_min[triangle][axis], axis);
        last[axis] = d.cell_coordinate(d.triangle_max[triangle][axis], axis);
      }
      for (std::int64_t k = first[2]; k <= last[2]; ++k)
        for (std::int64_t j = first[1]; j <= last[1]; ++j)
          for (std::int64_t i = first[0]; i <= last[0]; ++i)
            visit(static_cast<std::size_t>(i + d.dims[0] * (j + d.dims[1] * k)));
    };
    const auto cell_count = static_cast<std::size_t>(d.dims[0] * d.dims[1] * d.dims[2]);
    d.cell_start.assign(cell_count + 1, 0);
    for (std::size_t t = 0; t < d.triangles.size(); ++t)
      for_each_cell(t, [&d](std::size_t c) { ++d.cell_start[c + 1]; });
    for (std::size_t c = 0; c < cell_count; ++c) d.cell_start[c + 1] += d.cell_start[c];
    d.cell_triangles.resize(d.cell_start[cell_count]);
    std::vector<std::uint32_t> fill(d.cell_start.begin(), d.cell_start.end() - 1);
    for (std::size_t t = 0; t < d.triangles.size(); ++t)
      for_each_cell(t, [&](std::size_t c) { d.cell_triangles[fill[c]++] = static_cast<Index>(t); });
  } catch (...) {
    delete impl_;
    throw;
  }
}

SurfaceDistance::~SurfaceDistance() { delete impl_; }

SurfaceDistance::SurfaceDistance(SurfaceDistance&& other) noexcept : impl_(other.impl_) { other.impl_ = nullptr; }

SurfaceDistance& SurfaceDistance::operator=(SurfaceDistance&& other) noexcept {
  std::swap(impl_, other.impl_);
  return *this;
}

SurfaceDistance::Query SurfaceDistance::query(const Vec3& point) const {
  if (impl_ == nullptr) throw std::logic_error("SurfaceDistance::query on a moved-from object");
  if (!is_finite(point)) throw std::invalid_argument("SurfaceDistance::query: the point is not finite");
  const Impl& d = *impl_;
  const double r = d.search_radius;

  Query far;
  far.distance = r;
  // Rejected before any cell arithmetic, which keeps that arithmetic bounded.
  for (int axis = 0; axis < 3; ++axis) {
    if (point[axis] < d.grid_min[axis] - r || point[axis] > d.grid_max[axis] + r) return far;
  }

  // Cells are at least search_radius wide, so [p - r, p + r] meets at most 3 cells along an
  // axis, and 4 where rounding puts its ends on either side of two cell boundaries (p = 0.3,
  // r = 0.1 on cells of 0.1: (p - r) / 0.1 = 1.9999999999999998, (p + r) / 0.1 = 4), so the
  // buffer holds 4 x 4 x 4. Visiting the cells nearest first lets the best distance so far
  // prune the rest.
  constexpr std::int64_t kMostCellsPerAxis = 4;
  std::array<std::int64_t, 3> first{}, last{};
  for (int axis = 0; axis < 3; ++axis) {
    first[axis] = d.cell_coordinate(point[axis] - r, axis);
    last[axis] = std::min(d.cell_coordinate(point[axis] + r, axis), first[axis] + kMostCellsPerAxis - 1);
  }
  std::array<std::pair<double, std::size_t>, kMostCellsPerAxis * kMostCellsPerAxis * kMostCellsPerAxis> cells{};
  std::size_t cell_count = 0;
  for (std::int64_t k = first[2]; k <= last[2]; ++k) {
    for (std::int64_t j = first[1]; j <= last[1]; ++j) {
      for (std::int64_t i = first[0]; i <= last[0]; ++i) {
        const Vec3 lo =
            d.grid_min + d.cell_size * Vec3(static_cast<double>(i), static_cast<double>(j), static_cast<double>(k));
        const Vec3 hi = lo + Vec3::Constant(d.cell_size);
        cells[cell_count++] = {box_distance_sq(point, lo, hi),
                               static_cast<std::size_t>(i + d.dims[0] * (j + d.dims[1] * k))};
      }
    }
  }
  std::sort(cells.begin(), cells.begin() + static_cast<std::ptrdiff_t>(cell_count));

  double best_sq = d.search_radius_sq;
  bool found = false;
  Vec3 best_point = Vec3::Zero();
  Vec3 best_normal = Vec3::Zero();
  for (std::size_t n = 0; n < cell_count && cells[n].first <= best_sq; ++n) {
    const std::size_t c = cells[n].second;
    for (std::uint32_t s = d.cell_start[c]; s < d.cell_start[c + 1]; ++s) {
      const Index t = d.cell_triangles[s];
      if (box_distance_sq(point, d.triangle_min[t], d.triangle_max[t]) > best_sq) continue;
      const Triangle& tri = d.triangles[t];
      const ClosestPoint closest =
          closest_point_on_triangle(point, d.vertices[tri[0]], d.vertices[tri[1]], d.vertices[tri[2]]);
      const double distance_sq = (point - closest.point).squaredNorm();
      // Ties keep the first candidate; the visiting order depends only on the input.
      if (distance_sq < best_sq || (!found && distance_sq <= best_sq)) {
        best_sq = distance_sq;
        found = true;
        best_point = closest.point;
        best_normal = d.pseudo_normal(t, closest.feature);
      }
    }
  }
  if (!found) return far;
  Query result;
  result.within_radius = true;
  result.distance = std::sqrt(best_sq);
  result.inside = (point - best_point).dot(best_normal) < 0.0;
  return result;
}

PairContactMetrics measure_pair(const SurfaceMesh& a, const SurfaceMesh& b, double search_radius) {
  return measure_pair(a, SurfaceDistance(a, search_radius), b, SurfaceDistance(b, search_radius), search_radius);
}

PairContactMetrics measure_pair(const SurfaceMesh& a, const SurfaceDistance& distance_to_a, const SurfaceMesh& b,
                                const SurfaceDistance& distance_to_b, double search_radius) {
  PairContactMetrics metrics;
  double closest_outside = search_radius;  // m
  auto visit = [&](const SurfaceMesh& from, const SurfaceDistance& to) {
    for (const Vec3& vertex : from.vertices) {
      const SurfaceDistance::Query q = to.query(vertex);
      if (!q.within_radius) continue;
      metrics.near = true;
      if (q.inside) {
        metrics.penetration_m = std::max(metrics.penetration_m, q.distance);
        ++metrics.penetrating_vertices;
      } else
        closest_outside = std::min(closest_outside, q.distance);
    }
  };
  visit(a, distance_to_b);
  visit(b, distance_to_a);
  metrics.gap_m = metrics.penetration_m > 0.0 ? 0.0 : closest_outside;
  return metrics;
}

}  // namespace ffd
