#!/usr/bin/env python3
"""Peer benchmark: truss-deploy against Exudyn (PyPI) on the one-DOF oracle mast.

The oracle mast
---------------
A planar pantograph mast of N scissor units in the x-z plane: rods of 0.5 m pinned at their
midpoints, opening from 5 deg to 60 deg from horizontal; no gravity, no damping; a frictionless
drive cable at a constant 10 N from a motor at L0 to its anchor at R0 across the bottom unit
(`--cable bottom`, the default: 3,872 steps of 0.05 s at 64 units), or over L0-R0-L1-R1-...-L_N
to R_N (`--cable full`: each horizontal run pulls, the mast deploys sqrt(N+1) times faster);
0.25 kg per rod end lumped at the joints (0.25 kg at levels 0 and N, 0.5 kg between). L0 is
fixed, R0 slides along x, every joint stays in y = 0: one mechanism. The mast has one degree of
freedom phi, so the deploy time (unit height z(L1) - z(L0) reaching L sin 60 deg) follows from
energy conservation, m(phi) phidot^2 / 2 = T (l(phi0) - l(phi)); the script integrates
dt = dphi / phidot with phi = phi0 + s^2 by composite Simpson, doubling the panels until the
relative change is below 1e-13.

The two models
--------------
truss-deploy: the file `truss-deploy generate mast --units N --rod-length-m 0.5 --joint-mass-kg
0.25 --tension-n 10 --mu 0 --damping 0 --start-deg 5 --deploy-deg 60` writes, with the
interior joints' mass_kg rewritten to 0.5 and, for `--cable bottom`, the cable's path to
["L0", "R0"] (line-based, checked by parsing both files: only those differ, and every joint
sits where the Exudyn model puts it).

Exudyn: NodePoint + MassPoint per joint; each rod an ObjectConnectorDistance; each scissor pivot
an ObjectConnectorCoordinateVector between two MarkerObjectODE2Coordinates, each on an
ObjectGenericODE2 without matrices that only groups one rod's two end nodes, so that the rows
x_a + x_b - x_c - x_d = 0 and z_a + z_b - z_c - z_d = 0 are exact and linear (the y row would
repeat the supports); supports as CoordinateConstraints to a ground node; the cable as one
ObjectConnectorSpringDamper per straight segment with zero stiffness and damping and a constant
force T (tension). Solver: generalized-alpha, index 3, EigenSparse, fixed step (adaptive step
off), Exudyn's default Newton settings (modified Newton, relativeTolerance 1e-8), no solution
file, console output off during the solve (Exudyn 1.13.6 warns of "memory allocations in every
time step" on this model). The unit height is stored every step by four in-memory node sensors
(z and vz of L0 and L1); its crossing is located by cubic Hermite interpolation between the
bracketing steps and bisection. The run ends 2 steps past the exact deploy time.

What is measured
----------------
For each mast size and dt, R repetitions, truss-deploy then Exudyn in turn:
* truss-deploy: CPU = user + sys of the child process `truss-deploy simulate MODEL --dt DT
  --json OUT` (the whole process: parse, set-up, run) from getrusage(RUSAGE_CHILDREN) deltas;
  also its own wall_time_s and sub-step count from the JSON.
* Exudyn: CPU = time.process_time() around SolveDynamic only (model building excluded); also
  its steps, Newton iterations and Jacobian updates.
The tables give the medians, the ratio Exudyn/truss-deploy, each deploy time and its relative
error against the quadrature.

Before timing, on every mast size, the Exudyn model is checked: constraint residuals at the
start, ComputeSystemDegreeOfFreedom (1 DOF, no redundant rows), that the mast rises, that the
kinetic energy follows the cable work (recorded before every step by a pre-step function, in an
untimed run), what the sensors cost (runs with and without), the errors with spectralRadius 1.0
and Exudyn's default 0.9 at dt 0.05 (the more accurate is used unless --rho is given), a bound
on the Hermite interpolation error, and on masts up to --order-check-max-units the second order
(errors at dt 0.05, 0.025, 0.0125).

--equal-accuracy TOL (default 2e-8) instead halves dt from 0.05 for each code until its
|deploy-time error| <= TOL (down to --min-dt; the table says if the floor was hit), reports how
much Exudyn's default Newton tolerance moves its deploy time at the dt found (against 1e-10),
then times both codes at their dt. Because halving dt changes the CPU time twofold, the last
column also gives the ratio of CPU times interpolated (log-log) to |error| = TOL.

Command lines (from the repository root; any venv with `pip install exudyn==1.13.6 numpy`):
    python benches/peer_exudyn.py --units 64 256 --dt 0.05 --repeats 3
    python benches/peer_exudyn.py --units 64 --equal-accuracy 2e-8
    python benches/peer_exudyn.py --units 64 --dt 0.05 0.025 0.0125 --json sweep.json --markdown
The truss-deploy binary is --bin (default target/release/truss-deploy); --json writes every raw
number (each run, the checks, the machine).
"""

import argparse
import hashlib
import json
import math
import os
import platform
import resource
import statistics
import subprocess
import sys
import tempfile
import time
import tomllib

