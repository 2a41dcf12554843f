#!/usr/bin/env python3
"""Cyclone DDS peer that looks at the truss_deploy node as ROS 2 tools do
(tests/node/node_ros.rs). For PEER_SECS at most it
  - lists every endpoint the other participants announce (the DCPSPublication and
    DCPSSubscription builtin topics: topic, type, QoS), as `ros2 topic list -t` does;
  - reads rt/rosout (rcl_interfaces/Log, reliable, transient local, keep last 1000);
  - with PEER_JS_TOPIC: takes sensor_msgs/JointState samples there and pairs each
    stamp with the wall clock (for the real-time factor);
  - with PEER_TF=1: reads rt/tf and rt/tf_static (tf2_msgs/TFMessage) and
    rt/truss/state, and pairs each /tf frame with the joint position of the same stamp;
  - with PEER_SAIL_CMDS=1 (the sail array): writes two partial CableForceCommands back to
    back, one for drive_A and one for drive_B, and reads /truss/lock_status until both are
    in force (or the budget ends);
  - with PEER_ACTION=1: drives /truss/simulate_steps (SimulateSteps) as rcl_action over
    rmw_cyclonedds does: a goal of PEER_ACTION_STEPS steps run to its end (feedback, result,
    the stamp advance on rt/joint_states), then a second one canceled after its first feedback;
  - with PEER_PARAMS=NODE (e.g. /truss_deploy): calls the node's parameter services
    as rmw_cyclonedds_cpp does (`ros2 param list/get/describe/set`), measuring the
    real-time factor on rt/joint_states before and after setting rtf to PEER_SET_RTF.
Stops early once it has seen PEER_WAIT_TOPIC announced and PEER_WAIT_LOG in /rosout
(and, with PEER_TF=1, matched frames). Every loop is bounded in count and time.
Prints one line `SUMMARY {json}`.
"""
import json
import os
import sys
import time
from dataclasses import dataclass

from cyclonedds.builtin import BuiltinDataReader, BuiltinTopicDcpsPublication, BuiltinTopicDcpsSubscription
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import array, float64, int8, int32, int64, sequence, uint8, uint32, uint64
from cyclonedds.pub import DataWriter
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from peer import CableForceCommand, Header, JointState, LockStatus, Time  # noqa: E402


@dataclass
class Log(IdlStruct, typename="rcl_interfaces::msg::dds_::Log_"):
    stamp: Time
    level: uint8
    name: str
    msg: str
    file: str
    function: str
    line: uint32


@dataclass
class Vector3(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):
    x: float64
    y: float64
    z: float64


@dataclass
class Point(IdlStruct, typename="geometry_msgs::msg::dds_::Point_"):
    x: float64
    y: float64
    z: float64


@dataclass
class Quaternion(IdlStruct, typename="geometry_msgs::msg::dds_::Quaternion_"):
    x: float64
    y: float64
    z: float64
    w: float64


@dataclass
class Transform(IdlStruct, typename="geometry_msgs::msg::dds_::Transform_"):
    translation: Vector3
    rotation: Quaternion


@dataclass
class TransformStamped(IdlStruct, typename="geometry_msgs::msg::dds_::TransformStamped_"):
    header: Header
    child_frame_id: str
    transform: Transform


@dataclass
class TFMessage(IdlStruct, typename="tf2_msgs::msg::dds_::TFMessage_"):
    transforms: sequence[TransformStamped]


# msg/TrussState.msg
@dataclass
class TrussState(IdlStruct, typename="truss_deploy::msg::dds_::TrussState_"):
    header: Header
    joint_names: sequence[str]
    positions: sequence[Point]
    velocities: sequence[Vector3]
    deploy_fraction: float64
    remaining_dof: uint32
    cable_names: sequence[str]
    motor_tensions_n: sequence[float64]
    reeled_in_m: sequence[float64]
    motor_modes: sequence[str]


