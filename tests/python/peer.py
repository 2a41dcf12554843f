#!/usr/bin/env python3
"""Independent Cyclone DDS peer for the truss_deploy node (tests/node_cyclone.rs).

Types are written by hand from msg/*.msg (and sensor_msgs/JointState); the typename
is ROS 2's DDS mangling pkg::msg::dds_::Type_. The peer
  (a) receives and decodes rt/joint_states,
  (b) late-joins rt/truss/lock_status (reliable, transient local, keep last 1),
  (c) sends rt/truss/cable_force_cmd and waits for LockStatus to show it in force,
  (d) with PEER_SIM_IF=1: drives the simulation_interfaces services as rmw_cyclonedds_cpp
      calls them (rq/<name>Request, rr/<name>Reply, a 16-byte header of client id and
      sequence number before the request): features, pause, step 5, resume, reset; and
      joins /truss/lock_status late once more, counting what it gets (must be exactly 1);
  (e) with PEER_SPEED=S: then sends one rt/truss/cable_speed_cmd (CableSpeedCommand, S m/s
      for `drive`) and reads the `drive_motor` joint on rt/joint_states: from when the motor
      runs at S, its velocity stays S (to 1e-9) and its position (the cable reeled in) grows
      at S over 1 s of simulated time (the node must run a mast that stays taut).
Every loop is bounded in count and time. Exit code 0 iff all of them worked.
Env: ROS_DOMAIN_ID, PEER_SECS (default 20), PEER_TENSION (default 0.123), PEER_SPEED,
CYCLONEDDS_URI (tests pass a loopback-only config).
"""
import json
import os
import sys
import time
from dataclasses import dataclass

from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import float64, int32, int64, sequence, uint8, uint16, uint32, uint64
from cyclonedds.pub import DataWriter
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration


@dataclass
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: int32
    nanosec: uint32


@dataclass
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time
    frame_id: str


@dataclass
class JointState(IdlStruct, typename="sensor_msgs::msg::dds_::JointState_"):
    header: Header
    name: sequence[str]
    position: sequence[float64]
    velocity: sequence[float64]
    effort: sequence[float64]


# msg/LockStatus.msg
@dataclass
class LockStatus(IdlStruct, typename="truss_deploy::msg::dds_::LockStatus_"):
    header: Header
    names: sequence[str]
    locked: sequence[bool]
    time_s: sequence[float64]
    impulse_ns: sequence[float64]
    energy_lost_j: sequence[float64]
    deployed: bool
    paused: bool
    cable_names: sequence[str]
    cable_tensions_n: sequence[float64]
    accepted_commands: uint32
    rejected_commands: uint32
    rejected_unknown_cable: uint32
    rejected_mismatched_lengths: uint32
    rejected_bad_tension: uint32
    rejected_malformed: uint32
    rejected_bad_speed: uint32


# msg/CableForceCommand.msg
@dataclass
class CableForceCommand(IdlStruct, typename="truss_deploy::msg::dds_::CableForceCommand_"):
    names: sequence[str]
    tensions_n: sequence[float64]


# msg/CableSpeedCommand.msg
@dataclass
class CableSpeedCommand(IdlStruct, typename="truss_deploy::msg::dds_::CableSpeedCommand_"):
    names: sequence[str]
    speeds_m_s: sequence[float64]


# simulation_interfaces 2.x (tests/data/simulation_interfaces-2.1.0), each request and
# reply prefixed with rmw_cyclonedds_cpp's header (uint64 client id, int64 sequence number).
@dataclass
class SimResult(IdlStruct, typename="simulation_interfaces::msg::dds_::Result_"):
    result: uint8
    error_message: str


@dataclass
class SimulationState(IdlStruct, typename="simulation_interfaces::msg::dds_::SimulationState_"):
    state: uint8


@dataclass
class SimulatorFeatures(IdlStruct, typename="simulation_interfaces::msg::dds_::SimulatorFeatures_"):
    features: sequence[uint16]
    spawn_formats: sequence[str]
    custom_info: str


@dataclass
class GetSimulatorFeaturesRq(IdlStruct, typename="simulation_interfaces::srv::dds_::GetSimulatorFeatures_Request_"):
    guid: uint64
    seq: int64
    structure_needs_at_least_one_member: uint8


@dataclass
class GetSimulatorFeaturesRp(IdlStruct, typename="simulation_interfaces::srv::dds_::GetSimulatorFeatures_Response_"):
    guid: uint64
    seq: int64
    features: SimulatorFeatures


