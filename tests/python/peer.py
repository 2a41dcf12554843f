#!/usr/bin/env python3
"""Independent Cyclone DDS peer for the truss_deploy node (tests/node_cyclone.rs).

Types are written by hand from msg/*.msg (and sensor_msgs/JointState); the typename
is ROS 2's DDS mangling pkg::msg::dds_::Type_. The peer
  (a) receives and decodes rt/joint_states,
  (b) late-joins rt/truss/lock_status (reliable, transient local, keep last 1),
  (c) sends rt/truss/cable_force_cmd and waits for LockStatus to show it in force.
Every loop is bounded in count and time. Exit code 0 iff all three worked.
Env: ROS_DOMAIN_ID, PEER_SECS (default 20), PEER_TENSION (default 0.123),
CYCLONEDDS_URI (tests pass a loopback-only config).
"""
import json
import os
import sys
import time
from dataclasses import dataclass

from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import float64, int32, sequence, uint32
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


# msg/CableForceCommand.msg
@dataclass
class CableForceCommand(IdlStruct, typename="truss_deploy::msg::dds_::CableForceCommand_"):
    names: sequence[str]
    tensions_n: sequence[float64]


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
        "result": "PASS" if ok else "FAIL",
    }
    print("SUMMARY " + json.dumps(summary), flush=True)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
