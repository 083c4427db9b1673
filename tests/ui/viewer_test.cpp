// The viewer, headless on EGL: what it draws is where the simulation says, scripted mouse
// input grabs and drags, a slider change reaches the physics thread at its stamped step, and
// a stalled UI never holds the physics back.
#include <algorithm>
#include <chrono>
#include <thread>

#include <catch2/catch.hpp>

#include "app/picking.h"
#include "app/scripted_input.h"
#include "app/viewer.h"
#include "ffd/scene_loader.h"
#include "ffd/toml_reader.h"
#include "ffd/trilinear.h"
#include "platform/headless_gl.h"
#include "support/fp_traps.h"

using namespace ffd;
using namespace ffd::ui;

namespace {

// Mesa's software rasteriser (llvmpipe) and its worker threads compute with infinities by
// design, so these tests run with the floating-point traps off (threads inherit the setting).
using NoFpTraps = ffd::test::FpTrapsOff;

const std::string kBoxes = std::string(FFDSIM_TEST_DATA_DIR) + "/scenes/probe_and_grab.toml";

// The viewer on an offscreen framebuffer, stepping UI frames at about 60 Hz.
struct HeadlessViewer {
  HeadlessGl gl;
  Viewer viewer;
  explicit HeadlessViewer(const std::string& scene, std::uint64_t lead_steps = 50, std::int64_t period_ns = 1'000'000)
      : gl(1280, 720), viewer(options(scene, lead_steps, period_ns)) {}  // room for the panels and the scene
  static ViewerOptions options(const std::string& scene, std::uint64_t lead_steps, std::int64_t period_ns) {
    ViewerOptions o;
    o.scene_path = scene;
    o.session.loop.period_ns = o.session.loop.budget_ns = period_ns;
    // Generous: sanitizer builds are slow, and only the stamping is under test here.
    o.session.command_lead_steps = lead_steps;
    return o;
  }
  void frame(const InputState& input = {}) {
    gl.bind();
    viewer.frame(input, gl.width(), gl.height(), 1.0f / 60.0f);
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  // Runs the script to its end, then `settle_steps` more steps with the last input held,
  // counted from when the last command the UI sent was applied: a loaded machine may give
  // the UI thread few frames, so the script's moves can land late (bounded in wall time).
  void run(ScriptedInput& script, std::uint64_t settle_steps = 0) {
    const double dt = viewer.session().model().settings.dt;
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(120);
    InputState input;
    while (!script.finished(viewer.session().newest_step(), dt) && std::chrono::steady_clock::now() < give_up) {
      input = script.next(viewer, viewer.session().newest_step(), dt, gl.width(), gl.height());
      frame(input);
    }
    input.pressed.clear();
    input.wheel = 0.0f;
    const auto settled = [&] {
      const auto& applied = viewer.session().log().commands;
      const std::uint64_t last = applied.empty() ? 0 : applied.back().step;
      return applied.size() >= viewer.sent_commands().size() && viewer.session().newest_step() >= last + settle_steps;
    };
    while (!settled() && std::chrono::steady_clock::now() < give_up) frame(input);
  }
};

UiScript script(const std::string& text) { return parse_ui_script(text, "test.toml", ""); }

bool is_background(const std::uint8_t* p, const Vec3f& background) {
  for (int k = 0; k < 3; ++k)
    if (std::abs(static_cast<int>(p[k]) - static_cast<int>(std::lround(background[k] * 255.0f))) > 2) return false;
  return true;
}

}  // namespace

TEST_CASE("Viewer: headless rendering puts each teapot where the simulation says", "[viewer]") {
  const NoFpTraps no_traps;
  HeadlessGl gl(640, 480);
  gl.bind();
  std::vector<std::string> log;
  const Model model = compile(load_scene_file(default_scene_path()), log);
  SceneRenderer renderer(model);
  // Not the rest pose: the upper teapot moved 12 cm along x and 3 cm down, its lower half
  // squashed, so an image drawn from rest positions fails.
  Frame frame;
  frame.nodes = initial_state(model).x;
  const ObjectModel& high = model.objects[1];
  for (Index n = high.node_begin; n < high.node_end; ++n) {
    frame.nodes[n] += Vec3(0.12, -0.03, 0.0);
    if (frame.nodes[n].y() < 0.25) frame.nodes[n].y() = 0.25 - 0.5 * (0.25 - frame.nodes[n].y());
  }
  OrbitCamera camera;
  camera.target = Vec3f(0.05f, 0.15f, 0.0f);
  camera.distance = 1.0f;
  RenderOptions options;
  options.planes = options.probe = options.contacts = options.probe_force = false;
  renderer.draw(frame, camera, gl.width(), gl.height(), options);
  const std::vector<std::uint8_t> image = gl.read_pixels();

  // The same surfaces rasterised on the CPU from the same lattice (eq. 2), object by object.
  const int w = gl.width(), h = gl.height();
  std::vector<std::uint8_t> expected(static_cast<std::size_t>(w * h), 0);  // bit o set: object o covers it
  for (std::size_t o = 0; o < model.objects.size(); ++o) {
    const ObjectModel& object = model.objects[o];
    std::vector<Vec2f> pixels(object.surface.vertices.size());
    for (std::size_t v = 0; v < pixels.size(); ++v) {
      const auto& corners = model.cell_nodes[object.vertex_cell[v]];
      const Vec3 x = trilinear_map(object.vertex_local[v], [&](int j) -> const Vec3& { return frame.nodes[corners[j]]; });
      REQUIRE(camera.project(x.cast<float>(), w, h, pixels[v]));
    }
    for (const auto& t : object.surface.triangles) {
      const Vec2f a = pixels[t[0]], b = pixels[t[1]], c = pixels[t[2]];
      const float area = (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
      if (std::abs(area) < 1e-6f) continue;
      const int x0 = std::max(0, static_cast<int>(std::floor(std::min({a.x(), b.x(), c.x()}))));
      const int x1 = std::min(w - 1, static_cast<int>(std::ceil(std::max({a.x(), b.x(), c.x()}))));
      const int y0 = std::max(0, static_cast<int>(std::floor(std::min({a.y(), b.y(), c.y()}))));
      const int y1 = std::min(h - 1, static_cast<int>(std::ceil(std::max({a.y(), b.y(), c.y()}))));
      for (int y = y0; y <= y1; ++y)
        for (int x = x0; x <= x1; ++x) {
          const Vec2f p(static_cast<float>(x), static_cast<float>(y));
          const float u = ((b - p).x() * (c - p).y() - (b - p).y() * (c - p).x()) / area;
          const float v = ((c - p).x() * (a - p).y() - (c - p).y() * (a - p).x()) / area;
          if (u >= 0.0f && v >= 0.0f && u + v <= 1.0f) expected[static_cast<std::size_t>(y * w + x)] |= std::uint8_t(1u << o);
        }
    }
  }
  // Compare away from silhouette edges (1 px either way is rasterisation detail).
  std::size_t inside = 0, inside_drawn = 0, outside = 0, outside_drawn = 0, only_high = 0, only_high_blue = 0;
  std::size_t only_low = 0, only_low_orange = 0;
  for (int y = 1; y < h - 1; ++y)
    for (int x = 1; x < w - 1; ++x) {
      std::uint8_t all = 0xff, any = 0;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          all &= expected[static_cast<std::size_t>((y + dy) * w + x + dx)] ? 1 : 0;
          any |= expected[static_cast<std::size_t>((y + dy) * w + x + dx)];
        }
      const std::uint8_t* p = &image[static_cast<std::size_t>((y * w + x) * 4)];
      const bool drawn = !is_background(p, options.background);
      const std::uint8_t here = expected[static_cast<std::size_t>(y * w + x)];
      if (all) {
        ++inside;
        inside_drawn += drawn;
      } else if (!any) {
        ++outside;
        outside_drawn += drawn;
      }
      if (all && here == 2) {  // only the upper (blue) teapot covers this pixel
        ++only_high;
        only_high_blue += p[2] > p[0];
      }
      if (all && here == 1) {  // only the lower (orange) teapot
        ++only_low;
        only_low_orange += p[0] > p[2];
      }
    }
  INFO("inside " << inside << " drawn " << inside_drawn << "; outside " << outside << " drawn " << outside_drawn);
  REQUIRE(inside > 10000);  // the teapots fill a good part of the image
  CHECK(static_cast<double>(inside_drawn) >= 0.995 * static_cast<double>(inside));
  CHECK(static_cast<double>(outside_drawn) <= 0.001 * static_cast<double>(outside));
  REQUIRE(only_high > 5000);
  REQUIRE(only_low > 5000);
  CHECK(static_cast<double>(only_high_blue) >= 0.99 * static_cast<double>(only_high));
  CHECK(static_cast<double>(only_low_orange) >= 0.99 * static_cast<double>(only_low));
}

TEST_CASE("Viewer: a picked surface point maps back to its cell and local coordinates", "[viewer]") {
  const NoFpTraps no_traps;
  std::vector<std::string> log;
  const Model model = compile(load_scene_file(kBoxes), log);
  Frame frame;
  frame.nodes = initial_state(model).x;
  frame.boxes.resize(model.box_count());
  for (Index b = 0; b < model.box_count(); ++b)
    for (int i = 0; i < 9; ++i) {
      const auto& corners = model.cell_nodes[model.boxes.box_cell[b]];
      frame.boxes[b][static_cast<std::size_t>(i)] =
          trilinear_map(model.boxes.box_local[b][static_cast<std::size_t>(i)], [&](int j) -> const Vec3& { return frame.nodes[corners[j]]; });
    }
  const Index cell = model.boxes.box_cell[3];
  const Vec3 local(0.25, 0.6, 0.9);
  const Vec3 point = trilinear_map(local, [&](int j) -> const Vec3& { return frame.nodes[model.cell_nodes[cell][j]]; });
  const CellPoint found = cell_at(model, frame, point);
  REQUIRE(found.cell != kNoIndex);
  // The same world point, whichever of the cells sharing it was chosen.
  const Vec3 back = trilinear_map(found.local, [&](int j) -> const Vec3& { return frame.nodes[model.cell_nodes[found.cell][j]]; });
  CHECK((back - point).norm() < 1e-9);
  CHECK(cell_at(model, frame, Vec3(5.0, 5.0, 5.0)).cell == kNoIndex);
}

TEST_CASE("Viewer: a scripted drag in headless mode lifts the grabbed object", "[viewer]") {
  const NoFpTraps no_traps;
  HeadlessViewer v(kBoxes);
  ScriptedInput input(script(R"(
duration_ms = 1400
[[input]]
at_ms = 300
mouse_to = "high"
[[input]]
at_ms = 350
press = "left"
[[input]]
at_ms = 400
offset = [0, -300]
glide_ms = 500
)"));
  v.run(input, 600);
  REQUIRE(input.events_done() == 3);
  // Written frames are opaque where ImGui blended its panels, as the window shows them.
  const std::vector<std::uint8_t> pixels = v.gl.read_pixels();
  bool opaque = true;
  for (std::size_t i = 3; i < pixels.size(); i += 4) opaque = opaque && pixels[i] == 255;
  CHECK(opaque);
  const Session& s = v.viewer.session();
  const Model& model = s.model();
  const auto& commands = s.log().commands;
  const auto grab = std::find_if(commands.begin(), commands.end(), [](const Command& c) { return c.kind == CommandKind::Grab; });
  REQUIRE(grab != commands.end());
  CHECK(model.cell_object[grab->cell] == 1);  // the box under the cursor: "high"
  CHECK(std::count_if(commands.begin(), commands.end(), [](const Command& c) { return c.kind == CommandKind::Drag; }) > 5);
  // Held 300 px higher (the 200 N/m grab spring sags under the box's weight): the box rose
  // more than 2.5 cm off the one below it (it rests with its centre at 0.15 m).
  const Vec3 centre = object_centre(model, *s.frame(), 1);
  INFO("centre " << centre.transpose());
  CHECK(centre.y() > 0.175);
  // Letting go drops it.
  InputState up;
  up.mouse_x = 1.0f;
  up.mouse_y = 1.0f;
  v.frame(up);
  CHECK(std::any_of(v.viewer.sent_commands().begin(), v.viewer.sent_commands().end(),
                    [](const Command& c) { return c.kind == CommandKind::Release; }));
}

TEST_CASE("Viewer: a slider change reaches the physics thread at the step it was stamped for", "[viewer]") {
  const NoFpTraps no_traps;
  HeadlessViewer v(kBoxes, 200);
  ScriptedInput input(script(R"(
duration_ms = 800
[[input]]
at_ms = 100
widget = "alpha"
fraction = 0.25
[[input]]
at_ms = 150
press = "left"
[[input]]
at_ms = 200
release = "left"
)"));
  v.run(input);
  REQUIRE(input.events_done() == 3);
  const auto& sent = v.viewer.sent_commands();
  const auto alpha = std::find_if(sent.begin(), sent.end(), [](const Command& c) { return c.kind == CommandKind::SetAlpha; });
  REQUIRE(alpha != sent.end());
  CHECK(alpha->step != kNextStep);
  CHECK(alpha->value > 0.15);
  CHECK(alpha->value < 0.35);
  const auto& applied = v.viewer.session().log().commands;
  const auto arrived = std::find_if(applied.begin(), applied.end(), [](const Command& c) { return c.kind == CommandKind::SetAlpha; });
  REQUIRE(arrived != applied.end());
  CHECK(arrived->step == alpha->step);
  CHECK(arrived->value == alpha->value);
  CHECK(v.viewer.session().counters().commands_late == 0);
  CHECK(v.viewer.session().frame()->alpha == alpha->value);
}

TEST_CASE("Viewer: a stalled UI thread never holds a physics step back", "[viewer]") {
  const NoFpTraps no_traps;
  // The period this build keeps: 1 ms, or 4x the slowest step seen in 300 ms (sanitizer
  // builds step ~20x slower), so that only waiting on the UI could make a step late.
  std::int64_t period_ns = 1'000'000;
  {
    HeadlessViewer probe(kBoxes);
    for (int i = 0; i < 40; ++i) probe.frame();
    const LatencyHistory& h = probe.viewer.session().history();
    const float slowest_us = *std::max_element(h.compute_us.begin(), h.compute_us.end());
    period_ns = std::max<std::int64_t>(period_ns, static_cast<std::int64_t>(4.0f * slowest_us * 1000.0f));
  }
  HeadlessViewer v(kBoxes, 50, period_ns);
  for (int i = 0; i < 10; ++i) v.frame();
  const LatencyHistory& h = v.viewer.session().history();
  const std::uint64_t steps = h.steps, misses = h.misses;
  constexpr std::int64_t kStallNs = 600'000'000;
  std::this_thread::sleep_for(std::chrono::nanoseconds(kStallNs));  // the UI stalls
  v.frame();
  // Every step of the stall was taken on time and reached the UI afterwards.
  const std::uint64_t stalled_steps = h.steps - steps;
  INFO("period " << period_ns << " ns: " << stalled_steps << " steps and " << h.misses - misses << " misses during the stall");
  CHECK(static_cast<double>(stalled_steps) >= 0.9 * static_cast<double>(kStallNs / period_ns));
  // A physics thread held back by the UI would stop stepping or miss nearly every deadline of
  // the stall; this VM also pauses a SCHED_FIFO thread now and then (4 misses in 614 steps in
  // one CI run), so the bound is 5 % of the stall's steps, not a handful.
  CHECK(static_cast<double>(h.misses - misses) <= 0.05 * static_cast<double>(stalled_steps));
  CHECK(v.viewer.session().counters().telemetry_dropped == 0);
}

TEST_CASE("UI scripts: errors name the file, the line and the field", "[viewer]") {
  const NoFpTraps no_traps;
  auto error_of = [](const std::string& text) {
    try {
      parse_ui_script(text, "ui.toml", "");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  CHECK(error_of("[[input]]\nat_ms = 5\nkey = \"p\"\n") == "ui.toml:1:1: duration_ms: missing required key (how long the run lasts, ms of simulated time)");
  CHECK(error_of("duration_ms = 100\n[[input]]\nat_ms = 5\npress = \"lft\"\n") ==
        "ui.toml:4:9: input[0].press: unknown button 'lft' (valid: left, right, middle)");
  CHECK(error_of("duration_ms = 100\n[[input]]\nat_ms = 50\nkey = \"p\"\n[[input]]\nat_ms = 10\nkey = \"p\"\n") ==
        "ui.toml:6:9: input[1].at_ms: inputs must be in time order");
  CHECK(error_of("duration_ms = 100\n[[input]]\nat_ms = 5\nmose = [1, 2]\n").find("ui.toml:4:1: input[0].mose: unknown key 'mose'; did you mean 'mouse'?") == 0);
  CHECK(error_of("duration_ms = 100\n[[input]]\nat_ms = 5\n") == "ui.toml:2:1: input[0]: does nothing: give a cursor target, press, release, key, text or wheel");
  CHECK(error_of("duration_ms = 100\n[[input]]\nat_ms = 500\nkey = \"p\"\n") == "ui.toml:3:9: input[0].at_ms: is at or after the end of the run (duration_ms)");

  // A widget the viewer does not show is reported when the script reaches it.
  HeadlessViewer v(kBoxes);
  ScriptedInput input(parse_ui_script("duration_ms = 500\n[[input]]\nat_ms = 10\nwidget = \"alpah\"\n", "ui.toml", ""));
  v.frame();
  const auto step = [&] { return input.next(v.viewer, 1000, 0.001, 640, 480); };
  CHECK_THROWS_WITH(step(), Catch::Contains("ui.toml:2:1: input[0].widget: no widget 'alpah' is shown"));
}
