// ffdsim accuracy's floating-gap measure: which objects count as at rest, and what their gap
// is taken against.
#include "bench/accuracy_table.h"

#include <catch2/catch.hpp>

#include "ffd/measure.h"
#include "support/test_scenes.h"

using namespace ffd;

namespace {

// A box 2 mm above the floor, nothing moving.
struct BoxOverFloor {
  Model model;
  State state;
  BoxOverFloor() {
    SceneSpec spec;
    spec.settings.effects = static_cast<EffectSet>(Effect::Planes);
    spec.planes.push_back(test::floor_plane());
    spec.objects.push_back(test::box_object("box", Vec3(0.04, 0.04, 0.04), 0.02, Vec3(0.0, 0.022, 0.0)));
    model = test::compile_quietly(spec);
    state = initial_state(model);
  }
};

}  // namespace

TEST_CASE("Accuracy gap: a resting object's gap is its distance to what it rests on") {
  BoxOverFloor scene;
  const SurfaceContactReport contacts = measure_surface_contacts(scene.model, scene.state);
  CHECK(ffdbench::resting_gap(scene.model, scene.state, contacts) == Approx(0.002).margin(1e-9));
}

TEST_CASE("Accuracy gap: one jittering node leaves an object at rest, a moving object is not") {
  BoxOverFloor scene;
  const ObjectModel& box = scene.model.objects[0];
  const SurfaceContactReport contacts = measure_surface_contacts(scene.model, scene.state);
  // One node of the lattice at 9 cm/s, the rest still: the object as a whole is at rest.
  scene.state.v[box.node_begin] = Vec3(0.0, 0.09, 0.0);
  CHECK(ffdbench::resting_gap(scene.model, scene.state, contacts) == Approx(0.002).margin(1e-9));
  // Every node at 6 cm/s: it is moving (sliding, falling), its gap says nothing of floating.
  for (Index n = box.node_begin; n < box.node_end; ++n) scene.state.v[n] = Vec3(0.06, 0.0, 0.0);
  CHECK(ffdbench::resting_gap(scene.model, scene.state, contacts) == -1.0);
}
