"""Simulations from Python: the CLI's summary to the bit, the state arrays
against the CLI's CSV and JSON, save/restore and pickling to the bit, cable
commands from a controller, the history, Ctrl-C."""

import csv
import json
import multiprocessing as mp
import os
import pickle
import signal
import threading

import numpy as np
import pytest

import truss_deploy as td
from conftest import BUNDLED, MODELS


def without_wall(summary):
    s = dict(summary)
    s.pop("wall_time_s")
    return s


@pytest.mark.parametrize("name", BUNDLED)
def test_a_run_from_python_is_simulate_to_the_bit(cli, tmp_path, name):
    out = tmp_path / "s.json"
    path = MODELS / f"{name}.toml"
    cli("simulate", path, "--json", out)
    want = json.loads(out.read_text())
    got = td.Simulator(td.load(path)).run()
    # (json.loads of the CLI's file and the summary's dict: every float exact)
    assert without_wall(got) == without_wall(want)
    assert got["stop_reason"] == "deployed"


def test_the_state_arrays_are_the_csv_and_json_outputs(cli, tmp_path):
    path = MODELS / "pantograph_mast.toml"
    cli("simulate", path, "--until", "5", "--csv", tmp_path / "x.csv", "--json", tmp_path / "s.json")
    rows = list(csv.reader(open(tmp_path / "x.csv")))
    summary = json.loads((tmp_path / "s.json").read_text())
    sim = td.Simulator(td.load(path), record=True)
    got = sim.run(until=5.0)
    assert without_wall(got) == without_wall(summary)
    last = [float(v) for v in rows[-1]]
    assert last[0] == sim.t_s
    x = sim.positions
    assert x.shape == (10, 3) and x.dtype == np.float64
    assert np.array_equal(x.ravel(), np.array(last[1:]))
    assert sim.velocities.shape == (10, 3)
    assert list(sim.motor_tensions) == [m["tension_n"] for m in summary["motors"]]
    assert list(sim.reeled_in_m) == [m["reeled_in_m"] for m in summary["motors"]]
    assert sim.motor_modes == [m["mode"] for m in summary["motors"]]
    assert sim.cable_tensions[0][0] == sim.motor_tensions[0] and len(sim.cable_tensions[0]) == 9
    assert sim.locks == summary["locks"]
    assert sim.locked.dtype == bool and sim.locked.shape == (4,) and not sim.locked.any()
    assert sim.energy == summary["energy"] and sim.solver_stats == summary["solver_stats"]
    # the history: every CSV row, the motor tension and energy terms per step
    h = sim.history()
    assert len(h) == len(rows) - 1
    assert list(h.columns[:5]) == ["t_s", "step", "L0_x_m", "L0_y_m", "L0_z_m"]
    assert np.array_equal(h.iloc[:, 2:32].to_numpy(), np.array([[float(v) for v in r[1:]] for r in rows[1:]]))
    assert h["t_s"].tolist() == [float(r[0]) for r in rows[1:]]
    for c in ["drive_tension_n", "drive_reeled_in_m", "motor_work_j", "friction_loss_j", "kinetic_energy_j", "deploy_fraction"]:
        assert c in h.columns, c
    assert h["drive_tension_n"].iloc[-1] == sim.motor_tensions[0]


def test_save_step_restore_step_is_the_same_to_the_bit():
    sim = td.Simulator(td.load(MODELS / "pantograph_mast.toml"))
    for _ in range(100):
        sim.step()
    snap = sim.save()
    for _ in range(250):
        sim.step()
    first = (sim.positions, sim.velocities, sim.motor_tensions, sim.locks, sim.energy, sim.solver_stats)
    sim.restore(snap)
    assert sim.t_s == snap.t_s and sim.steps == 100
    for _ in range(250):
        sim.step()
    again = (sim.positions, sim.velocities, sim.motor_tensions, sim.locks, sim.energy, sim.solver_stats)
    for a, b in zip(first, again):
        if isinstance(a, np.ndarray):
            assert np.array_equal(a, b)
        else:
            assert a == b
    assert sim.save() != snap and td.Snapshot.from_json(snap.to_json()) == snap
    other = td.Simulator(td.load(MODELS / "sail_array.toml"))
    with pytest.raises(td.SolverError, match="another model|snapshot"):
        other.restore(snap)


