#!/usr/bin/env python3
"""Solver benchmarks of truss-deploy: run them, then plot cost per step against joints.

    cargo build --release --no-default-features
    python3 benches/scaling.py run     # generates models, runs every measurement, one process at a time
    python3 benches/scaling.py plot    # reads the JSON files, writes docs/bench_scaling.svg, prints tables

`run` writes into target/bench-scaling/ (override with --out): the generated models, one JSON file
per `bench`/`simulate` run, the `/usr/bin/time -v` outputs, and runs.json (the commands, their wall
time and the 1-minute load average just before each run). Run it on an otherwise idle machine:
the processes run strictly one after another, but anything else on the machine shows in the figures.

`plot` only reads those files (standard library only, hand-written SVG).
"""

import argparse
import json
import math
import os
import re
import shlex
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_OUT = ROOT / "target" / "bench-scaling"
DEFAULT_BIN = ROOT / "target" / "release" / "truss-deploy"
SVG = ROOT / "docs" / "bench_scaling.svg"

RING_SIDES = [18, 36, 90, 180, 360]
MAST_UNITS = [4, 20, 60, 100, 500]

# (label, model file, solver, steps). The median is per step, so large models need fewer steps.
# The first two are measurement 1 (dense against sparse on the 18-sided double ring, same run).
BENCHES = [
    # Issue 5's acceptance commands, literally (bench's default 200 steps).
    ("done_ring18_dense", "models/double_ring_synchronized.toml", "dense", 200),
    ("done_ring18_sparse", "models/double_ring_synchronized.toml", "sparse", 200),
    ("done_r180_sparse", "r180.toml", "sparse", 200),
    ("ring18_dense", "models/double_ring_synchronized.toml", "dense", 20),
    ("ring18_sparse", "models/double_ring_synchronized.toml", "sparse", 300),
    # The same 20 steps as the dense run (the start of the deployment), for a like-for-like ratio.
    ("ring18_sparse_20", "models/double_ring_synchronized.toml", "sparse", 20),
    # Scaling, sparse.
    ("r18_sparse", "r18.toml", "sparse", 100),
    ("r36_sparse", "r36.toml", "sparse", 100),
    ("r90_sparse", "r90.toml", "sparse", 100),
    ("r180_sparse", "r180.toml", "sparse", 100),
    ("r360_sparse", "r360.toml", "sparse", 100),
    ("m4_sparse", "m4.toml", "sparse", 100),
    ("m20_sparse", "m20.toml", "sparse", 100),
    ("m60_sparse", "m60.toml", "sparse", 100),
    ("m100_sparse", "m100.toml", "sparse", 100),
    ("m500_sparse", "m500.toml", "sparse", 100),
    # Scaling, dense (O(n^3): small models only).
    ("r18_dense", "r18.toml", "dense", 20),
    ("r36_dense", "r36.toml", "dense", 10),
    ("m4_dense", "m4.toml", "dense", 100),
    ("m20_dense", "m20.toml", "dense", 100),
    ("m60_dense", "m60.toml", "dense", 20),
]


def loadavg():
    return os.getloadavg()[0]


def run_cmd(cmd, runs, label, cwd):
    """Run one command (no other process of ours at the same time); record it in `runs`."""
    la = loadavg()
    t0 = time.perf_counter()
    p = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    shown = " ".join(shlex.quote(str(c)) for c in cmd)
    print(f"[{label}] load {la:.2f}, {wall:.1f} s: {shown}", flush=True)
    out = (p.stdout + p.stderr).strip()
    if out:
        print("   " + out.replace("\n", "\n   "), flush=True)
    runs.append({"label": label, "cmd": shown, "cwd": str(cwd), "rc": p.returncode,
                 "wall_s": wall, "load1_before": la, "stdout": p.stdout, "stderr": p.stderr})
    if p.returncode != 0:
        sys.exit(f"{label}: exit {p.returncode}")
    return p


def joints_of(path):
    return sum(1 for line in Path(path).read_text().splitlines() if line.strip() == "[[joint]]")


