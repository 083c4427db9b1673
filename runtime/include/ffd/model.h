#pragma once
// Model: everything about a scene that does not change while it runs — lattice topology,
// rest shape, FFD AABB local coordinates, springs, shape-matching regions, planes, the
// assembled pipeline. Built once by compile(); step() only reads it.
// Nodes, cells and boxes of all objects live in flat arrays; an object owns a contiguous
// range of each.
#include <stdexcept>
#include <string>
#include <vector>

#include "ffd/spec.h"
#include "ffd/state.h"
#include "ffd/trilinear.h"

namespace ffd {

// The stages a step may run, in order. compile() keeps only those the effects ask for.
enum class Stage : std::uint8_t {
  Gravity,      // v += g dt
  Dynamics,     // internal forces and integration of the lattice nodes
  BoxUpdate,    // FFD AABB nodes from the lattice (eq. 2), section 4
  BroadPhase,   // spatial hash of the boxes, section 6.1
  NarrowPhase,  // node-in-box tests + immediate response, Algorithm 1, sections 6.2 and 7
  Planes,       // static planes: node-below-plane tests + the same response
  Interaction,  // haptic probe (virtual coupling + probe contacts) and grab spring
  ContactSolve, // response "solver": lattice constraints and contacts solved together
  Sleep,        // objects at rest fall asleep (the "sleeping" effect)
  Count
};
const char* stage_name(Stage s);

struct ObjectModel {
  std::string name;
  DynamicsKind dynamics = DynamicsKind::MassSpring;
  MassSpringParams mass_spring;
  ShapeMatchingParams shape_matching;
  double cell_size = 0.0;         // m
  // Placement at time zero: world = initial_rotation * (object frame) + initial_translation.
  Mat3 initial_rotation = Mat3::Identity();
  Vec3 initial_translation = Vec3::Zero();  // m
  Vec3 initial_velocity = Vec3::Zero();     // m/s
  Vec3 initial_angular_velocity = Vec3::Zero();  // rad/s, about the lattice's centre of mass
  Vec3 lattice_origin;            // m, corner of lattice cell (0,0,0) at rest
  Vec3i lattice_dims;             // cells per axis of the full regular grid
  Index node_begin = 0, node_end = 0;      // range in Model::node_*
  Index cell_begin = 0, cell_end = 0;      // range in Model::cell_*
  Index box_begin = 0, box_end = 0;        // range in Model::boxes
  Index spring_begin = 0, spring_end = 0;  // range in Model::springs
  Index colour_begin = 0, colour_end = 0;  // range in Model::spring_colours (mass-spring)
  Index tetrahedron_begin = 0, tetrahedron_end = 0;  // range in Model::tetrahedra
  Index region_begin = 0, region_end = 0;  // range in Model::regions
  // The embedded surface: rest positions, and for every vertex its cell and local
  // coordinates (s, t, u) in [0, 1]^3 (eq. 1, divided by the cell size).
  SurfaceMesh surface;
  std::vector<Index> vertex_cell;  // global cell index
  std::vector<Vec3> vertex_local;
};

struct Spring {
  Index a, b;          // global node indices
  double rest_length;  // m
};

// The springs of an object in Gauss-Seidel order, colour by colour: a greedy colouring at
// compile time, so that no two springs of a colour share a node. A colour's springs are then
// solved several lanes at a time (kernels/spring_kernels.h) with exactly the result of solving
// them one after the other. The last colour (63) takes whatever the others could not, and may
// share nodes: it is solved one spring at a time.
struct SpringColour {
  Index begin, end;  // springs, in Model::springs
  bool independent;  // no two of its springs share a node
};

// A volume constraint of a mass-spring cell (MassSpringParams::bulk_modulus): one of the six
// tetrahedra of its Kuhn split, corners ordered so that the rest volume is positive.
struct Tetrahedron {
  std::array<Index, 4> nodes;  // global node indices
  double rest_volume;          // m^3, > 0
  double compliance;           // m^3/Pa: V0 / K, the XPBD compliance of C = V - V0
};

// A lattice shape-matching region (FastLSM): the nodes within half-width w of its centre.
struct Region {
  Index member_begin, member_end;  // range in Model::region_members
  Vec3 rest_centroid;              // m, mass-weighted
  double mass;                     // kg
};

// One set of collision boxes over the lattice cells, each given by 8 corners and a centre
// node in its cell's local coordinates (s, t, u), moved by trilinear FFD (eq. 2). Boxes are
// stored in cell order, so the boxes of cell c are [cell_box_begin[c], cell_box_begin[c + 1]).
// Boxes are updated in blocks of kBoxLanes (kernels/box_kernels.h): AVX-512's 8 doubles; a
// narrower target takes a block in parts.
inline constexpr Index kBoxLanes = 8;

struct BoxSet {
  std::vector<Index> box_cell;                  // lattice cell of each box
  std::vector<std::array<Vec3, 9>> box_local;   // corner k = (k & 1, k >> 1 & 1, k >> 2 & 1), then the centre
  std::vector<Index> cell_box_begin;            // (C + 1)
  std::vector<Vec3i> box_lattice;               // lattice coordinates of each box's cell
  // The same boxes for the update kernel, in blocks of kBoxLanes boxes (the last block
  // padded with copies of its last box), each field a row of kBoxLanes lanes. Every box is
  // axis-aligned in its cell's local frame, so its corners are the 2 x 2 x 2 products of
  // (lo, hi) per axis: per block 9 rows (lo s, t, u; hi s, t, u; centre s, t, u) of `local`,
  // and 8 rows of `corner`: where its cell's corner j starts in the State's positions (3 x
  // the node index, x first).
  std::vector<double> kernel_local;
  std::vector<std::int64_t> kernel_corner;
  std::size_t size() const { return box_cell.size(); }
  std::size_t block_count() const { return (size() + kBoxLanes - 1) / kBoxLanes; }
};

// Accuracy level 3's surface nodes per FFD AABB: the extreme points of the surface in its
// cell along the 26 directions of a 3 x 3 x 3 neighbourhood, in cell-local coordinates.
inline constexpr int kBoxSampleCount = 26;

struct PlaneModel {
  std::string name;
  Vec3 normal;    // unit
  double offset;  // m
};

// "box_overlap": the skin kept between boxes of two objects, as a share of the finer cell
// size. Large enough that two flat faces resting on each other (a plate's surface is its
// box's face) do not touch after a step's sinking under gravity (g dt^2 = 0.01 mm), small
// enough not to show: 0.1 mm on 1 cm cells.
inline constexpr double kBoxSkinShare = 0.01;

// Level 4 under the paper's response: the skin its sub-boxes keep between the nodes and faces
// of two objects' sub-boxes, as a share of the finer cell size (0.3 mm on 1 cm cells). Flat
// faces of two objects resting on each other lie in their sub-boxes' faces, and without it
// touched and crossed by a step's sinking. 3 % is the largest share tried that kept the
// random piles clean (docs/notes/2026-11-28-code-findings.md#sub-box-skin).
inline constexpr double kSubBoxSkinShare = 0.03;

struct Model {
  SimulationSettings settings;   // as compiled (validated)
  std::vector<Stage> pipeline;   // the stages this scene runs, in order

