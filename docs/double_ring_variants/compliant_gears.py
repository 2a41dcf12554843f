#!/usr/bin/env python3
"""Adds compliant gears to a stowing-ring variant (docs/double_ring_stowing.md, Finding 4):
at every post of the rings named by --rings, a `sync_hinge` (mirror "axial": the feet of
the two bays meeting there level along the post) held by a spring-damper of --stiffness
N/m and --damping N s/m instead of imposed.
Usage: python3 compliant_gears.py a1.toml g100.toml [--rings O|OI] [--stiffness 100] [--damping 5]"""
import argparse
ap = argparse.ArgumentParser()
ap.add_argument("src"); ap.add_argument("dst")
ap.add_argument("--rings", default="O", help="O (outer posts), I (inner) or OI")
ap.add_argument("--stiffness", type=float, default=100.0)
ap.add_argument("--damping", type=float, default=5.0)
a = ap.parse_args()
text = open(a.src).read()
n = text.count("[[joint]]") // 4
gears = []
for ring in a.rings:
    other = "I" if ring == "O" else "O"
    for k in range(n):
        gears.append(f'''[[element]]
type = "sync_hinge"
name = "G{ring}{k}"
joints = ["{ring}{k}_b", "{ring}{k}_t", "{other}{k}_b", "{ring}{(k - 1) % n}_b", "{ring}{(k + 1) % n}_b"]
mirror = "axial"
stiffness_n_per_m = {a.stiffness}
damping_n_s_per_m = {a.damping}
''')
at = text.index("[[cable]]")
open(a.dst, "w").write(text[:at] + "\n".join(gears) + "\n" + text[at:])
print(f"{len(gears)} compliant gears")
