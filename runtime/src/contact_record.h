#pragma once
// One contact, as every detector of the response "solver" hands it over (node-in-box at
// levels 0-4, edge through triangle, planes, the probe), to be appended to its constraints (contact_solver.h); the
// paper's response answers the same detections at once (eq. 8-9, paper_response.h). Its two
// sides are points carried by lattice nodes through trilinear weights (eq. 2): side b's
// point is to stay on the outer side, along the normal, of side a's surface.
#include <array>
#include <cstdint>

#include "ffd/model.h"
#include "ffd/step.h"

namespace ffd {

// A node index that stands for the probe proxy.
inline constexpr Index kProbeNode = kNoIndex - 1;

// One side of a contact: the point a box node, a box face, a surface vertex, the probe or
// nothing (a static plane) is, as a weighted sum of up to 8 nodes of one cell.
struct ContactSide {
  std::array<Index, 8> node;
  std::array<double, 8> weight;
  std::array<double, 8> share{};  // 1/kg: weight / mass of each node in this step's solve (0: static)
  std::uint8_t count = 0;         // node[0 .. count) carry the point
  Index cell = kNoIndex;          // the lattice cell whose 8 nodes these are (none: the probe, a plane)
};

// The side carried by cell `cell`'s nodes with `weight`, those of weight 0 left out, in
// cell order: a box corner is one node, a face's mean four. The solver's passes read and
// move a side many times a step; a weight of 0 adds exactly 0, so the sums are the same bit
// for bit.
ContactSide carried_by(const Model& model, Index cell, const std::array<double, 8>& weight);
// A point carried by cell `cell` at local coordinates `local` (eq. 2).
ContactSide cell_point(const Model& model, Index cell, const Vec3& local);
// Surface vertex v, carried by the cell it is bound to.
ContactSide vertex_point(const Model& model, Index v);
// The mean of a box face's four corners: the point its plane moves with.
ContactSide face_point(const Model& model, const BoxSet& boxes, Index b, int face);
// The point of a surface whose rest position (its mesh's frame) is `rest`, carried by the
// lattice cell that holds it at rest, found from surface vertex `near` of the same object
// (eq. 1 and 2): a point on an edge or a triangle that vertex belongs to. False where no cell
// of the object's lattice holds it.
bool surface_point(const Model& model, Index near, const Vec3& rest, ContactSide& side);
// The point of surface triangle `triangle` at `barycentric` (its corners' weights), carried
// so (surface_point).
bool triangle_point(const Model& model, Index triangle, const Vec3& barycentric, ContactSide& side);
ContactSide probe_point();
ContactSide static_side();  // a plane: nothing moves

// How far outside a box face or above a plane (m) the solver still takes a contact: a
// speculative one, inactive unless the solve would move the point in, so that a resting
// contact stays in the list from step to step. The broad phase grows the boxes by as much.
inline constexpr double kSpeculativeDistance = 0.001;

// A contact's identity from step to step (the solver keeps a sticking contact's anchor by
// it): what touches what, the accuracy level whose boxes the ids name, and two ids; 0 (never
// anchored) where an id does not fit.
enum class ContactKey : std::uint64_t {
  None = 0,
  BoxNode = 1,         // a box's tested node against another box's face
  PlaneNode = 2,       // a box's tested node against a plane
  PlaneVertex = 3,     // a surface vertex against a plane (level 5)
  SurfaceEdge = 4,     // a surface edge through another object's triangle
  SurfaceVertex = 5,   // a surface vertex against a triangle of another cell (level 5)
};
std::uint64_t contact_key(ContactKey kind, Accuracy accuracy, std::uint64_t a, std::uint64_t b);

struct ContactRecord {
  ContactSide a, b;
  Vec3 normal = Vec3::Zero();  // unit, out of side a's surface
  double depth = 0.0;          // m: how far side b's point is to go along the normal (< 0: that far out already)
  std::uint64_t key = 0;       // from step to step (0: none)
  Index face_box = kNoIndex;   // side a's box and face, whose frame an anchor is kept in
  std::uint8_t face = 0;       // (kNoIndex: the world's)
};

}  // namespace ffd