import numpy as np

ROD_LENGTH_M = 0.5
TENSION_N = 10.0
ROD_END_MASS_KG = 0.25
# The cable's horizontal runs (`--cable`): set in main().
CABLE = {"mode": "bottom"}


def cable_path(units):
    """The drive cable's path: L0 -> R0, or L0 -> R0 -> L1 -> ... -> R_N."""
    if CABLE["mode"] == "bottom":
        return ["L0", "R0"]
    return [f"{side}{u}" for u in range(units + 1) for side in "LR"]


def cable_runs(units):
    """How many horizontal runs (each L cos phi long) the cable shortens."""
    return 1 if CABLE["mode"] == "bottom" else units + 1
START_DEG = 5.0
DEPLOY_DEG = 60.0
EXUDYN_DEFAULT_RHO = 0.9


# ---------------------------------------------------------------- the mast and its exact time


def mast_joints(units):
    """Joints [(name, level, side, position, mass)] in level order, L before R."""
    phi0 = math.radians(START_DEG)
    joints = []
    for u in range(units + 1):
        mass = ROD_END_MASS_KG * (1 if u in (0, units) else 2)
        z = u * ROD_LENGTH_M * math.sin(phi0)
        joints.append((f"L{u}", u, "L", (0.0, 0.0, z), mass))
        joints.append((f"R{u}", u, "R", (ROD_LENGTH_M * math.cos(phi0), 0.0, z), mass))
    return joints


def simpson(f, a, b, panels):
    x = np.linspace(a, b, panels + 1)
    y = f(x)
    return (b - a) / panels / 3.0 * (y[0] + y[-1] + 4.0 * y[1:-1:2].sum() + 2.0 * y[2:-1:2].sum())


def exact_deploy_time(units, masses_l, masses_r):
    """Deploy time from K(phi) = T (l(phi0) - l(phi)), K = m(phi) phidot^2 / 2, by quadrature.

    m(phi) = sum_i m_i |dx_i/dphi|^2 with dx/dphi = (0, 0, u L cos phi) for L_u and
    (-L sin phi, 0, u L cos phi) for R_u; l(phi) = k L cos phi + const, k the cable's horizontal
    runs (`cable_runs`). Returns (time,
    estimated relative quadrature error, panels).
    """
    length, tension, runs = ROD_LENGTH_M, TENSION_N, cable_runs(units)
    phi0, phid = math.radians(START_DEG), math.radians(DEPLOY_DEG)
    levels = np.arange(units + 1, dtype=float)
    a = float(((np.asarray(masses_l) + np.asarray(masses_r)) * levels**2).sum())
    b = float(np.asarray(masses_r).sum())

    def mass(phi):
        return length**2 * (a * np.cos(phi) ** 2 + b * np.sin(phi) ** 2)

    def integrand(s):
        s = np.asarray(s, dtype=float)
        phi = phi0 + s * s
        # l(phi0) - l(phi) without cancellation
        drop = runs * length * 2.0 * np.sin(phi0 + 0.5 * s * s) * np.sin(0.5 * s * s)
        out = np.empty_like(s)
        nz = s > 0.0
        out[nz] = 2.0 * s[nz] / np.sqrt(2.0 * tension * drop[nz] / mass(phi[nz]))
        # limit s -> 0: l(phi0) - l(phi0 + s^2) ~ k L sin(phi0) s^2
        k = runs * length * math.sin(phi0)
        out[~nz] = 2.0 / math.sqrt(2.0 * tension * k / mass(phi0))
        return out

    smax = math.sqrt(phid - phi0)
    panels = 1000
    t = simpson(integrand, 0.0, smax, panels)
    while True:
        panels *= 2
        t2 = simpson(integrand, 0.0, smax, panels)
        change = abs(t2 - t) / t2
        t = t2
        if change < 1e-13:
            # Simpson's error falls 16-fold per doubling: the last change bounds it
            return t, change / 15.0, panels
        if panels > 1 << 24:
            raise RuntimeError("quadrature did not converge")


# ---------------------------------------------------------------- truss-deploy


def truss_version(binary):
    return subprocess.run([binary, "--version"], capture_output=True, text=True,
                          check=True).stdout.strip()


def binary_identity(binary):
    """sha256 prefix and modification time: the version string does not show uncommitted edits."""
    with open(binary, "rb") as f:
        digest = hashlib.sha256(f.read()).hexdigest()
    mtime = time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(os.path.getmtime(binary)))
    return {"sha256": digest, "mtime": mtime, "bytes": os.path.getsize(binary)}


