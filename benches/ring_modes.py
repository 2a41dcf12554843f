"""The deployed first natural frequency of generated double rings against their number of sides.

For each number of sides, `truss-deploy generate ring --sides N` (rigid latches) and the same
with `--latch-stiffness 2e5 --latch-damping 300` (the bundled ring's compliant latches), then
`truss-deploy analyze --modes 3 --json`: the first three frequencies, what each mode is, and
the wall time of the whole `analyze` (mobility counts, the consistent start and the modes).
Writes a CSV table and a plot (matplotlib).

usage: python benches/ring_modes.py [--bin target/release/truss-deploy] [--sides 12,18,...]
           [-o docs/ring_first_frequency]   (writes .csv, .svg and .png)
"""

import argparse
import csv
import json
import os
import subprocess
import tempfile
import time


def first_modes(binary, sides, latch, workdir):
    model = os.path.join(workdir, f"ring{sides}_{latch}.toml")
    args = [binary, "generate", "ring", "--sides", str(sides), "-o", model]
    if latch == "compliant":
        args += ["--latch-stiffness", "2e5", "--latch-damping", "300"]
    subprocess.run(args, check=True, capture_output=True)
    out = model + ".json"
    t0 = time.perf_counter()
    subprocess.run([binary, "analyze", model, "--modes", "3", "--json", out],
                   check=True, capture_output=True)
    wall = time.perf_counter() - t0
    with open(out) as f:
        m = json.load(f)["modes"]
    return m, wall


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bin", default="target/release/truss-deploy")
    ap.add_argument("--sides", default="12,18,24,30,36,42,48,54,60,66,72")
    ap.add_argument("-o", "--output", default="docs/ring_first_frequency")
    a = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as d:
        for n in [int(s) for s in a.sides.split(",")]:
            for latch in ("rigid", "compliant"):
                m, wall = first_modes(a.bin, n, latch, d)
                f = [x["frequency_hz"] for x in m["modes"]]
                rows.append({
                    "sides": n, "latches": latch, "coordinates": m["coordinates"],
                    "degrees_of_freedom": m["degrees_of_freedom"],
                    "f1_hz": f[0], "f2_hz": f[1], "f3_hz": f[2],
                    "mode1": m["modes"][0]["motion"], "mode2": m["modes"][1]["motion"],
                    "mode3": m["modes"][2]["motion"], "analyze_wall_s": round(wall, 3),
                })
                print(f"{n:3d} sides, {latch:9s} latches: f1 {f[0]:.5f} Hz ({m['modes'][0]['motion']}), "
                      f"f2 {f[1]:.5f}, f3 {f[2]:.5f}; {m['coordinates']} coordinates, analyze {wall:.2f} s",
                      flush=True)
    with open(a.output + ".csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 4.2))
    for latch, style in (("rigid", "o-"), ("compliant", "s--")):
        pts = [(r["sides"], r["f1_hz"]) for r in rows if r["latches"] == latch]
        label = "rigid latches" if latch == "rigid" else "compliant latches 2e5 N/m (as models/double_ring.toml)"
        ax.loglog([p[0] for p in pts], [p[1] for p in pts], style, label=label)
    ax.set_xlabel("sides")
    ax.set_ylabel("first natural frequency (Hz)")
    ax.set_title("Generated double rings, deployed and latched, held at post O0")
    ax.set_xticks([12, 18, 24, 36, 48, 72])
    ax.xaxis.set_major_formatter(matplotlib.ticker.ScalarFormatter())
    ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax.set_yticks([1.5, 2, 3, 5, 10, 20, 30, 50])
    ax.yaxis.set_major_formatter(matplotlib.ticker.ScalarFormatter())
    ax.yaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    for ext in ("svg", "png"):
        fig.savefig(f"{a.output}.{ext}", dpi=110)
    print(f"wrote {a.output}.csv, .svg, .png")


if __name__ == "__main__":
    main()
