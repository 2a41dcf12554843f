"""Reads a truss-deploy MCAP recording with two independent readers and prints
what they decoded as one line `SUMMARY {json}` for tests/record_mcap.rs.

    check_mcap.py FILE            whole file: `mcap` + `mcap-ros2-support`, and `rosbags`
    check_mcap.py FILE --partial  a file whose writer was killed (no summary, no footer):
                                  `mcap`'s linear StreamReader up to the first incomplete record

Neither reader shares code with the writer (the Rust `mcap` crate and rustdds' CDR):
the message types come from the schemas in the file, the QoS from the channels' YAML.
"""

import json
import sys
from pathlib import Path

STAMPED = ("/joint_states", "/truss/state", "/truss/lock_status")


def stamp_ns(t):
    return t.sec * 1_000_000_000 + t.nanosec


def check_topic(out, topic, log_time, publish_time, msg):
    """Per-topic counts and stamp checks: header (or /clock) stamp = log time =
    publish time, log times non-decreasing in file order per topic."""
    t = out.setdefault(topic, {"count": 0, "first_ns": None, "last_ns": None,
                               "stamp_mismatches": 0, "backwards": 0})
    t["count"] += 1
    if topic in STAMPED:
        s = stamp_ns(msg.header.stamp)
    elif topic == "/clock":
        s = stamp_ns(msg.clock)
    elif topic in ("/tf", "/tf_static"):  # every transform's header
        stamps = {stamp_ns(tr.header.stamp) for tr in msg.transforms}
        s = stamps.pop() if len(stamps) == 1 else -1
    else:  # markers: every marker's header
        stamps = {stamp_ns(m.header.stamp) for m in msg.markers}
        s = stamps.pop() if len(stamps) == 1 else -1
    if not (s == log_time == publish_time):
        t["stamp_mismatches"] += 1
    if t["last_ns"] is not None and log_time < t["last_ns"]:
        t["backwards"] += 1
    if t["first_ns"] is None:
        t["first_ns"] = log_time
    t["last_ns"] = log_time
    if topic in ("/joint_states", "/truss/markers"):
        t.setdefault("stamps_ns", []).append(log_time)
    if topic in ("/tf", "/tf_static"):
        t["last_transforms"] = [
            {"parent": tr.header.frame_id, "child": tr.child_frame_id,
             "translation": [float(tr.transform.translation.x), float(tr.transform.translation.y),
                             float(tr.transform.translation.z)],
             "rotation": [float(tr.transform.rotation.x), float(tr.transform.rotation.y),
                          float(tr.transform.rotation.z), float(tr.transform.rotation.w)]}
            for tr in msg.transforms]


def lock_facts(m):
    return {
        "names": list(m.names),
        "locked": [bool(x) for x in m.locked],
        "time_s": [float(x) for x in m.time_s],
        "impulse_ns": [float(x) for x in m.impulse_ns],
        "deployed": bool(m.deployed),
        "cable_names": list(m.cable_names),
        "cable_tensions_n": [float(x) for x in m.cable_tensions_n],
        "rejected_bad_speed": int(m.rejected_bad_speed),
    }


def state_facts(m):
    return {
        "joint_names": list(m.joint_names),
        "last_position": [m.positions[-1].x, m.positions[-1].y, m.positions[-1].z],
        "deploy_fraction": float(m.deploy_fraction),
        "remaining_dof": int(m.remaining_dof),
        "cable_names": list(m.cable_names),
        "motor_tensions_n": [float(x) for x in m.motor_tensions_n],
        "reeled_in_m": [float(x) for x in m.reeled_in_m],
        "motor_modes": list(m.motor_modes),
    }


