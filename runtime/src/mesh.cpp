#include "ffd/mesh.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <limits>
#include <map>
#include <numeric>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace ffd {

namespace {

using Triangle = std::array<Index, 3>;

std::string plural(std::size_t count, const char* singular, const char* plural_form) {
  return std::to_string(count) + " " + (count == 1 ? singular : plural_form);
}

std::string short_number(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.6g", value);
  return text;
}

// Positions scaled by a power of two so the largest |coordinate| is below 1: exact, and no
// squared length or cross product of a finite input can overflow.
std::vector<Vec3> unit_scaled_positions(const std::vector<Vec3>& vertices) {
  double max_abs = 0.0;
  for (const Vec3& p : vertices) max_abs = std::max(max_abs, p.cwiseAbs().maxCoeff());
  int exponent = 0;
  std::frexp(max_abs, &exponent);
  // Clamped so the factor itself stays finite; inputs that tiny are sub-normal anyway.
  const double factor = std::ldexp(1.0, -std::clamp(exponent, -1000, 1000));
  std::vector<Vec3> scaled;
  scaled.reserve(vertices.size());
  for (const Vec3& p : vertices) scaled.push_back(p * factor);
  return scaled;
}

// representative[i] = the lowest-index vertex within `tolerance` of i that is itself a
// representative (greedy in index order, so the result is independent of any hashing).
std::vector<Index> weld_vertices(const std::vector<Vec3>& positions, double tolerance) {
  const std::size_t count = positions.size();
  std::vector<Index> representative(count);
  if (count == 0) return representative;

  Vec3 lo = positions[0], hi = positions[0];
  for (const Vec3& p : positions) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const double diagonal = (hi - lo).norm();
  // A cell at least as wide as the tolerance puts every partner in the 27 neighbouring
  // cells; the floor keeps cell coordinates below ~1e12 so they fit an int64.
  const double cell = std::max({tolerance, diagonal * 1e-12, 1e-300});
  const double tolerance_sq = tolerance * tolerance;

  using CellKey = std::array<std::int64_t, 3>;
  auto cell_of = [&](const Vec3& p) {
    const Vec3 c = (p - lo) / cell;
    return CellKey{static_cast<std::int64_t>(std::floor(c.x())), static_cast<std::int64_t>(std::floor(c.y())),
                   static_cast<std::int64_t>(std::floor(c.z()))};
  };
  // Vertices sorted by (cell, index): a cell's members are a contiguous, index-ordered run.
  std::vector<std::pair<CellKey, Index>> by_cell(count);
  for (std::size_t i = 0; i < count; ++i) by_cell[i] = {cell_of(positions[i]), static_cast<Index>(i)};
  std::sort(by_cell.begin(), by_cell.end());

  for (std::size_t i = 0; i < count; ++i) {
    const CellKey home = cell_of(positions[i]);
    Index best = static_cast<Index>(i);
    for (std::int64_t dx = -1; dx <= 1; ++dx) {
      for (std::int64_t dy = -1; dy <= 1; ++dy) {
        for (std::int64_t dz = -1; dz <= 1; ++dz) {
          const CellKey key{home[0] + dx, home[1] + dy, home[2] + dz};
          auto it = std::lower_bound(by_cell.begin(), by_cell.end(), std::make_pair(key, Index{0}));
          for (; it != by_cell.end() && it->first == key && it->second < best; ++it) {
            const Index j = it->second;
            if (representative[j] == j && (positions[j] - positions[i]).squaredNorm() <= tolerance_sq) {
              best = j;  // members are index-ordered: the first match is this cell's lowest
              break;
            }
          }
        }
      }
    }
    representative[i] = best;
  }
  return representative;
}

// Zero area up to rounding: |e1 x e2| <= 64 eps |e1| |e2|, i.e. the corner angle is below
// about 1e-14 rad.
bool has_zero_area(const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 e1 = b - a;
  const Vec3 e2 = c - a;
  const double bound = 64.0 * std::numeric_limits<double>::epsilon();
  return e1.cross(e2).squaredNorm() <= bound * bound * e1.squaredNorm() * e2.squaredNorm();
}

// Vertex set of a triangle (sorted indices) and whether its winding is the "even" one;
// two triangles on the same set have the same winding exactly when the flags agree.
std::pair<Triangle, bool> vertex_set_and_winding(const Triangle& t) {
  const std::size_t first = static_cast<std::size_t>(std::min_element(t.begin(), t.end()) - t.begin());
  const Index a = t[first], b = t[(first + 1) % 3], c = t[(first + 2) % 3];
  return {Triangle{a, std::min(b, c), std::max(b, c)}, b < c};
}

struct UnionFind {
  std::vector<std::size_t> parent;
  explicit UnionFind(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), std::size_t{0}); }
  std::size_t find(std::size_t x) {
    while (parent[x] != x) {
      parent[x] = parent[parent[x]];
      x = parent[x];
    }
    return x;
  }
  void unite(std::size_t a, std::size_t b) {
    a = find(a);
    b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
};

}  // namespace

