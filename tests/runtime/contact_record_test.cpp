// Tests for contact_record.h: the points a contact's sides are carried by.
#include <catch2/catch.hpp>

#include "contact_record.h"
#include "ffd/model.h"
#include "support/test_scenes.h"

using namespace ffd;

namespace {

Vec3 carried(const State& state, const ContactSide& side) {
  Vec3 p = Vec3::Zero();
  for (int j = 0; j < side.count; ++j) p += side.weight[j] * state.x[side.node[j]];
  return p;
}

}  // namespace

TEST_CASE("Contact record: a point of a surface is carried by the cell that holds it at rest", "[contact_record]") {
  // A box's faces are two triangles each, across 4 x 4 cells: their edges and insides lie
  // cells away from their corners' cells. At rest the lattice maps every point of the
  // surface to itself (eq. 2 is affine on an undeformed lattice), so a carried point read
  // from the state is the point itself.
  SceneSpec spec;
  spec.objects.push_back(test::box_object("box", Vec3(0.1, 0.1, 0.1), 0.025, Vec3::Zero()));
  spec.objects.back().mesh = make_box_mesh(Vec3(0.1, 0.1, 0.1));  // undivided
  const Model model = test::compile_quietly(spec);
  const State state = initial_state(model);
  const std::vector<Vec3>& rest = model.surface_vertex_rest;
  REQUIRE(model.surface_triangles.size() == 12);
  for (Index v = 0; v < rest.size(); ++v) {
    ContactSide side;
    REQUIRE(surface_point(model, v, rest[v], side));
    CHECK(side.cell == model.surface_vertex_cell[v]);  // a vertex: the cell it is bound to
    CHECK((carried(state, side) - rest[v]).norm() < 1e-12);
  }
  int cells_away = 0;  // points carried by a cell none of their triangle's corners is bound to
  for (const std::array<Index, 3>& tri : model.surface_triangles)
    for (const Vec3& w : {Vec3(Vec3::Constant(1.0 / 3.0)), Vec3(0.5, 0.5, 0.0), Vec3(0.1, 0.2, 0.7), Vec3(0.0, 0.37, 0.63)}) {
      const Vec3 point = w[0] * rest[tri[0]] + w[1] * rest[tri[1]] + w[2] * rest[tri[2]];
      for (const Index near : tri) {
        ContactSide side;
        INFO("corner " << near << ", barycentric " << w.transpose());
        REQUIRE(surface_point(model, near, point, side));
        CHECK((carried(state, side) - point).norm() < 1e-12);
        CHECK(model.cell_object[side.cell] == 0);
        cells_away += side.cell != model.surface_vertex_cell[tri[0]] && side.cell != model.surface_vertex_cell[tri[1]] &&
                      side.cell != model.surface_vertex_cell[tri[2]];
      }
    }
  CHECK(cells_away > 0);
  // Outside the lattice: no cell holds it.
  ContactSide side;
  CHECK_FALSE(surface_point(model, 0, Vec3(1.0, 1.0, 1.0), side));
  CHECK_FALSE(surface_point(model, 0, Vec3(1e300, 0.0, 0.0), side));
}
