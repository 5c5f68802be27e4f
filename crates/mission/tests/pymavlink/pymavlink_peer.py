"""Independent MAVLink 2 signing peers from pymavlink (ArduPilot's Python
MAVLink, whose signing code MAVProxy uses), driven by vp-mission's tests.

    python pymavlink_peer.py vehicle PORT KEY_FILE|-
        An autopilot (system 1, component 1, PX4) on udpin 127.0.0.1:PORT
        that serves the mission protocol. With a key file (64 hex digits)
        it signs everything and rejects whatever is not signed with the key
        (no allow_unsigned_callback, as an autopilot with signing on).
        Prints "READY"; on each line "REPORT" from standard input prints one
        JSON line: {"items": [...], "rejected": N, "good_signatures": N};
        exits on "QUIT" or end of input.

    python pymavlink_peer.py ground PORT KEY_FILE|- N_ITEMS
        A ground station (system 255, component 190) on udpout
        127.0.0.1:PORT, signing with the key if given: waits for a
        heartbeat, uploads N_ITEMS waypoints, reads the mission back and
        prints one JSON line: {"heartbeat": bool, "ack": name|null,
        "read_back": [...]|null, "sent": [...]} (null where the vehicle did
        not answer within the protocol's timeouts).
"""

import json
import os
import select
import sys
import time

os.environ["MAVLINK20"] = "1"
from pymavlink import mavutil  # noqa: E402

mavutil.set_dialect("common")
mavlink = mavutil.mavlink


def load_key(path):
    if path == "-":
        return None
    with open(path) as f:
        return bytes.fromhex(f.read().strip())


def connect(url, key, system, component):
    m = mavutil.mavlink_connection(
        url, source_system=system, source_component=component, autoreconnect=True
    )
    if key is not None:
        # Rejects unsigned messages: no allow_unsigned_callback.
        m.setup_signing(key, sign_outgoing=True, link_id=0)
    return m


def item_dict(it):
    return {
        "seq": it.seq,
        "frame": it.frame,
        "command": it.command,
        "current": it.current,
        "autocontinue": it.autocontinue,
        "param1": it.param1,
        "param2": it.param2,
        "param3": it.param3,
        "param4": it.param4,
        "x": it.x,
        "y": it.y,
        "z": it.z,
    }


def nan_to_none(o):
    # JSON has no NaN; NaN params ("unchanged") travel as null.
    if isinstance(o, float) and o != o:
        return None
    if isinstance(o, dict):
        return {k: nan_to_none(v) for k, v in o.items()}
    if isinstance(o, list):
        return [nan_to_none(v) for v in o]
    return o


def is_rejected(msg):
    return msg.get_type() == "BAD_DATA" and "signature" in str(getattr(msg, "reason", ""))


