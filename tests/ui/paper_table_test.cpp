// ffdsim bench's Table 1 (ui/bench/paper_table.h): a row per scenario and contact response,
// the response in the JSON, and the per-element costs for the paper's response only (under
// the solver the springs are solved inside the contact solve).
#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include "bench/paper_table.h"

namespace {

ffdbench::ScenarioResult row(ffd::ContactResponse response, double step_p99_ms) {
  ffdbench::ScenarioResult r;
  r.scenario = ffdbench::paper_scenarios().front();  // teapots
  r.response = response;
  r.warmup_steps = 500;
  r.measured_steps = 2500;
  r.single.step_p99_ms = 2.0 * step_p99_ms;
  r.parallel.threads = 2;
  r.parallel.step_p99_ms = step_p99_ms;
  r.springs = 22960;
  return r;
}

std::size_t count(const std::string& text, const std::string& part) {
  std::size_t n = 0;
  for (std::size_t at = text.find(part); at != std::string::npos; at = text.find(part, at + 1)) ++n;
  return n;
}

}  // namespace

TEST_CASE("bench table: a row per response, the steps listed once, per-element costs for the paper's rows", "[bench]") {
  const std::vector<ffdbench::ScenarioResult> results = {row(ffd::ContactResponse::Paper, 0.78),
                                                         row(ffd::ContactResponse::Solver, 0.82)};
  const std::string table = ffdbench::markdown_table(results, "test CPU (2 cores)", false);
  INFO(table);
  CHECK_THAT(table, Catch::Contains("| scenario | response |"));
  CHECK_THAT(table, Catch::Contains("| teapots | paper |"));
  CHECK_THAT(table, Catch::Contains("| teapots | solver |"));
  CHECK_THAT(table, Catch::Contains("0.82 ✗"));                 // the solver's whole step, against its target
  CHECK(count(table, "teapots 500 + 2,500") == 1);              // the windows, once per scenario
  CHECK(count(table, "| teapots | 22,960 |") == 1);             // per element: the paper's row only
  const nlohmann::json json = ffdbench::to_json(results);
  REQUIRE(json.size() == 2);
  CHECK(json[0].at("response") == "paper");
  CHECK(json[1].at("response") == "solver");
}

TEST_CASE("bench --compare: a scene more than 25 % slower than the reference fails, naming it and its stage", "[bench]") {
  ffdbench::ScenarioResult before = row(ffd::ContactResponse::Paper, 0.78);
  before.parallel.step_p50_ms = 0.40;
  before.parallel.step_mean_ms = 0.42;
  before.parallel.collision_mean_ms = 0.20;
  before.parallel.box_update_mean_ms = 0.05;
  before.parallel.dynamics_mean_ms = 0.15;
  const nlohmann::json reference = {{"machine", {{"cpu", "test CPU"}}}, {"scenarios", ffdbench::to_json({before})}};

  ffdbench::ScenarioResult after = before;
  after.parallel.step_p50_ms = 0.48;  // 20 % slower: within
  ffdbench::Comparison c = ffdbench::compare_to_reference({after}, reference, "test CPU", "ref.json");
  CHECK(c.compared);
  CHECK(c.failures.empty());
  REQUIRE(c.lines.size() == 1);
  CHECK_THAT(c.lines[0], Catch::Contains("teapots (paper)") && Catch::Contains(": ok"));

  after.parallel.step_p50_ms = 0.52;  // 30 % slower, the dynamics 0.1 ms of it
  after.parallel.dynamics_mean_ms = 0.25;
  after.parallel.step_mean_ms = 0.52;
  c = ffdbench::compare_to_reference({after}, reference, "test CPU", "ref.json");
  REQUIRE(c.failures.size() == 1);
  CHECK_THAT(c.failures[0], Catch::Contains("teapots (paper)") && Catch::Contains("SLOWER by 30 %") &&
                                Catch::Contains("dynamics, +0.100 ms"));

  // A quick run after the same warm-up: held against the reference's first steps.
  ffdbench::ScenarioResult quick = after;
  quick.measured_steps = 400;
  quick.parallel.step_p50_ms = 0.39;  // 30 % above the first steps' 0.30 ms, under the whole run's
  nlohmann::json with_head = reference;
  nlohmann::json& head = with_head["scenarios"][0]["threads"][1]["head"];
  head["steps"] = 400;
  head["step_p50_ms"] = 0.30;  // the first steps' own figures: against them the collision stages
                               // grew most (0.10 ms; dynamics 0.05, the rest 0.07)
  head["step_mean_ms"] = 0.30, head["collision_mean_ms"] = 0.10, head["box_update_mean_ms"] = 0.05;
  head["dynamics_mean_ms"] = 0.20;
  c = ffdbench::compare_to_reference({quick}, with_head, "test CPU", "ref.json");
  REQUIRE(c.failures.size() == 1);
  CHECK_THAT(c.failures[0], Catch::Contains("0.390 ms on 2 threads, reference 0.300 ms: SLOWER by 30 %") &&
                                Catch::Contains("the stage that grew the most: broad and narrow phase, planes, +0.100 ms"));
  quick.measured_steps = 300;  // not the reference's first steps: not compared
  c = ffdbench::compare_to_reference({quick}, with_head, "test CPU", "ref.json");
  CHECK(c.failures.empty());
  REQUIRE(c.lines.size() == 1);
  CHECK_THAT(c.lines[0], Catch::Contains("measured over other steps than ref.json's, not compared"));

  // Another CPU model: nothing compared, nothing failed.
  c = ffdbench::compare_to_reference({after}, reference, "other CPU", "ref.json");
  CHECK_FALSE(c.compared);
  CHECK(c.reference_cpu == "test CPU");
  CHECK(c.failures.empty());

  // Not a bench.json, or one without the p50: an error naming the file and the field.
  CHECK_THROWS_WITH(ffdbench::compare_to_reference({after}, nlohmann::json::array(), "test CPU", "ref.json"),
                    Catch::Contains("ref.json: not a bench.json"));
  nlohmann::json old = reference;
  old["scenarios"][0]["threads"][1].erase("step_p50_ms");
  CHECK_THROWS_WITH(ffdbench::compare_to_reference({after}, old, "test CPU", "ref.json"),
                    Catch::Contains("ref.json: scenarios[0].threads[1].step_p50_ms"));
}
