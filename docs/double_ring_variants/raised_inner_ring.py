#!/usr/bin/env python3
"""The raised-inner-ring variant of the stowing ring (docs/double_ring_stowing.md):
the inner ring deployed w sin(theta_d) above the outer one (radial frames deployed as
parallelograms sheared theta_d, plan depth kept), inner chords on ball joints, the outer
bay diagonals latch, and the frame diagonals of --frame-latches (default: frame 0, at the
mount) latch at their deployed length. Start: the 2-periodic symmetric fold at --phi
(even frames tilted theta_d + x, odd theta_d - x; the small-x branch, or --large).
Usage: truss-deploy generate ring --stow -o stow.toml; python3 raised_inner_ring.py stow.toml out.toml"""
import argparse, math, re
ap = argparse.ArgumentParser()
ap.add_argument("src"); ap.add_argument("dst")
ap.add_argument("--thd", type=float, default=20.0)
ap.add_argument("--phi", type=float, default=75.0)
ap.add_argument("--frame-latches", default="0", help="comma list of frames with a diagonal latch, or 'all' or ''")
ap.add_argument("--inner-diags", action="store_true")
ap.add_argument("--inner-cable", action="store_true")
ap.add_argument("--mu", type=float); ap.add_argument("--tension", type=float)
ap.add_argument("--end", type=float)
ap.add_argument("--large", action="store_true", help="start on the large-x branch (even frames steep)")
a = ap.parse_args()
text = open(a.src).read()
n = text.count("[[joint]]") // 4
co, ci, h = 0.8757, 0.6167, 0.5
S = math.sin(math.pi / n); w0 = (co - ci) / (2 * S)
thd = math.radians(a.thd); w = w0 / math.cos(thd)
def chord(phi, te, to):
    aa = co * math.sin(phi) / 2; ro = co * math.cos(phi) / (2 * S)
    re_ = ro - w * math.cos(te); rod = ro - w * math.cos(to); t = 2 * math.pi / n
    px = rod * math.cos(t) - re_; py = rod * math.sin(t)
    dz = 2 * aa + w * math.sin(to) - w * math.sin(te)
    return math.sqrt(px * px + py * py + dz * dz) - ci
def fold(phi):
    # continuation of te = thd + x, to = thd - x from x = 0 at phi = 0
    if phi == 0: return thd, thd
    if a.large:
        f = lambda x: chord(phi, thd + x, thd - x)
        xs = [math.radians(i * 0.01) for i in range(9000)]
        roots = [x for x, y in zip(xs, xs[1:]) if (f(x) > 0) != (f(y) > 0)]
        lo, hi = roots[-1], roots[-1] + math.radians(0.01)
        for _ in range(100):
            m = 0.5 * (lo + hi)
            if (f(m) > 0) == (f(lo) > 0): lo = m
            else: hi = m
        x = 0.5 * (lo + hi); return thd + x, thd - x
    steps = 200; x = 0.0
    for i in range(1, steps + 1):
        p = phi * i / steps
        # bracket root near previous x: scan upward from x
        lo = x; f = lambda x: chord(p, thd + x, thd - x)
        hi = lo; dx = 1e-4
        flo = f(lo)
        while True:
            hi = lo + dx
            if (f(hi) > 0) != (flo > 0): break
            dx *= 1.5
            if hi > math.pi: raise SystemExit("no fold")
        for _ in range(100):
            m = 0.5 * (lo + hi)
            if (f(m) > 0) == (flo > 0): lo = m
            else: hi = m
        x = 0.5 * (lo + hi)
    return thd + x, thd - x
def positions(phi):
    te, to = fold(phi)
    aa = co * math.sin(phi) / 2; ro = co * math.cos(phi) / (2 * S)
    out = []
    for k in range(n):
        th = 2 * math.pi * k / n; c, s = math.cos(th), math.sin(th)
        ev = k % 2 == 0; zo = -aa if ev else aa; t = te if ev else to
        ri = ro - w * math.cos(t); zi = zo + w * math.sin(t)
        out += [[ro * c, ro * s, zo], [ro * c, ro * s, zo + h], [ri * c, ri * s, zi], [ri * c, ri * s, zi + h]]
    return out, te, to
x0, te, to = positions(math.radians(a.phi)); xd, _, _ = positions(0.0)
shift = [x0[0][i] - xd[0][i] for i in range(3)]
RD = co / (2 * S)
ext = max(math.hypot(p[0], p[1]) for p in x0) / RD
print(f"w {w:.4f} raise {w*math.sin(thd):.4f} start te {math.degrees(te):.2f} to {math.degrees(to):.2f} extent(axis) {ext:.3f}")
head, *blocks = re.split(r"\n(?=\[\[)", text)
ji = 0; out = []
fl = set(range(n)) if a.frame_latches == "all" else set(int(v) for v in a.frame_latches.split(",") if v != "")
for b in blocks:
    if b.startswith("[[joint]]"):
        p = x0[ji]; d = [xd[ji][i] + shift[i] for i in range(3)]; ji += 1
        b = re.sub(r"position_m = \[[^\]]*\]", "position_m = [%r, %r, %r]" % tuple(p), b)
        b = re.sub(r"reference_m = \[[^\]]*\]", "reference_m = [%r, %r, %r]" % tuple(d), b)
    if b.startswith("[[element]]"):
        name = re.search(r'name = "([^"]+)"', b).group(1)
        if re.fullmatch(r"I\d+_hinge_.*", name): continue
        m = re.fullmatch(r"R(\d+)_diag", name)
        if m:
            k = int(m.group(1))
            if k not in fl: continue
            # joints: outer end and inner end as in the stowing ring; lock at the deployed length
            js = re.findall(r'"([OI]\d+_[bt])"', b)
            names = []
            for kk in range(n): names += [f"O{kk}_b", f"O{kk}_t", f"I{kk}_b", f"I{kk}_t"]
            pa, pb = xd[names.index(js[0])], xd[names.index(js[1])]
            L = math.dist(pa, pb)
            b = re.sub(r"lock_length_m = [0-9.e-]+", f"lock_length_m = {L!r}", b)
    out.append(b.rstrip("\n") + "\n")
new = []
if a.inner_diags:
    # inner bays: even inner posts high when stowed (te > to)
    p = [f"I{k%n}_{'b' if k%2==1 else 't'}" for k in range(n+1)]
    for k in range(n):
        new.append(f'[[element]]\ntype = "sleeve"\nname = "I_diag{k}"\njoints = ["{p[k]}", "{p[k+1]}"]\nlock_length_m = {math.sqrt(ci*ci+h*h)!r}\n')
idx = next(i for i, b in enumerate(out) if b.startswith("[[cable]]"))
out[idx:idx] = new
res = head.rstrip("\n") + "\n\n" + "\n".join(out)
if a.inner_cable:
    c = next(b for b in out if b.startswith("[[cable]]"))
    p = [f"I{k%n}_{'b' if k%2==1 else 't'}" for k in range(n+1)]
    c2 = c.replace('name = "drive"', 'name = "inner_drive"')
    c2 = re.sub(r'path = \[[^\]]*\]', 'path = [' + ", ".join(f'"{j}"' for j in p) + ']', c2)
    res = res.rstrip("\n") + "\n\n" + c2
if a.mu is not None: res = re.sub(r"friction_mu = [0-9.]+", f"friction_mu = {a.mu}", res)
if a.tension is not None: res = re.sub(r"tension_n = [0-9.]+", f"tension_n = {a.tension}", res)
if a.end is not None: res = re.sub(r"end_time_s = [0-9.]+", f"end_time_s = {a.end}", res)
open(a.dst, "w").write(res)