def write_truss_model(binary, units, path):
    """`generate mast` with uniform masses, then the interior joints' mass_kg rewritten.

    The edit is line-based inside [[joint]] tables; it is checked by parsing both files: the
    result differs from the generated file in those masses only, every mass is the oracle's,
    and every position is the one the Exudyn model uses.
    """
    generated = path + ".generated"
    subprocess.run([binary, "generate", "mast", "--units", str(units),
                    "--rod-length-m", repr(ROD_LENGTH_M), "--joint-mass-kg", repr(ROD_END_MASS_KG),
                    "--tension-n", repr(TENSION_N), "--mu", "0", "--damping", "0",
                    "--start-deg", repr(START_DEG), "--deploy-deg", repr(DEPLOY_DEG),
                    "-o", generated], check=True, capture_output=True)
    with open(generated) as f:
        text = f.read()
    joints = {name: (pos, mass) for name, _, _, pos, mass in mast_joints(units)}
    lines, out, table, name, edits = text.splitlines(keepends=True), [], None, None, 0
    for line in lines:
        s = line.strip()
        if s.startswith("["):
            table, name = s, None
        elif table == "[[joint]]" and s.startswith("name ="):
            name = tomllib.loads(s)["name"]
        elif table == "[[cable]]" and s.startswith("path ="):
            line = "path = " + json.dumps(cable_path(units)) + "\n"
        elif table == "[[joint]]" and s.startswith("mass_kg ="):
            if name is None:
                raise RuntimeError("mass_kg before name in a [[joint]] table")
            mass = joints[name][1]
            if mass != tomllib.loads(s)["mass_kg"]:
                line = f"mass_kg = {mass!r}\n"
                edits += 1
        out.append(line)
    new_text = "".join(out)
    old, new = tomllib.loads(text), tomllib.loads(new_text)
    if edits != 2 * (units - 1) or len(new["joint"]) != len(joints):
        raise RuntimeError(f"{edits} masses rewritten, expected {2 * (units - 1)}")
    for j_old, j_new in zip(old["joint"], new["joint"]):
        pos, mass = joints[j_new["name"]]
        if j_new["mass_kg"] != mass or max(abs(p - q) for p, q in zip(j_new["position_m"], pos)) > 1e-15:
            raise RuntimeError(f"joint {j_new['name']} differs from the oracle")
        j_old.pop("mass_kg")
        j_new.pop("mass_kg")
    if new["cable"][0]["path"] != cable_path(units):
        raise RuntimeError("the cable path edit failed")
    old["cable"][0].pop("path")
    new["cable"][0].pop("path")
    if old != new:
        raise RuntimeError("the mass edit changed something else")
    with open(path, "w") as f:
        f.write(new_text)
    os.remove(generated)


