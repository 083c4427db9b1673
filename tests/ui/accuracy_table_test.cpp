// ffdsim accuracy's floating-gap measure: which objects count as at rest, and what their gap
// is taken against.
#include "bench/accuracy_table.h"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include "ffd/measure.h"
#include "ffd/scene_loader.h"
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

TEST_CASE("Accuracy table: levels 2, 3 and 5 of a scene get their comparison lines") {
  auto run = [](Accuracy level, double collision_ms, double gap_mm, double penetration_mm) {
    ffdbench::AccuracyRun r;
    r.scene = "bunnies";
    r.level = level;
    r.rest_samples = 1;
    r.collision_p50_ms = collision_ms;
    r.gap_max_mm = gap_mm;
    r.penetration_max_mm = penetration_mm;
    return r;
  };
  const std::vector<ffdbench::AccuracyRun> runs = {run(Accuracy::CentreOfMass, 2.0, 3.79, 0.0),
                                                   run(Accuracy::SampleNodes, 2.1, 0.0, 0.55),
                                                   run(Accuracy::Exact, 8.0, 0.0, 0.0)};
  const std::string table = ffdbench::markdown_accuracy(runs, "test CPU", 3000);
  CHECK_THAT(table, Catch::Contains("Level 2 (the paper's) against level 5 (exact): 4.0x cheaper per step; gap max "
                                    "3.79 mm vs 0.00 mm; penetration max 0.00 mm vs 0.00 mm."));
  CHECK_THAT(table, Catch::Contains("Level 3 (surface nodes) against level 2: 1.05x the collision time; gap max "
                                    "0.00 mm vs 3.79 mm; penetration max 0.55 mm vs 0.00 mm."));
  // Without a level 3 run, no level 3 line.
  const std::string without = ffdbench::markdown_accuracy({runs[0], runs[2]}, "test CPU", 3000);
  CHECK_THAT(without, !Catch::Contains("Level 3 (surface nodes)"));
}

TEST_CASE("Accuracy table: each response gets its rows and its own comparison lines") {
  auto run = [](Accuracy level, ContactResponse response, double collision_ms) {
    ffdbench::AccuracyRun r;
    r.scene = "teapots";
    r.level = level;
    r.response = response;
    r.rest_samples = 1;
    r.collision_p50_ms = collision_ms;
    return r;
  };
  ffdbench::AccuracyRun crossed = run(Accuracy::CentreOfMass, ContactResponse::Paper, 0.3);
  crossed.intersections_mean = 61.4;
  crossed.intersections_max = 80;
  crossed.intersecting_share = 0.5;
  const std::vector<ffdbench::AccuracyRun> runs = {crossed,
                                                   run(Accuracy::Exact, ContactResponse::Paper, 0.9),
                                                   run(Accuracy::CentreOfMass, ContactResponse::Solver, 0.2),
                                                   run(Accuracy::Exact, ContactResponse::Solver, 1.0)};
  const std::string table = ffdbench::markdown_accuracy(runs, "test CPU", 3000);
  CHECK_THAT(table, Catch::Contains("| level | response | collision ms p50 |"));
  CHECK_THAT(table, Catch::Contains("| 2 FFD AABB + centre of mass | paper | 0.300 |"));
  CHECK_THAT(table, Catch::Contains("| 2 FFD AABB + centre of mass | solver | 0.200 |"));
  CHECK_THAT(table, Catch::Contains("Level 2 (the paper's) against level 5 (exact): 3.0x cheaper per step"));
  CHECK_THAT(table, Catch::Contains("Level 2 (the paper's) against level 5 (exact) (response solver): 5.0x cheaper per step"));
  const nlohmann::json json = ffdbench::to_json(runs);
  CHECK(json[2]["response"] == "solver");
  // The intersection columns: mean, max and the share of samples with any.
  CHECK_THAT(table, Catch::Contains("intersecting pairs mean | max | samples with any |"));
  CHECK_THAT(table, Catch::Contains("| 61 | 80 | 50 % |"));
  CHECK_THAT(table, Catch::Contains("| 0 | 0 | 0 % |"));
  CHECK(json[0]["intersections_max"] == 80);
  CHECK(json[0]["intersecting_share"] == 0.5);
}

TEST_CASE("Accuracy run: the teapots at level 2 under the paper's response cross each other's surfaces",
          "[bench][intersections]") {
  const ffd::Model model = ffd::test::compile_quietly(
      ffd::load_scene_file(std::string(FFDSIM_SCENARIO_DIR) + "/scenes/two_teapots.toml"));
  const ffdbench::AccuracyRun r = ffdbench::run_accuracy(model, "teapots", Accuracy::CentreOfMass, 1500, 250,
                                                         [](const std::string&, std::uint64_t, std::uint64_t) {});
  // Samples at 1000, 1250 and 1500 ms: the upper teapot rests on the lower one, and the surfaces
  // cross there (the vertex measure sees 1.4 mm of it).
  CHECK(r.samples == 3);
  CHECK(r.intersections_max > 0);
  CHECK(r.intersecting_share == 1.0);
}
