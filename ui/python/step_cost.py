#!/usr/bin/env python3
"""What stepping from Python costs beside `ffdsim simulate`: writes docs/results/python_step_cost.md.

    PYTHONPATH=build/python python3 ui/python/step_cost.py build/ui/ffdsim [--steps N] [--rounds R] [--out FILE]

Rounds alternate between the two, on the default scene with the same thread count, and both
figures are wall time per step. The command line's: `ffdsim simulate` run for N and for 2N
steps, the difference of their wall times divided by N (what loading the scene and starting
costs cancels out). Python's: after N steps, a loop calling sim.step() once per step for the
next N, its wall time divided by N: everything a Python user pays (the call, the GIL released and taken back, the command
queue, the recording's hashes). The command line's own mean of ffd::step alone (its report)
is shown beside them.
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
    cli_us, python_us, step_us = [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        report = os.path.join(tmp, "report.json")

        def simulate(steps):
            start = time.perf_counter()
            subprocess.run([a.binary, "simulate", "--steps", str(steps), "--threads", str(a.threads), "-q",
                            "--report", report], check=True)
            return time.perf_counter() - start

        for _ in range(a.rounds):
            short = simulate(a.steps)
            long = simulate(2 * a.steps)
            cli_us.append((long - short) / a.steps * 1e6)
            step_us.append(json.load(open(report))["step"]["mean_us"])
            sim = ffdsim.Simulation(threads=a.threads)
            sim.step(a.steps)  # the same steps as simulate's difference: n to 2n
            start = time.perf_counter()
            for _ in range(a.steps):
                sim.step()
            python_us.append((time.perf_counter() - start) / a.steps * 1e6)
    # The call alone: step(0) goes through everything step(1) does but the step itself.
    sim = ffdsim.Simulation(threads=a.threads)
    calls = 100000
    start = time.perf_counter()
    for _ in range(calls):
        sim.step(0)
    call_us = (time.perf_counter() - start) / calls * 1e6
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
        "Wall time per step: `ffdsim simulate` from the difference of a 2n-step and an n-step run",
        "divided by n; Python from `for _ in range(n): sim.step()` over the same steps (n to 2n) divided",
        "by n, everything included.",
        "The last column is simulate's own mean of the step alone (its 2n-step report).",
        "",
        "| round | simulate: wall per step (us) | Python: wall per step (us) | simulate: ffd::step mean (us) |",
        "|---|---|---|---|",
    ]
    lines += [f"| {i + 1} | {c:.1f} | {q:.1f} | {m:.1f} |"
              for i, (c, q, m) in enumerate(zip(cli_us, python_us, step_us))]
    lines += ["", f"Median: simulate {cli:.1f} us, Python {py:.1f} us per step: Python costs "
                  f"{(py / cli - 1.0) * 100.0:+.2f} % (the target: at most +2 %). The rounds of either vary",
              "more than that from one to the next (the machine's speed varies), so the call itself is measured",
              f"too: `sim.step(0)` {calls} times, {call_us:.2f} us a call, {call_us / cli * 100.0:.2f} % of simulate's "
              "step.", ""]
    with open(a.out, "w") as f:
        f.write("\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    sys.exit(main())