def read_mcap(path):
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    out = {"topics": {}, "channels": {}}
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        header = reader.get_header()
        summary = reader.get_summary()
        out["profile"] = header.profile
        out["library"] = header.library
        out["statistics_message_count"] = summary.statistics.message_count
        out["statistics_channel_counts"] = {
            summary.channels[c].topic: n
            for c, n in summary.statistics.channel_message_counts.items()
        }
        out["chunks"] = len(summary.chunk_indexes)
        out["compression"] = sorted({c.compression for c in summary.chunk_indexes})
        for ch in summary.channels.values():
            sc = summary.schemas[ch.schema_id]
            out["channels"][ch.topic] = {
                "type": sc.name,
                "schema_encoding": sc.encoding,
                "message_encoding": ch.message_encoding,
                "offered_qos_profiles": ch.metadata.get("offered_qos_profiles"),
            }
        last_lock = last_state = None
        js_names = None
        for schema, channel, message, msg in reader.iter_decoded_messages(log_time_order=False):
            check_topic(out["topics"], channel.topic, message.log_time, message.publish_time, msg)
            if channel.topic == "/truss/lock_status":
                last_lock = msg
            elif channel.topic == "/truss/state":
                last_state = msg
            elif channel.topic == "/joint_states":
                js_names = list(msg.name)
        out["final_lock"] = lock_facts(last_lock) if last_lock else None
        out["final_state"] = state_facts(last_state) if last_state else None
        out["joint_names"] = js_names
    return out


def official_stores():
    """rosbags' type stores of the distributions, from their released .msg files."""
    from rosbags.typesys import Stores, get_typestore

    return {
        "galactic": get_typestore(Stores.ROS2_GALACTIC),
        "humble": get_typestore(Stores.ROS2_HUMBLE),
        "jazzy": get_typestore(Stores.ROS2_JAZZY),
    }


def read_rosbags(path):
    from rosbags.highlevel import AnyReader

    out = {"topics": {}, "channels": {}}
    with AnyReader([Path(path)]) as reader:
        for c in reader.connections:
            q = c.ext.offered_qos_profiles[0] if c.ext.offered_qos_profiles else None
            out["channels"][c.topic] = {
                "type": c.msgtype,
                "msgcount": c.msgcount,
                "serialization_format": c.ext.serialization_format,
                "qos": None if q is None else {
                    "history": q.history.name,
                    "depth": q.depth,
                    "reliability": q.reliability.name,
                    "durability": q.durability.name,
                    "liveliness": q.liveliness.name,
                    "deadline_sec": q.deadline.sec,
                },
            }
        last_lock = last_state = None
        official = official_stores()
        out["official_markers"] = {name: {"ok": 0, "fail": 0} for name in official}
        for conn, ts, raw in reader.messages():
            msg = reader.deserialize(raw, conn.msgtype)
            if conn.topic == "/truss/markers":
                # the raw CDR against each distribution's own Marker definition
                # (rosbags' bundled type stores, not the schema in the file)
                for name, store in official.items():
                    try:
                        store.deserialize_cdr(raw, conn.msgtype)
                        out["official_markers"][name]["ok"] += 1
                    except Exception:
                        out["official_markers"][name]["fail"] += 1
            # rosbags gives only the log time: publish time is checked by the other reader
            check_topic(out["topics"], conn.topic, ts, ts, msg)
            if conn.topic == "/truss/lock_status":
                last_lock = msg
            elif conn.topic == "/truss/state":
                last_state = msg
        out["final_lock"] = lock_facts(last_lock) if last_lock else None
        out["final_state"] = state_facts(last_state) if last_state else None
        out["message_count"] = reader.message_count
    return out


def read_partial(path):
    """Linear read of an unfinished file: records until the stream ends
    (mid-record or where the footer would be)."""
    from mcap.stream_reader import StreamReader
    from mcap.records import Channel, Message, Schema
    from mcap_ros2.decoder import DecoderFactory

    factory = DecoderFactory()
    schemas, channels, decoders = {}, {}, {}
    out = {"topics": {}, "end": None}
    with open(path, "rb") as f:
        records = StreamReader(f, skip_magic=False).records
        try:
            for r in records:
                if isinstance(r, Schema):
                    schemas[r.id] = r
                elif isinstance(r, Channel):
                    channels[r.id] = r
                    decoders[r.id] = factory.decoder_for(r.message_encoding, schemas[r.schema_id])
                elif isinstance(r, Message):
                    ch = channels[r.channel_id]
                    msg = decoders[r.channel_id](r.data)
                    check_topic(out["topics"], ch.topic, r.log_time, r.publish_time, msg)
        except Exception as e:  # the cut: EndOfFile or an incomplete record
            out["end"] = type(e).__name__
    return out


def main():
    path = sys.argv[1]
    if "--partial" in sys.argv[2:]:
        res = {"partial": read_partial(path)}
    else:
        res = {"mcap": read_mcap(path), "rosbags": read_rosbags(path)}
    print("SUMMARY " + json.dumps(res))


if __name__ == "__main__":
    main()