# rcl_interfaces (msg and srv), each request and reply with rmw_cyclonedds_cpp's
# header (uint64 client id, int64 sequence number) first.
@dataclass
class ParameterValue(IdlStruct, typename="rcl_interfaces::msg::dds_::ParameterValue_"):
    type: uint8
    bool_value: bool
    integer_value: int64
    double_value: float64
    string_value: str
    byte_array_value: sequence[uint8]
    bool_array_value: sequence[bool]
    integer_array_value: sequence[int64]
    double_array_value: sequence[float64]
    string_array_value: sequence[str]


def double_value(x):
    return ParameterValue(type=3, bool_value=False, integer_value=0, double_value=x, string_value="",
                          byte_array_value=[], bool_array_value=[], integer_array_value=[],
                          double_array_value=[], string_array_value=[])


@dataclass
class Parameter(IdlStruct, typename="rcl_interfaces::msg::dds_::Parameter_"):
    name: str
    value: ParameterValue


@dataclass
class ParameterEvent(IdlStruct, typename="rcl_interfaces::msg::dds_::ParameterEvent_"):
    stamp: Time
    node: str
    new_parameters: sequence[Parameter]
    changed_parameters: sequence[Parameter]
    deleted_parameters: sequence[Parameter]


@dataclass
class SetParametersResult(IdlStruct, typename="rcl_interfaces::msg::dds_::SetParametersResult_"):
    successful: bool
    reason: str


@dataclass
class ListParametersResult(IdlStruct, typename="rcl_interfaces::msg::dds_::ListParametersResult_"):
    names: sequence[str]
    prefixes: sequence[str]


@dataclass
class FloatingPointRange(IdlStruct, typename="rcl_interfaces::msg::dds_::FloatingPointRange_"):
    from_value: float64
    to_value: float64
    step: float64


@dataclass
class IntegerRange(IdlStruct, typename="rcl_interfaces::msg::dds_::IntegerRange_"):
    from_value: int64
    to_value: int64
    step: uint64


@dataclass
class ParameterDescriptor(IdlStruct, typename="rcl_interfaces::msg::dds_::ParameterDescriptor_"):
    name: str
    type: uint8
    description: str
    additional_constraints: str
    read_only: bool
    dynamic_typing: bool
    floating_point_range: sequence[FloatingPointRange, 1]
    integer_range: sequence[IntegerRange, 1]


@dataclass
class ListParametersRq(IdlStruct, typename="rcl_interfaces::srv::dds_::ListParameters_Request_"):
    guid: uint64
    seq: int64
    prefixes: sequence[str]
    depth: uint64


@dataclass
class ListParametersRp(IdlStruct, typename="rcl_interfaces::srv::dds_::ListParameters_Response_"):
    guid: uint64
    seq: int64
    result: ListParametersResult


@dataclass
class GetParametersRq(IdlStruct, typename="rcl_interfaces::srv::dds_::GetParameters_Request_"):
    guid: uint64
    seq: int64
    names: sequence[str]


@dataclass
class GetParametersRp(IdlStruct, typename="rcl_interfaces::srv::dds_::GetParameters_Response_"):
    guid: uint64
    seq: int64
    values: sequence[ParameterValue]


@dataclass
class DescribeParametersRq(IdlStruct, typename="rcl_interfaces::srv::dds_::DescribeParameters_Request_"):
    guid: uint64
    seq: int64
    names: sequence[str]


@dataclass
class DescribeParametersRp(IdlStruct, typename="rcl_interfaces::srv::dds_::DescribeParameters_Response_"):
    guid: uint64
    seq: int64
    descriptors: sequence[ParameterDescriptor]


@dataclass
class SetParametersRq(IdlStruct, typename="rcl_interfaces::srv::dds_::SetParameters_Request_"):
    guid: uint64
    seq: int64
    parameters: sequence[Parameter]


@dataclass
class SetParametersRp(IdlStruct, typename="rcl_interfaces::srv::dds_::SetParameters_Response_"):
    guid: uint64
    seq: int64
    results: sequence[SetParametersResult]


