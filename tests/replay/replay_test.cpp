// Replay scripts and recordings: malformed scripts name file, line, column and field; a
// recorded session replays bit for bit in fast and in real-time mode; a divergence is
// reported with the step it was found at.
#include <catch2/catch.hpp>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <thread>

#include "ffd/physics_loop.h"
#include "ffd/recording.h"
#include "ffd/replay_runner.h"
#include "ffd/replay_script.h"

using namespace ffd;
using Catch::Matchers::Contains;
using Catch::Matchers::StartsWith;

namespace {

const std::string kScene = FFDSIM_TEST_DATA_DIR "/scenes/probe_and_grab.toml";

std::string script_with(const std::string& body) {
  return "version = 1\nscene = \"" + kScene + "\"\nsteps = 200\n" + body;
}

LoadedReplay parse(const std::string& text) { return parse_replay(text, "test.toml", ""); }

std::string temporary_path(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("ffdsim_" + name + "_" + std::to_string(getpid()))).string();
}

}  // namespace

TEST_CASE("Replay scripts: a well-formed script resolves times, names and paths") {
  const LoadedReplay replay = parse(script_with(R"(
[[event]]
at_ms = 20
alpha = 0.5
beta = 0.25

[[event]]
at_step = 30
grab = { object = "high", point = [0.05, 0.05, 0.05], target = [0.1, 0.3, 0.0] }

[[probe_path]]
interpolation = "linear"
keyframes = [ { at_step = 100, position = [0.0, 0.4, 0.0] }, { at_step = 110, position = [0.0, 0.3, 0.0] } ]

[assert.stability]
finite = true
[[assert.hash]]
step = 200
value = "0123456789abcdef"
)"));
  const ReplayScript& s = replay.script;
  CHECK(s.steps == 200);
  REQUIRE(s.commands.size() == 2 + 2 + 11);
  CHECK(s.commands[0].kind == CommandKind::SetAlpha);
  CHECK(s.commands[0].step == 20);
  CHECK(s.commands[1].kind == CommandKind::SetBeta);
  CHECK(s.commands[2].kind == CommandKind::Grab);
  CHECK(replay.model.cell_object[s.commands[2].cell] == 1);
  CHECK(s.commands[3].kind == CommandKind::Drag);  // the grab's target
  CHECK(s.commands[3].vector == Vec3(0.1, 0.3, 0.0));
  CHECK(s.commands[4].step == 100);
  CHECK(s.commands[9].vector.y() == Approx(0.35));  // halfway along the linear path
  CHECK(s.commands.back().step == 110);
  REQUIRE(s.hashes.size() == 1);
  CHECK(s.hashes[0].value == 0x0123456789abcdefull);
}

TEST_CASE("Replay scripts: a probe stiffness event reads and a recording writes it back") {
  const LoadedReplay replay = parse(script_with("[[event]]\nat_ms = 20\nprobe_stiffness = 800.0\n"));
  REQUIRE(replay.script.commands.size() == 1);
  const Command& c = replay.script.commands[0];
  CHECK(c.kind == CommandKind::SetProbeStiffness);
  CHECK(c.value == 800.0);
  Recording recording;
  recording.scene_path = kScene;
  recording.steps = 200;
  recording.commands.push_back(c);
  const LoadedReplay again = parse(recording_text(replay.model, recording));
  REQUIRE(again.script.commands.size() == 1);
  CHECK(again.script.commands[0].kind == CommandKind::SetProbeStiffness);
  CHECK(again.script.commands[0].value == 800.0);
  CHECK_THROWS_WITH(parse(script_with("[[event]]\nat_ms = 20\nprobe_stiffness = -1.0\n")),
                    "test.toml:6:19: event[0].probe_stiffness: must be >= 0 (got -1)");
}

TEST_CASE("Replay scripts: malformed scripts name the file, line, column and field") {
  struct Case {
    const char* what;
    std::string text;
    std::string message;
  };
  const std::vector<Case> cases = {
      {"syntax", "version = 1\nscene = \n", "test.toml:2:9: TOML syntax error"},
      {"no version", "scene = \"" + kScene + "\"\nsteps = 5\n", "test.toml:1:1: version: missing required key"},
      {"bad version", "version = 2\nscene = \"" + kScene + "\"\nsteps = 5\n", "test.toml:1:11: version: unsupported version 2"},
      {"missing scene file", "version = 1\nscene = \"nowhere.toml\"\nsteps = 5\n", "test.toml:2:9: scene: cannot find scene file"},
      {"unknown key", script_with("[[event]]\nat_ms = 5\nalpah = 0.5\n"), "test.toml:6:1: event[0].alpah: unknown key 'alpah'; did you mean 'alpha'?"},
      {"out of range", script_with("[[event]]\nat_ms = 5\nalpha = 1.5\n"), "test.toml:6:9: event[0].alpha: must be in [0, 1] (got 1.5)"},
      {"after the end", script_with("[[event]]\nat_ms = 500\nalpha = 0.5\n"), "test.toml:5:9: event[0].at_ms: is at step 500, after the end of the run (200 steps)"},
      {"no action", script_with("[[event]]\nat_ms = 5\n"), "test.toml:4:1: event[0]: an event needs an action"},
      {"unknown object", script_with("[[event]]\nat_ms = 5\nstiffness = { object = \"hihg\", value = 10.0 }\n"),
       "test.toml:6:24: event[0].stiffness.object: no object named 'hihg' in the scene; did you mean 'high'?"},
      {"keyframes out of order", script_with("[[probe_path]]\nkeyframes = [ { at_step = 10, position = [0, 0, 0] }, { at_step = 5, position = [0, 0, 0] } ]\n"),
       "test.toml:5:55: probe_path[0].keyframes[1]: keyframes must be in increasing time"},
      {"bad hash", script_with("[[assert.hash]]\nstep = 10\nvalue = \"xyz\"\n"), "test.toml:6:9: assert.hash[0].value: expected 16 hexadecimal digits"},
      {"both times", script_with("[[event]]\nat_ms = 5\nat_step = 5\nreset = true\n"), "test.toml:5:9: event[0].at_ms: give either 'at_step' or 'at_ms', not both"},
  };
  for (const Case& c : cases) {
    INFO(c.what);
    REQUIRE_THROWS_WITH(parse(c.text), StartsWith(c.message));
  }
}

TEST_CASE("Replay scripts: a run longer than the step limit is an error naming the limit") {
  const std::string head = "version = 1\nscene = \"" + kScene + "\"\n";
  REQUIRE_THROWS_AS(parse(head + "steps = 100000001\n"), ReplayError);
  REQUIRE_THROWS_WITH(parse(head + "steps = 100000001\n"),
                      StartsWith("test.toml:3:9: steps: must be in [1, 100000000] (got 100000001)"));
  // 10^12 ms at dt = 1 ms.
  REQUIRE_THROWS_WITH(parse(head + "duration_ms = 1e12\n"),
                      StartsWith("test.toml:3:15: duration_ms: is 1e+12 steps of 1 ms, more than the limit "
                                 "of 100000000 steps"));
  REQUIRE_THROWS_WITH(parse(head + "steps = 10\n[[event]]\nat_ms = 1e300\nalpha = 0.5\n"),
                      StartsWith("test.toml:5:9: event[0].at_ms: is 1e+300 steps of 1 ms, more than the limit"));
}

TEST_CASE("Replay scripts: keyframed paths over the command limit are an error naming the limit") {
  // Each path is one command per step it spans: 400,001 (probe paths are read first) + 600,001.
  const std::string paths =
      "[[drag_path]]\nkeyframes = [ { at_step = 0, position = [0, 0, 0] }, { at_step = 600000, position = [0, 1, 0] } ]\n"
      "[[probe_path]]\nkeyframes = [ { at_step = 600001, position = [0, 0, 0] }, { at_step = 1000001, position = [0, 1, 0] } ]\n";
  const std::string text = "version = 1\nscene = \"" + kScene + "\"\nsteps = 2000000\n" + paths;
  REQUIRE_THROWS_AS(parse(text), ReplayError);
  REQUIRE_THROWS_WITH(parse(text), StartsWith("test.toml:4:1: drag_path[0]: the paths so far span 1000002 steps, "
                                              "more than the limit of 1000000 (one command per step) in a script"));
}

TEST_CASE("Replay scripts: the script's scene is read within the given scene limits") {
  SceneLimits limits;
  limits.objects = 1;  // the scene has two
  const std::string text = "version = 1\nscene = \"" + kScene + "\"\nsteps = 5\n";
  REQUIRE_THROWS_WITH(parse_replay(text, "test.toml", "", limits),
                      Contains("object[1]: the scene has more than 1 objects (the limit)"));
}

TEST_CASE("Replay scripts: a missing file is named") {
  REQUIRE_THROWS_WITH(load_replay_file("/nonexistent/poke.toml"), StartsWith("/nonexistent/poke.toml: cannot open replay script"));
}

TEST_CASE("Replay: a recorded session replays bit for bit, fast and in real time") {
  const LoadedReplay scene_only = parse(script_with(""));
  const Model& model = scene_only.model;
  // A "user": probe poses and a grab sent while the loop runs in real time, stamped by the
  // loop with the step they applied at.
  LoopOptions options;
  options.hash_every = 25;
  options.lock_memory = false;
  options.stop_at_step = 600;
  PhysicsLoop loop(model, initial_state(model), options);
  loop.start();
  Recording recording;
  recording.scene_path = kScene;
  recording.hash_every = 25;
  Telemetry t;
  Command c;
  for (int i = 0; !loop.finished(); ++i) {
    Command pose;
    pose.kind = CommandKind::ProbePose;
    pose.vector = Vec3(0.02, 0.4 - 0.002 * i, 0.0);
    loop.push(pose);
    if (i == 30) {
      Command grab;
      grab.kind = CommandKind::Grab;
      grab.cell = model.objects[0].cell_begin + 2;
      grab.local = Vec3(0.25, 0.5, 0.75);
      loop.push(grab);
    }
    while (loop.pop_telemetry(t)) {
      recording.steps = t.step;
      if (t.has_hash) recording.hashes.emplace_back(t.step, t.state_hash);
    }
    while (loop.pop_applied_command(c)) recording.commands.push_back(c);
    std::this_thread::sleep_for(std::chrono::milliseconds(3));
  }
  loop.join();
  while (loop.pop_telemetry(t)) {
    recording.steps = t.step;
    if (t.has_hash) recording.hashes.emplace_back(t.step, t.state_hash);
  }
  while (loop.pop_applied_command(c)) recording.commands.push_back(c);
  REQUIRE(recording.steps == 600);
  REQUIRE(recording.commands.size() > 50);
  REQUIRE(recording.hashes.size() == 24);

  const std::string path = temporary_path("recording.toml");
  write_recording(path, model, recording);
  const LoadedReplay replay = load_replay_file(path);
  REQUIRE(replay.script.commands.size() == recording.commands.size());
  for (const Pacing pacing : {Pacing::Fast, Pacing::RealTime}) {
    ReplayRunOptions run;
    run.pacing = pacing;
    const ReplayResult result = run_replay(replay, run);
    INFO(format_replay_result(replay.script, result));
    CHECK(result.passed());
    CHECK(result.final_hash == recording.hashes.back().second);
    CHECK_FALSE(result.first_divergence);
  }

  // One hash changed: the replay fails and names the step.
  std::ifstream in(path);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  char wanted[64];
  std::snprintf(wanted, sizeof wanted, "step = 300\nvalue = \"%016llx\"",
                static_cast<unsigned long long>(recording.hashes[11].second));
  const std::size_t at = text.find(wanted);
  REQUIRE(at != std::string::npos);
  text.replace(at + std::string("step = 300\nvalue = \"").size(), 16, "0000000000000bad");
  const LoadedReplay tampered = parse_replay(text, "tampered.toml", "");
  const ReplayResult result = run_replay(tampered, ReplayRunOptions{});
  CHECK_FALSE(result.passed());
  REQUIRE(result.first_divergence);
  CHECK(*result.first_divergence == 300);
  CHECK_THAT(format_replay_result(tampered.script, result),
             Contains("FAIL determinism.state_hash: diverged: state hash at step 300") &&
                 Contains("last equal at step 275"));
  std::filesystem::remove(path);
}

TEST_CASE("Replay scripts: the energy gain and position and rest assertions read strictly") {
  const LoadedReplay replay = parse(script_with(R"(
[assert.stability]
energy_gain_max_j = 0.5
[[assert.position]]
object = "hi*"
relative_to = "low"
min = [-0.1, 0.0, -0.1]
from_ms = 100
every_steps = 5
[assert.rest]
from_step = 150
speed_max_m_s = 0.02
)"));
  const ReplayScript& s = replay.script;
  CHECK(s.stability.energy_gain_max_j == 0.5);
  REQUIRE(s.positions.size() == 1);
  const PositionLimit& p = s.positions[0];
  REQUIRE(p.objects.size() == 1);
  CHECK(replay.model.objects[p.objects[0]].name == "high");
  CHECK(p.relative_to == Index{0});
  CHECK(p.min == Vec3(-0.1, 0.0, -0.1));
  CHECK(p.max.x() == std::numeric_limits<double>::infinity());  // no 'max': unbounded
  CHECK(p.from_step == 100);
  CHECK(p.to_step == 200);
  CHECK(p.every_steps == 5);
  CHECK(s.rest.speed_max_m_s == 0.02);
  CHECK(s.rest.from_step == 150);
  CHECK(s.rest.every_steps == 10);

  struct Case {
    const char* what;
    std::string text;
    std::string message;
  };
  const std::vector<Case> cases = {
      {"gain with a grab", script_with("[[event]]\nat_step = 5\ngrab = { object = \"high\", cell = 0, local = [0.5, 0.5, 0.5] }\n"
                                       "[assert.stability]\nenergy_gain_max_j = 1.0\n"),
       "test.toml:8:21: assert.stability.energy_gain_max_j: counts the probe's work only, and the script has a 'grab' "
       "command at step 5"},
      {"gain with gravity", script_with("[[event]]\nat_step = 5\ngravity = [0, -1, 0]\n[assert.stability]\nenergy_gain_max_j = 1.0\n"),
       "test.toml:8:21: assert.stability.energy_gain_max_j: counts the probe's work only, and the script has a 'gravity'"},
      {"no bounds", script_with("[[assert.position]]\nobject = \"high\"\n"), "test.toml:4:1: assert.position[0]: give 'min' and/or 'max'"},
      {"no such prefix", script_with("[[assert.position]]\nobject = \"box*\"\nmax = [1, 1, 1]\n"),
       "test.toml:5:10: assert.position[0].object: no object name starts with 'box'"},
      {"min above max", script_with("[[assert.position]]\nobject = \"high\"\nmin = [0, 2, 0]\nmax = [1, 1, 1]\n"),
       "test.toml:7:7: assert.position[0].max: is below 'min' on axis 1"},
      {"unknown relative", script_with("[[assert.position]]\nobject = \"high\"\nrelative_to = \"lwo\"\nmax = [1, 1, 1]\n"),
       "test.toml:6:15: assert.position[0].relative_to: no object named 'lwo' in the scene; did you mean 'low'?"},
      {"rest without a speed", script_with("[assert.rest]\nfrom_step = 10\n"), "test.toml:4:1: assert.rest.speed_max_m_s: missing required key"},
      {"rest after the end", script_with("[assert.rest]\nfrom_step = 195\nspeed_max_m_s = 1.0\n"),
       "test.toml:4:1: assert.rest: the window from 'from' leaves no whole 'every' interval"},
  };
  for (const Case& c : cases) {
    INFO(c.what);
    REQUIRE_THROWS_WITH(parse(c.text), StartsWith(c.message));
  }
}

TEST_CASE("Replay scripts: [assert.paper] and [assert.solver] apply under their response only") {
  const std::string text = script_with(R"(
[[assert.position]]
object = "high"
max = [1, 1, 1]
[[assert.paper.position]]
object = "high"
max = [2, 2, 2]
[[assert.solver.position]]
object = "low"
max = [3, 3, 3]
[assert.solver.rest]
speed_max_m_s = 0.5
)");
  // The scene's own response (paper): [assert] and [assert.paper].
  const LoadedReplay paper = parse(text);
  REQUIRE(paper.script.positions.size() == 2);
  CHECK(paper.script.positions[1].max == Vec3(2, 2, 2));
  CHECK_FALSE(paper.script.rest.speed_max_m_s);
  // The run asked for the solver: [assert] and [assert.solver], and the model says so.
  const LoadedReplay solver = parse_replay(text, "test.toml", "", {}, RecordedScene::MustMatch, ContactResponse::Solver);
  CHECK(solver.model.settings.response == ContactResponse::Solver);
  REQUIRE(solver.script.positions.size() == 2);
  CHECK(solver.script.positions[1].max == Vec3(3, 3, 3));
  CHECK(solver.script.rest.speed_max_m_s == 0.5);
  // A per-response force window compares with the one in [assert] before it, whatever the run.
  const std::string windows = script_with(R"(
[[assert.force_window]]
from_step = 10
to_step = 20
mean_min_n = 0.0
[[assert.solver.force_window]]
from_step = 30
to_step = 40
above_previous = true
)");
  CHECK(parse(windows).script.force_windows.size() == 1);
  CHECK(parse_replay(windows, "test.toml", "", {}, RecordedScene::MustMatch, ContactResponse::Solver)
            .script.force_windows.size() == 2);

  struct Case {
    const char* what;
    std::string text;
    std::string message;
  };
  const std::vector<Case> cases = {
      // The other response's table is read too: its mistakes are reported whatever the run.
      {"bad key under the other response", script_with("[[assert.solver.position]]\nobject = \"high\"\nmax = [1, 1, 1]\nevery = 3\n"),
       "test.toml:7:1: assert.solver.position[0].every: unknown key"},
      {"unknown response", script_with("[assert.exact.force]\nmax_n = 1.0\n"), "test.toml:4:9: assert.exact: unknown key"},
      {"a single table twice", script_with("[assert.rest]\nspeed_max_m_s = 1.0\n[assert.paper.rest]\nspeed_max_m_s = 2.0\n"),
       "test.toml:6:1: assert.paper: [assert.paper.rest] is given in [assert] too"},
      {"with a response event", script_with("[[event]]\nat_step = 5\nresponse = \"solver\"\n[assert.paper.rest]\nspeed_max_m_s = 2.0\n"),
       "test.toml:7:1: assert.paper: per-response assertions need one response for the whole run, and the script "
       "switches the response at step 5"},
  };
  for (const Case& c : cases) {
    INFO(c.what);
    REQUIRE_THROWS_WITH(parse(c.text), StartsWith(c.message));
  }
}

TEST_CASE("Replay: the energy gain and position and rest assertions measure the run") {
  // The upper box falls 5 cm onto the lower one and settles, its contacts inelastic (alpha
  // = 1 from the start: at the scene's 0.5 each bounce's height is chaotic, the lattice's
  // springs giving back what they stored); the probe hovers 15 cm above.
  const LoadedReplay settled = parse(R"(version = 1
scene = ")" + kScene + R"("
steps = 600
[[event]]
at_step = 0
alpha = 1.0
[assert.stability]
energy_gain_max_j = 5.0
[[assert.position]]
object = "high"
relative_to = "low"
min = [-0.05, 0.09, -0.05]
max = [0.05, 0.11, 0.05]
from_step = 400
[[assert.position]]
object = "*"
min = [-0.2, 0.04, -0.2]
[assert.rest]
from_step = 400
every_steps = 50
speed_max_m_s = 0.05
)");
  const ReplayResult result = run_replay(settled, ReplayRunOptions{});
  INFO(format_replay_result(settled.script, result));
  CHECK(result.passed());
  CHECK(result.probe_work_j == 0.0);  // the device never moved
  // The boxes meet with damped contacts (alpha = 1) and only lose energy: the largest
  // "gain" is the first step's, 0.1 mJ below the 2.46 J they start with.
  CHECK(std::abs(result.max_energy_gain_j) < 1.0e-3);
  CHECK(result.initial_energy_j > 0.0);

  // The same run with limits it does not meet: each failure names what it measured.
  const LoadedReplay strict = parse(R"(version = 1
scene = ")" + kScene + R"("
steps = 600
[assert.stability]
energy_gain_max_j = -1.0
[[assert.position]]
object = "high"
max = [1.0, 0.1, 1.0]
[assert.rest]
from_step = 0
every_steps = 50
speed_max_m_s = 0.01
)");
  const ReplayResult failed = run_replay(strict, ReplayRunOptions{});
  const std::string text = format_replay_result(strict.script, failed);
  CHECK_FALSE(failed.passed());
  CHECK_THAT(text, Contains("FAIL stability.energy_gain_max_j:") && Contains("initial ") && Contains("probe work 0 J"));
  CHECK_THAT(text, Contains("FAIL position[high]: high at [") && Contains("m outside"));
  CHECK_THAT(text, Contains("FAIL rest.speed_max_m_s:") && Contains("(high, step 100)"));
}

TEST_CASE("Replay: an energy gain within the energy sums' rounding passes, a larger one fails") {
  // The same settling run, its limit set just below the gain it measures: half the rounding
  // allowance (kEnergyRounding x the energies compared, about 5e-12 J here) below passes, twice
  // it below fails.
  const std::string head = "version = 1\nscene = \"" + kScene + "\"\nsteps = 300\n[[event]]\nat_step = 0\nalpha = 1.0\n";
  auto run = [&](double limit) {
    std::ostringstream script;
    script.precision(17);
    script << head << "[assert.stability]\nenergy_gain_max_j = " << limit << "\n";
    return run_replay(parse(script.str()), ReplayRunOptions{});
  };
  const ReplayResult measured = run(1.0);
  REQUIRE(measured.passed());
  const double gain = measured.max_energy_gain_j;  // J
  const double allowance = kEnergyRounding * (std::abs(gain + measured.initial_energy_j) + std::abs(measured.initial_energy_j));
  REQUIRE(allowance > 0.0);
  CHECK(run(gain - 0.5 * allowance).passed());
  CHECK_FALSE(run(gain - 2.0 * allowance).passed());
}

TEST_CASE("Replay: the probe's work counts as energy put in") {
  // The device goes down into the resting boxes and up again: the work it does is counted,
  // and the gain is the energy above the initial energy plus that work.
  const LoadedReplay replay = parse(R"(version = 1
scene = ")" + kScene + R"("
steps = 700
[[probe_path]]
keyframes = [ { at_step = 300, position = [0.0, 0.4, 0.0] }, { at_step = 450, position = [0.02, 0.17, 0.0] },
              { at_step = 600, position = [0.0, 0.4, 0.0] } ]
[assert.stability]
energy_gain_max_j = 1e6
)");
  const ReplayResult result = run_replay(replay, ReplayRunOptions{});
  INFO(format_replay_result(replay.script, result));
  REQUIRE(result.passed());
  CHECK(result.peak_force_n > 1.0);  // the probe pressed
  CHECK(result.probe_work_j > 0.0);
  // The energy at the step of the largest gain is one of the sampled energies.
  CHECK(result.max_energy_gain_j + result.initial_energy_j + result.probe_work_at_max_gain_j <=
        result.max_energy_j + 1e-9);
}

TEST_CASE("Replay scripts: a response event reads, a recording writes it back, and an unknown one is an error") {
  const LoadedReplay replay = parse(script_with("[[event]]\nat_ms = 20\nresponse = \"solver\"\n"));
  REQUIRE(replay.script.commands.size() == 1);
  const Command& c = replay.script.commands[0];
  CHECK(c.kind == CommandKind::SetResponse);
  CHECK(c.value == static_cast<double>(ContactResponse::Solver));
  Recording recording;
  recording.scene_path = kScene;
  recording.steps = 200;
  recording.commands.push_back(c);
  const std::string text = recording_text(replay.model, recording);
  CHECK_THAT(text, Contains("response = \"solver\""));
  const LoadedReplay again = parse(text);
  REQUIRE(again.script.commands.size() == 1);
  CHECK(again.script.commands[0].kind == CommandKind::SetResponse);
  CHECK(again.script.commands[0].value == static_cast<double>(ContactResponse::Solver));
  CHECK_THROWS_WITH(parse(script_with("[[event]]\nat_ms = 20\nresponse = \"fast\"\n")),
                    Contains("test.toml:6:12: event[0].response: unknown response 'fast'"));
}

namespace {

const AssertionResult* find_assertion(const ReplayResult& result, const std::string& prefix) {
  for (const AssertionResult& a : result.assertions)
    if (a.name.rfind(prefix, 0) == 0) return &a;
  return nullptr;
}

}  // namespace

TEST_CASE("Replay scripts: motion, creep and force-window assertions measure what a hand feels, and fail past their limits") {
  // The probe-and-grab boxes under the response "solver": the upper box lands on the lower one
  // by 0.4 s and both rest; by 0.7 s the probe presses on the upper box and holds, its device
  // 2 then 4 cm past where the proxy stops (the coupling stretched: a steady force that rises).
  const std::string body = R"(
[[event]]
at_step = 0
response = "solver"
[[probe_path]]
interpolation = "smooth"
keyframes = [
  { at_step = 0, position = [0.02, 0.4, 0.0] },
  { at_step = 700, position = [0.02, 0.19, 0.0] },
  { at_step = 800, position = [0.02, 0.19, 0.0] },
  { at_step = 900, position = [0.02, 0.17, 0.0] },
  { at_step = 1199, position = [0.02, 0.17, 0.0] },
]
)";
  auto run = [&](const std::string& asserts) {
    const LoadedReplay replay = parse("version = 1\nscene = \"" + kScene + "\"\nsteps = 1200\n" + body + asserts);
    return run_replay(replay, ReplayRunOptions{});
  };
  const std::string met = R"(
[assert.motion]
from_step = 500
rms_speed_max_m_s = 0.05
kinetic_energy_max_j = 0.01
speed_max_m_s = 0.5
[[assert.creep]]
object = "low"
from_step = 500
to_step = 1200
every_steps = 50
max_m = 0.002
[[assert.force_window]]
from_step = 750
to_step = 800
mean_min_n = 0.5
[[assert.force_window]]
from_step = 1000
to_step = 1200
relative_std_max = 0.05
above_previous = true
)";
  const ReplayResult passed = run(met);
  INFO(format_replay_result(parse("version = 1\nscene = \"" + kScene + "\"\nsteps = 1200\n" + body + met).script, passed));
  CHECK(passed.passed());
  REQUIRE(find_assertion(passed, "motion.rms_speed_max_m_s"));
  REQUIRE(find_assertion(passed, "creep[low]"));
  REQUIRE(find_assertion(passed, "force_window[1000, 1200]"));

  // Limits the run does not meet: each fails and says what it measured.
  const ReplayResult failed = run(R"(
[assert.motion]
from_step = 0
rms_speed_max_m_s = 0.001
[[assert.creep]]
object = "high"
from_step = 0
to_step = 600
every_steps = 50
max_m = 0.01
[[assert.force_window]]
from_step = 1000
to_step = 1200
mean_min_n = 100.0
)");
  CHECK_FALSE(failed.passed());
  const AssertionResult* motion = find_assertion(failed, "motion.rms_speed_max_m_s");
  const AssertionResult* creep = find_assertion(failed, "creep[high]");
  const AssertionResult* force = find_assertion(failed, "force_window[1000, 1200]");
  REQUIRE(motion);
  REQUIRE(creep);
  REQUIRE(force);
  CHECK_FALSE(motion->passed);  // the fall
  CHECK_FALSE(creep->passed);   // the upper box falls 5 cm
  CHECK_THAT(creep->measured, Contains("high"));
  CHECK_FALSE(force->passed);
  CHECK_THAT(force->measured, Contains("mean"));
}

