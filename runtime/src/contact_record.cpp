#include "contact_record.h"

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
