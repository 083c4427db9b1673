// Eq. 1-2 and the FFD AABB of section 4 on the shipped teapot and on random deformations.
#include <catch2/catch.hpp>
#include <random>

#include "collision.h"
#include "ffd/box_test.h"
#include "ffd/measure.h"
#include "ffd/mesh_import.h"
#include "ffd/step.h"
#include "ffd/trilinear.h"
#include "support/test_scenes.h"

using namespace ffd;

namespace {

SceneSpec teapot_scene(bool fill_interior) {
  SceneSpec spec;
  ObjectSpec o = test::box_object("teapot", Vec3::Ones(), 0.016, Vec3::Zero());
  o.mesh = import_mesh(std::string(FFDSIM_SCENARIO_DIR) + "/meshes/teapot.obj");
  for (Vec3& v : o.mesh.vertices) v *= 0.05;
  o.fill_interior = fill_interior;
  spec.objects.push_back(o);
  return spec;
}

}  // namespace

TEST_CASE("trilinear weights are a partition of unity and interpolate the corners", "[trilinear]") {
  for (int j = 0; j < 8; ++j) {
    const Vec3 corner(j & 1, (j >> 1) & 1, (j >> 2) & 1);
    const auto w = trilinear_weights(corner);
    for (int k = 0; k < 8; ++k) CHECK(w[k] == (k == j ? 1.0 : 0.0));
  }
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int i = 0; i < 100; ++i) {
    const auto w = trilinear_weights(Vec3(u(rng), u(rng), u(rng)));
    double sum = 0.0;
    for (double x : w) sum += x;
    CHECK(sum == Approx(1.0).margin(1e-15));
  }
}

TEST_CASE("eq. 2 at rest reproduces every teapot vertex", "[trilinear]") {
  const Model model = test::compile_quietly(teapot_scene(false));
  State state = initial_state(model);
  const ObjectModel& o = model.objects[0];
  const SurfaceMesh moved = deformed_surface(model, state, 0);
  REQUIRE(moved.vertices.size() == o.surface.vertices.size());
  double worst = 0.0;
  for (std::size_t v = 0; v < moved.vertices.size(); ++v) {
    worst = std::max(worst, (moved.vertices[v] - o.surface.vertices[v]).cwiseAbs().maxCoeff());
    // Every vertex is bound to a cell whose box holds it: local coordinates within [0, 1].
    CHECK(o.vertex_local[v].minCoeff() >= 0.0);
    CHECK(o.vertex_local[v].maxCoeff() <= 1.0);
  }
  // "Exactly" up to the rounding of (p - c0) / h and back: a few ulps of 0.3 m.
  CHECK(worst <= 1e-15);
}

TEST_CASE("every embedded vertex stays inside its FFD AABB under random affine deformations", "[trilinear][ffd_aabb]") {
  const Model model = test::compile_quietly(teapot_scene(false));
  const ObjectModel& o = model.objects[0];
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Scratch scratch = make_scratch(model);
  for (int trial = 0; trial < 20; ++trial) {
    // A random affine map with a positive determinant (no reflection): rotation, shear, scale.
    Mat3 M = Mat3::Identity() + 0.6 * Mat3::NullaryExpr([&] { return u(rng); });
    if (M.determinant() < 0.2) continue;
    const Vec3 t(u(rng), u(rng), u(rng));
    State state = initial_state(model);
    for (std::size_t n = 0; n < model.node_count(); ++n) state.x[n] = M * model.node_rest[n] + t;
    update_all_boxes(model, state, scratch);
    const SurfaceMesh moved = deformed_surface(model, state, 0);
    double worst_excess = -INFINITY;
    for (std::size_t v = 0; v < moved.vertices.size(); ++v) {
      const Index cell = o.vertex_cell[v];
      REQUIRE(model.boxes.cell_box_begin[cell + 1] == model.boxes.cell_box_begin[cell] + 1);  // a surface cell has one box
      const Index box = model.boxes.cell_box_begin[cell];
      const BoxPlanes planes = box_planes(scratch.box_nodes()[box]);
      REQUIRE_FALSE(planes.degenerate);
      for (int f = 0; f < 6; ++f)
        worst_excess = std::max(worst_excess, planes.normal[f].dot(moved.vertices[v]) - planes.offset[f]);
    }
    // Vertices on a box face sit on its plane: allow rounding of a 0.3 m object only.
    CHECK(worst_excess <= 1e-12);
  }
}

TEST_CASE("the teapot lattice matches the paper's resolution and interior fill adds cells", "[lattice]") {
  const Model shell = test::compile_quietly(teapot_scene(false));
  // The paper's teapot has 602 cells; 0.016 m cells on a 0.32 m teapot come close.
  CHECK(shell.box_count() > 450);
  CHECK(shell.box_count() < 800);
  CHECK(shell.cell_count() == shell.box_count());  // no interior fill: every cell holds surface
  const Model solid = test::compile_quietly(teapot_scene(true));
  CHECK(solid.box_count() == shell.box_count());  // fill adds cells without surface only
  CHECK(solid.cell_count() >= shell.cell_count());
  // A closed box fills completely.
  SceneSpec box_spec;
  box_spec.objects.push_back(test::box_object("box", Vec3(0.1, 0.1, 0.1), 0.02, Vec3::Zero()));
  box_spec.objects[0].fill_interior = true;
  const Model box = test::compile_quietly(box_spec);
  CHECK(box.cell_count() > box.box_count());
  CHECK(box.cell_count() == 6 * 6 * 6);  // floor(0.1/0.02)+1 = 6 cells per axis, all kept
}