TEST_CASE("Replay scripts: malformed motion, creep and force-window assertions name the file, line and field") {
  CHECK_THROWS_WITH(parse(script_with("[assert.motion]\nfrom_step = 10\n")),
                    Contains("assert.motion: give 'rms_speed_max_m_s', 'kinetic_energy_max_j' and/or 'speed_max_m_s'"));
  CHECK_THROWS_WITH(parse(script_with("[assert.motion]\nfrom_step = 500\nspeed_max_m_s = 1.0\n")),
                    Contains("assert.motion.from_step: starts after the run's last step"));
  CHECK_THROWS_WITH(parse(script_with("[[assert.creep]]\nobject = \"low\"\n")),
                    Contains("assert.creep[0].max_m: missing required key"));
  CHECK_THROWS_WITH(parse(script_with("[[assert.creep]]\nobject = \"nobody\"\nmax_m = 0.001\n")),
                    Contains("assert.creep[0].object"));
  CHECK_THROWS_WITH(parse(script_with("[[assert.creep]]\nobject = \"low\"\nmax_m = 0.001\nfrom_step = 15\n")),
                    Contains("'from' must be a whole number of 'every' intervals"));
  CHECK_THROWS_WITH(parse(script_with("[[assert.force_window]]\nfrom_step = 10\nto_step = 20\nabove_previous = true\n")),
                    Contains("assert.force_window[0].above_previous: the first force window has none before it"));
  CHECK_THROWS_WITH(parse(script_with("[[assert.force_window]]\nfrom_step = 20\nto_step = 20\nmean_min_n = 1.0\n")),
                    Contains("the window holds no step"));
  CHECK_THROWS_WITH(parse(script_with("[[assert.force_window]]\nfrom_step = 10\nto_step = 20\n")),
                    Contains("give 'relative_std_max', 'mean_min_n', 'mean_max_n' and/or 'above_previous'"));
}

