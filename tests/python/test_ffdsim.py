"""The Python module ffdsim (docs/python.md), run by ctest through pytest.

FFDSIM_BINARY names the ffdsim program the results are compared with; FFDSIM_SCENARIOS the
scenarios folder.
"""
import gc
import json
import os
import subprocess
import threading

import numpy as np
import pytest

import ffdsim

BINARY = os.environ["FFDSIM_BINARY"]
SCENES = os.path.join(os.environ["FFDSIM_SCENARIOS"], "scenes")
TEAPOTS = os.path.join(SCENES, "two_teapots.toml")
PROBE_BOX = os.path.join(SCENES, "probe_box.toml")


def ffdsim_cli(*args):
    r = subprocess.run([BINARY, *args], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr
    return r


def test_stepping_gives_the_state_hash_of_ffdsim_simulate(tmp_path):
    sim = ffdsim.Simulation(TEAPOTS)
    sim.step(150)
    sim.step(0)
    for _ in range(50):
        sim.step()
    assert sim.steps == 200
    assert sim.time == pytest.approx(200 * sim.dt)
    report = tmp_path / "report.json"
    ffdsim_cli("simulate", TEAPOTS, "--steps", "200", "-q", "--report", str(report))
    assert sim.state_hash() == json.loads(report.read_text())["state_hash"]


def test_the_thread_count_does_not_change_the_state():
    hashes = set()
    for threads in (1, 2):
        sim = ffdsim.Simulation(TEAPOTS, threads=threads)
        assert sim.threads == threads
        sim.step(100)
        hashes.add(sim.state_hash())
    assert len(hashes) == 1


def test_a_recording_made_in_python_replays_bit_identically(tmp_path):
    sim = ffdsim.Simulation(PROBE_BOX, hash_every=25)
    sim.step(40)
    sim.set_probe((0.0, 0.11, 0.0))
    sim.set_beta(0.3)
    sim.set_alpha(0.8)
    sim.step(60)
    sim.set_probe_stiffness(500.0)
    sim.set_gravity((0.0, -5.0, 0.0))
    sim.set_stiffness("block", 3000.0)
    sim.set_accuracy(2)
    sim.set_response("solver")
    sim.step(50)
    sim.reset()
    sim.step(30)
    recording = tmp_path / "session.toml"
    sim.save_recording(str(recording))
    r = ffdsim_cli("replay", str(recording), "--fast", "--report", str(tmp_path / "replay.json"))
    report = json.loads((tmp_path / "replay.json").read_text())
    assert report["passed"], r.stdout
    assert report["final_state_hash"] == sim.state_hash()
    # The same from Python, and every recorded hash was checked.
    result = ffdsim.replay(str(recording), check_latency=False)
    assert result.passed and result.first_divergence is None
    assert result.final_hash == sim.state_hash()
    hashes = [a for a in result.assertions if a.name == "determinism.state_hash"]
    assert hashes and hashes[0].passed and hashes[0].measured.startswith("8 of 8")
    assert result.figures["steps"] == 180


def test_a_recording_of_a_scene_given_as_text_writes_the_scene_beside_it(tmp_path):
    with open(PROBE_BOX) as f:
        text = f.read()
    sim = ffdsim.Simulation.from_string(text)
    sim.step(20)
    sim.set_beta(0.1)
    sim.step(20)
    sim.save_recording(str(tmp_path / "run.toml"))
    assert (tmp_path / "run.scene.toml").read_text() == text
    assert ffdsim.replay(str(tmp_path / "run.toml"), check_latency=False).final_hash == sim.state_hash()
    # A mesh read relative to base_dir would not be found from another folder: refused.
    with open(TEAPOTS) as f:
        teapots = ffdsim.Simulation.from_string(f.read(), base_dir=SCENES)
    teapots.step()
    with pytest.raises(RuntimeError, match="teapot.obj"):
        teapots.save_recording(str(tmp_path / "teapots.toml"))
    assert not (tmp_path / "teapots.toml").exists()


def test_arrays_have_the_documented_shapes_and_dtypes():
    sim = ffdsim.Simulation(TEAPOTS)
    assert [o.name for o in sim.objects] == ["teapot_low", "teapot_high"]
    teapot = sim.object("teapot_high")
    assert sim.object(1).name == "teapot_high"
    n = teapot.nodes.shape[0]
    for array in (teapot.nodes, teapot.velocities, teapot.rest_nodes):
        assert array.shape == (n, 3) and array.dtype == np.float64
        assert not array.flags.writeable
        with pytest.raises(ValueError):
            array[0, 0] = 1.0
    assert sim.nodes.shape == (sum(o.nodes.shape[0] for o in sim.objects), 3)
    triangles = teapot.triangles
    vertices = teapot.surface_vertices()
    assert triangles.dtype == np.uint32 and triangles.shape[1] == 3 and triangles.max() < vertices.shape[0]
    assert vertices.dtype == np.float64 and vertices.shape[1] == 3 and vertices.flags.writeable
    # Views follow the simulation; the surface copy is where the lattice put it.
    start = teapot.nodes.copy()
    surface = teapot.surface_vertices()
    view = teapot.nodes
    sim.step(50)
    assert not np.array_equal(view, start)
    assert np.array_equal(view, sim.object("teapot_high").nodes)
    assert np.array_equal(view, sim.nodes[sim.nodes.shape[0] - n:])
    moved = teapot.surface_vertices() - surface
    assert np.all(moved[:, 1] < 0.0)  # falling under gravity
    assert np.abs(teapot.velocities[:, 1]).max() > 0.0


def test_what_the_last_step_did():
    sim = ffdsim.Simulation(TEAPOTS)
    sim.step(300)
    contacts = sim.contacts()
    k = contacts["depth"].shape[0]
    assert k > 0
    assert contacts["point"].shape == (k, 3) and contacts["normal"].shape == (k, 3)
    assert np.allclose(np.linalg.norm(contacts["normal"], axis=1), 1.0)
    assert set(contacts["kind"]) <= {"inter", "self", "plane", "probe"}
    times = sim.stage_times()
    assert times["step"] > 0.0 and "dynamics" in times and "broad_phase" in times
    measure = sim.surface_contacts()
    assert {(c["a"], c["b"]) for c in measure["contacts"]} >= {("teapot_low", "floor")}
    assert measure["max_gap_m"] >= 0.0


def test_the_probe_renders_a_force_when_pressed():
    sim = ffdsim.Simulation(PROBE_BOX)
    sim.step(200)
    assert np.linalg.norm(sim.probe_force) < 1e-3
    sim.set_probe((0.0, 0.07, 0.0))  # 3 cm into the top of the block
    sim.step(300)
    assert sim.probe_force.shape == (3,)
    assert sim.probe_force[1] > 1.0


def test_grab_and_drag_lift_an_object():
    sim = ffdsim.Simulation(TEAPOTS)
    sim.grab("teapot_low", 0)
    sim.step()
    start = sim.object("teapot_low").surface_vertices()[0]
    sim.drag(start + np.array([0.0, 0.1, 0.0]))
    sim.step(300)
    assert sim.object("teapot_low").surface_vertices()[0][1] > start[1] + 0.05
    sim.release()
    sim.step()
    assert np.all(sim.grab_force == 0.0)


def test_a_bad_scene_raises_scene_error_with_its_line(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[simulation]\ndt = 0.001\nalpha = 7\n")
    with pytest.raises(ffdsim.SceneError) as e:
        ffdsim.Simulation(str(bad))
    assert e.value.file == str(bad) and e.value.line == 3 and e.value.column == 9
    assert "alpha" in str(e.value)
    assert isinstance(e.value, ValueError)
    with pytest.raises(ffdsim.SceneError) as e:
        ffdsim.Simulation.from_string("[simulation]\nno_such_key = 1\n", name="typed")
    assert e.value.file == "typed" and e.value.line == 2
    with pytest.raises(ffdsim.SceneError, match="no_such_file"):
        ffdsim.Simulation(str(tmp_path / "no_such_file.toml"))
    bad_replay = tmp_path / "bad_replay.toml"
    bad_replay.write_text('format = "ffdsim-replay"\nversion = 1\nscene = "nowhere.toml"\nsteps = 10\n')
    with pytest.raises(ffdsim.ReplayError) as e:
        ffdsim.replay(str(bad_replay))
    assert e.value.line == 3


def test_bad_calls_raise_and_leave_the_simulation_as_it_was():
    sim = ffdsim.Simulation(TEAPOTS)
    before = sim.state_hash()
    for call in (lambda: sim.set_alpha(2.0), lambda: sim.set_beta(float("nan")), lambda: sim.set_accuracy(9),
                 lambda: sim.set_gravity((0.0, float("inf"), 0.0)), lambda: sim.set_stiffness("teapot_low", -1.0),
                 lambda: sim.set_probe((float("nan"), 0.0, 0.0))):
        with pytest.raises(ValueError):
            call()
    with pytest.raises(IndexError, match="3241 surface vertices"):
        sim.grab("teapot_low", 10**9)
    with pytest.raises(ValueError, match="teapot_low, teapot_high"):
        sim.object("kettle")
    with pytest.raises(IndexError):
        sim.object(2)
    with pytest.raises(ValueError, match="paper"):
        sim.set_response("fast")
    with pytest.raises(ValueError):
        sim.step(-1)
    for threads in (-1, 65):
        with pytest.raises(ValueError, match="threads"):
            ffdsim.Simulation(TEAPOTS, threads=threads)
        with pytest.raises(ValueError, match="threads"):  # before the script is read
            ffdsim.replay("/nonexistent/replay.toml", threads=threads)
    with pytest.raises(ValueError, match="hash_every"):
        ffdsim.Simulation(TEAPOTS, hash_every=0)
    with pytest.raises(RuntimeError, match="take a step"):
        sim.save_recording("/tmp/never_written.toml")
    sim.step(10)
    reference = ffdsim.Simulation(TEAPOTS)
    reference.step(10)
    assert sim.state_hash() == reference.state_hash() != before


def test_a_view_keeps_its_simulation_alive():
    sim = ffdsim.Simulation(TEAPOTS)
    sim.step(20)
    nodes = sim.object("teapot_low").nodes
    expected = nodes.copy()
    triangles = sim.objects[1].triangles
    del sim
    gc.collect()
    junk = [ffdsim.Simulation(TEAPOTS) for _ in range(2)]  # reuse freed memory, if any was freed
    assert np.array_equal(nodes, expected)
    assert triangles.shape[1] == 3 and triangles.max() > 0
    del junk


def test_step_releases_the_gil_and_refuses_a_second_stepper():
    sim = ffdsim.Simulation(TEAPOTS, threads=1)
    ticks, errors = [], []
    stepped = [0]
    started = threading.Event()

    def stepper():
        started.set()
        while True:  # the other thread may step first
            try:
                sim.step(1500)
                return
            except RuntimeError:
                pass

    def other():
        started.wait()
        while worker.is_alive():
            ticks.append(1)
            try:
                sim.step()
                stepped[0] += 1
            except RuntimeError as e:
                errors.append(str(e))
            threading.Event().wait(0.001)

    worker = threading.Thread(target=stepper)
    watcher = threading.Thread(target=other)
    worker.start()
    watcher.start()
    worker.join()
    watcher.join()
    assert len(ticks) > 5  # Python ran while the steps did
    assert errors and "another thread" in errors[0]
    assert sim.steps == 1500 + stepped[0]


def test_help_documents_the_module():
    assert "Simulation" in ffdsim.__doc__
    assert "read-only view" in ffdsim.Object.nodes.__doc__
    assert "GIL" in ffdsim.Simulation.step.__doc__
    assert ffdsim.__version__
