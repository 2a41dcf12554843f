#!/usr/bin/env python3
"""Variants of the stowing ring (text transforms of `truss-deploy generate ring --stow`);
see docs/double_ring_stowing.md, "Ball-jointed inner chords, measured"."""
import argparse, re, math, sys
ap = argparse.ArgumentParser()
ap.add_argument("src"); ap.add_argument("dst")
ap.add_argument("--drop", action="append", default=[], help="regex on element names to drop")
ap.add_argument("--inner-diags", action="store_true")
ap.add_argument("--inner-cable", action="store_true")
ap.add_argument("--frame-cable", action="store_true")
ap.add_argument("--tension", type=float)
ap.add_argument("--mu", type=float)
ap.add_argument("--end", type=float)
ap.add_argument("--add", action="append", default=[], help="raw element block text")
a = ap.parse_args()
text = open(a.src).read()
head, *blocks = re.split(r"\n(?=\[\[)", text)
n = sum(1 for b in blocks if b.startswith("[[joint]]")) // 4
out = []
for b in blocks:
    if b.startswith("[[element]]"):
        name = re.search(r'name = "([^"]+)"', b).group(1)
        if any(re.fullmatch(d, name) for d in a.drop):
            continue
    out.append(b.rstrip("\n") + "\n")
h, ci = 0.5, 0.6167
def ipath():
    return [f"I{k%n}_{'b' if k%2==1 else 't'}" for k in range(n+1)]
new = []
if a.inner_diags:
    p = ipath()
    for k in range(n):
        new.append(f'[[element]]\ntype = "sleeve"\nname = "I_diag{k}"\njoints = ["{p[k]}", "{p[k+1]}"]\nlock_length_m = {math.sqrt(ci*ci+h*h)!r}\n')
for r in a.add:
    new.append(r.rstrip("\n") + "\n")
# insert new elements before first cable
idx = next(i for i, b in enumerate(out) if b.startswith("[[cable]]"))
out[idx:idx] = new
res = head.rstrip("\n") + "\n\n" + "\n".join(out)
if a.inner_cable:
    c = next(b for b in out if b.startswith("[[cable]]"))
    p = ipath()
    c2 = re.sub(r'name = "drive"', 'name = "inner_drive"', c)
    c2 = re.sub(r'path = \[[^\]]*\]', 'path = [' + ", ".join(f'"{j}"' for j in p) + ']', c2)
    res = res.rstrip("\n") + "\n\n" + c2
if a.tension is not None:
    res = re.sub(r"tension_n = [0-9.]+", f"tension_n = {a.tension}", res)
if a.mu is not None:
    res = re.sub(r"friction_mu = [0-9.]+", f"friction_mu = {a.mu}", res)
if a.end is not None:
    res = re.sub(r"end_time_s = [0-9.]+", f"end_time_s = {a.end}", res)
open(a.dst, "w").write(res)
print("n =", n, "elements", sum(1 for b in res.split("\n[[") if b.startswith("element")))
