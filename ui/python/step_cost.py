#!/usr/bin/env python3
"""What stepping from Python costs beside `ffdsim simulate`: writes docs/results/python_step_cost.md.

    PYTHONPATH=build/python python3 ui/python/step_cost.py build/ui/ffdsim [--steps N] [--rounds R] [--out FILE]

Rounds alternate between the two, on the default scene with the same thread count. The command
line's figure is its own mean step time (ffd::step alone, from its report); Python's is the wall
time of a loop calling sim.step() once per step divided by the steps: everything a Python user
pays (the call, the GIL released and taken back, the command queue, the recording's hashes).
"""
import argparse
import datetime
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

import ffdsim


def cpu_name():
    try:
        for line in subprocess.run(["lscpu"], capture_output=True, text=True).stdout.splitlines():
            if line.startswith("Model name:"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return "unknown CPU"


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("binary")
    p.add_argument("--steps", type=int, default=3000)
    p.add_argument("--rounds", type=int, default=5)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--out", default=os.path.join(os.path.dirname(__file__), "..", "..", "docs", "results",
                                                  "python_step_cost.md"))
    a = p.parse_args()
    cli_us, python_us = [], []
    with tempfile.TemporaryDirectory() as tmp:
        report = os.path.join(tmp, "report.json")
        for _ in range(a.rounds):
            subprocess.run([a.binary, "simulate", "--steps", str(a.steps), "--threads", str(a.threads), "-q",
                            "--report", report], check=True)
            cli_us.append(json.load(open(report))["step"]["mean_us"])
            sim = ffdsim.Simulation(threads=a.threads)
            start = time.perf_counter()
            for _ in range(a.steps):
                sim.step()
            python_us.append((time.perf_counter() - start) / a.steps * 1e6)
    cli, py = statistics.median(cli_us), statistics.median(python_us)
    commit = subprocess.run(["git", "rev-parse", "--short=12", "HEAD"], capture_output=True, text=True,
                            cwd=os.path.dirname(os.path.abspath(__file__))).stdout.strip() or "unknown"
    cpu = cpu_name()
    lines = [
        "# Stepping from Python beside `ffdsim simulate`",
        "",
        "<!-- Written by ui/python/step_cost.py; run the command below again to update it. -->",
        "",
        f"- Command: `PYTHONPATH=build/python python3 ui/python/step_cost.py build/ui/ffdsim --steps {a.steps} "
        f"--rounds {a.rounds} --threads {a.threads}`",
        f"- Commit: {commit}",
        f"- Machine: {cpu} ({os.cpu_count()} cores)",
        f"- Date: {datetime.date.today().isoformat()}",
        "",
        f"The default scene (two teapots), {a.steps} steps, {a.threads} threads, {a.rounds} rounds alternating.",
        "The command line's figure is ffd::step alone (its report's mean); Python's is the wall time",
        "of `for _ in range(n): sim.step()` divided by n, everything included.",
        "",
        "| round | simulate: mean step (us) | Python: wall per step (us) |",
        "|---|---|---|",
    ]
    lines += [f"| {i + 1} | {c:.1f} | {q:.1f} |" for i, (c, q) in enumerate(zip(cli_us, python_us))]
    lines += ["", f"Median: simulate {cli:.1f} us, Python {py:.1f} us per step: Python costs "
                  f"{(py / cli - 1.0) * 100.0:+.2f} % (the target: at most +2 %).", ""]
    with open(a.out, "w") as f:
        f.write("\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    sys.exit(main())