std::string MeshCleanReport::summary() const {
  std::vector<std::string> parts;
  if (welded_vertices > 0)
    parts.push_back("welded " + plural(welded_vertices, "duplicate vertex", "duplicate vertices"));
  if (unused_vertices > 0) parts.push_back("dropped " + plural(unused_vertices, "unused vertex", "unused vertices"));
  if (degenerate_triangles > 0)
    parts.push_back("dropped " + plural(degenerate_triangles, "degenerate triangle", "degenerate triangles"));
  if (duplicate_triangles > 0)
    parts.push_back("dropped " + plural(duplicate_triangles, "duplicate triangle", "duplicate triangles"));
  if (opposite_pair_triangles > 0)
    parts.push_back("dropped " + plural(opposite_pair_triangles, "triangle", "triangles") + " in " +
                    plural(opposite_pair_triangles / 2, "opposite-winding pair", "opposite-winding pairs"));
  if (stray_components > 0)
    parts.push_back("dropped " + plural(stray_components, "stray component", "stray components") + " (" +
                    plural(stray_component_triangles, "triangle", "triangles") + ")");
  if (turned_outward) {
    char volume[64];
    std::snprintf(volume, sizeof volume, "%.3g", inside_out_volume_m3);
    parts.push_back(std::string("wound inside out (enclosed volume ") + volume + " m^3): turned outward");
  }
  if (parts.empty()) return "clean";
  std::string line = parts[0];
  for (std::size_t i = 1; i < parts.size(); ++i) line += "; " + parts[i];
  return line;
}