class Client:
    """A service client as rmw_cyclonedds_cpp makes one, for the service `srv` (ROS name)."""

    def __init__(self, dp, srv, rq_type, rp_type, qos):
        self.w = DataWriter(dp, Topic(dp, f"rq{srv}Request", rq_type), qos=qos)
        self.r = DataReader(dp, Topic(dp, f"rr{srv}Reply", rp_type), qos=qos)
        self.rq_type, self.srv = rq_type, srv
        self.guid = 0x0123_4567_89AB_0000 | (hash(srv) & 0xFFFF)
        self.seq = 0

    def call(self, timeout_s=8.0, resend_s=None, **fields):
        """Waits (bounded) for the service, calls it; the reply or None.

        Seeing the server's reply writer does not mean it has seen our reply
        reader yet (discovery is not symmetric in time), and a reply written
        before that is lost: an idempotent request (`resend_s` set) is sent
        again, under a new sequence number, every `resend_s` without a reply."""
        t0 = time.monotonic()
        for _ in range(int(timeout_s / 0.01) + 1):
            if (len(self.w.get_matched_subscriptions()) and len(self.r.get_matched_publications())) \
                    or time.monotonic() - t0 > timeout_s:
                break
            time.sleep(0.01)
        sent = []
        t_sent = None
        for _ in range(int(timeout_s / 0.005) + 1):
            if t_sent is None or (resend_s is not None and time.monotonic() - t_sent > resend_s):
                self.seq += 1
                sent.append(self.seq)
                self.w.write(self.rq_type(guid=self.guid, seq=self.seq, **fields))
                t_sent = time.monotonic()
            for rp in self.r.take(N=10):
                if rp.guid == self.guid and rp.seq in sent:
                    return rp
            if time.monotonic() - t0 > timeout_s:
                break
            time.sleep(0.005)
        return None


