#include "contact_record.h"

#include <algorithm>

#include "ffd/box_test.h"
#include "ffd/trilinear.h"

namespace ffd {

ContactSide carried_by(const Model& model, Index cell, const std::array<double, 8>& weight) {
  ContactSide side;
  side.node.fill(kNoIndex);
  side.weight.fill(0.0);
  side.count = 0;
  side.cell = cell;
  for (int j = 0; j < 8; ++j) {
    if (weight[j] == 0.0) continue;
    side.node[side.count] = model.cell_nodes[cell][j];
    side.weight[side.count] = weight[j];
    ++side.count;
  }
  return side;
}

ContactSide cell_point(const Model& model, Index cell, const Vec3& local) {
  return carried_by(model, cell, trilinear_weights(local));
}

ContactSide vertex_point(const Model& model, Index v) {
  return cell_point(model, model.surface_vertex_cell[v], model.surface_vertex_local[v]);
}

ContactSide face_point(const Model& model, const BoxSet& boxes, Index b, int face) {
  std::array<double, 8> weight{};
  for (int i = 0; i < 4; ++i) {
    const std::array<double, 8> w = trilinear_weights(boxes.box_local[b][kBoxFaces[face][i]]);
    for (int j = 0; j < 8; ++j) weight[j] += 0.25 * w[j];
  }
  return carried_by(model, boxes.box_cell[b], weight);
}

namespace {
// Cells are kept in lattice order, z slowest, x fastest (lattice.cpp): the object's cell at
// integer lattice coordinates `coord`, or kNoIndex.
Index kept_cell(const Model& model, const ObjectModel& object, const Vec3i& coord) {
  const auto lattice_order = [](const Vec3i& a, const Vec3i& b) {
    return a.z() != b.z() ? a.z() < b.z() : a.y() != b.y() ? a.y() < b.y() : a.x() < b.x();
  };
  const auto begin = model.cell_coord.begin() + object.cell_begin, end = model.cell_coord.begin() + object.cell_end;
  const auto it = std::lower_bound(begin, end, coord, lattice_order);
  return it != end && *it == coord ? static_cast<Index>(it - model.cell_coord.begin()) : kNoIndex;
}
}  // namespace

bool surface_point(const Model& model, Index near, const Vec3& rest, ContactSide& side) {
  const Index near_cell = model.surface_vertex_cell[near];
  const ObjectModel& object = model.objects[model.cell_object[near_cell]];
  // Local coordinates in near's cell (eq. 1: rest offsets divided by the cell size).
  const Vec3 local = model.surface_vertex_local[near] + (rest - model.surface_vertex_rest[near]) / object.cell_size;
  // A point on a cell's face may lie in either cell: near's where it can.
  constexpr double kOnFace = 1e-9;
  if ((local.array() >= -kOnFace).all() && (local.array() <= 1.0 + kOnFace).all()) {
    side = cell_point(model, near_cell, local.cwiseMax(0.0).cwiseMin(1.0));
    return true;
  }
  const Vec3 whole = local.array().floor();
  // Beyond the object's lattice (a nearly degenerate triangle's weights may put a point far
  // out): no cell, and no integer conversion of a value an int cannot hold.
  if (!((whole.array().abs() <= object.lattice_dims.cast<double>().array()).all())) return false;
  const Index cell = kept_cell(model, object, model.cell_coord[near_cell] + whole.cast<int>());
  if (cell == kNoIndex) return false;
  side = cell_point(model, cell, local - whole);
  return true;
}

bool triangle_point(const Model& model, Index triangle, const Vec3& barycentric, ContactSide& side) {
  const std::array<Index, 3>& tri = model.surface_triangles[triangle];
  const auto rest = [&](int k) -> const Vec3& { return model.surface_vertex_rest[tri[k]]; };
  return surface_point(model, tri[0], barycentric[0] * rest(0) + barycentric[1] * rest(1) + barycentric[2] * rest(2), side);
}

ContactSide probe_point() {
  ContactSide side;
  side.node.fill(kNoIndex);
  side.weight.fill(0.0);
  side.node[0] = kProbeNode;
  side.weight[0] = 1.0;
  side.count = 1;
  return side;
}

ContactSide static_side() {
  ContactSide side;
  side.node.fill(kNoIndex);
  side.weight.fill(0.0);
  side.count = 0;
  return side;
}

std::uint64_t contact_key(ContactKey kind, Accuracy accuracy, std::uint64_t a, std::uint64_t b) {
  if (kind == ContactKey::None || a >= (std::uint64_t{1} << 28) || b >= (std::uint64_t{1} << 30)) return 0;
  return (static_cast<std::uint64_t>(kind) << 61) | (static_cast<std::uint64_t>(accuracy) << 58) | (a << 30) | b;
}

}  // namespace ffd