TEST_CASE("Replay scripts: an intersection assertion counts crossing surfaces, and fails past its limit") {
  // The upper box falls 4.9 cm onto the lower one (about 0.1 s) and, without inter-object
  // collision, on through it to the floor: its faces cross the lower box's.
  std::ifstream in(kScene);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string collision = "\"inter_collision\", ";
  const std::size_t effect = text.find(collision);
  REQUIRE(effect != std::string::npos);
  text.erase(effect, collision.size());
  const std::string scene = temporary_path("crossing_boxes.toml");
  std::ofstream(scene) << text;
  auto run = [&](const std::string& asserts) {
    const LoadedReplay replay = parse("version = 1\nscene = \"" + scene + "\"\nsteps = 500\n" + asserts);
    return run_replay(replay, ReplayRunOptions{});
  };
  const ReplayResult falling = run("[[assert.intersections]]\nto_step = 80\nevery_steps = 20\nmax_pairs = 0\n");
  const AssertionResult* apart = find_assertion(falling, "intersections.max_pairs");
  REQUIRE(apart);
  CHECK(apart->passed);
  CHECK_THAT(apart->measured, StartsWith("0 at step"));
  const ReplayResult resting = run("[[assert.intersections]]\nfrom_step = 300\nevery_steps = 50\nmax_pairs = 0\n");
  const AssertionResult* crossed = find_assertion(resting, "intersections.max_pairs");
  REQUIRE(crossed);
  CHECK_FALSE(crossed->passed);
  CHECK_FALSE(resting.passed());
  CHECK_THAT(crossed->limit, Contains("<= 0 from step 300 to 500"));
  // With it (the scene as shipped) the same boxes rest apart.
  const LoadedReplay apart_replay =
      parse("version = 1\nscene = \"" + kScene + "\"\nsteps = 500\n[[assert.intersections]]\nfrom_step = 300\n"
            "every_steps = 50\nmax_pairs = 0\n");
  CHECK(run_replay(apart_replay, ReplayRunOptions{}).passed());
  std::filesystem::remove(scene);
}