@dataclass
class GetSimulationStateRq(IdlStruct, typename="simulation_interfaces::srv::dds_::GetSimulationState_Request_"):
    guid: uint64
    seq: int64
    structure_needs_at_least_one_member: uint8


@dataclass
class GetSimulationStateRp(IdlStruct, typename="simulation_interfaces::srv::dds_::GetSimulationState_Response_"):
    guid: uint64
    seq: int64
    state: SimulationState
    result: SimResult


@dataclass
class SetSimulationStateRq(IdlStruct, typename="simulation_interfaces::srv::dds_::SetSimulationState_Request_"):
    guid: uint64
    seq: int64
    state: SimulationState


@dataclass
class SetSimulationStateRp(IdlStruct, typename="simulation_interfaces::srv::dds_::SetSimulationState_Response_"):
    guid: uint64
    seq: int64
    result: SimResult


@dataclass
class ResetSimulationRq(IdlStruct, typename="simulation_interfaces::srv::dds_::ResetSimulation_Request_"):
    guid: uint64
    seq: int64
    scope: uint8


@dataclass
class ResetSimulationRp(IdlStruct, typename="simulation_interfaces::srv::dds_::ResetSimulation_Response_"):
    guid: uint64
    seq: int64
    result: SimResult


@dataclass
class StepSimulationRq(IdlStruct, typename="simulation_interfaces::srv::dds_::StepSimulation_Request_"):
    guid: uint64
    seq: int64
    steps: uint64


@dataclass
class StepSimulationRp(IdlStruct, typename="simulation_interfaces::srv::dds_::StepSimulation_Response_"):
    guid: uint64
    seq: int64
    result: SimResult


RESULT_OK, STATE_PLAYING, STATE_PAUSED = 1, 1, 2


class CycloneClient:
    """A service client as rmw_cyclonedds_cpp makes one."""

    def __init__(self, dp, name, rq_type, rp_type, qos):
        self.w = DataWriter(dp, Topic(dp, f"rq/truss/{name}Request", rq_type), qos=qos)
        self.r = DataReader(dp, Topic(dp, f"rr/truss/{name}Reply", rp_type), qos=qos)
        self.rq_type = rq_type
        self.guid = 0x1234_5678_9ABC_DEF0 ^ hash(name) & 0xFFFF_FFFF
        self.seq = 0
        self.name = name

    def available(self):
        return len(self.w.get_matched_subscriptions()) > 0 and len(self.r.get_matched_publications()) > 0

    def call(self, timeout_s=5.0, **fields):
        """Waits (bounded) for the service, calls it; returns (reply, seconds from
        availability to reply) or (None, None)."""
        t0 = time.monotonic()
        for _ in range(int(timeout_s / 0.005) + 1):
            if self.available() or time.monotonic() - t0 > timeout_s:
                break
            time.sleep(0.005)
        if not self.available():
            log(self.name, "never available")
            return None, None
        t_av = time.monotonic()
        self.seq += 1
        self.w.write(self.rq_type(guid=self.guid, seq=self.seq, **fields))
        for _ in range(int(timeout_s / 0.002) + 1):
            for rp in self.r.take(N=10):
                if rp.guid == self.guid and rp.seq == self.seq:
                    return rp, time.monotonic() - t_av
            if time.monotonic() - t_av > timeout_s:
                break
            time.sleep(0.002)
        log(self.name, "no reply within", timeout_s, "s")
        return None, None


def latest_stamp(js_r, settle_s=0.3):
    """The newest /joint_states stamp after settle_s (bounded)."""
    t = None
    t0 = time.monotonic()
    for _ in range(int(settle_s / 0.01) + 2):
        for s in js_r.take(N=200):
            t = s.header.stamp.sec + 1e-9 * s.header.stamp.nanosec
        if time.monotonic() - t0 > settle_s:
            break
        time.sleep(0.01)
    return t


