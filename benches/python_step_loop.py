#!/usr/bin/env python3
"""The Python package's stepping loop against `truss-deploy simulate` on the
same model (docs/benchmarks.md, "Python package"): a loop of
`Simulator.step(dt)` in Python until the model deploys, and the command's
run, interleaved ROUNDS times, each as a whole process (start, load, run)
and as its stepping loop alone (the command's `wall_time_s`, the Python
loop's own clock).

    python benches/python_step_loop.py target/release/truss-deploy models/double_ring.toml [ROUNDS]
"""

import json
import statistics
import subprocess
import sys
import tempfile
import time

CHILD = r"""
import sys, time, json
import truss_deploy as td
sim = td.Simulator(td.load(sys.argv[1]))
dt = sim.model.dt_s
t0 = time.perf_counter()
while not sim.deployed:
    sim.step(dt)
loop = time.perf_counter() - t0
print(json.dumps({"loop_s": loop, "steps": sim.steps, "deploy_time_s": sim.deploy_time_s}))
"""


def main() -> None:
    exe, model = sys.argv[1], sys.argv[2]
    rounds = int(sys.argv[3]) if len(sys.argv) > 3 else 3
    cli, py, cli_loop, py_loop = [], [], [], []
    with tempfile.TemporaryDirectory() as d:
        for r in range(rounds):
            t0 = time.perf_counter()
            subprocess.run([exe, "simulate", model, "--json", f"{d}/s.json"], check=True, stdout=subprocess.DEVNULL)
            cli.append(time.perf_counter() - t0)
            s = json.load(open(f"{d}/s.json"))
            cli_loop.append(s["wall_time_s"])
            t0 = time.perf_counter()
            out = subprocess.run([sys.executable, "-c", CHILD, model], check=True, capture_output=True, text=True).stdout
            py.append(time.perf_counter() - t0)
            p = json.loads(out)
            py_loop.append(p["loop_s"])
            assert p["steps"] == s["steps"] and p["deploy_time_s"] == s["deploy_time_s"], (p, s)
            print(f"round {r + 1}: cli {cli[-1]:.3f} s (loop {cli_loop[-1]:.3f}), python {py[-1]:.3f} s (loop {py_loop[-1]:.3f})", flush=True)
    med = statistics.median
    print(f"median whole process: cli {med(cli):.3f} s, python {med(py):.3f} s, ratio {med(py) / med(cli):.3f}")
    print(f"median stepping loop: cli {med(cli_loop):.3f} s, python {med(py_loop):.3f} s, ratio {med(py_loop) / med(cli_loop):.3f}")


if __name__ == "__main__":
    main()