SurfaceMesh clean_mesh(const SurfaceMesh& input, const MeshCleanOptions& options, MeshCleanReport& report) {
  report = MeshCleanReport{};
  report.input_vertices = input.vertices.size();
  report.input_triangles = input.triangles.size();

  if (!std::isfinite(options.weld_tolerance) || options.weld_tolerance < 0.0)
    throw std::invalid_argument("clean_mesh: weld_tolerance must be finite and >= 0");
  if (!(options.min_component_fraction >= 0.0 && options.min_component_fraction <= 1.0))
    throw std::invalid_argument("clean_mesh: min_component_fraction must be in [0, 1]");
  for (std::size_t i = 0; i < input.vertices.size(); ++i) {
    if (!is_finite(input.vertices[i]))
      throw std::invalid_argument("clean_mesh: vertex " + std::to_string(i + 1) + " (counting from 1) is not finite");
  }
  for (std::size_t t = 0; t < input.triangles.size(); ++t) {
    for (Index v : input.triangles[t]) {
      if (v >= input.vertices.size())
        throw std::invalid_argument("clean_mesh: triangle " + std::to_string(t) + " uses vertex index " +
                                    std::to_string(v) + ", but the mesh has " + std::to_string(input.vertices.size()) +
                                    " vertices");
    }
  }

  // 1. Weld, in power-of-two scaled coordinates (exact; the tolerance is relative anyway).
  const std::vector<Vec3> positions = unit_scaled_positions(input.vertices);
  double scaled_diagonal = 0.0;
  if (!positions.empty()) {
    Vec3 lo = positions[0], hi = positions[0];
    for (const Vec3& p : positions) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    scaled_diagonal = (hi - lo).norm();
  }
  // A tolerance of one diagonal already welds everything; capping first avoids overflow.
  const double tolerance = std::min(options.weld_tolerance, 1.0) * scaled_diagonal;
  const std::vector<Index> representative = weld_vertices(positions, tolerance);
  for (std::size_t i = 0; i < representative.size(); ++i) {
    if (representative[i] != i) ++report.welded_vertices;
  }

  // 2. Degenerate triangles: repeated index after welding, or zero area.
  std::vector<Triangle> triangles(input.triangles.size());
  std::vector<char> keep(input.triangles.size(), 1);
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    const Triangle& original = input.triangles[t];
    Triangle& welded = triangles[t];
    for (int k = 0; k < 3; ++k) welded[k] = representative[original[k]];
    const bool repeated = welded[0] == welded[1] || welded[1] == welded[2] || welded[0] == welded[2];
    if (repeated || has_zero_area(positions[welded[0]], positions[welded[1]], positions[welded[2]])) {
      keep[t] = 0;
      ++report.degenerate_triangles;
    }
  }

  // 3. Triangles on the same vertex set. Opposite windings cancel pairwise (a zero-thickness
  // sheet has no inside); of the surplus winding the earliest copy stays, the rest are
  // duplicates. Cancelling only pairs keeps a closed surface closed: dropping every triangle
  // of a mixed-winding set instead opened hundreds of boundary edges on the Happy Buddha.
  {
    std::vector<std::pair<Triangle, std::size_t>> by_set;
    by_set.reserve(triangles.size());
    for (std::size_t t = 0; t < triangles.size(); ++t) {
      if (keep[t]) by_set.emplace_back(vertex_set_and_winding(triangles[t]).first, t);
    }
    std::sort(by_set.begin(), by_set.end());
    std::vector<std::size_t> even, odd;
    for (std::size_t begin = 0; begin < by_set.size();) {
      std::size_t end = begin + 1;
      while (end < by_set.size() && by_set[end].first == by_set[begin].first) ++end;
      if (end - begin > 1) {
        even.clear();
        odd.clear();
        for (std::size_t g = begin; g < end; ++g) {
          const std::size_t t = by_set[g].second;
          (vertex_set_and_winding(triangles[t]).second ? even : odd).push_back(t);
        }
        const std::size_t pairs = std::min(even.size(), odd.size());
        std::vector<std::size_t>& surplus = even.size() > odd.size() ? even : odd;
        for (std::size_t t : even) keep[t] = 0;
        for (std::size_t t : odd) keep[t] = 0;
        if (surplus.size() > pairs) {
          keep[surplus[0]] = 1;  // lists are in input order: this is the earliest copy
          report.duplicate_triangles += surplus.size() - 1 - pairs;
        }
        report.opposite_pair_triangles += 2 * pairs;
      }
      begin = end;
    }
  }

  // 4. Stray components: triangles connected through shared (welded) vertices.
  {
    UnionFind components(triangles.size());
    std::vector<std::size_t> first_triangle_of_vertex(input.vertices.size(), std::numeric_limits<std::size_t>::max());
    for (std::size_t t = 0; t < triangles.size(); ++t) {
      if (!keep[t]) continue;
      for (Index v : triangles[t]) {
        if (first_triangle_of_vertex[v] == std::numeric_limits<std::size_t>::max())
          first_triangle_of_vertex[v] = t;
        else
          components.unite(first_triangle_of_vertex[v], t);
      }
    }
    std::vector<std::size_t> size(triangles.size(), 0);
    std::size_t largest = 0;
    for (std::size_t t = 0; t < triangles.size(); ++t) {
      if (keep[t]) largest = std::max(largest, ++size[components.find(t)]);
    }
    const double min_size = options.min_component_fraction * static_cast<double>(largest);
    for (std::size_t t = 0; t < triangles.size(); ++t) {
      if (keep[t] && components.find(t) == t && static_cast<double>(size[t]) < min_size) {
        ++report.stray_components;
        report.stray_component_triangles += size[t];
      }
    }
    for (std::size_t t = 0; t < triangles.size(); ++t) {
      if (keep[t] && static_cast<double>(size[components.find(t)]) < min_size) keep[t] = 0;
    }
  }

  // 5. Compact: used vertices and kept triangles, both in their original relative order.
  std::vector<Index> new_index(input.vertices.size(), kNoIndex);
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    if (keep[t]) {
      for (Index v : triangles[t]) new_index[v] = 0;  // mark used
    }
  }
  SurfaceMesh output;
  for (std::size_t i = 0; i < input.vertices.size(); ++i) {
    if (representative[i] != i) continue;  // welded away, counted above
    if (new_index[i] == kNoIndex) {
      ++report.unused_vertices;
      continue;
    }
    new_index[i] = static_cast<Index>(output.vertices.size());
    output.vertices.push_back(input.vertices[i]);
  }
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    if (keep[t])
      output.triangles.push_back({new_index[triangles[t][0]], new_index[triangles[t][1]], new_index[triangles[t][2]]});
  }
  report.output_vertices = output.vertices.size();
  report.output_triangles = output.triangles.size();
  if (output.triangles.empty())
    throw std::invalid_argument("clean_mesh: no triangles remain (" + report.summary() + ")");

  // 6. Orientation: a closed, consistently wound surface that encloses a negative volume is
  // wound inside out (its normals point in); the response pushes along those normals, so it
  // is turned outward, and the report says so.
  if (is_closed_and_consistent(output)) {
    const double volume = enclosed_volume(output);
    if (volume < 0.0) {
      for (auto& t : output.triangles) std::swap(t[1], t[2]);
      report.turned_outward = true;
      report.inside_out_volume_m3 = volume;
    }
  }
  return output;
}