def run_truss(binary, model, dt, json_out, until_s):
    """`simulate` to the deploy time; `--until` past the exact one (the generated model's
    end_time_s of 600 s is short of the 256-unit mast's 1,548 s)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    proc = subprocess.run([binary, "simulate", model, "--dt", repr(dt), "--until", repr(float(until_s)),
                           "--json", json_out],
                          capture_output=True, text=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise RuntimeError(f"truss-deploy exit {proc.returncode}: {proc.stderr or proc.stdout}")
    with open(json_out) as f:
        res = json.load(f)
    if not res["deployed"]:
        raise RuntimeError(f"truss-deploy did not deploy: {res['stop_message']}")
    stats = res.get("solver_stats", {})
    return {
        "cpu_s": (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime),
        "wall_time_s": res["wall_time_s"],
        "deploy_time_s": res["deploy_time_s"],
        "steps": res["steps"],
        "substeps": stats.get("substeps"),
        "newmark_iterations": stats.get("newmark_iterations"),
        "factorizations": stats.get("factorizations"),
        "energy_balance_rel_error": res["energy_balance_rel_error"],
        "max_constraint_violation_m": res["max_constraint_violation_m"],
    }


# ---------------------------------------------------------------- Exudyn


class ExudynMast:
    """The oracle mast in Exudyn: one MainSystem, ready for SolveDynamic."""

    def __init__(self, exu, units, sensors=True):
        from exudyn.itemInterface import (DistanceConstraint, CoordinateConstraint,
                                          MarkerNodeCoordinate, MarkerNodePosition,
                                          MarkerObjectODE2Coordinates, MassPoint, NodePoint,
                                          NodePointGround, ObjectConnectorCoordinateVector,
                                          ObjectConnectorSpringDamper, ObjectGenericODE2,
                                          SensorNode)
        self.exu = exu
        self.sc = exu.SystemContainer()
        mbs = self.mbs = self.sc.AddSystem()
        self.node = {}
        position_marker = {}
        for name, _, _, pos, mass in mast_joints(units):
            n = mbs.AddNode(NodePoint(referenceCoordinates=list(pos)))
            mbs.AddObject(MassPoint(mass=mass, nodeNumber=n))
            self.node[name] = n
            position_marker[name] = mbs.AddMarker(MarkerNodePosition(nodeNumber=n))
        ground = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=mbs.AddNode(NodePointGround()),
                                                    coordinate=0))
        self.supports = []

        def fix(name, axis):
            m = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=self.node[name], coordinate=axis))
            self.supports.append(mbs.AddObject(CoordinateConstraint(markerNumbers=[ground, m])))

        for axis in range(3):
            fix("L0", axis)
        fix("R0", 1)
        fix("R0", 2)
        for u in range(1, units + 1):
            fix(f"L{u}", 1)
            fix(f"R{u}", 1)
        # pivot of unit u: x and z of (X_Lu + X_R(u+1)) = (X_Ru + X_L(u+1)); y is held by the
        # supports, so its row would be redundant
        pivot_rows = np.zeros((2, 6))
        pivot_rows[0, 0] = pivot_rows[0, 3] = 1.0
        pivot_rows[1, 2] = pivot_rows[1, 5] = 1.0
        self.rods, self.pivots = [], []
        for u in range(units):
            rod_markers = []
            for a, b in ((f"L{u}", f"R{u + 1}"), (f"R{u}", f"L{u + 1}")):
                self.rods.append(mbs.AddObject(DistanceConstraint(
                    markerNumbers=[position_marker[a], position_marker[b]],
                    distance=ROD_LENGTH_M)))
                group = mbs.AddObject(ObjectGenericODE2(nodeNumbers=[self.node[a], self.node[b]]))
                rod_markers.append(mbs.AddMarker(MarkerObjectODE2Coordinates(objectNumber=group)))
            self.pivots.append(mbs.AddObject(ObjectConnectorCoordinateVector(
                markerNumbers=rod_markers, scalingMarker0=pivot_rows,
                scalingMarker1=pivot_rows, offset=[0.0, 0.0])))
        self.cable_path = cable_path(units)
        for a, b in zip(self.cable_path[:-1], self.cable_path[1:]):
            mbs.AddObject(ObjectConnectorSpringDamper(
                markerNumbers=[position_marker[a], position_marker[b]],
                referenceLength=0.0, stiffness=0.0, damping=0.0, force=TENSION_N))
        self.sensors = None
        if sensors:
            ovt = exu.OutputVariableType
            self.sensors = [mbs.AddSensor(SensorNode(nodeNumber=self.node[j], storeInternal=True,
                                                     writeToFile=False, outputVariableType=v))
                            for j in ("L0", "L1") for v in (ovt.Position, ovt.Velocity)]
        mbs.Assemble()

    def settings(self, dt, end_time, rho, newton_rtol=None):
        exu = self.exu
        s = exu.SimulationSettings()
        steps = int(math.ceil(end_time / dt - 1e-9))
        ti = s.timeIntegration
        ti.numberOfSteps, ti.endTime = steps, steps * dt
        ti.adaptiveStep = False
        ti.automaticStepSize = False
        ti.verboseMode = 0
        ti.generalizedAlpha.spectralRadius = rho
        ti.generalizedAlpha.useIndex2Constraints = False
        ti.generalizedAlpha.useNewmark = False
        if newton_rtol is not None:
            ti.newton.relativeTolerance = newton_rtol
        s.linearSolver.solverType = exu.LinearSolverType.EigenSparse
        s.solution.file.write = False
        s.solution.sensors.writePeriod = 0.5 * dt  # below dt: every step is stored
        return s

    def solve(self, dt, end_time, rho, newton_rtol=None):
        s = self.settings(dt, end_time, rho, newton_rtol)
        self.exu.config.printToConsole = False  # see the module docstring
        try:
            t0 = time.process_time()
            ok = self.exu.SolveDynamic(self.mbs, s, solverType=self.exu.DynamicSolverType.GeneralizedAlpha,
                                       storeSolver=True)
            cpu = time.process_time() - t0
        finally:
            self.exu.config.printToConsole = True
        if not ok:
            raise RuntimeError("Exudyn SolveDynamic failed")
        it = self.mbs.sys["dynamicSolver"].it
        return cpu, {"steps": s.timeIntegration.numberOfSteps,
                     "newton_iterations": int(it.newtonStepsCount),
                     "jacobians": int(it.newtonJacobiCount)}

    def height_history(self):
        """(t, h, hdot) of the unit height z(L1) - z(L0) at every step."""
        p0, v0, p1, v1 = (self.mbs.GetSensorStoredData(s) for s in self.sensors)
        return p1[:, 0], p1[:, 3] - p0[:, 3], v1[:, 3] - v0[:, 3]

    def state(self):
        """Absolute positions and velocities, one row per joint, in mast_joints order."""
        sd, cfg = self.mbs.systemData, self.exu.ConfigurationType
        q = np.asarray(sd.GetODE2Coordinates(configuration=cfg.Current))
        q = q + np.asarray(sd.GetODE2Coordinates(configuration=cfg.Reference))
        v = np.asarray(sd.GetODE2Coordinates_t(configuration=cfg.Current))
        return q.reshape(-1, 3), v.reshape(-1, 3)


def hermite_crossing(t, h, v, level):
    """First time the cubic Hermite interpolant of (h, v) reaches level, and a bound on the
    interpolation error (max|h''''| dt^4 / 384 over |hdot|, h'''' from 4th differences)."""
    k = int(np.argmax(h >= level))
    if h[k] < level or k == 0:
        raise RuntimeError("the height never crosses the deploy level")
    k -= 1
    dt = t[k + 1] - t[k]
    h0, h1, m0, m1 = h[k], h[k + 1], v[k] * dt, v[k + 1] * dt

    def p(x):
        x2, x3 = x * x, x * x * x
        return ((2 * x3 - 3 * x2 + 1) * h0 + (x3 - 2 * x2 + x) * m0
                + (-2 * x3 + 3 * x2) * h1 + (x3 - x2) * m1)

    lo, hi = 0.0, 1.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if p(mid) < level:
            lo = mid
        else:
            hi = mid
        if hi - lo < 1e-17:
            break
    t_cross = t[k] + 0.5 * (lo + hi) * dt
    j = max(k - 3, 0)  # samples k-3 .. k+1
    d4 = abs(h[j] - 4 * h[j + 1] + 6 * h[j + 2] - 4 * h[j + 3] + h[j + 4])
    err_bound = d4 / 384.0 / abs(0.5 * (v[k] + v[k + 1]))
    return t_cross, err_bound


def run_exudyn(exu, units, dt, rho, exact, newton_rtol=None):
    mast = ExudynMast(exu, units)
    cpu, stats = mast.solve(dt, exact + 2 * dt, rho, newton_rtol)
    t, h, v = mast.height_history()
    if len(t) != stats["steps"] + 1 or np.ptp(np.diff(t)) > 1e-9 * dt:
        raise RuntimeError(f"sensors stored {len(t)} samples for {stats['steps']} steps")
    deploy, interp_bound = hermite_crossing(t, h, v, ROD_LENGTH_M * math.sin(math.radians(DEPLOY_DEG)))
    return {"cpu_s": cpu, "deploy_time_s": deploy, "interpolation_error_bound_s": interp_bound,
            "rho": rho, "newton_rtol": newton_rtol, **stats}


def verify_exudyn(exu, units, exact, dt):
    """Checks of the Exudyn model before it is timed (see the module docstring)."""
    from exudyn.solver import ComputeSystemDegreeOfFreedom
    out = {}
    mast = ExudynMast(exu, units)
    ovt = exu.OutputVariableType
    res = [abs(mast.mbs.GetObjectOutput(i, ovt.Distance) - ROD_LENGTH_M) for i in mast.rods]
    res += [float(np.max(np.abs(mast.mbs.GetObjectOutput(i, ovt.ConstraintEquation))))
            for i in mast.pivots + mast.supports]
    out["initial_constraint_residual_max"] = float(max(res))
    exu.config.printToConsole = False  # its advice to use a sparse solver: it is dense by design
    try:
        dof = ComputeSystemDegreeOfFreedom(mast.mbs)
    finally:
        exu.config.printToConsole = True
    out["dof"], out["redundant_constraints"] = int(dof["degreeOfFreedom"]), int(dof["redundantConstraints"])
    if out["dof"] != 1 or out["redundant_constraints"] != 0:
        raise RuntimeError(f"Exudyn mast has {dof}")

    # energy: kinetic energy against the cable work T (l0 - l), recorded before every step
    masses = np.repeat([m for *_, m in mast_joints(units)], 3)
    order = np.array([int(mast.node[name]) for name in mast.cable_path])
    record = []

    def pre_step(mbs, t):
        x, v = mast.state()
        length = np.linalg.norm(np.diff(x[order], axis=0), axis=1).sum()
        record.append((t, 0.5 * float((masses * v.ravel() ** 2).sum()), length, x[2, 2] - x[0, 2]))
        return True

    mast.mbs.SetPreStepUserFunction(pre_step)
    mast.solve(dt, exact, EXUDYN_DEFAULT_RHO)
    rec = np.array(record)
    work = TENSION_N * (rec[0, 2] - rec[:, 2])
    out["energy_rel_error_max"] = float(np.max(np.abs(rec[:, 1] - work)) / np.max(work))
    out["height_start_end_m"] = [float(rec[0, 3]), float(rec[-1, 3])]
    if not rec[-1, 3] > 2.0 * rec[0, 3]:
        raise RuntimeError("the Exudyn mast does not rise")

    # sensors' cost: the same run without them, alternately, the fastest of each (three pairs
    # where a run takes less than 2 s)
    bare_cpu, sensor_cpu = [], []
    while True:
        bare_cpu.append(ExudynMast(exu, units, sensors=False).solve(dt, exact + 2 * dt,
                                                                    EXUDYN_DEFAULT_RHO)[0])
        with_sensors = run_exudyn(exu, units, dt, EXUDYN_DEFAULT_RHO, exact)
        sensor_cpu.append(with_sensors["cpu_s"])
        if len(bare_cpu) == 3 or sensor_cpu[0] > 2.0:
            break
    out["cpu_without_sensors_s"], out["cpu_with_sensors_s"] = min(bare_cpu), min(sensor_cpu)

    out["rho_errors"] = {}
    for rho in (1.0, EXUDYN_DEFAULT_RHO):
        r = with_sensors if rho == EXUDYN_DEFAULT_RHO else run_exudyn(exu, units, dt, rho, exact)
        out["rho_errors"][str(rho)] = (r["deploy_time_s"] - exact) / exact
        out["interpolation_error_bound_rel"] = r["interpolation_error_bound_s"] / exact
    return out


def order_check(exu, units, exact, dt, rho):
    """Exudyn's deploy-time errors at dt, dt/2, dt/4: second order makes the ratios ~4."""
    errs = [(run_exudyn(exu, units, dt / 2**k, rho, exact)["deploy_time_s"] - exact) / exact
            for k in range(3)]
    return {"rho": rho, "dt": [dt / 2**k for k in range(3)], "rel_errors": errs,
            "ratios": [errs[0] / errs[1], errs[1] / errs[2]]}


# ---------------------------------------------------------------- benchmark driver


def machine():
    model = "unknown"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    model = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return {"cpu": model, "cores": os.cpu_count(), "platform": platform.platform(),
            "python": platform.python_version()}


class Bench:
    def __init__(self, args, exu, workdir):
        self.args, self.exu, self.workdir = args, exu, workdir
        self.records = []
        self.exact = {}
        self.models = {}
        self.rho = {}
        self.verification = {}

    def prepare(self, units):
        joints = mast_joints(units)
        ml = [m for _, _, side, _, m in joints if side == "L"]
        mr = [m for _, _, side, _, m in joints if side == "R"]
        t, qerr, panels = exact_deploy_time(units, ml, mr)
        self.exact[units] = {"deploy_time_s": t, "quadrature_rel_error": qerr, "panels": panels}
        model = os.path.join(self.workdir, f"mast{units}.toml")
        write_truss_model(self.args.bin, units, model)
        self.models[units] = model
        ver = verify_exudyn(self.exu, units, t, 0.05)
        self.verification[units] = ver
        if self.args.rho is not None:
            self.rho[units] = self.args.rho
        else:
            self.rho[units] = float(min(ver["rho_errors"], key=lambda r: abs(ver["rho_errors"][r])))
        if units <= self.args.order_check_max_units:
            ver["order_check"] = order_check(self.exu, units, t, 0.05, self.rho[units])

    def truss(self, units, dt, rep, mode):
        out = os.path.join(self.workdir, f"truss_{units}_{dt!r}_{rep}.json")
        r = run_truss(self.args.bin, self.models[units], dt, out,
                      1.5 * self.exact[units]["deploy_time_s"])
        return self.record("truss-deploy", units, dt, rep, mode, r)

    def exudyn(self, units, dt, rep, mode):
        r = run_exudyn(self.exu, units, dt, self.rho[units], self.exact[units]["deploy_time_s"])
        return self.record("exudyn", units, dt, rep, mode, r)

    def record(self, code, units, dt, rep, mode, r):
        exact = self.exact[units]["deploy_time_s"]
        r.update(code=code, units=units, dt=dt, rep=rep, mode=mode,
                 rel_error=(r["deploy_time_s"] - exact) / exact, load_avg_1min=os.getloadavg()[0])
        self.records.append(r)
        return r

    def timed_pair(self, units, dt_truss, dt_exudyn, mode):
        """R interleaved repetitions; medians per code."""
        runs = {"truss-deploy": [], "exudyn": []}
        for rep in range(self.args.repeats):
            runs["truss-deploy"].append(self.truss(units, dt_truss, rep, mode))
            runs["exudyn"].append(self.exudyn(units, dt_exudyn, rep, mode))
        return {code: summarize(rs) for code, rs in runs.items()}

    def find_dt(self, code, units, tol):
        dt = 0.05
        while True:
            r = (self.truss if code == "truss-deploy" else self.exudyn)(units, dt, 0, "search")
            if abs(r["rel_error"]) <= tol:
                return dt, True
            if dt / 2 < self.args.min_dt:
                return dt, False
            dt /= 2


def summarize(runs):
    def med(key):
        return statistics.median(r[key] for r in runs)

    out = {"cpu_s": med("cpu_s"), "cpu_all_s": [r["cpu_s"] for r in runs],
           "deploy_time_s": runs[0]["deploy_time_s"], "rel_error": runs[0]["rel_error"], "dt": runs[0]["dt"]}
    for key in ("wall_time_s", "substeps", "steps", "newton_iterations", "jacobians"):
        if runs[0].get(key) is not None:
            out[key] = med(key)
    return out


def print_table(headers, rows, markdown):
    cells = [[str(c) for c in row] for row in rows]
    if markdown:
        print("| " + " | ".join(headers) + " |")
        print("|" + "|".join("---:" for _ in headers) + "|")
        for row in cells:
            print("| " + " | ".join(row) + " |")
        return
    widths = [max(len(h), *(len(r[i]) for r in cells)) for i, h in enumerate(headers)]
    print("  ".join(h.rjust(w) for h, w in zip(headers, widths)))
    for row in cells:
        print("  ".join(c.rjust(w) for c, w in zip(row, widths)))


def print_checks(bench, units):
    ex, ver = bench.exact[units], bench.verification[units]
    over = ver["cpu_with_sensors_s"] / ver["cpu_without_sensors_s"] - 1.0
    print(f"{units} units: exact deploy time {ex['deploy_time_s']:.12f} s "
          f"(quadrature rel. error ~{ex['quadrature_rel_error']:.0e}, {ex['panels']} Simpson panels)")
    print(f"  Exudyn model: |Phi(0)| <= {ver['initial_constraint_residual_max']:.1e} m, "
          f"{ver['dof']} DOF, {ver['redundant_constraints']} redundant rows; unit height "
          f"{ver['height_start_end_m'][0]:.4f} -> {ver['height_start_end_m'][1]:.4f} m; "
          f"max |K - W| / W_max {ver['energy_rel_error_max']:.1e} (dt 0.05, rho 0.9)")
    print(f"  Exudyn at dt 0.05: rel. error {ver['rho_errors']['1.0']:+.4e} with spectralRadius 1.0, "
          f"{ver['rho_errors']['0.9']:+.4e} with 0.9 (default): using {bench.rho[units]}")
    print(f"  Exudyn crossing: Hermite interpolation error bound {ver['interpolation_error_bound_rel']:.0e} "
          f"(relative); the height sensors cost {100 * over:+.1f}% CPU (fastest runs with and without)")
    if "order_check" in ver:
        oc = ver["order_check"]
        print(f"  Exudyn order (rho {oc['rho']}): errors " +
              ", ".join(f"{e:+.4e}" for e in oc["rel_errors"]) +
              " at dt " + ", ".join(f"{d:g}" for d in oc["dt"]) +
              f"; ratios {oc['ratios'][0]:.3f}, {oc['ratios'][1]:.3f}")


def fixed_dt_table(bench, args):
    rows, table = [], []
    for units in args.units:
        for dt in args.dt:
            s = bench.timed_pair(units, dt, dt, "fixed_dt")
            td, ed = s["truss-deploy"], s["exudyn"]
            rows.append([units, f"{dt:g}", f"{bench.exact[units]['deploy_time_s']:.9f}",
                         f"{td['cpu_s']:.3f}", f"{td['wall_time_s']:.3f}", f"{ed['cpu_s']:.3f}",
                         f"{ed['cpu_s'] / td['cpu_s']:.2f}",
                         f"{td['deploy_time_s']:.9f}", f"{td['rel_error']:+.2e}",
                         f"{ed['deploy_time_s']:.9f}", f"{ed['rel_error']:+.2e}",
                         int(td["substeps"]), int(ed["steps"]),
                         f"{ed['newton_iterations'] / ed['steps']:.2f}", int(ed["jacobians"])])
            table.append({"units": units, "dt": dt, **s})
    print(f"CPU time: median of {args.repeats} interleaved runs. truss-deploy: user+sys of the whole "
          f"process (wall: its own wall_time_s); Exudyn: process_time of SolveDynamic")
    print_table(["units", "dt s", "exact s", "truss CPU s", "truss wall s", "Exudyn CPU s",
                 "Exudyn/truss", "truss deploy s", "truss err", "Exudyn deploy s", "Exudyn err",
                 "truss sub-steps", "Exudyn steps", "Exudyn Newton it/step", "Exudyn Jacobians"],
                rows, args.markdown)
    return table


def cpu_at_tolerance(trail, tol):
    """CPU time at |error| = tol, interpolated log-log between the last two search runs."""
    if len(trail) < 2 or abs(trail[-1]["rel_error"]) > tol:
        return None
    (e1, c1), (e2, c2) = ((abs(r["rel_error"]), r["cpu_s"]) for r in trail[-2:])
    if not e1 > tol >= e2 > 0.0:
        return None
    x = math.log(e1 / tol) / math.log(e1 / e2)
    return math.exp(math.log(c1) + x * math.log(c2 / c1))


def equal_accuracy_table(bench, args):
    tol, rows, table = args.equal_accuracy, [], []
    codes = ("truss-deploy", "exudyn")
    for units in args.units:
        found = {code: bench.find_dt(code, units, tol) for code in codes}
        interpolated = {}
        for code in codes:
            trail = [r for r in bench.records if r["mode"] == "search" and r["units"] == units
                     and r["code"] == code]
            interpolated[code] = cpu_at_tolerance(trail, tol)
            print(f"{units} units, {code} search: " +
                  ", ".join(f"dt {r['dt']:g} err {r['rel_error']:+.3e} ({r['cpu_s']:.2f} s)" for r in trail))
        dt_exudyn = found["exudyn"][0]
        tight = run_exudyn(bench.exu, units, dt_exudyn, bench.rho[units],
                           bench.exact[units]["deploy_time_s"], newton_rtol=1e-10)
        default = [r for r in bench.records if r["mode"] == "search" and r["units"] == units
                   and r["code"] == "exudyn" and r["dt"] == dt_exudyn][0]
        newton_shift = (default["deploy_time_s"] - tight["deploy_time_s"]) / bench.exact[units]["deploy_time_s"]
        print(f"{units} units, Exudyn at dt {dt_exudyn:g}: Newton relativeTolerance 1e-8 (default) against "
              f"1e-10 moves the deploy time by {newton_shift:+.2e} (relative)")
        s = bench.timed_pair(units, found["truss-deploy"][0], dt_exudyn, "equal_accuracy")
        td, ed = s["truss-deploy"], s["exudyn"]
        mark = {code: "" if found[code][1] else " (floor, not reached)" for code in codes}
        interp = ("" if None in interpolated.values() else
                  f"{interpolated['exudyn'] / interpolated['truss-deploy']:.2f}")
        rows.append([units, f"{tol:g}", f"{td['dt']:g}{mark['truss-deploy']}", int(td["substeps"]),
                     f"{td['rel_error']:+.2e}", f"{td['cpu_s']:.3f}",
                     f"{ed['dt']:g}{mark['exudyn']}", int(ed["steps"]), f"{ed['rel_error']:+.2e}",
                     f"{ed['cpu_s']:.3f}", f"{ed['cpu_s'] / td['cpu_s']:.2f}", interp])
        table.append({"units": units, "tol": tol, "reached": {c: f[1] for c, f in found.items()},
                      "cpu_at_tol_interpolated_s": interpolated, "exudyn_newton_shift_rel": newton_shift,
                      **s})
    print(f"\nequal accuracy: dt halved from 0.05 per code until |deploy-time error| <= {tol:g} "
          f"(floor {args.min_dt:g} s); CPU: median of {args.repeats} interleaved runs at the dt found; "
          f"last column: the ratio of CPU times interpolated log-log to |error| = {tol:g} between "
          f"each code's last two search runs (one run each)")
    print_table(["units", "tol", "truss dt s", "truss sub-steps", "truss err", "truss CPU s",
                 "Exudyn dt s", "Exudyn steps", "Exudyn err", "Exudyn CPU s", "Exudyn/truss",
                 "Exudyn/truss at tol"], rows, args.markdown)
    return table


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--bin", default="target/release/truss-deploy", help="truss-deploy binary")
    ap.add_argument("--units", type=int, nargs="+", default=[64, 256])
    ap.add_argument("--dt", type=float, nargs="+", default=[0.05])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--cable", choices=["bottom", "full"], default="bottom",
                    help="the drive cable across the bottom unit only (default) or over every unit")
    ap.add_argument("--json", help="write every raw number here")
    ap.add_argument("--markdown", action="store_true", help="print the tables as Markdown")
    ap.add_argument("--equal-accuracy", type=float, nargs="?", const=2e-8, default=None, metavar="TOL",
                    help="halve dt from 0.05 per code until |error| <= TOL (default 2e-8), then time both")
    ap.add_argument("--min-dt", type=float, default=0.05 / 2**10, help="floor of the --equal-accuracy search")
    ap.add_argument("--rho", type=float, default=None,
                    help="Exudyn spectralRadius (default: the more accurate of 1.0 and 0.9 at dt 0.05)")
    ap.add_argument("--order-check-max-units", type=int, default=64,
                    help="verify Exudyn's second order (dt 0.05, 0.025, 0.0125) on masts up to this size")
    args = ap.parse_args()
    args.bin = os.path.abspath(args.bin)
    CABLE["mode"] = args.cable

    import exudyn as exu
    mach = machine()
    load_start = os.getloadavg()
    print(f"machine       {mach['cpu']}, {mach['cores']} cores ({mach['platform']})")
    ident = binary_identity(args.bin)
    print(f"truss-deploy  {truss_version(args.bin)}, {args.bin} "
          f"(sha256 {ident['sha256'][:12]}, {ident['bytes']} bytes, modified {ident['mtime']})")
    print(f"exudyn        {exu.__version__} (Python {mach['python']}, numpy {np.__version__})")
    print(f"load average  {load_start[0]:.2f} {load_start[1]:.2f} {load_start[2]:.2f} (1, 5, 15 min) at start")
    print(f"oracle mast   rods 0.5 m, 5 -> 60 deg, T 10 N ({args.cable} cable), 0.25 kg per rod end, "
          "no gravity/damping/friction")
    print()

    with tempfile.TemporaryDirectory(prefix="peer_exudyn_") as workdir:
        bench = Bench(args, exu, workdir)
        for units in args.units:
            bench.prepare(units)
            print_checks(bench, units)
        print()
        if args.equal_accuracy is None:
            tables = {"fixed_dt": fixed_dt_table(bench, args)}
        else:
            tables = {"equal_accuracy": equal_accuracy_table(bench, args)}

    ratios = [r["interpolation_error_bound_s"] / r["deploy_time_s"] / max(abs(r["rel_error"]), 1e-300)
              for r in bench.records if r["code"] == "exudyn"]
    print(f"\nExudyn crossings: the Hermite interpolation error bound is at most {max(ratios):.0e} of "
          f"the run's deploy-time error")
    load_end = os.getloadavg()
    loads = [r["load_avg_1min"] for r in bench.records]
    print(f"load average  {load_end[0]:.2f} {load_end[1]:.2f} {load_end[2]:.2f} at the end; "
          f"1-min load after each run {min(loads):.2f} .. {max(loads):.2f}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"machine": mach, "truss_deploy_version": truss_version(args.bin),
                       "truss_deploy_binary": ident,
                       "exudyn_version": exu.__version__, "args": vars(args),
                       "load_avg_start": load_start, "load_avg_end": load_end,
                       "exact": bench.exact, "exudyn_verification": bench.verification,
                       "exudyn_rho": bench.rho, "tables": tables, "runs": bench.records},
                      f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
