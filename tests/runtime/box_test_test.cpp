// Narrow phase of section 6.2: face planes (eq. 3), the conservative anchor (eq. 4-6) and
// node-in-box, on hand-made boxes: axis-aligned, sheared, twisted, flat and inverted.
#include <catch2/catch.hpp>
#include <random>

#include "ffd/box_test.h"
#include "support/fp_traps.h"

using namespace ffd;

namespace {

using BoxNodes = std::array<Vec3, 8>;

BoxNodes unit_box(const Vec3& lo = Vec3::Zero(), const Vec3& size = Vec3::Ones()) {
  BoxNodes b;
  for (int k = 0; k < 8; ++k) b[k] = lo + Vec3((k & 1) * size.x(), ((k >> 1) & 1) * size.y(), ((k >> 2) & 1) * size.z());
  return b;
}

}  // namespace

TEST_CASE("an axis-aligned box has its six faces as planes", "[narrow_phase]") {
  const BoxPlanes p = box_planes(unit_box());
  REQUIRE_FALSE(p.degenerate);
  const Vec3 expected[6] = {-Vec3::UnitX(), Vec3::UnitX(), -Vec3::UnitY(), Vec3::UnitY(), -Vec3::UnitZ(), Vec3::UnitZ()};
  const double offsets[6] = {0, 1, 0, 1, 0, 1};
  for (int f = 0; f < 6; ++f) {
    CHECK((p.normal[f] - expected[f]).norm() < 1e-15);
    CHECK(p.offset[f] == Approx(offsets[f]).margin(1e-15));
  }
}

TEST_CASE("node-in-box on an axis-aligned box", "[narrow_phase]") {
  const BoxPlanes p = box_planes(unit_box());
  const NodeInBox centre = node_in_box(p, Vec3(0.5, 0.5, 0.5));
  CHECK(centre.inside);
  CHECK(centre.depth == Approx(0.5));
  const NodeInBox near_top = node_in_box(p, Vec3(0.5, 0.9, 0.4));
  REQUIRE(near_top.inside);
  CHECK(near_top.face == 3);  // +y: least penetration (eq. 7)
  CHECK(near_top.depth == Approx(0.1));
  CHECK_FALSE(node_in_box(p, Vec3(1.1, 0.5, 0.5)).inside);
  CHECK_FALSE(node_in_box(p, Vec3(0.5, -0.01, 0.5)).inside);
  CHECK_FALSE(node_in_box(p, Vec3(1.0, 0.5, 0.5)).inside);  // on a face is not inside
}

TEST_CASE("node-in-box on a sheared box follows the shear", "[narrow_phase]") {
  BoxNodes b = unit_box();
  for (Vec3& n : b) n.x() += 0.8 * n.y();  // shear x by y
  const BoxPlanes p = box_planes(b);
  REQUIRE_FALSE(p.degenerate);
  CHECK(node_in_box(p, Vec3(1.2, 0.9, 0.5)).inside);         // outside the unsheared cube
  CHECK_FALSE(node_in_box(p, Vec3(0.1, 0.9, 0.5)).inside);   // inside the unsheared cube only
}

TEST_CASE("the conservative plane keeps all four face nodes inside for random deformed boxes", "[narrow_phase]") {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-0.35, 0.35);
  int checked = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    BoxNodes b = unit_box();
    // Random shear + independent jitter of each node: faces are no longer planar.
    Mat3 shear = Mat3::Identity();
    shear(0, 1) = 2 * u(rng);
    shear(1, 2) = 2 * u(rng);
    shear(2, 0) = 2 * u(rng);
    for (Vec3& n : b) n = shear * n + Vec3(u(rng), u(rng), u(rng));
    const BoxPlanes p = box_planes(b);
    if (p.degenerate) continue;
    ++checked;
    for (int f = 0; f < 6; ++f) {
      for (int c = 0; c < 4; ++c) {
        const Vec3& node = b[kBoxFaces[f][c]];
        // Eq. 4-6: every node of the face on or below its plane (rounding of unit-size boxes).
        CHECK(p.normal[f].dot(node) - p.offset[f] <= 1e-12);
      }
    }
  }
  CHECK(checked > 1900);
}

TEST_CASE("the anchor choice matters: the other diagonal would leave nodes outside", "[narrow_phase]") {
  // A twisted top face: nodes 2 and 7 raised, so the two diagonals sit at different heights.
  BoxNodes b = unit_box();
  b[2].y() += 0.2;
  b[7].y() += 0.2;
  const BoxPlanes p = box_planes(b);
  REQUIRE_FALSE(p.degenerate);
  // +y face is {2, 6, 7, 3}: diagonal 2-7 is the higher one, so the plane passes through it.
  CHECK(p.normal[3].dot(b[2]) - p.offset[3] == Approx(0.0).margin(1e-14));
  CHECK(p.normal[3].dot(b[6]) - p.offset[3] < -0.05);
  // A node just under the raised diagonal counts as inside.
  CHECK(node_in_box(p, 0.5 * (b[2] + b[7]) - Vec3(0, 0.01, 0)).inside);
}

TEST_CASE("flat and collapsed boxes are degenerate and contain nothing, without NaN", "[narrow_phase]") {
  BoxNodes flat = unit_box(Vec3::Zero(), Vec3(1, 0, 1));  // zero height
  const BoxPlanes pf = box_planes(flat);
  CHECK(pf.degenerate);
  CHECK_FALSE(node_in_box(pf, Vec3(0.5, 0.0, 0.5)).inside);
  for (int f = 0; f < 6; ++f) CHECK(pf.normal[f].allFinite());

  BoxNodes point;
  point.fill(Vec3(0.3, 0.3, 0.3));
  const BoxPlanes pp = box_planes(point);
  CHECK(pp.degenerate);
  CHECK_FALSE(node_in_box(pp, Vec3(0.3, 0.3, 0.3)).inside);
}

