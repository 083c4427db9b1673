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
