#!/usr/bin/env python3
"""A model that starts where a run was: every joint's position_m set to the
positions a `simulate --csv` run wrote at time T (the first row at or after T;
default its last row), velocities zero. Sleeves within [solver] lock_tol_m of
their lock at that state latch at the start (Simulator::initialize), so a
rigidly latched run restarts latched. For studying a long run's endgame
without running its first part again (the velocities are lost: a restart from
rest, not a checkpoint).

Usage: python3 restart_from_csv.py MODEL.toml RUN.csv OUT.toml [T]"""
import re
import subprocess
import sys

if len(sys.argv) not in (4, 5):
    sys.exit(__doc__)
model, csv_path, out = sys.argv[1:4]
t = float(sys.argv[4]) if len(sys.argv) == 5 else None
with open(csv_path) as f:
    header = f.readline().strip().split(",")
    line = None
    if t is None:
        line = subprocess.run(["tail", "-n", "1", csv_path], capture_output=True, text=True).stdout
    else:
        for row in f:
            if float(row.split(",", 1)[0]) >= t:
                line = row
                break
if not line or len(line.strip().split(",")) != len(header):
    sys.exit(f"{csv_path}: no whole row at or after t = {t}")
row = [float(v) for v in line.strip().split(",")]
print(f"restart at t = {row[0]!r} s", file=sys.stderr)
pos = {h[: -len("_x_m")]: row[i : i + 3] for i, h in enumerate(header) if h.endswith("_x_m")}
text = open(model).read()


def place(m):
    name = m.group(1)
    if name not in pos:
        sys.exit(f"joint {name} is not in {csv_path}")
    x, y, z = pos[name]
    return f'[[joint]]\nname = "{name}"\nposition_m = [{x!r}, {y!r}, {z!r}]'


text, n = re.subn(r'\[\[joint\]\]\nname = "([^"]+)"\nposition_m = \[[^\]]*\]', place, text)
if n != len(pos):
    sys.exit(f"{model}: placed {n} joints, the run has {len(pos)}")
open(out, "w").write(text)