def measure_rtf(js, wall_s, part_s=0.5):
    """Simulated seconds per wall second on a JointState reader over wall_s
    (bounded): the median over parts of part_s. A node that fell behind (a
    busy machine) steps faster until it has caught up with the wall clock;
    the median keeps such a burst from standing for its steady rate."""
    points = []
    t0 = time.monotonic()
    for _ in range(int(wall_s / 0.005) + 10):
        for s in js.take(N=200):
            points.append((time.monotonic(), stamp_s(s.header)))
        if time.monotonic() - t0 > wall_s:
            break
        time.sleep(0.005)
    if len(points) < 2 or points[-1][0] - points[0][0] < 0.5 * wall_s:
        return None
    rates, start = [], points[0]
    for p in points[1:]:
        if p[0] - start[0] >= part_s:
            rates.append((p[1] - start[1]) / (p[0] - start[0]))
            start = p
    if len(rates) < 3:
        return None
    rates.sort()
    return rates[len(rates) // 2]


def params_calls(dp, node, rel):
    """ros2 param list / get / describe / set from a Cyclone client; the rtf before and after."""
    q = Qos(Policy.Reliability.Reliable(duration(milliseconds=100)), Policy.Durability.Volatile,
            Policy.History.KeepLast(10), Policy.DataRepresentation(use_cdrv0_representation=True))
    out = {}
    js = DataReader(dp, Topic(dp, "rt/joint_states", JointState), qos=rel)
    events = DataReader(dp, Topic(dp, "rt/parameter_events", ParameterEvent), qos=q)
    lst = Client(dp, f"{node}/list_parameters", ListParametersRq, ListParametersRp, q)
    get = Client(dp, f"{node}/get_parameters", GetParametersRq, GetParametersRp, q)
    desc = Client(dp, f"{node}/describe_parameters", DescribeParametersRq, DescribeParametersRp, q)
    setc = Client(dp, f"{node}/set_parameters", SetParametersRq, SetParametersRp, q)
    rp = lst.call(resend_s=1.0, prefixes=[], depth=0)
    out["list"] = list(rp.result.names) if rp else None
    rp = get.call(resend_s=1.0, names=["rtf", "model", "no_such"])
    out["get"] = [[v.type, v.double_value, v.string_value] for v in rp.values] if rp else None
    rp = desc.call(resend_s=1.0, names=["rtf"])
    out["describe_rtf"] = ({"read_only": rp.descriptors[0].read_only,
                            "range": [rp.descriptors[0].floating_point_range[0].from_value,
                                      rp.descriptors[0].floating_point_range[0].to_value],
                            "description": rp.descriptors[0].description} if rp and rp.descriptors else None)
    out["rtf_before"] = measure_rtf(js, 3.0)
    # (/parameter_events is volatile: an event written before the node's
    # writer has seen our reader is lost; wait, bounded, until we see its
    # writer, and give it as long again to see ours)
    t0 = time.monotonic()
    while not len(events.get_matched_publications()) and time.monotonic() - t0 < 10.0:
        time.sleep(0.01)
    out["events_writer_seen_s"] = time.monotonic() - t0
    time.sleep(min(time.monotonic() - t0, 1.0) + 0.2)
    target = float(os.environ.get("PEER_SET_RTF", "2.0"))
    rp = setc.call(parameters=[Parameter(name="rtf", value=double_value(target)),
                               Parameter(name="rtf", value=double_value(-1.0)),
                               Parameter(name="model", value=double_value(1.0))])
    out["set"] = [[r.successful, r.reason] for r in rp.results] if rp else None
    time.sleep(0.2)
    js.take(N=1000)
    out["rtf_after"] = measure_rtf(js, 3.0)
    rp = get.call(resend_s=1.0, names=["rtf"])
    out["rtf_get_after"] = rp.values[0].double_value if rp else None
    taken = events.take(N=100)
    t0 = time.monotonic()
    while not taken and time.monotonic() - t0 < 3.0:
        time.sleep(0.01)
        taken = events.take(N=100)
    out["events"] = [[e.node, [[p.name, p.value.double_value] for p in e.changed_parameters]]
                     for e in taken]
    return out


# SimulateSteps (simulation_interfaces/action) and action_msgs, with the Cyclone header.
@dataclass
class UUID(IdlStruct, typename="unique_identifier_msgs::msg::dds_::UUID_"):
    uuid: array[uint8, 16]


@dataclass
class GoalInfo(IdlStruct, typename="action_msgs::msg::dds_::GoalInfo_"):
    goal_id: UUID
    stamp: Time


@dataclass
class SimResult(IdlStruct, typename="simulation_interfaces::msg::dds_::Result_"):
    result: uint8
    error_message: str


@dataclass
class SendGoalRq(IdlStruct, typename="simulation_interfaces::action::dds_::SimulateSteps_SendGoal_Request_"):
    guid: uint64
    seq: int64
    goal_id: UUID
    steps: uint64


@dataclass
class SendGoalRp(IdlStruct, typename="simulation_interfaces::action::dds_::SimulateSteps_SendGoal_Response_"):
    guid: uint64
    seq: int64
    accepted: bool
    stamp: Time


@dataclass
class CancelGoalRq(IdlStruct, typename="action_msgs::srv::dds_::CancelGoal_Request_"):
    guid: uint64
    seq: int64
    goal_info: GoalInfo


@dataclass
class CancelGoalRp(IdlStruct, typename="action_msgs::srv::dds_::CancelGoal_Response_"):
    guid: uint64
    seq: int64
    return_code: int8
    goals_canceling: sequence[GoalInfo]


@dataclass
class GetResultRq(IdlStruct, typename="simulation_interfaces::action::dds_::SimulateSteps_GetResult_Request_"):
    guid: uint64
    seq: int64
    goal_id: UUID


@dataclass
class GetResultRp(IdlStruct, typename="simulation_interfaces::action::dds_::SimulateSteps_GetResult_Response_"):
    guid: uint64
    seq: int64
    status: int8
    result: SimResult


@dataclass
class Feedback(IdlStruct, typename="simulation_interfaces::action::dds_::SimulateSteps_FeedbackMessage_"):
    goal_id: UUID
    completed_steps: uint64
    remaining_steps: uint64


def action_calls(dp, rel, steps):
    """A goal run to its end, then one canceled after its first feedback."""
    q = Qos(Policy.Reliability.Reliable(duration(milliseconds=100)), Policy.Durability.Volatile,
            Policy.History.KeepLast(100), Policy.DataRepresentation(use_cdrv0_representation=True))
    base = "/truss/simulate_steps/_action"
    send = Client(dp, f"{base}/send_goal", SendGoalRq, SendGoalRp, q)
    cancel = Client(dp, f"{base}/cancel_goal", CancelGoalRq, CancelGoalRp, q)
    result = Client(dp, f"{base}/get_result", GetResultRq, GetResultRp, q)
    fb = DataReader(dp, Topic(dp, f"rt{base}/feedback", Feedback), qos=q)
    js = DataReader(dp, Topic(dp, "rt/joint_states", JointState), qos=rel)
    out = {}

    def latest_stamp():
        t, t0 = None, time.monotonic()
        for _ in range(100):
            for x in js.take(N=500):
                t = stamp_s(x.header)
            if t is not None and time.monotonic() - t0 > 0.4:
                break
            time.sleep(0.01)
        return t

    def feedback_of(gid, until_s, first_only=False):
        got, t0 = [], time.monotonic()
        for _ in range(int(until_s / 0.005) + 1):
            for f in fb.take(N=100):
                if list(f.goal_id.uuid) == gid:
                    got.append([f.completed_steps, f.remaining_steps])
            if (first_only and got) or time.monotonic() - t0 > until_s:
                break
            if got and got[-1][1] == 0:
                break
            time.sleep(0.005)
        return got

    # (the feedback is volatile: a feedback written before the node's writer
    # has seen our reader is lost; wait, bounded, until we see its writer,
    # and give it as long again to see ours)
    t0 = time.monotonic()
    while not len(fb.get_matched_publications()) and time.monotonic() - t0 < 10.0:
        time.sleep(0.01)
    time.sleep(min(time.monotonic() - t0, 1.0) + 0.2)
    # 1. a goal to its end
    out["stamp_before"] = latest_stamp()
    gid = list(range(1, 17))
    rp = send.call(goal_id=UUID(uuid=gid), steps=steps)
    out["accepted"] = rp.accepted if rp else None
    out["feedback"] = feedback_of(gid, 20.0)
    # (get_result is idempotent: asked again each second without a reply)
    rp = result.call(timeout_s=20.0, resend_s=1.0, goal_id=UUID(uuid=gid))
    out["status"], out["result"] = (rp.status, [rp.result.result, rp.result.error_message]) if rp else (None, None)
    time.sleep(0.3)
    out["stamp_after"] = latest_stamp()
    # 2. a goal canceled after its first feedback
    gid2 = list(range(101, 117))
    rp = send.call(goal_id=UUID(uuid=gid2), steps=steps)
    out["accepted2"] = rp.accepted if rp else None
    first = feedback_of(gid2, 10.0, first_only=True)
    out["first_feedback2"] = first[0] if first else None
    rp = cancel.call(goal_info=GoalInfo(goal_id=UUID(uuid=gid2), stamp=Time(sec=0, nanosec=0)))
    out["cancel_code"] = rp.return_code if rp else None
    out["canceling"] = len(rp.goals_canceling) if rp else None
    rp = result.call(timeout_s=20.0, resend_s=1.0, goal_id=UUID(uuid=gid2))
    out["status2"], out["result2"] = (rp.status, [rp.result.result, rp.result.error_message]) if rp else (None, None)
    return out


def sail_commands(dp, rel, budget_s):
    """Two partial commands written together; the tensions LockStatus shows after them."""
    xcdr1 = Policy.DataRepresentation(use_cdrv0_representation=True)
    latched = Qos(Policy.Reliability.Reliable(duration(milliseconds=100)),
                  Policy.Durability.TransientLocal, Policy.History.KeepLast(1), xcdr1)
    w = DataWriter(dp, Topic(dp, "rt/truss/cable_force_cmd", CableForceCommand), qos=rel)
    lock = DataReader(dp, Topic(dp, "rt/truss/lock_status", LockStatus), qos=latched)
    t0 = time.monotonic()
    for _ in range(int(budget_s / 0.01) + 1):
        if len(w.get_matched_subscriptions()) or time.monotonic() - t0 > budget_s:
            break
        time.sleep(0.01)
    time.sleep(0.5)  # the node's reader has matched this writer too
    want = {"drive_A": 3.25, "drive_B": 4.5}
    w.write(CableForceCommand(names=["drive_A"], tensions_n=[want["drive_A"]]))
    w.write(CableForceCommand(names=["drive_B"], tensions_n=[want["drive_B"]]))
    last = None
    for _ in range(int(budget_s / 0.01) + 1):
        for s in lock.take(N=100):
            last = s
        if last is not None and last.accepted_commands >= 2:
            t = dict(zip(last.cable_names, last.cable_tensions_n))
            if t == want or time.monotonic() - t0 > budget_s:
                break
        if time.monotonic() - t0 > budget_s:
            break
        time.sleep(0.01)
    return {"want": want, "tensions": dict(zip(last.cable_names, last.cable_tensions_n)) if last else None,
            "accepted": last.accepted_commands if last else None}


def qos_of(q):
    """(reliability, durability, history depth) of a discovered endpoint's QoS."""
    rel = dur = depth = None
    for p in q:
        n = type(p).__name__
        if n.startswith("Reliability."):
            rel = n.split(".")[1]
        elif n.startswith("Durability."):
            dur = n.split(".")[1]
        elif n == "History.KeepLast":
            depth = p.depth
        elif n == "History.KeepAll":
            depth = -1
    return rel, dur, depth


def stamp_s(h):
    return h.stamp.sec + 1e-9 * h.stamp.nanosec


def main() -> int:
    domain = int(os.environ.get("ROS_DOMAIN_ID", "0"))
    budget_s = float(os.environ.get("PEER_SECS", "15"))
    wait_topic = os.environ.get("PEER_WAIT_TOPIC", "rt/truss/lock_status")
    wait_log = os.environ.get("PEER_WAIT_LOG", "")
    js_topic = os.environ.get("PEER_JS_TOPIC", "")
    want_tf = os.environ.get("PEER_TF") == "1"
    dp = DomainParticipant(domain)
    xcdr1 = Policy.DataRepresentation(use_cdrv0_representation=True)
    if os.environ.get("PEER_ACTION") == "1":
        rel = Qos(Policy.Reliability.Reliable(duration(milliseconds=100)),
                  Policy.Durability.Volatile, Policy.History.KeepLast(100), xcdr1)
        steps = int(os.environ.get("PEER_ACTION_STEPS", "200"))
        print("SUMMARY " + json.dumps(action_calls(dp, rel, steps)), flush=True)
        return 0
    if os.environ.get("PEER_SAIL_CMDS") == "1":
        rel10 = Qos(Policy.Reliability.Reliable(duration(milliseconds=100)),
                    Policy.Durability.Volatile, Policy.History.KeepLast(10), xcdr1)
        print("SUMMARY " + json.dumps(sail_commands(dp, rel10, budget_s)), flush=True)
        return 0
    if os.environ.get("PEER_PARAMS"):
        rel = Qos(Policy.Reliability.Reliable(duration(milliseconds=100)),
                  Policy.Durability.Volatile, Policy.History.KeepLast(100), xcdr1)
        out = params_calls(dp, os.environ["PEER_PARAMS"], rel)
        print("SUMMARY " + json.dumps(out), flush=True)
        return 0
    pubs = BuiltinDataReader(dp, BuiltinTopicDcpsPublication)
    subs = BuiltinDataReader(dp, BuiltinTopicDcpsSubscription)
    rosout_q = Qos(Policy.Reliability.Reliable(duration(milliseconds=100)),
                   Policy.Durability.TransientLocal, Policy.History.KeepLast(1000), xcdr1)
    rosout = DataReader(dp, Topic(dp, "rt/rosout", Log), qos=rosout_q)
    rel = Qos(Policy.Reliability.Reliable(duration(milliseconds=100)),
              Policy.Durability.Volatile, Policy.History.KeepLast(100), xcdr1)
    js = DataReader(dp, Topic(dp, js_topic, JointState), qos=rel) if js_topic else None
    if want_tf:
        tf = DataReader(dp, Topic(dp, "rt/tf", TFMessage), qos=rel)
        tf_static = DataReader(dp, Topic(dp, "rt/tf_static", TFMessage), qos=Qos(
            Policy.Reliability.Reliable(duration(milliseconds=100)),
            Policy.Durability.TransientLocal, Policy.History.KeepLast(1), xcdr1))
        state = DataReader(dp, Topic(dp, "rt/truss/state", TrussState), qos=rel)
    me = dp.guid
    endpoints = {}
    logs = []
    js_samples = []
    tf_frames = {}  # (child, stamp) -> (parent, x, y, z)
    static = []
    states = {}  # stamp -> {joint: (x, y, z)}
    t0 = time.monotonic()
    seen_at = None
    for _ in range(int(budget_s / 0.01) + 1):
        now = time.monotonic()
        if now - t0 > budget_s:
            break
        for kind, r in (("pub", pubs), ("sub", subs)):
            for e in r.take(N=200):
                if e.participant_key == me:
                    continue
                relq, durq, depth = qos_of(e.qos)
                endpoints[str(e.key)] = {"kind": kind, "topic": e.topic_name, "type": e.type_name,
                                         "reliability": relq, "durability": durq, "depth": depth}
        for s in rosout.take(N=200):
            logs.append({"name": s.name, "level": int(s.level), "msg": s.msg})
        if js is not None:
            for s in js.take(N=200):
                js_samples.append((time.monotonic() - t0, stamp_s(s.header)))
        if want_tf:
            for m in tf.take(N=200):
                for t in m.transforms:
                    v = t.transform.translation
                    tf_frames[(t.child_frame_id, stamp_s(t.header))] = (t.header.frame_id, v.x, v.y, v.z)
            for m in tf_static.take(N=10):
                for t in m.transforms:
                    v = t.transform.translation
                    static.append({"parent": t.header.frame_id, "child": t.child_frame_id,
                                   "xyz": [v.x, v.y, v.z], "w": t.transform.rotation.w})
            for s in state.take(N=200):
                states[stamp_s(s.header)] = {n: (p.x, p.y, p.z) for n, p in zip(s.joint_names, s.positions)}
        have_topic = any(e["topic"] == wait_topic for e in endpoints.values())
        have_log = (not wait_log) or any(wait_log in l["msg"] for l in logs)
        have_tf = (not want_tf) or (static and sum(1 for (c, st) in tf_frames if st in states) >= 20)
        have_js = (not js_topic) or (len(js_samples) >= 2 and js_samples[-1][0] - js_samples[0][0] > 3.0)
        if have_topic and have_log and have_tf and have_js:
            if seen_at is None:
                seen_at = now
            elif now - seen_at > 1.5:  # a little longer: late endpoints
                break
        time.sleep(0.01)
    pairs = []
    for (child, st), (parent, x, y, z) in tf_frames.items():
        if st in states:
            pairs.append({"child": child, "parent": parent, "stamp_s": st, "tf": [x, y, z], "state": states[st]})
    summary = {
        "endpoints": sorted(endpoints.values(), key=lambda e: (e["topic"], e["kind"], e["type"])),
        "rosout": logs,
        "js_samples": js_samples,
        "tf_pairs": pairs[:200],
        "tf_static": static,
    }
    print("SUMMARY " + json.dumps(summary), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