def _continue_in_child(blob, queue):
    sim = pickle.loads(blob)
    for _ in range(200):
        sim.step()
    queue.put((sim.t_s, sim.positions.tobytes(), json.dumps(sim.energy)))


def test_a_pickled_simulator_restores_in_another_process():
    sim = td.Simulator(td.load(MODELS / "pantograph_mast.toml"))
    for _ in range(150):
        sim.step()
    blob = pickle.dumps(sim)
    snap_blob = pickle.dumps(sim.save())
    ctx = mp.get_context("spawn")
    q = ctx.Queue()
    p = ctx.Process(target=_continue_in_child, args=(blob, q))
    p.start()
    t, x, energy = q.get(timeout=120)
    p.join(timeout=60)
    assert p.exitcode == 0
    for _ in range(200):
        sim.step()
    assert t == sim.t_s and x == sim.positions.tobytes() and json.loads(energy) == sim.energy
    # a pickled snapshot restores into a fresh simulator of the model
    fresh = td.Simulator(td.load(MODELS / "pantograph_mast.toml"))
    fresh.restore(pickle.loads(snap_blob))
    for _ in range(200):
        fresh.step()
    assert np.array_equal(fresh.positions, sim.positions)


def test_a_python_controller_holds_the_commanded_speed():
    """A speed profile commanded step by step (set_cable_speed): once the
    motor is engaged (tracking), the cable's reel-in rate is the command
    within 1e-6 m/s at every step, until the latches end the motion."""
    m = td.load(MODELS / "pantograph_mast.toml")
    # (undamped, the bundled mast runs ahead of any constant cable speed: its
    # motor goes slack; with some joint damping the motor holds it)
    m.damping_n_s_per_m = 0.3
    sim = td.Simulator(m)
    dt = 0.05
    tracked = 0
    while not sim.deployed and sim.t_s < 300:
        t = sim.t_s
        cmd = min(0.01, 0.002 * (t + dt))  # a ramp to 0.01 m/s over 5 s
        sim.set_cable_speed("drive", cmd)
        sim.step(dt)
        if sim.motor_modes[0] == "tracking":
            tracked += 1
            assert abs(sim.reel_in_rate_m_s[0] - cmd) <= 1e-6, (sim.t_s, sim.reel_in_rate_m_s[0], cmd)
    assert sim.deployed and tracked > 2000
    sim.set_cable_speed("drive", None)
    assert sim.motor_modes == ["tension"]
    with pytest.raises(ValueError, match="tension"):
        sim.set_cable_tension("drive", -1.0)
    with pytest.raises(KeyError, match="no cable `nope`"):
        sim.set_cable_speed("nope", 0.1)
    with pytest.raises(ValueError):
        sim.step(-1.0)


def test_bad_run_arguments_raise_value_errors():
    sim = td.Simulator(td.load(MODELS / "pantograph_mast.toml"))
    with pytest.raises(ValueError, match="until = -1"):
        sim.run(until=-1.0)
    with pytest.raises(ValueError, match="longer than the run"):
        sim.run(until=0.01, dt=0.05)
    with pytest.raises(ValueError, match="solver"):
        td.Simulator(td.load(MODELS / "pantograph_mast.toml"), solver="qr")
    with pytest.raises(ValueError, match="record"):
        sim.record(["nothing"])


def test_a_wall_limit_stops_the_run_with_what_was_computed():
    sim = td.Simulator(td.load(MODELS / "double_ring.toml"))
    s = sim.run(max_wall_s=0.3)
    assert s["stop_reason"] == "error" and "wall-clock limit" in s["stop_message"]
    assert sim.t_s == s["time_s"] > 0


def test_ctrl_c_stops_a_run_cleanly():
    sim = td.Simulator(td.load(MODELS / "double_ring.toml"), record=True)
    # (Python's own SIGINT handler, as in a terminal or a notebook: a process
    # started in the background by a script inherits SIGINT ignored)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    timer = threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT))
    try:
        timer.start()
        with pytest.raises(KeyboardInterrupt):
            sim.run()
    finally:
        timer.join()
        signal.signal(signal.SIGINT, previous)
    s = sim.last_summary
    assert s["stop_reason"] == "interrupted" and s["time_s"] == sim.t_s > 0
    assert len(sim.history()) == sim.steps + 1
    # and it goes on from there
    sim.step()
    assert sim.steps == s["steps"] + 1