def cmd_run(a):
    out = Path(a.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    exe = Path(a.bin).resolve()
    runs = []
    # Models (not timed).
    for n in RING_SIDES:
        run_cmd([exe, "generate", "ring", "--sync", "--sides", str(n), "-o", f"r{n}.toml"], runs, f"gen r{n}", out)
    for u in MAST_UNITS:
        run_cmd([exe, "generate", "mast", "--units", str(u), "-o", f"m{u}.toml"], runs, f"gen m{u}", out)
    # Measurements 1 and 2: per-step cost.
    for label, model, solver, steps in BENCHES:
        m = ROOT / model if model.startswith("models/") else out / model
        run_cmd([exe, "bench", m, "--solver", solver, "--steps", str(steps),
                 "--json", out / f"{label}.json"], runs, label, out)
    # Measurement 1: the whole deployment of the 18-sided double ring (sparse, the default).
    run_cmd([exe, "simulate", ROOT / "models/double_ring_synchronized.toml", "--json", out / "ring18_simulate.json"],
            runs, "ring18_simulate", out)
    # Measurement 3: peak memory of a 360-sided ring.
    tv = "/usr/bin/time"
    for label, args in [("mem_r360_bench", ["bench", "r360.toml", "--steps", "15"]),
                        ("mem_r360_simulate", ["simulate", "r360.toml", "--until", "2"])]:
        p = run_cmd([tv, "-v", exe, *args], runs, label, out)
        (out / f"{label}.txt").write_text(p.stdout + p.stderr)
    (out / "runs.json").write_text(json.dumps(runs, indent=1))


# ---------------------------------------------------------------- plot

def load(out, label):
    f = Path(out) / f"{label}.json"
    return json.loads(f.read_text()) if f.exists() else None


def scaling_runs(out):
    """(label, model, solver, bench JSON) of the generated-model runs that have a result."""
    for label, model, solver, _steps in BENCHES:
        if model.startswith("models/") or label.startswith("done_"):
            continue
        j = load(out, label)
        if j is not None:
            yield label, model, solver, j


def series(out):
    """{name: [(joints, us_per_step, label)]} for the four series."""
    s = {"sparse, rings": [], "sparse, masts": [], "dense, rings": [], "dense, masts": []}
    for label, model, solver, j in scaling_runs(out):
        kind = "rings" if model.startswith("r") else "masts"
        s[f"{solver}, {kind}"].append((joints_of(Path(out) / model), j["us_per_step"], label))
    for v in s.values():
        v.sort()
    return s


def nice_decades(lo, hi):
    return list(range(math.floor(math.log10(lo)), math.ceil(math.log10(hi)) + 1))


def write_svg(s, path):
    W, H = 760, 520
    L, R, T, B = 90, 200, 50, 70
    pts = [p for v in s.values() for p in v]
    xs = [p[0] for p in pts]
    ys = [p[1] for p in pts]
    dx = nice_decades(min(xs), max(xs))
    dy = nice_decades(min(ys), max(ys))
    x0, x1 = dx[0], dx[-1]
    y0, y1 = dy[0], dy[-1]

    def X(v):
        return L + (math.log10(v) - x0) / (x1 - x0) * (W - L - R)

    def Y(v):
        return H - B - (math.log10(v) - y0) / (y1 - y0) * (H - T - B)

    e = []
    e.append(f'<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" '
             f'viewBox="0 0 {W} {H}" font-family="DejaVu Sans, Arial, sans-serif" font-size="13">')
    e.append(f'<rect width="{W}" height="{H}" fill="white"/>')
    e.append(f'<text x="{(L + W - R) / 2}" y="28" text-anchor="middle" font-size="16">'
             'truss-deploy: cost per step against model size (release, median)</text>')
    # Grid: decades and 2, 5 minor lines.
    for d in range(x0, x1 + 1):
        for m in ([1, 2, 5] if d < x1 else [1]):
            v = m * 10 ** d
            sw, col = ("1", "#bbb") if m == 1 else ("0.5", "#e2e2e2")
            e.append(f'<line x1="{X(v):.1f}" y1="{T}" x2="{X(v):.1f}" y2="{H - B}" stroke="{col}" stroke-width="{sw}"/>')
            e.append(f'<text x="{X(v):.1f}" y="{H - B + 18}" text-anchor="middle" '
                     f'fill="{"#000" if m == 1 else "#777"}" font-size="{13 if m == 1 else 11}">{v:g}</text>')
    for d in range(y0, y1 + 1):
        for m in ([1, 2, 5] if d < y1 else [1]):
            v = m * 10 ** d
            sw, col = ("1", "#bbb") if m == 1 else ("0.5", "#e2e2e2")
            e.append(f'<line x1="{L}" y1="{Y(v):.1f}" x2="{W - R}" y2="{Y(v):.1f}" stroke="{col}" stroke-width="{sw}"/>')
            if m == 1:
                lab = f"{v:g}" if v < 1e5 else f"1e{d}"
                e.append(f'<text x="{L - 8}" y="{Y(v) + 4:.1f}" text-anchor="end">{lab}</text>')
    e.append(f'<rect x="{L}" y="{T}" width="{W - L - R}" height="{H - T - B}" fill="none" stroke="#000"/>')
    e.append(f'<text x="{(L + W - R) / 2}" y="{H - 25}" text-anchor="middle">joints (log scale)</text>')
    e.append(f'<text transform="translate(24 {(T + H - B) / 2}) rotate(-90)" text-anchor="middle">'
             'µs per step (log scale)</text>')
    # Real time at dt 0.05 s: 50 000 µs per step.
    if 10 ** y0 <= 5e4 <= 10 ** y1:
        e.append(f'<line x1="{L}" y1="{Y(5e4):.1f}" x2="{W - R}" y2="{Y(5e4):.1f}" stroke="#c00" '
                 'stroke-dasharray="6 4" stroke-width="1"/>')
        e.append(f'<text x="{W - R - 6}" y="{Y(5e4) + 15:.1f}" text-anchor="end" fill="#c00" font-size="11">'
                 'real time at dt 0.05 s (50 ms per step)</text>')
    style = {
        "sparse, rings": ("#1f77b4", "circle", ""),
        "sparse, masts": ("#2ca02c", "square", ""),
        "dense, rings": ("#d62728", "circle", "5 3"),
        "dense, masts": ("#ff7f0e", "square", "5 3"),
    }
    for name, pts in s.items():
        if not pts:
            continue
        col, mark, dash = style[name]
        path_d = " ".join(f"{'M' if i == 0 else 'L'}{X(x):.1f},{Y(y):.1f}" for i, (x, y, _) in enumerate(pts))
        e.append(f'<path d="{path_d}" fill="none" stroke="{col}" stroke-width="2"'
                 + (f' stroke-dasharray="{dash}"' if dash else "") + "/>")
        for x, y, _ in pts:
            if mark == "circle":
                e.append(f'<circle cx="{X(x):.1f}" cy="{Y(y):.1f}" r="4.5" fill="{col}"/>')
            else:
                e.append(f'<rect x="{X(x) - 4:.1f}" y="{Y(y) - 4:.1f}" width="8" height="8" fill="{col}"/>')
    # Slope guides through the first sparse-ring point: cost ∝ n and ∝ n^3.
    ref = s["sparse, rings"][0] if s["sparse, rings"] else None
    if ref:
        for k, lab in [(1, "∝ n"), (3, "∝ n³")]:
            xa, ya = ref[0], ref[1]
            xb = 10 ** x1
            yb = ya * (xb / xa) ** k
            if yb > 10 ** y1:
                yb = 10 ** y1
                xb = xa * (yb / ya) ** (1 / k)
            e.append(f'<line x1="{X(xa):.1f}" y1="{Y(ya):.1f}" x2="{X(xb):.1f}" y2="{Y(yb):.1f}" '
                     'stroke="#888" stroke-width="1" stroke-dasharray="2 3"/>')
            e.append(f'<text x="{X(xb) - 8:.1f}" y="{Y(yb) + 16:.1f}" text-anchor="end" fill="#666" '
                     f'font-size="11">{lab}</text>')
    # Legend.
    lx, ly = W - R + 16, T + 10
    for i, (name, (col, mark, dash)) in enumerate(style.items()):
        yy = ly + 24 * i
        e.append(f'<line x1="{lx}" y1="{yy}" x2="{lx + 30}" y2="{yy}" stroke="{col}" stroke-width="2"'
                 + (f' stroke-dasharray="{dash}"' if dash else "") + "/>")
        if mark == "circle":
            e.append(f'<circle cx="{lx + 15}" cy="{yy}" r="4.5" fill="{col}"/>')
        else:
            e.append(f'<rect x="{lx + 11}" y="{yy - 4}" width="8" height="8" fill="{col}"/>')
        e.append(f'<text x="{lx + 38}" y="{yy + 4}">{name}</text>')
    e.append(f'<text x="{lx}" y="{ly + 110}" font-size="11" fill="#444">rings: 18–360 sides</text>')
    e.append(f'<text x="{lx}" y="{ly + 126}" font-size="11" fill="#444">masts: 4–500 units</text>')
    e.append(f'<text x="{lx}" y="{ly + 142}" font-size="11" fill="#444">dt 0.05 s</text>')
    e.append(f'<text x="{lx}" y="{ly + 158}" font-size="11" fill="#444">dotted: ∝ n and ∝ n³</text>')
    e.append(f'<text x="{lx}" y="{ly + 174}" font-size="11" fill="#444">from the 18-sided ring</text>')
    e.append("</svg>")
    Path(path).write_text("\n".join(e) + "\n")


def cmd_plot(a):
    out = Path(a.out)
    s = series(out)
    write_svg(s, a.svg)
    print(f"wrote {a.svg}")
    # Tables for BENCHMARKS.md.
    runs = {r["label"]: r for r in json.loads((out / "runs.json").read_text())} if (out / "runs.json").exists() else {}
    print("\n| model | joints | solver | steps | µs/step (median) | ratio | load before |")
    print("|---|---|---|---|---|---|---|")
    base = {}
    for label, model, solver, j in scaling_runs(out):
        kind = "r" if model.startswith("r") else "m"
        base.setdefault((kind, solver), j["us_per_step"])
        la = runs.get(label, {}).get("load1_before", float("nan"))
        print(f"| {model} | {joints_of(out / model)} | {solver} | {j['steps']} | {j['us_per_step']:.1f} | "
              f"{j['us_per_step'] / base[(kind, solver)]:.2f} | {la:.2f} |")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run", help="generate the models and run every measurement")
    r.add_argument("--out", default=DEFAULT_OUT)
    r.add_argument("--bin", default=DEFAULT_BIN)
    p = sub.add_parser("plot", help="write the SVG from the JSON files of a run")
    p.add_argument("--out", default=DEFAULT_OUT)
    p.add_argument("--svg", default=SVG)
    a = ap.parse_args()
    {"run": cmd_run, "plot": cmd_plot}[a.cmd](a)


if __name__ == "__main__":
    main()