def vehicle(port, key):
    m = connect(f"udpin:127.0.0.1:{port}", key, 1, 1)
    mission, incoming, expected, gcs = [], [], 0, (255, 190)
    rejected = 0
    print("READY", flush=True)
    next_hb = 0.0
    while True:
        now = time.monotonic()
        if now >= next_hb:
            m.mav.heartbeat_send(
                mavlink.MAV_TYPE_QUADROTOR, mavlink.MAV_AUTOPILOT_PX4, 0, 0,
                mavlink.MAV_STATE_STANDBY,
            )
            next_hb = now + 0.1
        if select.select([sys.stdin], [], [], 0)[0]:
            line = sys.stdin.readline()
            if line.strip() == "REPORT":
                print(json.dumps(nan_to_none({
                    "items": [item_dict(i) for i in mission],
                    "rejected": rejected,
                    "good_signatures": m.mav.signing.goodsig_count,
                })), flush=True)
            elif line == "" or line.strip() == "QUIT":
                return
        msg = m.recv_match(blocking=True, timeout=0.02)
        if msg is None:
            continue
        if is_rejected(msg):
            rejected += 1
            continue
        t = msg.get_type()
        src = (msg.get_srcSystem(), msg.get_srcComponent())
        if t == "MISSION_COUNT" and msg.target_system in (0, 1):
            gcs, expected, incoming = src, msg.count, []
            if expected == 0:
                mission = []
                m.mav.mission_ack_send(*gcs, mavlink.MAV_MISSION_ACCEPTED, 0)
            else:
                m.mav.mission_request_int_send(*gcs, 0, 0)
        elif t == "MISSION_ITEM_INT" and msg.target_system in (0, 1):
            if msg.seq == len(incoming) and len(incoming) < expected:
                incoming.append(msg)
            if len(incoming) < expected:
                m.mav.mission_request_int_send(*gcs, len(incoming), 0)
            else:
                mission = list(incoming)
                m.mav.mission_ack_send(*gcs, mavlink.MAV_MISSION_ACCEPTED, 0)
        elif t == "MISSION_REQUEST_LIST" and msg.target_system in (0, 1):
            gcs = src
            m.mav.mission_count_send(*gcs, len(mission), 0)
        elif t in ("MISSION_REQUEST_INT", "MISSION_REQUEST") and msg.target_system in (0, 1):
            if msg.seq < len(mission):
                it = mission[msg.seq]
                m.mav.mission_item_int_send(
                    *gcs, it.seq, it.frame, it.command, it.current, it.autocontinue,
                    it.param1, it.param2, it.param3, it.param4, it.x, it.y, it.z, 0,
                )
            else:
                m.mav.mission_ack_send(*gcs, mavlink.MAV_MISSION_INVALID_SEQUENCE, 0)


def wait(m, types, timeout):
    """The next message of one of `types`, or None after `timeout` s."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        msg = m.recv_match(type=types, blocking=True, timeout=end - time.monotonic())
        if msg is not None:
            return msg
    return None


def exchange(m, send, types, retries=5, timeout=0.25):
    """Sends, waits for an answer, resends: the mission protocol's retry."""
    for _ in range(retries):
        send()
        msg = wait(m, types, timeout)
        if msg is not None:
            return msg
    return None


def ground(port, key, n_items):
    m = connect(f"udpout:127.0.0.1:{port}", key, 255, 190)
    result = {"heartbeat": False, "ack": None, "read_back": None, "sent": []}
    # Our heartbeat tells the vehicle where we are; then wait for its own.
    hb = exchange(
        m,
        lambda: m.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0),
        ["HEARTBEAT"], retries=10, timeout=0.2,
    )
    result["heartbeat"] = hb is not None
    items = [
        (i, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mavlink.MAV_CMD_NAV_WAYPOINT, 0, 1,
         2.0, 0.0, 0.0, 0.0, 473977420 + 100 * i, 85455940 - 50 * i, 30.0 + i)
        for i in range(n_items)
    ]
    result["sent"] = [dict(zip(
        ["seq", "frame", "command", "current", "autocontinue", "param1", "param2",
         "param3", "param4", "x", "y", "z"], it)) for it in items]
    msg = exchange(m, lambda: m.mav.mission_count_send(1, 1, n_items, 0),
                   ["MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK"])
    while msg is not None and msg.get_type() != "MISSION_ACK":
        it = items[msg.seq]
        msg = exchange(m, lambda: m.mav.mission_item_int_send(1, 1, *it, 0),
                       ["MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK"])
    if msg is not None:
        result["ack"] = mavlink.enums["MAV_MISSION_RESULT"][msg.type].name
        count = exchange(m, lambda: m.mav.mission_request_list_send(1, 1, 0), ["MISSION_COUNT"])
        if count is not None:
            back = []
            for seq in range(count.count):
                got = exchange(m, lambda: m.mav.mission_request_int_send(1, 1, seq, 0),
                               ["MISSION_ITEM_INT"])
                if got is None:
                    back = None
                    break
                back.append(item_dict(got))
            result["read_back"] = back
    print(json.dumps(nan_to_none(result)), flush=True)


def main():
    mode, port, key = sys.argv[1], int(sys.argv[2]), load_key(sys.argv[3])
    if mode == "vehicle":
        vehicle(port, key)
    elif mode == "ground":
        ground(port, key, int(sys.argv[4]))
    else:
        sys.exit(f"unknown mode {mode!r}")


if __name__ == "__main__":
    main()
