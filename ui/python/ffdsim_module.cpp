// The Python module `ffdsim` (docs/python.md): a scene stepped from Python, its lattice and
// surfaces as NumPy arrays, the viewer's live commands, recordings and replays.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <atomic>
#include <cctype>
#include <optional>
#include <stdexcept>
#include <string>

#include "ffd/measure.h"
#include "ffd/replay_runner.h"
#include "ffd/replay_script.h"
#include "ffd/scene_loader.h"
#include "simulation.h"

namespace py = pybind11;
using namespace pybind11::literals;

namespace ffd::python {

namespace {

PyObject* g_scene_error = nullptr;   // ffdsim.SceneError
PyObject* g_replay_error = nullptr;  // ffdsim.ReplayError

// Where a loader's message places its problem: "scene.toml:12:5: ..." gives the file, the
// line and the column; a message without one ("scene.toml: object 'box': ...") the file alone.
struct Place {
  std::optional<std::string> file;
  std::optional<int> line, column;
};

Place place_of(const std::string& message) {
  auto digits_at = [&](std::size_t i, std::size_t& end) {
    end = i;
    while (end < message.size() && end - i < 9 && std::isdigit(static_cast<unsigned char>(message[end]))) ++end;
    return end > i;
  };
  for (std::size_t colon = message.find(':'); colon != std::string::npos; colon = message.find(':', colon + 1)) {
    std::size_t line_end = 0, column_end = 0;
    if (digits_at(colon + 1, line_end) && line_end < message.size() && message[line_end] == ':' &&
        digits_at(line_end + 1, column_end) && message.compare(column_end, 2, ": ") == 0)
      return {message.substr(0, colon), std::stoi(message.substr(colon + 1, line_end - colon - 1)),
              std::stoi(message.substr(line_end + 1, column_end - line_end - 1))};
  }
  const std::size_t colon = message.find(": ");
  if (colon == std::string::npos) return {};
  return {message.substr(0, colon), std::nullopt, std::nullopt};
}

// Raises `type` (SceneError or ReplayError) with the loader's message, and its place as the
// attributes file, line and column (None where it has none).
[[noreturn]] void raise_input_error(PyObject* type, const std::string& message) {
  py::object error = py::reinterpret_steal<py::object>(PyObject_CallFunction(type, "s", message.c_str()));
  if (!error) throw py::error_already_set();
  const Place place = place_of(message);
  error.attr("file") = place.file ? py::cast(*place.file) : py::none();
  error.attr("line") = place.line ? py::cast(*place.line) : py::none();
  error.attr("column") = place.column ? py::cast(*place.column) : py::none();
  PyErr_SetObject(type, error.ptr());
  throw py::error_already_set();
}

// A read-only (N, 3) float64 view of `n` Vec3s that keeps `owner` alive.
py::array vec3_view(const Vec3* data, std::size_t n, py::handle owner) {
  static_assert(sizeof(Vec3) == 3 * sizeof(double));
  py::array_t<double> a({n, std::size_t{3}}, {sizeof(Vec3), sizeof(double)}, data ? data->data() : nullptr, owner);
  a.attr("setflags")("write"_a = false);
  return a;
}

py::array vec3_copy(const Vec3& v) {
  py::array_t<double> a(3);
  for (int i = 0; i < 3; ++i) a.mutable_at(i) = v[i];
  return a;
}

Vec3 to_vec3(const std::array<double, 3>& v) { return Vec3(v[0], v[1], v[2]); }

// The Python object for a Simulation, with the flag that keeps two threads from stepping it
// at once (step() runs without the GIL).
struct PySimulation {
  std::unique_ptr<Simulation> sim;
  std::atomic<bool> stepping{false};

