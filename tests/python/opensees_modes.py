"""The first natural frequencies of a bars-only ring truss by truss-deploy and by OpenSees.

A deployed ring of SIDES bays (outer radius 2 m, inner 1.6 m, depth 0.5 m): four joints per
post, every bay a hexahedron whose six faces are triangulated by bars (chords, verticals,
radials and one diagonal per face), pinned joints with lumped masses, every bar elastic along
its axis, post 0 clamped. Masses and EA vary from joint to joint and bar to bar. Both codes
express this exactly: truss-deploy's `bar` elements (compliance L/EA) and `support` rows;
OpenSees's `Truss` elements (E = EA, A = 1), lumped nodal masses, `fix`, `eigen` by LAPACK's
dense generalized solver. No preload (no cable), so the stiffness is elastic only.

usage: opensees_modes.py TRUSS_DEPLOY_BIN WORKDIR [SIDES] [MODES]
prints JSON: {"ours": [...], "opensees": [...], "max_rel": ..., "joints": ..., "bars": ...}
"""

import json
import math
import os
import subprocess
import sys

import openseespy.opensees as ops


def ring(sides):
    ro, ri, depth = 2.0, 1.6, 0.5
    joints = []  # (name, position, mass)
    for i in range(sides):
        th = 2.0 * math.pi * i / sides
        for tag, r, z in (("Ob", ro, 0.0), ("Ot", ro, depth), ("Ib", ri, 0.0), ("It", ri, depth)):
            k = len(joints)
            mass = 0.15 + 0.1 * math.sin(1.7 * k + 0.3) ** 2
            joints.append((f"{tag}{i}", (r * math.cos(th), r * math.sin(th), z), mass))
    bars = []  # (name, a, b)
    for i in range(sides):
        j = (i + 1) % sides
        bars += [
            (f"vo{i}", f"Ob{i}", f"Ot{i}"),
            (f"vi{i}", f"Ib{i}", f"It{i}"),
            (f"rb{i}", f"Ob{i}", f"Ib{i}"),
            (f"rt{i}", f"Ot{i}", f"It{i}"),
            (f"rd{i}", f"Ob{i}", f"It{i}"),
            (f"cob{i}", f"Ob{i}", f"Ob{j}"),
            (f"cot{i}", f"Ot{i}", f"Ot{j}"),
            (f"cib{i}", f"Ib{i}", f"Ib{j}"),
            (f"cit{i}", f"It{i}", f"It{j}"),
            (f"do{i}", f"Ob{i}", f"Ot{j}"),
            (f"di{i}", f"Ib{i}", f"It{j}"),
            (f"db{i}", f"Ob{i}", f"Ib{j}"),
            (f"dt{i}", f"Ot{i}", f"It{j}"),
        ]
    ea = {name: 6.0e6 * (1.0 + 0.3 * math.sin(0.9 * k)) for k, (name, _, _) in enumerate(bars)}
    clamped = ["Ob0", "Ot0", "Ib0", "It0"]
    return joints, bars, ea, clamped


def model_toml(joints, bars, ea, clamped):
    out = [
        '[model]\nname = "bar_ring"\n',
        "[settings]\ndt_s = 0.01\nend_time_s = 1.0\ngravity_m_s2 = [0.0, 0.0, 0.0]\n",
    ]
    for name, p, m in joints:
        out.append(f'[[joint]]\nname = "{name}"\nposition_m = [{p[0]!r}, {p[1]!r}, {p[2]!r}]\nmass_kg = {m!r}\n')
    for name in clamped:
        out.append(f'[[element]]\ntype = "support"\nname = "clamp_{name}"\njoints = ["{name}"]\nfix = "xyz"\n')
    for name, a, b in bars:
        out.append(f'[[element]]\ntype = "bar"\nname = "{name}"\njoints = ["{a}", "{b}"]\naxial_stiffness_n = {ea[name]!r}\n')
    return "".join(out)


def ours(binary, workdir, text, modes):
    path = os.path.join(workdir, "bar_ring.toml")
    out = os.path.join(workdir, "bar_ring_modes.json")
    with open(path, "w") as f:
        f.write(text)
    run = subprocess.run([binary, "analyze", path, "--modes", str(modes), "--json", out],
                         capture_output=True, text=True)
    if run.returncode != 0:
        sys.exit(f"truss-deploy analyze failed ({run.returncode}): {run.stderr}")
    with open(out) as f:
        report = json.load(f)
    return [m["frequency_hz"] for m in report["modes"]["modes"]], report["modes"]


def opensees(joints, bars, ea, clamped, modes):
    ops.wipe()
    ops.model("basic", "-ndm", 3, "-ndf", 3)
    tag = {}
    for k, (name, p, m) in enumerate(joints):
        tag[name] = k + 1
        ops.node(k + 1, *p)
        ops.mass(k + 1, m, m, m)
    for name in clamped:
        ops.fix(tag[name], 1, 1, 1)
    for k, (name, a, b) in enumerate(bars):
        ops.uniaxialMaterial("Elastic", k + 1, ea[name])
        ops.element("Truss", k + 1, tag[a], tag[b], 1.0, k + 1)
    omega2 = ops.eigen("-fullGenLapack", modes)
    return [math.sqrt(w) / (2.0 * math.pi) for w in omega2]


def main():
    binary, workdir = sys.argv[1], sys.argv[2]
    sides = int(sys.argv[3]) if len(sys.argv) > 3 else 12
    modes = int(sys.argv[4]) if len(sys.argv) > 4 else 10
    joints, bars, ea, clamped = ring(sides)
    f_ours, report = ours(binary, workdir, model_toml(joints, bars, ea, clamped), modes)
    f_ops = opensees(joints, bars, ea, clamped, modes)
    max_rel = max(abs(a - b) / b for a, b in zip(f_ours, f_ops))
    print(json.dumps({
        "ours": f_ours,
        "opensees": f_ops,
        "max_rel": max_rel,
        "joints": len(joints),
        "bars": len(bars),
        "mechanisms": report["mechanisms"],
        "degrees_of_freedom": report["degrees_of_freedom"],
    }))


if __name__ == "__main__":
    main()
