// ffdsim piles' runner (bench/pile_table.h): pairs counted while surfaces cross, and how long
// a crossing lasts, on scenes whose answers are known because nothing collides.
#include "bench/pile_table.h"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include "ffd/surface_intersections.h"
#include "support/test_scenes.h"

using namespace ffd;

namespace {

void no_progress(const std::string&, std::uint64_t, std::uint64_t) {}

// Two 2 cm boxes, the second 1 cm higher and 5 mm further along z than the first, so neither
// can hold the other whole and no faces lie in one plane (coplanar faces would make the count
// hang on rounding); no gravity and no collision, so they keep the velocities they start with.
Model two_boxes(const Vec3& moving_start, const Vec3& moving_velocity) {
  SceneSpec spec;
  spec.settings.effects = 0;
  spec.objects.push_back(test::box_object("still", Vec3(0.02, 0.02, 0.02), 0.01, Vec3(0.0, 0.0, 0.0)));
  ObjectSpec moving = test::box_object("moving", Vec3(0.02, 0.02, 0.02), 0.01, moving_start);
  moving.velocity = moving_velocity;
  spec.objects.push_back(moving);
  return test::compile_quietly(spec);
}

}  // namespace

TEST_CASE("Pile runner: a box passing through another crosses it for as long as their faces overlap") {
  // From x = -5 cm at 1 m/s: the faces cross while the centres are less than 2 cm apart
  // along x, from t = 30 ms to t = 70 ms.
  const Model model = two_boxes(Vec3(-0.05, 0.01, 0.005), Vec3(1.0, 0.0, 0.0));
  const ffdbench::PileRun run =
      ffdbench::run_pile(model, 1, Accuracy::CentreOfMass, ContactResponse::Paper, 100, 1, no_progress);
  REQUIRE(run.pairs.size() == 100);
  CHECK(run.longest_crossing_ms == Approx(40.0).margin(2.0));
  CHECK(run.longest_between == "still / moving");
  CHECK(run.pairs[19] == 0);   // 20 ms: 3 cm apart
  CHECK(run.pairs[49] > 0);    // 50 ms: 1 cm apart
  CHECK(run.pairs[89] == 0);   // 90 ms: past
  CHECK(run.last_second_max == run.pairs_max);  // a run this short is all last second
  CHECK_FALSE(run.at_rest);                     // still moving at 1 m/s
  CHECK_FALSE(run.clean());
}

TEST_CASE("Pile runner: surfaces held crossed stay crossed to the end, apart and still they are clean") {
  SECTION("crossed") {
    // Off the faces' 1 cm squares, so that no edge lies in a face of the other box.
    const Model model = two_boxes(Vec3(0.013, 0.007, 0.005), Vec3::Zero());
    const SurfaceIntersections crossings(model);
    const std::size_t expected = crossings.count(initial_state(model)).between;
    REQUIRE(expected > 0);
    const ffdbench::PileRun run =
        ffdbench::run_pile(model, 1, Accuracy::Exact, ContactResponse::Solver, 50, 10, no_progress);
    REQUIRE(run.pairs.size() == 5);
    for (const std::size_t pairs : run.pairs) CHECK(pairs == expected);
    CHECK(run.longest_crossing_ms == Approx(50.0));
    CHECK(run.at_rest);
    CHECK_FALSE(run.clean());
  }
  SECTION("apart") {
    const Model model = two_boxes(Vec3(0.05, 0.0, 0.0), Vec3::Zero());
    const ffdbench::PileRun run =
        ffdbench::run_pile(model, 1, Accuracy::CentreOfMass, ContactResponse::Paper, 50, 10, no_progress);
    CHECK(run.pairs_max == 0);
    CHECK(run.longest_crossing_ms == 0.0);
    CHECK(run.longest_between.empty());
    CHECK(run.clean());
    const nlohmann::json json = ffdbench::to_json({run});
    CHECK(json[0]["clean"] == true);
    CHECK(json[0]["pairs"].size() == 5);
    CHECK(ffdbench::markdown_piles({run}, "test CPU", 2).find("| paper | 2 ") != std::string::npos);
    CHECK(json[0]["box_overlap"] == false);
    ffdbench::PileRun overlapping = run;  // a scene with box_overlap gets rows of its own
    overlapping.box_overlap = true;
    const std::string both = ffdbench::markdown_piles({run, overlapping}, "test CPU", 2);
    CHECK(both.find("| paper | 2 ") != std::string::npos);
    CHECK(both.find("| paper + box_overlap | 2 ") != std::string::npos);
    CHECK(ffdbench::markdown_unclean_piles({run}).empty());
    ffdbench::PileRun crossed = run;
    crossed.last_second_max = 3;
    CHECK(ffdbench::markdown_unclean_piles({run, crossed}).find("3 pairs in the last second") != std::string::npos);
  }
}
