#pragma once
// Triangle surface meshes and their clean-up. Meshes "from the wild" carry duplicate
// vertices, unused vertices, duplicate and degenerate triangles and stray pieces; the
// lattice builder wants a clean indexed triangle list.
#include <string>
#include <vector>

#include "ffd/types.h"

namespace ffd {

struct SurfaceMesh {
  std::vector<Vec3> vertices;                 // (V) positions, metres
  std::vector<std::array<Index, 3>> triangles;  // (F) counter-clockwise seen from outside
};

struct MeshCleanOptions {
  // Vertices closer than weld_tolerance * (bounding-box diagonal) are merged. 0 welds only
  // bit-identical positions.
  double weld_tolerance = 1e-9;
  // Connected components with fewer triangles than this fraction of the largest component
  // are dropped (stray scan fragments). 0 keeps every component.
  double min_component_fraction = 0.01;
};

struct MeshCleanReport {
  std::size_t input_vertices = 0;
  std::size_t input_triangles = 0;
  std::size_t welded_vertices = 0;          // vertices merged into another one
  std::size_t unused_vertices = 0;          // vertices no kept triangle references
  std::size_t degenerate_triangles = 0;     // repeated index or zero area
  std::size_t duplicate_triangles = 0;      // same vertex set as another triangle, same winding
  std::size_t opposite_pair_triangles = 0;  // both triangles of a pair with opposite winding
  std::size_t stray_component_triangles = 0;
  std::size_t stray_components = 0;
  std::size_t output_vertices = 0;
  std::size_t output_triangles = 0;
  bool turned_outward = false;        // closed and wound inside out: every triangle flipped
  double inside_out_volume_m3 = 0.0;  // the (negative) volume it enclosed as given
  // One line saying what was cleaned, e.g. "welded 403 duplicate vertices; ...", or "clean".
  std::string summary() const;
};

// Returns the cleaned mesh, turned outward if it was closed and wound inside out; `report`
// says what was removed or turned. Throws std::invalid_argument
// when nothing is left (no triangles) or an index is out of range.
SurfaceMesh clean_mesh(const SurfaceMesh& input, const MeshCleanOptions& options,
                       MeshCleanReport& report);

// Signed volume enclosed by a closed surface (m^3): positive when its triangles wind
// counter-clockwise seen from outside (normals out). Only its sign (-1, 0 or 1) where the
// mesh is more than 1e100 m or less than 1e-100 m across.
double enclosed_volume(const SurfaceMesh& mesh);
// Every edge has exactly two triangles, which wind it in opposite directions.
bool is_closed_and_consistent(const SurfaceMesh& mesh);

// `levels` rounds of 1-to-4 midpoint subdivision: every triangle becomes four, edge
// midpoints shared by both triangles of an edge (the surface stays closed where it was).
// The shape is unchanged; only the sampling gets finer.
SurfaceMesh subdivide_mesh(const SurfaceMesh& mesh, int levels);

// Built-in shapes, centred at the origin, outward-facing.
// Box: `size` full edge lengths (m); each face a grid of divisions[a] x divisions[b] squares
// along its axes a, b (1..kMaxBoxDivisions), two triangles each, the squares' diagonals
// alternating as a chessboard's colours (no direction preferred). A face bends with the
// lattice only through its vertices: box_divisions gives squares about a cell across.
inline constexpr int kMaxBoxDivisions = 4096;
SurfaceMesh make_box_mesh(const Vec3& size, const Vec3i& divisions = Vec3i::Ones());
// The divisions for faces of squares about `cell_size` across: ceil(size / cell_size) per
// axis, at least 1. Throws std::invalid_argument for a size or cell size not finite and > 0,
// or past kMaxBoxDivisions on an axis.
Vec3i box_divisions(const Vec3& size, double cell_size);
SurfaceMesh make_sphere_mesh(double radius, int subdivisions);  // icosphere, 0..6 subdivisions
// Surfaces of revolution about the y axis, `segments` (8..1024) around it; the profiles are
// sampled about as finely as the circumference, so the triangles are near-equilateral.
// Torus: its centre line a circle of `radius` in the xz plane, its tube `thickness` across
// (< 2 radius). Ring: a short thick-walled tube, `radius` outside, its wall `thickness`
// (< radius) and `height` along y, centred on y = 0. Bowl: a hemispherical shell opening up
// (+y), `radius` outside, its wall `thickness` (< radius), its rim at y = 0.
SurfaceMesh make_torus_mesh(double radius, double thickness, int segments);
SurfaceMesh make_ring_mesh(double radius, double thickness, double height, int segments);
SurfaceMesh make_bowl_mesh(double radius, double thickness, int segments);

// Axis-aligned bounds of the vertices (min, max).
std::pair<Vec3, Vec3> mesh_bounds(const SurfaceMesh& mesh);

}  // namespace ffd