TEST_CASE("an inverted box contains no node", "[narrow_phase]") {
  BoxNodes b = unit_box();
  for (Vec3& n : b) n.x() = 1.0 - n.x();  // mirror: turned inside out
  const BoxPlanes p = box_planes(b);
  REQUIRE_FALSE(p.degenerate);
  CHECK_FALSE(node_in_box(p, Vec3(0.5, 0.5, 0.5)).inside);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 2.0);
  for (int i = 0; i < 1000; ++i) CHECK_FALSE(node_in_box(p, Vec3(u(rng), u(rng), u(rng))).inside);
}

TEST_CASE("node-in-box rejects NaN nodes", "[narrow_phase]") {
  const BoxPlanes p = box_planes(unit_box());
  test::FpTrapsOff no_traps;
  CHECK_FALSE(node_in_box(p, Vec3(std::nan(""), 0.5, 0.5)).inside);
  BoxNodes b = unit_box();
  b[7].x() = std::nan("");
  CHECK(box_planes(b).degenerate);
}

TEST_CASE("a node moving into a thin box takes the face it came through", "[narrow_phase]") {
  // A thin box 1 x 0.1 x 1 (a flat piece of shell); a node just entered through the bottom
  // face, 0.02 from it, but only 0.01 from the -x side face.
  const BoxPlanes p = box_planes(unit_box(Vec3::Zero(), Vec3(1.0, 0.1, 1.0)));
  const Vec3 node(0.01, 0.02, 0.5);
  const NodeInBox still = node_in_box(p, node);
  REQUIRE(still.inside);
  CHECK(still.face == 0);  // eq. 7 alone: the side face, which would push the node sideways
  const double dt = 0.001;
  const NodeInBox moving = node_in_box(p, node, Vec3(0.0, 25.0, 0.0), 2 * dt);  // up at 25 m/s
  REQUIRE(moving.inside);
  CHECK(moving.face == 2);  // -y: the face it entered through
  CHECK(moving.depth == Approx(0.02));
  // Slow approach: the entry is too old to say anything, eq. 7 decides.
  CHECK(node_in_box(p, node, Vec3(0.0, 0.5, 0.0), 2 * dt).face == 0);
  // At rest relative to the box: eq. 7.
  CHECK(node_in_box(p, node, Vec3::Zero(), 2 * dt).face == 0);
}

TEST_CASE("two thin boxes crossed like an X overlap with no corner in the other, and part along their thinnest way",
          "[narrow_phase]") {
  // Plate a: 1 x 0.1 x 1, lying flat; plate b: 0.1 x 1 x 1 standing, through a's edge region
  // (x in [0.05, 0.15]), reaching 0.45 above and below it.
  const BoxNodes a = unit_box(Vec3::Zero(), Vec3(1.0, 0.1, 1.0));
  const BoxNodes b = unit_box(Vec3(0.05, -0.45, 0.0), Vec3(0.1, 1.0, 1.0));
  const BoxPlanes pa = box_planes(a), pb = box_planes(b);
  for (const Vec3& corner : a) CHECK_FALSE(node_in_box(pb, corner).inside);
  for (const Vec3& corner : b) CHECK_FALSE(node_in_box(pa, corner).inside);
  const BoxOverlap o = box_overlap(pa, a.data(), 8, pb, b.data(), 8);
  REQUIRE(o.overlapping);
  // Least: b out past a's -x face, 0.15 (its other ways: 0.55 down, 0.95 right, 1 along z).
  CHECK(o.depth == Approx(0.15));
  CHECK((o.normal - (-Vec3::UnitX())).norm() < 1e-12);
  // b coming down into a at 1 m/s takes the way it came in: back up, its bottom from 0.45
  // below a's bottom face to a's top face, 0.55.
  const BoxOverlap falling = box_overlap(pa, a.data(), 8, pb, b.data(), 8, 0.0, Vec3(0.0, -1.0, 0.0), 1.0);
  REQUIRE(falling.overlapping);
  CHECK((falling.normal - Vec3::UnitY()).norm() < 1e-12);
  CHECK(falling.depth == Approx(0.55));
  // An entry longer ago than `recent` says nothing: the least depth again.
  CHECK(box_overlap(pa, a.data(), 8, pb, b.data(), 8, 0.0, Vec3(0.0, -1.0, 0.0), 0.1).depth == Approx(0.15));
}

TEST_CASE("box overlap: apart is apart, and a skin makes boxes close by overlap by the rest of it", "[narrow_phase]") {
  const BoxNodes a = unit_box();
  const BoxNodes b = unit_box(Vec3(0.0, 1.04, 0.0));  // 0.04 above a
  const BoxPlanes pa = box_planes(a), pb = box_planes(b);
  CHECK_FALSE(box_overlap(pa, a.data(), 8, pb, b.data(), 8).overlapping);
  CHECK_FALSE(box_overlap(pa, a.data(), 8, pb, b.data(), 8, 0.04).overlapping);  // exactly the skin apart
  const BoxOverlap o = box_overlap(pa, a.data(), 8, pb, b.data(), 8, 0.1);
  REQUIRE(o.overlapping);
  CHECK(o.depth == Approx(0.06));
  CHECK((o.normal - Vec3::UnitY()).norm() < 1e-12);
  // NaN nodes never overlap.
  test::FpTrapsOff no_traps;
  BoxNodes bad = b;
  bad[3].x() = std::nan("");
  CHECK_FALSE(box_overlap(pa, a.data(), 8, pb, bad.data(), 8, 0.1).overlapping);
}