TEST_CASE("Replay scripts: malformed intersection assertions name the file, line and field") {
  CHECK_THROWS_WITH(parse(script_with("[[assert.intersections]]\nfrom_step = 10\n")),
                    Contains("assert.intersections[0].max_pairs: missing required key"));
  CHECK_THROWS_WITH(parse(script_with("[[assert.intersections]]\nmax_pairs = -1\n")),
                    Contains("assert.intersections[0].max_pairs"));
  CHECK_THROWS_WITH(parse(script_with("[[assert.intersections]]\nmax_pairs = 1.5\n")),
                    Contains("assert.intersections[0].max_pairs"));
  CHECK_THROWS_WITH(parse(script_with("[[assert.intersections]]\nmax_pairs = 0\npairs = 3\n")),
                    Contains("test.toml:6:1: assert.intersections[0].pairs: unknown key 'pairs'"));
}

TEST_CASE("Replay: the inverted-cells assertion counts the steps a cell stays inside out") {
  // The crush case's first 750 ms: the probe drives through the mass-spring box to below
  // the floor and holds it there, with cells inside out under it for tens of steps.
  const std::string head = R"(version = 1
scene = ")" + std::string(FFDSIM_SCENARIO_DIR) + R"(/scenes/hard/crush.toml"
)";
  const LoadedReplay strict = parse(head + R"(duration_ms = 750
[[probe_path]]
interpolation = "smooth"
keyframes = [ { at_ms = 100, position = [-0.15, 0.2, 0.0] }, { at_ms = 500, position = [-0.15, -0.02, 0.0] },
              { at_ms = 700, position = [-0.15, -0.02, 0.0] } ]
[assert.stability]
inverted_steps_max = 1
)");
  CHECK(strict.script.stability.inverted_steps_max == 1u);
  const ReplayResult crushed = run_replay(strict, ReplayRunOptions{});
  const std::string report = format_replay_result(strict.script, crushed);
  INFO(report);
  CHECK(crushed.longest_inversion_steps > 10);
  CHECK(crushed.most_inverted_cells >= 1);
  CHECK_THAT(report, Contains("FAIL stability.inverted_steps_max: ") && Contains(" of 'spring_box', to step "));

  // Left alone, every cell stays upright.
  const LoadedReplay calm = parse(head + "duration_ms = 200\n[assert.stability]\ninverted_steps_max = 0\n");
  const ReplayResult upright = run_replay(calm, ReplayRunOptions{});
  CHECK(upright.longest_inversion_steps == 0);
  CHECK_THAT(format_replay_result(calm.script, upright), Contains("PASS stability.inverted_steps_max: no cell inside out"));

  REQUIRE_THROWS_WITH(parse(script_with("[assert.stability]\ninverted_steps_max = -1\n")),
                      StartsWith("test.toml:5:22: assert.stability.inverted_steps_max:"));
}