  std::vector<ObjectModel> objects;

  // Lattice nodes (N).
  std::vector<Vec3> node_rest;        // m
  std::vector<double> node_mass;      // kg
  std::vector<double> node_inv_mass;  // 1/kg
  std::vector<Index> node_object;

  // Lattice cells (C): 8 node indices each, corner j = i + 2 j + 4 k ordering (x fastest).
  std::vector<std::array<Index, 8>> cell_nodes;
  std::vector<Vec3i> cell_coord;      // integer lattice coordinates within the object
  std::vector<Index> cell_object;
  std::vector<double> cell_inv_mass;  // 1/kg, inverse of the summed mass share of the cell
  std::vector<double> cell_node_mass; // kg, the summed mass of the cell's 8 nodes
  std::vector<Vec3> cell_rest_centre; // m, their mass-weighted centre at rest
  // Cells that share a lattice node with cell c (c included): rows of a CSR table. When a
  // response moves c's nodes these cells' boxes are stale.
  std::vector<Index> cell_neighbour_begin;  // (C + 1)
  std::vector<Index> cell_neighbours;

  // FFD AABBs (B): one per surface cell. 8 boundary nodes at the corners of the bounding
  // box of the surface inside the cell + the surface's centre of mass, all in the cell's
  // local coordinates (section 4). Accuracy levels 1, 2, 3 collide these; level 5 keeps
  // them for the probe and the frames.
  BoxSet boxes;
  std::vector<std::array<Vec3, kBoxSampleCount>> box_samples;  // level 3's surface nodes per box
  // Accuracy level 0: the plain lattice cells of the surface as boxes (corners at 0 and 1,
  // centre node at the cell centre). Level 4: every FFD AABB split into k x k x k parts, each
  // fitted to the surface inside it.
  BoxSet grid_boxes;
  BoxSet sub_boxes;

