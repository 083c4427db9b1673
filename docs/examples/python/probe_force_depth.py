#!/usr/bin/env python3
"""Drive the haptic probe down into a soft block and plot the force it renders against depth.

    PYTHONPATH=build/python python3 docs/examples/python/probe_force_depth.py [OUT.png]

The scene is scenarios/scenes/probe_box.toml: a 20 x 10 x 20 cm block on the floor, a probe
sphere coupled to a device position by a spring (the virtual coupling). The device moves
down at a constant speed, as a hand would; every step the probe's force is read back and
plotted against how far the device has gone below the block's top (the probe's sphere stays
at the surface, held by the contact: the coupling spring between them is what is felt).
"""
import os
import sys

import matplotlib

matplotlib.use("Agg")  # no display needed
import matplotlib.pyplot as plt
import numpy as np

import ffdsim

HERE = os.path.dirname(os.path.abspath(__file__))
SCENE = os.path.join(HERE, "..", "..", "..", "scenarios", "scenes", "probe_box.toml")


def main(out_path):
    sim = ffdsim.Simulation(SCENE)
    block = sim.object("block")
    sim.step(300)                                  # the block settles on the floor
    top = block.surface_vertices()[:, 1].max()     # m: its top face (the surface, not the lattice)
    radius = 0.012                                 # m: the probe's radius (the scene's [probe] radius)
    start = np.array([0.0, top + radius + 0.01, 0.0])
    sim.set_probe(start)
    sim.step(300)                                  # the probe comes to rest 1 cm above the block
    speed = 0.02                       # m/s: the device's descent
    depths, forces = [], []
    steps = int(0.04 / speed / sim.dt)  # down 4 cm: the device ends 3 cm into the block
    for i in range(steps):
        device = start - np.array([0.0, speed * sim.dt * i, 0.0])
        sim.set_probe(device)
        sim.step()
        depths.append(top - (device[1] - radius))       # m: how far the device is into the top face
        forces.append(sim.probe_force[1])             # N: upwards on the device
    depths, forces = np.array(depths), np.array(forces)

    plt.figure(figsize=(6, 4))
    plt.plot(depths * 1000.0, forces)
    plt.xlabel("device depth below the block's top (mm)")
    plt.ylabel("rendered force, up (N)")
    plt.title("ffdsim: probe pressed into a soft block")
    plt.grid(True, alpha=0.3)
    plt.tight_layout()
    plt.savefig(out_path, dpi=100)
    print(f"{out_path}: {len(depths)} steps; with the device {depths[-1] * 1000:.1f} mm deep the block pushes "
          f"back {forces[-1]:.2f} N")
    # Nothing pushes back above the block, and it pushes back harder the deeper the device goes.
    above, shallow, deep = forces[(depths > -0.008) & (depths < -0.002)], forces[np.abs(depths - 0.01) < 0.001], forces[depths > 0.025]
    if not (np.abs(above).max() < 0.05 and deep.mean() > shallow.mean() > 0.1):
        sys.exit("probe_force_depth: the force did not rise with depth")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "probe_force_depth.png")
