// Section 7: eq. 8 (velocity) and eq. 9 (position) kernels, and one contact between two
// boxes resolved by the narrow-phase stage.
#include <catch2/catch.hpp>
#include <random>

#include "collision.h"
#include "ffd/box_test.h"
#include "ffd/response.h"
#include "ffd/step.h"
#include "support/test_scenes.h"

using namespace ffd;

TEST_CASE("eq. 8 with alpha = beta = 0 leaves the velocity as it is", "[response]") {
  std::mt19937_64 rng(2);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  for (int i = 0; i < 100; ++i) {
    const Vec3 V(u(rng), u(rng), u(rng)), ref(u(rng), u(rng), u(rng));
    const Vec3 n = Vec3(u(rng), u(rng), u(rng)).normalized();
    CHECK((respond_velocity(V, ref, n, 0.0, 0.0) - V).norm() < 1e-14);
  }
}

TEST_CASE("eq. 8 with alpha = 1 removes the normal component, beta the tangential one", "[response]") {
  const Vec3 n = Vec3(1, 2, 2).normalized();
  const Vec3 V = -2.0 * n + Vec3(2, -1, 0).normalized() * 0.7;  // approaching + sliding
  const Vec3 after = respond_velocity(V, Vec3::Zero(), n, 1.0, 0.0);
  CHECK(after.dot(n) == Approx(0.0).margin(1e-15));
  CHECK((after - (V - V.dot(n) * n)).norm() < 1e-15);  // tangential part kept
  const Vec3 stopped = respond_velocity(V, Vec3::Zero(), n, 1.0, 1.0);
  CHECK(stopped.norm() < 1e-15);
  const Vec3 half = respond_velocity(V, Vec3::Zero(), n, 0.5, 0.0);
  CHECK(half.dot(n) == Approx(0.5 * V.dot(n)));
  // Relative to a moving reference: alpha = 1 leaves no relative normal velocity.
  const Vec3 ref(0.3, -0.4, 0.1);
  CHECK((respond_velocity(V, ref, n, 1.0, 0.3) - ref).dot(n) == Approx(0.0).margin(1e-15));
}

TEST_CASE("a fresh contact rebounds with restitution 1 - alpha, a lodged one does not", "[response]") {
  const double recent = 0.002;  // s
  const double u = -1.5;        // m/s, approaching
  // Depth 1 mm: this approach made it within the last 0.7 ms.
  CHECK(rebound(u, 0.001, 1.0, recent) == 0.0);         // alpha = 1: eq. 8 stopped it, no more
  CHECK(rebound(u, 0.001, 0.0, recent) == Approx(3.0));  // elastic: -1.5 m/s becomes +1.5 m/s
  CHECK(rebound(u, 0.001, 0.8, recent) == Approx(0.6));  // 0.2 x (1.5 + 1.5)
  // After eq. 8 (1 - alpha) u is left; adding the rebound leaves -(1 - alpha) u.
  for (double alpha : {0.0, 0.3, 0.8, 1.0})
    CHECK((1.0 - alpha) * u + rebound(u, 0.001, alpha, recent) == Approx(-(1.0 - alpha) * u).margin(1e-15));
  // 5 mm deep at 1.5 m/s: in for over 3 ms, the normal says nothing reliable: no rebound.
  CHECK(rebound(u, 0.005, 0.0, recent) == 0.0);
  // Separating or at rest: nothing to reverse.
  CHECK(rebound(0.5, 0.001, 0.0, recent) == 0.0);
  CHECK(rebound(0.0, 0.0, 0.0, recent) == 0.0);
}

TEST_CASE("eq. 9 splits the correction by inverse mass", "[response]") {
  const PositionShares equal = position_shares(2.0, 2.0);
  CHECK(equal.a == 0.5);
  CHECK(equal.b == 0.5);
  const PositionShares on_plane = position_shares(0.0, 3.0);
  CHECK(on_plane.a == 0.0);
  CHECK(on_plane.b == 1.0);
  const PositionShares none = position_shares(0.0, 0.0);
  CHECK(none.a == 0.0);
  CHECK(none.b == 0.0);
}

TEST_CASE("one step of the narrow phase separates two overlapping boxes", "[response][narrow_phase]") {
  SceneSpec spec;
  spec.settings.effects = Effect::InterCollision | Effect::Friction;
  spec.settings.alpha = 1.0;
  // Two one-cell boxes, the second sunk 3 mm into the first from above and shifted sideways
  // (corners exactly on a face of the other box are not inside), approaching.
  spec.objects.push_back(test::box_object("low", Vec3(0.04, 0.04, 0.04), 0.05, Vec3::Zero()));
  spec.objects.push_back(test::box_object("high", Vec3(0.04, 0.04, 0.04), 0.05, Vec3(0.005, 0.037, 0.004)));
  spec.objects[1].velocity = Vec3(0, -0.5, 0);
  const Model model = test::compile_quietly(spec);
  State state = initial_state(model);
  Scratch scratch = make_scratch(model);
  StepReport report;
  step(model, state, scratch, report);
  const StageCounters& c = report.counters[static_cast<std::size_t>(Stage::NarrowPhase)];
  CHECK(c.inter_pairs_tested >= 1);
  CHECK(c.inter_contacts >= 1);
  CHECK(report.max_box_penetration_m > 0.002);
  // After the step no node of one object is inside a box of the other.
  update_all_boxes(model, state, scratch);
  int inside = 0;
  for (Index a = model.objects[0].box_begin; a < model.objects[0].box_end; ++a)
    for (Index b = model.objects[1].box_begin; b < model.objects[1].box_end; ++b) {
      const BoxPlanes pa = box_planes(scratch.box_nodes()[a]), pb = box_planes(scratch.box_nodes()[b]);
      for (const Vec3& p : scratch.box_nodes()[b]) inside += node_in_box(pa, p).inside;
      for (const Vec3& p : scratch.box_nodes()[a]) inside += node_in_box(pb, p).inside;
    }
  CHECK(inside == 0);
  // alpha = 1: the approach is stopped (the upper box no longer moves down into the lower).
  Vec3 v_low = Vec3::Zero(), v_high = Vec3::Zero();
  for (Index n = model.objects[0].node_begin; n < model.objects[0].node_end; ++n) v_low += state.v[n];
  for (Index n = model.objects[1].node_begin; n < model.objects[1].node_end; ++n) v_high += state.v[n];
  v_low /= model.objects[0].node_end - model.objects[0].node_begin;
  v_high /= model.objects[1].node_end - model.objects[1].node_begin;
  CHECK((v_high - v_low).y() > -0.05);
}