double enclosed_volume(const SurfaceMesh& mesh) {
  // In coordinates centred on the bounds and scaled to [-1, 1] (halves first: no overflow for
  // any finite input), then scaled back; the sign holds even where the m^3 would not fit.
  if (mesh.vertices.empty()) return 0.0;
  const auto [lo, hi] = mesh_bounds(mesh);
  const Vec3 half_centre = 0.5 * (0.5 * lo + 0.5 * hi);
  const double half_extent = (0.5 * hi - 0.5 * lo).maxCoeff();
  if (!(half_extent > 0.0)) return 0.0;
  const auto unit = [&](Index v) -> Vec3 { return (0.5 * mesh.vertices[v] - half_centre) / half_extent; };
  double six_volume = 0.0;  // divergence theorem: each triangle's tetrahedron with the centre
  for (const auto& t : mesh.triangles) six_volume += unit(t[0]).dot(unit(t[1]).cross(unit(t[2])));
  const double scale = 2.0 * half_extent;
  if (scale > 1e100 || scale < 1e-100) return six_volume < 0.0 ? -1.0 : six_volume > 0.0 ? 1.0 : 0.0;
  return six_volume / 6.0 * scale * scale * scale;
}

bool is_closed_and_consistent(const SurfaceMesh& mesh) {
  // Every directed edge once, and its reverse once: each edge has two triangles that wind it
  // in opposite directions. Then the sorted edges and the sorted reversed edges are equal.
  std::vector<std::uint64_t> edges, reversed;
  edges.reserve(3 * mesh.triangles.size());
  reversed.reserve(3 * mesh.triangles.size());
  for (const auto& t : mesh.triangles)
    for (std::size_t k = 0; k < 3; ++k) {
      const std::uint64_t a = t[k], b = t[(k + 1) % 3];
      edges.push_back(a << 32 | b);
      reversed.push_back(b << 32 | a);
    }
  std::sort(edges.begin(), edges.end());
  if (std::adjacent_find(edges.begin(), edges.end()) != edges.end()) return false;  // a directed edge twice
  std::sort(reversed.begin(), reversed.end());
  return edges == reversed;
}