  Simulation& get() {
    if (stepping.load()) throw std::runtime_error("the simulation is stepping on another thread");
    return *sim;
  }
  Index object(const py::object& which) {
    if (py::isinstance<py::str>(which)) return sim->object_index(which.cast<std::string>());
    const long long i = which.cast<long long>();
    if (i < 0 || i >= static_cast<long long>(sim->model().objects.size()))
      throw py::index_error("object index " + std::to_string(i) + " is out of range (the scene has " +
                            std::to_string(sim->model().objects.size()) + " objects)");
    return static_cast<Index>(i);
  }
  void queue(Command c) { get().queue(c); }
};

// One object of a simulation: views into its lattice, its surface.
struct ObjectHandle {
  py::object owner;  // the PySimulation, kept alive by every view made from here
  Index index;
  PySimulation& sim() const { return owner.cast<PySimulation&>(); }
  const ObjectModel& model() const { return sim().get().model().objects[index]; }
  // A read-only view of this object's rows of a per-node array (State::x, State::v, ...).
  py::array node_view(const std::vector<Vec3>& all) const {
    const ObjectModel& om = model();
    return vec3_view(all.data() + om.node_begin, om.node_end - om.node_begin, owner);
  }
};

template <class Load>
std::unique_ptr<PySimulation> load_simulation(Load load) {
  auto out = std::make_unique<PySimulation>();
  try {
    out->sim = load();
  } catch (const InputError& e) {
    raise_input_error(g_scene_error, e.what());
  }
  return out;
}

py::dict contacts_dict(const Simulation& sim) {
  const std::span<const Contact> contacts = sim.contacts();
  const std::size_t n = contacts.size();
  py::array_t<double> point({n, std::size_t{3}}), normal({n, std::size_t{3}}), depth(n);
  py::list kind;
  static const char* const kKinds[] = {"inter", "self", "plane", "probe"};
  for (std::size_t i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) {
      point.mutable_at(i, k) = contacts[i].point[k];
      normal.mutable_at(i, k) = contacts[i].normal[k];
    }
    depth.mutable_at(i) = contacts[i].depth;
    kind.append(kKinds[static_cast<int>(contacts[i].kind)]);
  }
  return py::dict("point"_a = point, "normal"_a = normal, "depth"_a = depth, "kind"_a = kind,
                  "dropped"_a = sim.last_report().contacts_dropped);
}

py::dict stage_times(const Simulation& sim) {
  py::dict out;
  const StepReport& r = sim.last_report();
  for (Stage stage : sim.model().pipeline) {
    const std::int64_t ns = r.stage_ns[static_cast<std::size_t>(stage)];
    if (ns >= 0) out[stage_name(stage)] = static_cast<double>(ns) * 1e-9;
  }
  out["step"] = static_cast<double>(r.total_ns) * 1e-9;
  return out;
}

py::dict surface_contacts(const Simulation& sim, double search_radius) {
  const SurfaceContactReport report = measure_surface_contacts(sim.model(), sim.state(), search_radius);
  py::list contacts;
  for (const SurfaceContact& c : report.contacts)
    contacts.append(py::dict("a"_a = c.a, "b"_a = c.b, "penetration_m"_a = c.penetration_m, "gap_m"_a = c.gap_m,
                             "penetrating_vertices"_a = c.penetrating_vertices));
  return py::dict("contacts"_a = contacts, "max_penetration_m"_a = report.max_penetration_m,
                  "max_gap_m"_a = report.max_gap_m, "search_radius_m"_a = report.search_radius_m);
}

py::dict replay_figures(const ReplayResult& r) {
  auto optional = [](const auto& v) { return v ? py::cast(*v) : py::none(); };
  return py::dict("steps"_a = r.steps, "finite"_a = r.finite, "max_energy_j"_a = r.max_energy_j,
                  "max_speed_m_s"_a = r.max_speed_m_s, "max_penetration_m"_a = r.max_penetration_m,
                  "peak_force_n"_a = r.peak_force_n, "mean_contacts"_a = r.mean_contacts,
                  "time_to_rest_s"_a = optional(r.time_to_rest_s), "force_ripple"_a = optional(r.force_ripple),
                  "compute_p50_us"_a = r.latency.compute.p50_us, "compute_p99_us"_a = r.latency.compute.p99_us,
                  "compute_max_us"_a = r.latency.compute.max_us, "commands_rejected"_a = r.commands_rejected);
}

struct PyReplayResult {
  ReplayResult result;
  std::string text, json;
};

}  // namespace

}  // namespace ffd::python