  // Accuracy level 5, the exact surfaces: every object's surface vertices (bound to a cell
  // by eq. 1) and triangles in flat arrays with global vertex indices, and per cell (CSR)
  // the vertices bound to it and the triangles with a vertex bound to it. Pairs of cells
  // come from the box broad phase, widened by the contact radius.
  std::vector<Index> surface_vertex_cell;
  std::vector<Vec3> surface_vertex_local;
  std::vector<Vec3> surface_vertex_rest;  // m, the vertex in the object's rest shape (its mesh)
  std::vector<std::array<Index, 3>> surface_triangles;
  std::vector<Index> cell_vertex_begin, cell_vertices;    // (C + 1), vertex indices
  std::vector<Index> cell_triangle_begin, cell_triangles;  // (C + 1), triangle indices
  // (C + 1) per cell, the cells the corners of its triangles are bound to: what its
  // triangles move with.
  std::vector<Index> cell_triangle_source_begin, cell_triangle_sources;
  // (C + 1) per cell, the edges of its triangles (each once, lower vertex index first): the
  // edges tested against other cells' triangles.
  std::vector<Index> cell_edge_begin;
  std::vector<std::array<Index, 2>> cell_edges;
  // (C + 1) per cell, the triangles it owns (those whose first corner is bound to it, or the
  // next corner with a box: each triangle has one owner) and their edges (each once per
  // cell). Levels 0-3 with edge contacts test the edges of one cell's owned triangles against
  // another's owned triangles, each pair of triangles once: a large triangle crosses many
  // cells (a box's face of 2 triangles crosses every cell of the face), and by the cells it
  // crosses a pair of triangles was tested once per pair of those cells.
  std::vector<Index> cell_owned_triangle_begin, cell_owned_triangles;
  std::vector<Index> cell_owned_edge_begin;
  std::vector<std::array<Index, 2>> cell_owned_edges;
  double surface_contact_radius = 0.0;  // m, deepest penetration the exact level sees
  // m, the gap the exact level keeps between the surfaces of two objects: a vertex this
  // close in front of a triangle is a contact too, and goes out to it. Pushed only to the
  // face, a vertex lies on it, and the surfaces touch (they intersect: share a point) until
  // they part.
  double surface_skin = 0.0;
  double box_skin = 0.0;  // m, "box_overlap": the gap kept between boxes of two objects (0: off)
  double sub_box_skin = 0.0;  // m, level 4's (kSubBoxSkinShare)
  std::uint32_t sleep_steps = 0;         // "sleeping": sleep_time in steps (>= 1)

  std::vector<Spring> springs;          // Gauss-Seidel order: colour by colour
  std::vector<SpringColour> spring_colours;
  // The same springs as arrays for the kernels: their nodes, and rest lengths (m).
  std::vector<Index> spring_node_a, spring_node_b;
  std::vector<double> spring_rest_length;
  std::vector<Tetrahedron> tetrahedra;
  std::vector<Region> regions;
  std::vector<Index> region_members;      // node indices
  std::vector<Index> node_region_count;   // regions containing each node

  std::vector<PlaneModel> planes;

  // Broad phase: boxes of different objects or of one object are paired (an effect asks).
  bool collides = false;

  std::size_t node_count() const { return node_rest.size(); }
  std::size_t cell_count() const { return cell_nodes.size(); }
  std::size_t box_count() const { return boxes.size(); }  // FFD AABBs
};

struct CompileError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Validates the spec, cleans the meshes, builds lattices, boxes, springs and regions, and
// assembles the pipeline from the effects. `log` receives one line per noteworthy fact
// (what mesh clean-up removed, lattice sizes). Throws CompileError naming the object.
Model compile(const SceneSpec& spec, std::vector<std::string>& log);

// The state at time zero: rest lattice placed by each object's position, rotation, velocity.
State initial_state(const Model& model);

// Whether cell `cell` is inside out as the state has it (cell_inside_out: the Jacobian of
// eq. 2 at its centre has a determinant <= 0). Its piece of the embedded surface is then
// inside out too: behind its triangles is outside.
inline bool cell_inverted(const Model& model, const State& state, Index cell) {
  const std::array<Index, 8>& n = model.cell_nodes[cell];
  return cell_inside_out([&](int j) -> const Vec3& { return state.x[n[j]]; });
}

// Tetrahedron k (0-5) of cell `cell`'s Kuhn split, around its diagonal from corner 0 to
// corner 7, corners ordered so that its rest volume is positive; compliance 0.
Tetrahedron kuhn_tetrahedron(const Model& model, Index cell, int k);

// Mass-weighted centre of one object's lattice nodes at positions x (m).
inline Vec3 centre_of_mass(const Model& model, const std::vector<Vec3>& x, Index object) {
  const ObjectModel& o = model.objects[object];
  Vec3 sum = Vec3::Zero();
  double mass = 0.0;
  for (Index n = o.node_begin; n < o.node_end; ++n) {
    sum += model.node_mass[n] * x[n];
    mass += model.node_mass[n];
  }
  return sum / mass;
}

}  // namespace ffd