SurfaceMesh make_box_mesh(const Vec3& size, const Vec3i& divisions) {
  if (!is_finite(size) || size.minCoeff() <= 0.0)
    throw std::invalid_argument("make_box_mesh: every edge length must be finite and > 0");
  if (divisions.minCoeff() < 1 || divisions.maxCoeff() > kMaxBoxDivisions)
    throw std::invalid_argument("make_box_mesh: divisions must be in 1.." + std::to_string(kMaxBoxDivisions) +
                                " per axis");
  const Vec3 h = 0.5 * size;
  SurfaceMesh mesh;
  // The grid points (i, j, k) on the surface, i in 0..divisions.x() along x and so on,
  // numbered x fastest, then y, then z: undivided, vertex i has x = +h when bit 0 is set, y
  // when bit 1, z when bit 2. Each point once, shared by the faces that meet there.
  std::map<std::array<int, 3>, Index> point_index;
  for (int k = 0; k <= divisions.z(); ++k)
    for (int j = 0; j <= divisions.y(); ++j) {
      // A row on a side face has every point; a row through the inside only its two ends.
      const bool side = k == 0 || k == divisions.z() || j == 0 || j == divisions.y();
      for (int i = 0; i <= divisions.x(); i += side ? 1 : divisions.x()) {
        const std::array<int, 3> g{i, j, k};
        Vec3 p;
        for (int a = 0; a < 3; ++a) p[a] = g[a] == divisions[a] ? h[a] : -h[a] + size[a] * g[a] / divisions[a];
        point_index.emplace(g, static_cast<Index>(mesh.vertices.size()));
        mesh.vertices.push_back(p);
      }
    }
  mesh.triangles.reserve(4 * static_cast<std::size_t>(divisions.x() * divisions.y() + divisions.y() * divisions.z() +
                                                      divisions.z() * divisions.x()));
  for (int a = 0; a < 3; ++a) {
    // The face at -h[a], then the one at +h[a], spanned by axes u and v with u x v = +e_a.
    const int u = (a + 1) % 3, v = (a + 2) % 3;
    for (const int side : {0, divisions[a]}) {
      for (int i = 0; i < divisions[u]; ++i)
        for (int j = 0; j < divisions[v]; ++j) {
          std::array<Index, 4> corner;  // (i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)
          for (int c = 0; c < 4; ++c) {
            std::array<int, 3> g{};
            g[a] = side;
            g[u] = i + (c == 1 || c == 2);
            g[v] = j + (c >= 2);
            corner[c] = point_index.at(g);
          }
          // The squares' diagonals alternate as a chessboard's colours do (corners 0-2 on the
          // square at (0, 0), 1-3 on its neighbours): with every diagonal one way, the faces of
          // a crushed box fold alike along them and stay crossed (hard case probe_force, its
          // box in squares, under the solver).
          const int d = (i + j) % 2;
          const Index p = corner[d], q = corner[d + 1], r = corner[d + 2], s = corner[(d + 3) % 4];
          // Counter-clockwise seen from outside: u, v order on the + face, reversed on the - face.
          if (side > 0) {
            mesh.triangles.push_back({p, q, r});
            mesh.triangles.push_back({p, r, s});
          } else {
            mesh.triangles.push_back({p, s, r});
            mesh.triangles.push_back({p, r, q});
          }
        }
    }
  }
  return mesh;
}