PYBIND11_MODULE(ffdsim, m) {
  using namespace ffd;
  using namespace ffd::python;
  m.doc() = R"(ffdsim: deformable objects embedded in FFD lattices, with FFD AABB collision handling.

    sim = ffdsim.Simulation("scene.toml")     # or Simulation.from_string(text)
    sim.step(1000)                            # 1000 steps of sim.dt seconds, GIL released
    teapot = sim.object("teapot")
    teapot.nodes                              # (N, 3) float64, a read-only view of the lattice
    teapot.surface_vertices()                 # (V, 3) float64, the embedded surface (a copy)
    sim.set_beta(0.4)                         # live commands apply at the start of the next step
    sim.save_recording("run.toml")            # `ffdsim replay run.toml` reproduces it bit for bit

See docs/python.md.)";
  g_scene_error = PyErr_NewExceptionWithDoc(
      "ffdsim.SceneError",
      "A scene that does not load or compile. Attributes: file, line, column (None where the problem has no place "
      "in the file) and the message as str(error).",
      PyExc_ValueError, nullptr);
  g_replay_error = PyErr_NewExceptionWithDoc(
      "ffdsim.ReplayError", "A replay script that does not load. Attributes: file, line, column, as SceneError.",
      PyExc_ValueError, nullptr);
  m.attr("SceneError") = py::handle(g_scene_error);
  m.attr("ReplayError") = py::handle(g_replay_error);
  m.attr("__version__") = ffdsim_version();
  m.attr("ACCURACY_LEVELS") = kAccuracyLevels;

  py::class_<ObjectHandle>(m, "Object", "One deformable object of a Simulation: its lattice and its embedded surface.")
      .def_property_readonly("name", [](const ObjectHandle& o) { return o.model().name; })
      .def_property_readonly("index", [](const ObjectHandle& o) { return o.index; })
      .def_property_readonly(
          "nodes",
          [](const ObjectHandle& o) { return o.node_view(o.sim().get().state().x); },
          "(N, 3) float64, m: the lattice node positions. A read-only view: it follows the simulation as it steps "
          "and keeps the simulation alive.")
      .def_property_readonly(
          "velocities",
          [](const ObjectHandle& o) { return o.node_view(o.sim().get().state().v); },
          "(N, 3) float64, m/s: the lattice node velocities. A read-only view, as nodes.")
      .def_property_readonly(
          "rest_nodes",
          [](const ObjectHandle& o) { return o.node_view(o.sim().get().model().node_rest); },
          "(N, 3) float64, m: the lattice node positions at rest, before the object is placed. A read-only view.")
      .def_property_readonly(
          "triangles",
          [](const ObjectHandle& o) {
            const auto& t = o.model().surface.triangles;
            static_assert(sizeof(t[0]) == 3 * sizeof(Index));
            py::array_t<Index> a({t.size(), std::size_t{3}}, {sizeof(t[0]), sizeof(Index)}, t.empty() ? nullptr : t[0].data(),
                                 o.owner);
            a.attr("setflags")("write"_a = false);
            return py::array(std::move(a));
          },
          "(F, 3) uint32: the embedded surface's triangles, counter-clockwise seen from outside, indexing "
          "surface_vertices(). A read-only view.")
      .def(
          "surface_vertices",
          [](const ObjectHandle& o) {
            const Simulation& sim = o.sim().get();
            const std::vector<Vec3> vertices = deformed_surface(sim.model(), sim.state(), o.index).vertices;
            py::array_t<double> a({vertices.size(), std::size_t{3}});
            for (std::size_t v = 0; v < vertices.size(); ++v)
              for (int k = 0; k < 3; ++k) a.mutable_at(v, k) = vertices[v][k];
            return a;
          },
          "(V, 3) float64, m: the embedded surface's vertices where the lattice has moved them now (eq. 1, "
          "trilinear FFD). A copy: computed at each call.")
      .def("__repr__", [](const ObjectHandle& o) {
        const ObjectModel& om = o.model();
        return "<ffdsim.Object '" + om.name + "': " + std::to_string(om.node_end - om.node_begin) + " nodes, " +
               std::to_string(om.surface.triangles.size()) + " triangles>";
      });

  py::class_<PySimulation>(m, "Simulation",
                           "A scene stepped on the calling thread (and `threads` - 1 workers), as `ffdsim simulate` "
                           "steps it: the same state hashes for the same steps and commands.")
      .def(py::init([](const std::optional<std::string>& path, int threads, std::uint32_t hash_every) {
             return load_simulation(
                 [&] { return Simulation::from_file(path ? *path : default_scene_path(), threads, hash_every); });
           }),
           "path"_a = py::none(), "threads"_a = 0, "hash_every"_a = 100,
           "Loads a scene file (TOML; None: the default scene, two teapots). threads: a step is spread over this many threads, 0 for the command line's "
           "default (the results are the same whatever the count). hash_every: steps between the state hashes "
           "save_recording() writes. Raises SceneError with the file, line and column.")
      .def_static(
          "from_string",
          [](const std::string& text, const std::string& base_dir, const std::string& name, int threads,
             std::uint32_t hash_every) {
            return load_simulation([&] { return Simulation::from_text(text, name, base_dir, threads, hash_every); });
          },
          "text"_a, "base_dir"_a = ".", "name"_a = "<string>", "threads"_a = 0, "hash_every"_a = 100,
          "A scene from TOML text. Mesh paths are read relative to base_dir; errors name `name` as their file.")
      .def(
          "step",
          [](PySimulation& s, long long n) {
            if (n < 0) throw py::value_error("step(n): n must be >= 0 (got " + std::to_string(n) + ")");
            bool idle = false;
            if (!s.stepping.compare_exchange_strong(idle, true))
              throw std::runtime_error("the simulation is stepping on another thread");
            struct Done {
              std::atomic<bool>& flag;
              ~Done() { flag.store(false); }
            } done{s.stepping};
            py::gil_scoped_release release;
            s.sim->step(static_cast<std::uint64_t>(n));
          },
          "n"_a = 1,
          "Takes n steps of dt seconds, the GIL released meanwhile. Commands given since the last step apply at the "
          "start of the first.")
      .def_property_readonly("steps", [](PySimulation& s) { return s.get().state().step; }, "Steps taken.")
      .def_property_readonly("dt", [](PySimulation& s) { return s.get().model().settings.dt; }, "The step, s.")
      .def_property_readonly(
          "time", [](PySimulation& s) { return static_cast<double>(s.get().state().step) * s.get().model().settings.dt; },
          "Simulated time, s (steps x dt).")
      .def_property_readonly("threads", [](PySimulation& s) { return s.get().threads(); })
      .def_property_readonly("scene_path", [](PySimulation& s) { return s.get().scene_path(); },
                             "The scene file, absolute ('' for a scene given as text).")
      .def("state_hash", [](PySimulation& s) { return hash_hex(state_hash(s.get().state())); },
           "The state hash `ffdsim simulate` prints: 16 hex digits over every node's x and v and the probe's.")
      .def_property_readonly(
          "objects",
          [](py::object self) {
            py::list out;
            PySimulation& s = self.cast<PySimulation&>();
            for (Index o = 0; o < s.get().model().objects.size(); ++o) out.append(ObjectHandle{self, o});
            return out;
          },
          "The scene's objects, in scene order.")
      .def(
          "object", [](py::object self, const py::object& which) { return ObjectHandle{self, self.cast<PySimulation&>().object(which)}; },
          "name_or_index"_a, "One object, by name or index.")
      .def_property_readonly(
          "nodes", [](py::object self) {
            const State& st = self.cast<PySimulation&>().get().state();
            return vec3_view(st.x.data(), st.x.size(), self);
          },
          "(N, 3) float64, m: every object's lattice nodes, in object order. A read-only view.")
      .def_property_readonly(
          "velocities", [](py::object self) {
            const State& st = self.cast<PySimulation&>().get().state();
            return vec3_view(st.v.data(), st.v.size(), self);
          },
          "(N, 3) float64, m/s: every lattice node's velocity. A read-only view.")
      // Live parameters, as they are now.
      .def_property_readonly("alpha", [](PySimulation& s) { return s.get().state().params.alpha; })
      .def_property_readonly("beta", [](PySimulation& s) { return s.get().state().params.beta; })
      .def_property_readonly("accuracy", [](PySimulation& s) { return static_cast<int>(s.get().state().params.accuracy); })
      .def_property_readonly("response", [](PySimulation& s) { return std::string(response_name(s.get().state().params.response)); })
      .def_property_readonly("probe_force", [](PySimulation& s) { return vec3_copy(s.get().state().probe.force); },
                             "(3,) N: the force the probe renders to its device (the virtual coupling's).")
      .def_property_readonly("probe_position", [](PySimulation& s) { return vec3_copy(s.get().state().probe.x); },
                             "(3,) m: the probe's proxy sphere, which follows the device pose.")
      .def_property_readonly("grab_force",
                             [](PySimulation& s) {
                               const GrabState& g = s.get().state().grab;
                               return vec3_copy(g.active ? g.force : Vec3::Zero());
                             },
                             "(3,) N: the grab spring's force on the object (zeros when nothing is grabbed).")
      // Live commands: applied at the start of the next step and recorded.
      .def("set_alpha", [](PySimulation& s, double v) { s.queue({.kind = CommandKind::SetAlpha, .value = v}); },
           "alpha"_a, "Collision damping alpha of eq. 8, in [0, 1].")
      .def("set_beta", [](PySimulation& s, double v) { s.queue({.kind = CommandKind::SetBeta, .value = v}); }, "beta"_a,
           "Friction beta of eq. 8, in [0, 1].")
      .def("set_gravity",
           [](PySimulation& s, std::array<double, 3> g) { s.queue({.kind = CommandKind::SetGravity, .vector = to_vec3(g)}); },
           "gravity"_a, "m/s^2, as (x, y, z).")
      .def("set_stiffness",
           [](PySimulation& s, const py::object& object, double v) {
             s.queue({.kind = CommandKind::SetStiffness, .object = s.object(object), .value = v});
           },
           "object"_a, "stiffness"_a,
           "An object's stiffness: N/m per spring (mass_spring) or the pull fraction in (0, 1] (shape_matching).")
      .def("set_probe_stiffness",
           [](PySimulation& s, double v) { s.queue({.kind = CommandKind::SetProbeStiffness, .value = v}); }, "stiffness"_a,
           "N/m: the probe's virtual coupling spring (scene with the \"probe\" effect).")
      .def("set_accuracy",
           [](PySimulation& s, int level) { s.queue({.kind = CommandKind::SetAccuracy, .value = static_cast<double>(level)}); },
           "level"_a, "Collision accuracy level 0..5 (docs/accuracy.md).")
      .def("set_response",
           [](PySimulation& s, const std::string& name) {
             ContactResponse r;
             if (!response_from_name(name, r)) throw py::value_error("response must be 'paper' or 'solver' (got '" + name + "')");
             s.queue({.kind = CommandKind::SetResponse, .value = static_cast<double>(r)});
           },
           "name"_a, "The contact response: 'paper' or 'solver'.")
      .def("set_probe",
           [](PySimulation& s, std::array<double, 3> p) { s.queue({.kind = CommandKind::ProbePose, .vector = to_vec3(p)}); },
           "position"_a, "m: the probe device's position (scene with the \"probe\" effect).")
      .def("grab",
           [](PySimulation& s, const py::object& object, long long vertex) {
             const ObjectModel& om = s.get().model().objects[s.object(object)];
             if (vertex < 0 || vertex >= static_cast<long long>(om.vertex_local.size()))
               throw py::index_error("vertex " + std::to_string(vertex) + " is out of range ('" + om.name + "' has " +
                                     std::to_string(om.vertex_local.size()) + " surface vertices)");
             s.queue({.kind = CommandKind::Grab,
                      .cell = om.vertex_cell[static_cast<std::size_t>(vertex)],
                      .local = om.vertex_local[static_cast<std::size_t>(vertex)]});
           },
           "object"_a, "vertex"_a,
           "Grabs an object at one of its surface vertices (scene with the \"grab\" effect); drag() moves the target.")
      .def("drag", [](PySimulation& s, std::array<double, 3> t) { s.queue({.kind = CommandKind::Drag, .vector = to_vec3(t)}); },
           "target"_a, "m: where the grabbed point is pulled to.")
      .def("release", [](PySimulation& s) { s.queue({.kind = CommandKind::Release}); }, "Lets go of the grabbed point.")
      .def("reset", [](PySimulation& s) { s.queue({.kind = CommandKind::Reset}); },
           "Back to the scene's initial state at the next step (the step count goes on).")
      // What the last step did.
      .def("contacts", [](PySimulation& s) { return contacts_dict(s.get()); },
           "The last step's contacts (the contact record): a dict of point (K, 3) m, normal (K, 3), depth (K,) m, "
           "kind (K names: inter, self, plane, probe) and dropped (contacts beyond the record's room). Copies.")
      .def("stage_times", [](PySimulation& s) { return stage_times(s.get()); },
           "The last step's wall time per stage that ran, and 'step' for the whole step, in seconds.")
      .def("surface_contacts", [](PySimulation& s, double radius) { return surface_contacts(s.get(), radius); },
           "search_radius"_a = 0.0,
           "The surface contact measure: for each pair of surfaces (or surface and plane) within search_radius "
           "(m; 0: the largest cell size), the deepest penetration and the gap, m.")
      .def("save_recording",
           [](PySimulation& s, const std::string& path) { s.get().save_recording(path); }, "path"_a,
           "Writes the session so far as a replay script: `ffdsim replay PATH` reproduces it bit for bit. A scene "
           "given as text is written beside it as STEM.scene.toml.")
      .def("__repr__", [](PySimulation& s) {
        const Simulation& sim = s.get();
        return "<ffdsim.Simulation '" + sim.name() + "': " + std::to_string(sim.model().objects.size()) +
               " objects, step " + std::to_string(sim.state().step) + ">";
      });

  py::class_<AssertionResult>(m, "Assertion", "One assertion of a replay script and what the run measured.")
      .def_readonly("name", &AssertionResult::name)
      .def_readonly("where", &AssertionResult::where, "file:line:column of the assertion in the script")
      .def_readonly("passed", &AssertionResult::passed)
      .def_readonly("skipped", &AssertionResult::skipped, "not measurable in this run (latency in a sanitizer build)")
      .def_readonly("measured", &AssertionResult::measured)
      .def_readonly("limit", &AssertionResult::limit)
      .def("__repr__", [](const AssertionResult& a) {
        return std::string("<") + (a.skipped ? "SKIP" : a.passed ? "PASS" : "FAIL") + " " + a.name + ": " + a.measured +
               " (limit " + a.limit + ")>";
      });

  py::class_<PyReplayResult>(m, "ReplayResult", "What `ffdsim replay` reports: the assertions and the run's figures.")
      .def_property_readonly("passed", [](const PyReplayResult& r) { return r.result.passed(); })
      .def_property_readonly("assertions", [](const PyReplayResult& r) { return r.result.assertions; })
      .def_property_readonly("figures", [](const PyReplayResult& r) { return replay_figures(r.result); },
                             "steps, finite, maxima (energy J, speed m/s, penetration m, force N) and step times (us).")
      .def_property_readonly("final_hash", [](const PyReplayResult& r) { return hash_hex(r.result.final_hash); })
      .def_property_readonly("first_divergence",
                             [](const PyReplayResult& r) { return r.result.first_divergence ? py::cast(*r.result.first_divergence) : py::none(); },
                             "The first step whose state hash differed from the recording's, or None.")
      .def_property_readonly("report", [](const PyReplayResult& r) { return py::module_::import("json").attr("loads")(r.json); },
                             "The JSON report of `ffdsim replay --report`, as Python objects.")
      .def("__str__", [](const PyReplayResult& r) { return r.text; });

  m.def(
      "replay",
      [](const std::string& path, int threads, bool check_latency) {
        ReplayRunOptions run;
        run.threads = thread_count(threads);  // a bad count before the script's load
        run.check_latency = check_latency;
        auto out = std::make_unique<PyReplayResult>();
        LoadedReplay replay;
        try {
          replay = load_replay_file(path);
        } catch (const InputError& e) {
          raise_input_error(g_replay_error, e.what());
        }
        {
          py::gil_scoped_release release;
          out->result = run_replay(replay, run);
        }
        out->text = format_replay_result(replay.script, out->result);
        out->json = replay_result_json(replay.script, out->result);
        return out;
      },
      "path"_a, "threads"_a = 0, "check_latency"_a = true,
      "Runs a replay script or recording as `ffdsim replay PATH --fast` does, the GIL released meanwhile, and "
      "returns its ReplayResult. Raises ReplayError with the file, line and column for a script that does not load.");
}