def sim_interfaces(dp, rel10, latched, js_r, xcdr1):
    """(d): returns a dict of results; 'ok' says whether all passed."""
    out = {"ok": False}
    feat = CycloneClient(dp, "get_simulator_features", GetSimulatorFeaturesRq, GetSimulatorFeaturesRp, rel10)
    get = CycloneClient(dp, "get_simulation_state", GetSimulationStateRq, GetSimulationStateRp, rel10)
    setc = CycloneClient(dp, "set_simulation_state", SetSimulationStateRq, SetSimulationStateRp, rel10)
    reset = CycloneClient(dp, "reset_simulation", ResetSimulationRq, ResetSimulationRp, rel10)
    step = CycloneClient(dp, "step_simulation", StepSimulationRq, StepSimulationRp, rel10)
    rp, lat = feat.call(structure_needs_at_least_one_member=0)
    if rp is None:
        return out
    out["first_call_latency_s"] = lat
    out["features"] = list(rp.features.features)
    rp, _ = setc.call(state=SimulationState(state=STATE_PAUSED))
    out["pause"] = rp.result.result if rp else None
    rp, _ = get.call(structure_needs_at_least_one_member=0)
    out["state_after_pause"] = rp.state.state if rp else None
    t_p = latest_stamp(js_r)
    rp, lat = step.call(steps=5)
    out["step"] = rp.result.result if rp else None
    out["step_latency_s"] = lat
    t_s = latest_stamp(js_r)
    out["stamp_paused_s"], out["stamp_after_step_s"] = t_p, t_s
    rp, _ = setc.call(state=SimulationState(state=STATE_PLAYING))
    out["resume"] = rp.result.result if rp else None
    time.sleep(1.0)
    t_r = latest_stamp(js_r)
    out["stamp_after_resume_s"] = t_r
    rp, _ = reset.call(scope=0)
    out["reset"] = rp.result.result if rp else None
    t_0 = latest_stamp(js_r, 0.2)
    out["stamp_after_reset_s"] = t_0
    # late joiner on lock_status once more, transient local, keeping up to 100 samples:
    # the node's writer (keep last 1) must send only its last one (RustDDS sent its
    # whole history; a keep-last-1 reader polled slowly would hide that)
    time.sleep(1.5)
    deep = Qos(Policy.Reliability.Reliable(duration(milliseconds=100)),
               Policy.Durability.TransientLocal, Policy.History.KeepLast(100), xcdr1)
    late = DataReader(dp, Topic(dp, "rt/truss/lock_status", LockStatus), qos=deep)
    got = []
    t0 = time.monotonic()
    for _ in range(300):
        got += late.take(N=100)
        if time.monotonic() - t0 > 2.0:
            break
        time.sleep(0.01)
    out["late_joiner_samples"] = len(got)
    dt = 0.05
    out["ok"] = (
        out["pause"] == RESULT_OK and out["state_after_pause"] == STATE_PAUSED
        and out["step"] == RESULT_OK and t_p is not None and t_s is not None
        and abs(t_s - (t_p + 5 * dt)) < 1e-6
        and out["resume"] == RESULT_OK and t_r is not None and t_r > t_s + 0.5
        and out["reset"] == RESULT_OK and t_0 is not None and t_0 < t_r
        and len(got) == 1
        and all(f in out["features"] for f in (20, 24, 25, 26, 31, 32))
    )
    return out


def speed_phase(dp, rel10, js_r, speed, budget_s=10.0):
    """(e): one speed command; the drive_motor joint on /joint_states after it."""
    out = {"ok": False, "speed_m_s": speed}
    w = DataWriter(dp, Topic(dp, "rt/truss/cable_speed_cmd", CableSpeedCommand), qos=rel10)
    t0 = time.monotonic()
    for _ in range(int(budget_s / 0.01) + 1):
        if len(w.get_matched_subscriptions()) or time.monotonic() - t0 > budget_s:
            break
        time.sleep(0.01)
    js_r.take(N=1000)  # what came before the command
    w.write(CableSpeedCommand(names=["drive"], speeds_m_s=[speed]))
    first = last = None
    n, err = 0, 0.0
    for _ in range(int(budget_s / 0.01) + 1):
        for s in js_r.take(N=100):
            names = list(s.name)
            if "drive_motor" not in names:
                continue
            k = names.index("drive_motor")
            t = s.header.stamp.sec + 1e-9 * s.header.stamp.nanosec
            e = abs(s.velocity[k] - speed)
            if first is None and e <= 1e-9:
                first = (t, s.position[k])
            elif first is not None and t > first[0]:
                n += 1
                err = max(err, e)
                last = (t, s.position[k])
        if last is not None and last[0] - first[0] >= 1.0:
            break
        if time.monotonic() - t0 > budget_s:
            break
        time.sleep(0.01)
    out["samples"] = n
    out["velocity_max_err"] = err
    if first is not None and last is not None:
        out["sim_s"] = last[0] - first[0]
        out["reel_in_rate"] = (last[1] - first[1]) / (last[0] - first[0])
        out["ok"] = (out["sim_s"] >= 1.0 and err <= 1e-9
                     and abs(out["reel_in_rate"] - speed) <= 1e-6)
    return out