Vec3i box_divisions(const Vec3& size, double cell_size) {
  if (!is_finite(size) || size.minCoeff() <= 0.0 || !std::isfinite(cell_size) || cell_size <= 0.0)
    throw std::invalid_argument("box_divisions: the edge lengths and the cell size must be finite and > 0");
  Vec3i divisions;
  for (int a = 0; a < 3; ++a) {
    const double squares = std::ceil(size[a] / cell_size);  // >= 1: both are > 0
    if (!(squares <= kMaxBoxDivisions))
      throw std::invalid_argument("a box edge of " + short_number(size[a]) + " m in squares of " +
                                  short_number(cell_size) + " m needs " + short_number(squares) +
                                  " squares, more than the limit of " + std::to_string(kMaxBoxDivisions));
    divisions[a] = std::max(1, static_cast<int>(squares));
  }
  return divisions;
}

SurfaceMesh make_sphere_mesh(double radius, int subdivisions) {
  if (!std::isfinite(radius) || radius <= 0.0)
    throw std::invalid_argument("make_sphere_mesh: radius must be finite and > 0");
  if (subdivisions < 0 || subdivisions > 6)
    throw std::invalid_argument("make_sphere_mesh: subdivisions must be in 0..6, got " + std::to_string(subdivisions));

  // Icosahedron on the unit sphere; faces counter-clockwise seen from outside.
  const double phi = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Vec3> unit = {{-1, phi, 0},  {1, phi, 0},  {-1, -phi, 0}, {1, -phi, 0}, {0, -1, phi},  {0, 1, phi},
                            {0, -1, -phi}, {0, 1, -phi}, {phi, 0, -1},  {phi, 0, 1},  {-phi, 0, -1}, {-phi, 0, 1}};
  for (Vec3& p : unit) p.normalize();
  std::vector<Triangle> faces = {{0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                                 {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                                 {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};

  for (int level = 0; level < subdivisions; ++level) {
    std::map<std::pair<Index, Index>, Index> midpoint_of_edge;  // ordered: deterministic
    auto midpoint = [&](Index a, Index b) {
      const std::pair<Index, Index> key{std::min(a, b), std::max(a, b)};
      auto [it, inserted] = midpoint_of_edge.try_emplace(key, static_cast<Index>(unit.size()));
      if (inserted) unit.push_back((unit[a] + unit[b]).normalized());
      return it->second;
    };
    std::vector<Triangle> finer;
    finer.reserve(faces.size() * 4);
    for (const Triangle& f : faces) {
      const Index ab = midpoint(f[0], f[1]), bc = midpoint(f[1], f[2]), ca = midpoint(f[2], f[0]);
      finer.push_back({f[0], ab, ca});
      finer.push_back({f[1], bc, ab});
      finer.push_back({f[2], ca, bc});
      finer.push_back({ab, bc, ca});
    }
    faces = std::move(finer);
  }

  SurfaceMesh mesh;
  mesh.vertices.reserve(unit.size());
  for (const Vec3& p : unit) mesh.vertices.push_back(radius * p);
  mesh.triangles = std::move(faces);
  return mesh;
}

namespace {

// A point of a profile in the half-plane of revolution: r >= 0 from the y axis, and y.
struct ProfilePoint {
  double r = 0.0, y = 0.0;
};

// The closed profile polygon `profile` (consecutive points joined, the last to the first)
// turned about the y axis in `segments` steps. A point on the axis (r = 0) becomes one pole
// vertex; an edge along the axis makes no triangles. Wound outward whatever the profile's
// direction: the triangles are flipped where the enclosed volume comes out negative.
SurfaceMesh revolve_profile(const std::vector<ProfilePoint>& profile, int segments) {
  SurfaceMesh mesh;
  std::vector<Index> first_vertex;  // per profile point: its vertex, or the first of its ring
  const double step = 2.0 * std::acos(-1.0) / segments;
  for (const ProfilePoint& p : profile) {
    first_vertex.push_back(static_cast<Index>(mesh.vertices.size()));
    if (p.r == 0.0) {
      mesh.vertices.emplace_back(0.0, p.y, 0.0);
      continue;
    }
    for (int j = 0; j < segments; ++j)
      mesh.vertices.emplace_back(p.r * std::cos(j * step), p.y, -p.r * std::sin(j * step));
  }
  const auto vertex = [&](std::size_t k, int j) {
    return profile[k].r == 0.0 ? first_vertex[k] : first_vertex[k] + static_cast<Index>(j % segments);
  };
  for (std::size_t k = 0; k < profile.size(); ++k) {
    const std::size_t next = (k + 1) % profile.size();
    const bool pole = profile[k].r == 0.0, next_pole = profile[next].r == 0.0;
    if (pole && next_pole) continue;
    for (int j = 0; j < segments; ++j) {
      const Index a = vertex(k, j), b = vertex(k, j + 1), c = vertex(next, j + 1), d = vertex(next, j);
      if (!pole) mesh.triangles.push_back({a, b, c});
      if (!next_pole) mesh.triangles.push_back({a, c, d});
    }
  }
  if (enclosed_volume(mesh) < 0.0)
    for (Triangle& t : mesh.triangles) std::swap(t[1], t[2]);
  return mesh;
}

// `pieces` points from `from` towards `to` (that one left out) on a straight line; append_arc:
// on the arc of `radius` about the origin, angles in radians from the +r direction.
void append_line(std::vector<ProfilePoint>& out, ProfilePoint from, ProfilePoint to, int pieces) {
  for (int i = 0; i < pieces; ++i) {
    const double t = static_cast<double>(i) / pieces;
    out.push_back({from.r + t * (to.r - from.r), from.y + t * (to.y - from.y)});
  }
}
void append_arc(std::vector<ProfilePoint>& out, double radius, double from_angle, double to_angle, int pieces) {
  for (int i = 0; i < pieces; ++i) {
    const double angle = from_angle + (to_angle - from_angle) * i / pieces;
    out.push_back({std::max(0.0, radius * std::cos(angle)), radius * std::sin(angle)});
  }
}

// The most points a profile may have: with 1024 segments, 4.2 million triangles.
constexpr double kMaxProfilePoints = 2048;

// Pieces for a length when the circumference 2 pi radius has `segments`: at least one. Throws
// when a profile would need more than kMaxProfilePoints (a ring far taller than it is wide).
int pieces_for(const char* what, double length, double radius, int segments) {
  const double pieces = std::round(length / (2.0 * std::acos(-1.0) * radius / segments));
  if (!(pieces <= kMaxProfilePoints))
    throw std::invalid_argument(std::string(what) + ": the shape is too long for its radius (its profile would need " +
                                "more than 2048 points)");
  return std::max(1, static_cast<int>(pieces));
}

void check_revolution(const char* what, double radius, double thickness, int segments) {
  if (!std::isfinite(radius) || radius <= 0.0) throw std::invalid_argument(std::string(what) + ": radius must be finite and > 0");
  if (!std::isfinite(thickness) || thickness <= 0.0)
    throw std::invalid_argument(std::string(what) + ": thickness must be finite and > 0");
  if (segments < 8 || segments > 1024)
    throw std::invalid_argument(std::string(what) + ": segments must be in 8..1024, got " + std::to_string(segments));
}

}  // namespace

SurfaceMesh make_torus_mesh(double radius, double thickness, int segments) {
  check_revolution("make_torus_mesh", radius, thickness, segments);
  if (!(thickness < 2.0 * radius)) throw std::invalid_argument("make_torus_mesh: thickness must be < 2 radius");
  const double tube = 0.5 * thickness;
  // The tube's circle, about as finely as the centre line, and at least 12 around.
  const int around = std::max(12, pieces_for("make_torus_mesh", 2.0 * std::acos(-1.0) * tube, radius, segments));
  std::vector<ProfilePoint> profile;
  for (int i = 0; i < around; ++i) {
    const double angle = 2.0 * std::acos(-1.0) * i / around;
    profile.push_back({radius + tube * std::cos(angle), tube * std::sin(angle)});
  }
  return revolve_profile(profile, segments);
}

SurfaceMesh make_ring_mesh(double radius, double thickness, double height, int segments) {
  check_revolution("make_ring_mesh", radius, thickness, segments);
  if (!(thickness < radius)) throw std::invalid_argument("make_ring_mesh: thickness must be < radius");
  if (!std::isfinite(height) || height <= 0.0) throw std::invalid_argument("make_ring_mesh: height must be finite and > 0");
  const double inner = radius - thickness, h = 0.5 * height;
  const int across = pieces_for("make_ring_mesh", thickness, radius, segments);
  const int along = pieces_for("make_ring_mesh", height, radius, segments);
  std::vector<ProfilePoint> profile;
  append_line(profile, {inner, -h}, {radius, -h}, across);
  append_line(profile, {radius, -h}, {radius, h}, along);
  append_line(profile, {radius, h}, {inner, h}, across);
  append_line(profile, {inner, h}, {inner, -h}, along);
  return revolve_profile(profile, segments);
}

SurfaceMesh make_bowl_mesh(double radius, double thickness, int segments) {
  check_revolution("make_bowl_mesh", radius, thickness, segments);
  if (!(thickness < radius)) throw std::invalid_argument("make_bowl_mesh: thickness must be < radius");
  const double inner = radius - thickness, quarter = 0.5 * std::acos(-1.0);
  const int outer_pieces = pieces_for("make_bowl_mesh", quarter * radius, radius, segments);
  const int inner_pieces = pieces_for("make_bowl_mesh", quarter * inner, radius, segments);
  std::vector<ProfilePoint> profile;
  append_arc(profile, radius, -quarter, 0.0, outer_pieces);  // outside, from the bottom pole up
  append_line(profile, {radius, 0.0}, {inner, 0.0}, pieces_for("make_bowl_mesh", thickness, radius, segments));  // the rim
  append_arc(profile, inner, 0.0, -quarter, inner_pieces);  // inside, down
  profile.push_back({0.0, -inner});  // the inside's pole; the axis edge to the outside's pole closes it
  profile[0].r = 0.0;                // exactly on the axis: a pole
  return revolve_profile(profile, segments);
}

std::pair<Vec3, Vec3> mesh_bounds(const SurfaceMesh& mesh) {
  if (mesh.vertices.empty()) throw std::invalid_argument("mesh_bounds: the mesh has no vertices");
  Vec3 lo = mesh.vertices[0], hi = mesh.vertices[0];
  for (const Vec3& p : mesh.vertices) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  return {lo, hi};
}

}  // namespace ffd

namespace ffd {

SurfaceMesh subdivide_mesh(const SurfaceMesh& mesh, int levels) {
  if (levels < 0 || levels > 3) throw std::invalid_argument("subdivide_mesh: levels must be in 0..3, got " + std::to_string(levels));
  SurfaceMesh out = mesh;
  for (int level = 0; level < levels; ++level) {
    SurfaceMesh next;
    next.vertices = out.vertices;
    next.triangles.reserve(4 * out.triangles.size());
    std::map<std::pair<Index, Index>, Index> midpoint;  // undirected edge -> its new vertex
    auto middle = [&](Index a, Index b) {
      const auto key = std::minmax(a, b);
      const auto [it, inserted] = midpoint.emplace(key, static_cast<Index>(next.vertices.size()));
      if (inserted) next.vertices.push_back(0.5 * (out.vertices[key.first] + out.vertices[key.second]));
      return it->second;
    };
    for (const auto& [a, b, c] : out.triangles) {
      const Index ab = middle(a, b), bc = middle(b, c), ca = middle(c, a);
      next.triangles.push_back({a, ab, ca});
      next.triangles.push_back({ab, b, bc});
      next.triangles.push_back({ca, bc, c});
      next.triangles.push_back({ab, bc, ca});
    }
    out = std::move(next);
  }
  return out;
}

}  // namespace ffd
