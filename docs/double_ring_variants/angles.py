#!/usr/bin/env python3
"""Shear angles (deg) over a `simulate --csv` run of a stowing ring, every N s:
phi_k outer bay k's chord tilt, chi_k inner bay k's, psi_k frame k's batten tilt, each
with the sign alternating by k (even k as measured, odd k negated), so the stowing ring
starts at phi = psi = 75, chi = -75, and a ring whose inner ring is raised by theta_d
reads psi = +theta_d on even and -theta_d on odd frames when deployed.
Usage: python3 angles.py run.csv [every_s]"""
import sys, csv, math
f = sys.argv[1]; every = float(sys.argv[2]) if len(sys.argv) > 2 else 10.0
rows = list(csv.reader(open(f)))
hdr = rows[0]; data = [[float(v) for v in r] for r in rows[1:]]
n = (len(hdr) - 1) // 12
def J(row, name):
    i = hdr.index(name + "_x_m"); return row[i:i+3]
def sub(a,b): return [a[0]-b[0],a[1]-b[1],a[2]-b[2]]
def angles(row):
    phi, psi, chi = [], [], []
    for k in range(n):
        k1 = (k + 1) % n
        ob, ob1 = J(row, f"O{k}_b"), J(row, f"O{k1}_b")
        d = sub(ob1, ob); phi.append(math.degrees(math.atan2(d[2], math.hypot(d[0], d[1]))) * (1 if k % 2 == 0 else -1))
        ib, ib1 = J(row, f"I{k}_b"), J(row, f"I{k1}_b")
        d = sub(ib1, ib); chi.append(math.degrees(math.atan2(d[2], math.hypot(d[0], d[1]))) * (1 if k % 2 == 0 else -1))
        d = sub(J(row, f"I{k}_b"), ob); psi.append(math.degrees(math.atan2(d[2], math.hypot(d[0], d[1]))) * (1 if k % 2 == 0 else -1))
    return phi, psi, chi
last = -1e9
for r in data:
    if r[0] - last >= every or r is data[-1]:
        last = r[0]
        phi, psi, chi = angles(r)
        print(f"t={r[0]:8.2f} phi " + " ".join(f"{v:5.1f}" for v in phi))
        print(f"           psi " + " ".join(f"{v:5.1f}" for v in psi))
        print(f"           chi " + " ".join(f"{v:5.1f}" for v in chi))
