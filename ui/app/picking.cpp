#include "app/picking.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

#include "ffd/trilinear.h"

namespace ffd::ui {

Vec3 inverse_trilinear(const std::array<Vec3, 8>& p, const Vec3& point) {
  Vec3 stu(0.5, 0.5, 0.5);
  for (int iteration = 0; iteration < 8; ++iteration) {
    const double s = stu.x(), t = stu.y(), u = stu.z();
    const Vec3 x = trilinear_map(stu, [&](int j) -> const Vec3& { return p[static_cast<std::size_t>(j)]; });
    Mat3 jacobian;
    jacobian.col(0) = (1 - t) * (1 - u) * (p[1] - p[0]) + t * (1 - u) * (p[3] - p[2]) + (1 - t) * u * (p[5] - p[4]) + t * u * (p[7] - p[6]);
    jacobian.col(1) = (1 - s) * (1 - u) * (p[2] - p[0]) + s * (1 - u) * (p[3] - p[1]) + (1 - s) * u * (p[6] - p[4]) + s * u * (p[7] - p[5]);
    jacobian.col(2) = (1 - s) * (1 - t) * (p[4] - p[0]) + s * (1 - t) * (p[5] - p[1]) + (1 - s) * t * (p[6] - p[2]) + s * t * (p[7] - p[3]);
    const Eigen::FullPivLU<Mat3> lu(jacobian);
    if (!lu.isInvertible()) break;  // a crushed cell: keep the last estimate
    const Vec3 delta = lu.solve(x - point);
    stu -= delta;
    if (delta.squaredNorm() < 1e-20) break;
  }
  return stu;
}

CellPoint cell_at(const Model& model, const Frame& frame, const Vec3& point) {
  CellPoint best;
  double best_violation = 0.25;  // accept up to a quarter of a cell outside
  if (frame.nodes.size() < model.node_rest.size()) return best;
  for (Index b = 0; b < model.box_count() && b < frame.boxes.size(); ++b) {
    Vec3 lo = frame.boxes[b][0], hi = lo;
    for (const Vec3& q : frame.boxes[b]) {
      lo = lo.cwiseMin(q);
      hi = hi.cwiseMax(q);
    }
    const double margin = 0.25 * model.objects[model.cell_object[model.boxes.box_cell[b]]].cell_size;
    if (((point.array() < lo.array() - margin) || (point.array() > hi.array() + margin)).any()) continue;
    const Index cell = model.boxes.box_cell[b];
    std::array<Vec3, 8> corners;
    for (int j = 0; j < 8; ++j) corners[static_cast<std::size_t>(j)] = frame.nodes[model.cell_nodes[cell][static_cast<std::size_t>(j)]];
    const Vec3 stu = inverse_trilinear(corners, point);
    if (!stu.allFinite()) continue;
    const double violation = std::max({0.0, -stu.minCoeff(), stu.maxCoeff() - 1.0});
    if (violation < best_violation) {
      best_violation = violation;
      best.cell = cell;
      best.local = stu.cwiseMax(0.0).cwiseMin(1.0);
    }
  }
  return best;
}

Vec3 object_centre(const Model& model, const Frame& frame, Index object) {
  const ObjectModel& o = model.objects[object];
  Vec3 sum = Vec3::Zero();
  for (Index n = o.node_begin; n < o.node_end && n < frame.nodes.size(); ++n) sum += frame.nodes[n];
  return o.node_end > o.node_begin ? Vec3(sum / static_cast<double>(o.node_end - o.node_begin)) : sum;
}

}  // namespace ffd::ui