def log(*a):
    print("[peer]", *a, flush=True)


def main() -> int:
    domain = int(os.environ.get("ROS_DOMAIN_ID", "0"))
    budget_s = float(os.environ.get("PEER_SECS", "20"))
    tension = float(os.environ.get("PEER_TENSION", "0.123"))
    dp = DomainParticipant(domain)
    xcdr1 = Policy.DataRepresentation(use_cdrv0_representation=True)  # as ROS 2 does
    rel10 = Qos(Policy.Reliability.Reliable(duration(milliseconds=100)),
                Policy.Durability.Volatile, Policy.History.KeepLast(10), xcdr1)
    latched = Qos(Policy.Reliability.Reliable(duration(milliseconds=100)),
                  Policy.Durability.TransientLocal, Policy.History.KeepLast(1), xcdr1)

    js_r = DataReader(dp, Topic(dp, "rt/joint_states", JointState), qos=rel10)
    lock_r = DataReader(dp, Topic(dp, "rt/truss/lock_status", LockStatus), qos=latched)
    cmd_w = DataWriter(dp, Topic(dp, "rt/truss/cable_force_cmd", CableForceCommand), qos=rel10)

    n_js = 0
    js_names = []
    first_lock = None
    obeyed = None
    sent = 0
    bad_sent = False
    t0 = time.monotonic()
    next_send = t0
    for _ in range(int(budget_s / 0.02) + 1):  # bounded count
        if time.monotonic() - t0 > budget_s:  # bounded time
            break
        for s in js_r.take(N=100):
            n_js += 1
            js_names = list(s.name)
        for s in lock_r.take(N=10):
            if first_lock is None:
                first_lock = s
                log("first LockStatus (late joiner): stamp", s.header.stamp.sec, s.header.stamp.nanosec,
                    "names", list(s.names), "cables", list(s.cable_names), list(s.cable_tensions_n))
            if sent and list(s.cable_tensions_n) == [tension] and s.accepted_commands >= 1:
                obeyed = s
        now = time.monotonic()
        if not bad_sent and first_lock is not None and len(cmd_w.get_matched_subscriptions()):
            # one of each fault kind, spaced out; the node must count them all
            for n, t in [(["nope"], [0.01]), (["drive"], [0.01, 0.02]), (["drive"], [-0.01]),
                         (["drive"], [float("nan")]), (["drive"], [1e9])]:
                cmd_w.write(CableForceCommand(names=n, tensions_n=t))
                time.sleep(0.05)
            bad_sent = True
            next_send = time.monotonic() + 0.5
            continue
        if bad_sent and obeyed is None and now >= next_send and sent < 20 and len(cmd_w.get_matched_subscriptions()):
            cmd_w.write(CableForceCommand(names=["drive"], tensions_n=[tension]))
            sent += 1
            next_send = now + 1.0
        if n_js >= 20 and first_lock is not None and obeyed is not None:
            break
        time.sleep(0.02)

    ok = n_js >= 20 and first_lock is not None and obeyed is not None
    sim_if = None
    if ok and os.environ.get("PEER_SIM_IF") == "1":
        sim_if = sim_interfaces(dp, rel10, latched, js_r, xcdr1)
        log("simulation_interfaces:", sim_if)
        ok = sim_if["ok"]
    speed = None
    if ok and os.environ.get("PEER_SPEED"):
        speed = speed_phase(dp, rel10, js_r, float(os.environ["PEER_SPEED"]))
        log("speed command:", speed)
        ok = speed["ok"]
    summary = {
        "joint_states": n_js,
        "joint_names": js_names,
        "late_lock_status": first_lock is not None,
        "late_lock_stamp_s": (first_lock.header.stamp.sec + 1e-9 * first_lock.header.stamp.nanosec)
        if first_lock else None,
        "lock_names": list(first_lock.names) if first_lock else [],
        "commands_sent": sent,
        "command_obeyed": obeyed is not None,
        "rejected": [obeyed.rejected_commands, obeyed.rejected_unknown_cable,
                     obeyed.rejected_mismatched_lengths, obeyed.rejected_bad_tension] if obeyed else None,
        "sim_interfaces": sim_if,
        "speed": speed,
        "result": "PASS" if ok else "FAIL",
    }
    print("SUMMARY " + json.dumps(summary), flush=True)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
