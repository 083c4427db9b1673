// Budget-aware accuracy: the governor's decisions from synthetic step times (so they are
// exact), and the physics loop turning them into recorded commands that replay bit for bit
// (physics_loop_test.cpp).
#include <catch2/catch.hpp>

#include <array>

#include "ffd/accuracy_governor.h"

using namespace ffd;

namespace {

constexpr std::int64_t kBudget = 1'000'000;  // ns

// Runs `steps` steps whose compute time is cost[level] x budget; returns the level of each
// step and counts the switches.
struct GovernedRun {
  std::vector<Accuracy> levels;
  int switches = 0;
  int tries_of_exact = 0;  // switches up to level 5
};

GovernedRun govern(Accuracy start, const std::array<double, kAccuracyLevels>& cost, int steps,
                   AccuracyGovernorSettings settings = {}) {
  AccuracyGovernor governor(settings);
  governor.start(start);
  GovernedRun run;
  Accuracy level = start;
  for (int i = 0; i < steps; ++i) {
    run.levels.push_back(level);
    const auto ns = static_cast<std::int64_t>(cost[static_cast<std::size_t>(level)] * static_cast<double>(kBudget));
    const Accuracy next = governor.observe(level, ns, kBudget);
    if (next != level) {
      ++run.switches;
      if (next == Accuracy::Exact) ++run.tries_of_exact;
      REQUIRE(std::abs(static_cast<int>(next) - static_cast<int>(level)) == 1);  // one level at a time
    }
    level = next;
  }
  return run;
}

}  // namespace

TEST_CASE("Accuracy governor: cheap steps climb one level per window up to exact") {
  const GovernedRun run = govern(Accuracy::CentreOfMass, {0.1, 0.1, 0.1, 0.1, 0.1, 0.1}, 2000);
  CHECK(run.levels[249] == Accuracy::CentreOfMass);
  CHECK(run.levels[250] == Accuracy::SampleNodes);
  CHECK(run.levels[500] == Accuracy::SubBoxes);
  CHECK(run.levels[750] == Accuracy::Exact);
  CHECK(run.levels.back() == Accuracy::Exact);
  CHECK(run.switches == 3);
}

TEST_CASE("Accuracy governor: it climbs only from a level with room to spare") {
  // Level 4 takes 60 % of the budget: it fits, but a level above it would not be tried.
  const GovernedRun run = govern(Accuracy::CentreOfMass, {0.1, 0.1, 0.2, 0.3, 0.6, 3.0}, 20000);
  CHECK(run.levels.back() == Accuracy::SubBoxes);
  CHECK(run.switches == 2);
  CHECK(run.tries_of_exact == 0);
}

TEST_CASE("Accuracy governor: a level over budget is left at once and retried ever more rarely") {
  // Exact takes 3x the budget, level 4 fits with room: the governor keeps probing exact, with
  // a hold that doubles from 2 s to 64 s.
  const GovernedRun run = govern(Accuracy::CentreOfMass, {0.1, 0.1, 0.1, 0.1, 0.3, 3.0}, 200'000);
  std::size_t steps_at_exact = 0;
  for (std::size_t i = 0; i < run.levels.size(); ++i) {
    if (run.levels[i] != Accuracy::Exact) continue;
    ++steps_at_exact;
    // Three overruns, then down: never more than three steps in a row over budget.
    if (i >= 3) CHECK_FALSE((run.levels[i - 1] == Accuracy::Exact && run.levels[i - 2] == Accuracy::Exact &&
                             run.levels[i - 3] == Accuracy::Exact));
  }
  // Tries at about 0.75, 3, 7, 15, 31, 63, 127 and 191 s of the 200 s run.
  CHECK(run.tries_of_exact >= 6);
  CHECK(run.tries_of_exact <= 9);
  CHECK(steps_at_exact == 3 * static_cast<std::size_t>(run.tries_of_exact));
  CHECK(run.levels.back() == Accuracy::SubBoxes);
}

TEST_CASE("Accuracy governor: never below the level it started from") {
  const GovernedRun run = govern(Accuracy::SampleNodes, {2.0, 2.0, 2.0, 2.0, 2.0, 2.0}, 5000);
  CHECK(run.switches == 0);
  CHECK(run.levels.back() == Accuracy::SampleNodes);
}

TEST_CASE("Accuracy governor: lone slow steps neither drop nor block a level") {
  AccuracyGovernor governor;
  governor.start(Accuracy::CentreOfMass);
  Accuracy level = Accuracy::CentreOfMass;
  for (int i = 0; i < 250; ++i) {
    // Two preemption spikes per window (one of them an overrun) and cheap steps otherwise.
    const std::int64_t ns = i == 17 ? 2 * kBudget : i == 90 ? kBudget / 2 : kBudget / 10;
    level = governor.observe(level, ns, kBudget);
  }
  CHECK(level == Accuracy::SampleNodes);
  // Two overruns in a window are tolerated, the third steps down.
  for (int i = 0; i < 2; ++i) level = governor.observe(level, 2 * kBudget, kBudget);
  CHECK(level == Accuracy::SampleNodes);
  level = governor.observe(level, 2 * kBudget, kBudget);
  CHECK(level == Accuracy::CentreOfMass);
}

TEST_CASE("Accuracy governor: a level set from outside is judged afresh") {
  AccuracyGovernor governor;
  governor.start(Accuracy::CentreOfMass);
  // Two overruns at level 2, then a command switches to level 4: its window starts empty.
  Accuracy level = Accuracy::SampleNodes;
  governor.observe(level, 2 * kBudget, kBudget);
  governor.observe(level, 2 * kBudget, kBudget);
  level = Accuracy::SubBoxes;
  level = governor.observe(level, 2 * kBudget, kBudget);
  CHECK(level == Accuracy::SubBoxes);
}
