#!/usr/bin/env python3
"""Find, by bisection, the smallest friction beta (eq. 8) at which a block on a slope sticks.

    PYTHONPATH=build/python python3 docs/examples/python/tune_beta_slope.py [ANGLE_DEG] [OUT.png]

Each trial builds the scene as text (a block resting on a plane tilted by ANGLE_DEG), lets it
settle for 0.3 s, then measures how far it slides down the slope in the next second. A block
that moved less than 1 mm sticks. The plot shows the slide of every trial against its beta.
The scene uses the contact response "solver", whose friction holds a contact that sticks
(docs/step.md, "Two contact responses"); beta then plays the part of a Coulomb friction
coefficient, and the answer comes out near tan(angle).
"""
import math
import sys

import matplotlib

matplotlib.use("Agg")  # no display needed
import matplotlib.pyplot as plt
import numpy as np

import ffdsim

SCENE = """
[simulation]
dt = 0.001
gravity = [0.0, -9.81, 0.0]
alpha = 1.0
beta = {beta}
response = "solver"
effects = ["gravity", "planes", "friction"]

[[plane]]
name = "slope"
normal = [{nx}, {ny}, 0.0]
offset = 0.0

[[object]]
name = "block"
shape = "box"
size = [0.1, 0.05, 0.1]
position = [{px}, {py}, 0.0]
rotation_deg = [0.0, 0.0, {angle}]
cell_size = 0.025
mass = 0.5
  [object.mass_spring]
  stiffness = 4000.0
  damping = 0.5
  iterations = 4
"""

STICK_M = 0.001  # m: a block that slid less than this in a second sticks


def slide(beta, angle_deg):
    """Metres the block slid down the slope in the second after it settled."""
    a = math.radians(angle_deg)
    normal = np.array([math.sin(a), math.cos(a), 0.0])  # tilted about z: downhill is +x
    centre = normal * (0.025 + 0.0005)                   # resting on the plane
    text = SCENE.format(beta=beta, nx=normal[0], ny=normal[1], px=centre[0], py=centre[1], angle=-angle_deg)
    sim = ffdsim.Simulation.from_string(text, name=f"slope {angle_deg} deg, beta {beta:.4f}")
    block = sim.object("block")
    sim.step(300)
    before = block.nodes.mean(axis=0)
    sim.step(1000)
    downhill = np.array([math.cos(a), -math.sin(a), 0.0])
    return float((block.nodes.mean(axis=0) - before) @ downhill)


def main(angle_deg, out_path):
    trials = []
    low, high = 0.0, 1.0  # slides at beta = low, sticks at beta = high (checked first)
    for beta in (low, high):
        trials.append((beta, slide(beta, angle_deg)))
    if trials[0][1] < STICK_M or trials[1][1] >= STICK_M:
        sys.exit(f"tune_beta_slope: at {angle_deg} deg the block does not slide at beta 0 and stick at beta 1 "
                 f"(slides {trials[0][1] * 1000:.1f} mm and {trials[1][1] * 1000:.1f} mm)")
    while high - low > 1.0 / 64:
        beta = 0.5 * (low + high)
        moved = slide(beta, angle_deg)
        trials.append((beta, moved))
        if moved < STICK_M:
            high = beta
        else:
            low = beta
    print(f"a block on a {angle_deg} deg slope sticks from beta = {high:.4f} (slides at {low:.4f}; "
          f"tan(angle) = {math.tan(math.radians(angle_deg)):.4f}); {len(trials)} trials")

    betas, slides = np.array(trials).T
    order = np.argsort(betas)
    plt.figure(figsize=(6, 4))
    plt.semilogy(betas[order], np.maximum(slides[order], 1e-6) * 1000.0, "o-")
    plt.axhline(STICK_M * 1000.0, color="grey", linestyle="--", label="sticks below")
    plt.axvline(high, color="green", alpha=0.5, label=f"beta = {high:.3f}")
    plt.xlabel("friction beta (eq. 8)")
    plt.ylabel("slide in 1 s (mm)")
    plt.title(f"ffdsim: a block on a {angle_deg} deg slope")
    plt.legend()
    plt.grid(True, alpha=0.3)
    plt.tight_layout()
    plt.savefig(out_path, dpi=100)
    print(out_path)


if __name__ == "__main__":
    main(float(sys.argv[1]) if len(sys.argv) > 1 else 20.0, sys.argv[2] if len(sys.argv) > 2 else "tune_beta_slope.png")
