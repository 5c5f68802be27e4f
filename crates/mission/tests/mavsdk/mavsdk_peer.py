"""Independent MAVLink peers from MAVSDK (PyPI `mavsdk` >= 4, which embeds
the C++ library), driven by vp-mission's tests.

    python mavsdk_peer.py vehicle PORT TIMEOUT_S
        Runs an autopilot (system 1, component 1) with MAVSDK's
        MissionRawServer listening on udp 127.0.0.1:PORT. Prints "READY",
        then one JSON line per mission it receives ({"result": ..., "items":
        [...]}) and exits after the first one, or after TIMEOUT_S.

    python mavsdk_peer.py import PLAN_FILE
        Imports a QGroundControl .plan with MAVSDK's MissionRaw importer and
        prints the items as one JSON line ({"items": [...]}).
"""

import json
import sys
import threading
import time

import mavsdk
from mavsdk import ComponentType, Configuration, Mavsdk


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
        "mission_type": it.mission_type,
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


def vehicle(port, timeout_s):
    from mavsdk.plugins.mission_raw_server import MissionRawServer

    cfg = Configuration.create_with_component_type(ComponentType.AUTOPILOT)
    drone = Mavsdk(cfg)
    result = drone.add_any_connection(f"udpin://127.0.0.1:{port}")
    if result != mavsdk.ConnectionResult.SUCCESS:
        print(json.dumps({"error": f"connection: {result!r}"}), flush=True)
        return 2
    server = MissionRawServer(drone.server_component())
    done = threading.Event()

    def on_mission(res, plan, _ud):
        items = [item_dict(i) for i in plan.mission_items]
        print(json.dumps(nan_to_none({"result": res.name, "items": items})), flush=True)
        done.set()

    server.subscribe_incoming_mission(on_mission)
    print("READY", flush=True)
    ok = done.wait(timeout_s)
    # Give the ground time to read the mission back before exiting.
    time.sleep(float(sys.argv[4]) if len(sys.argv) > 4 else 2.0)
    return 0 if ok else 1


def import_plan(path):
    from mavsdk.plugins.mission_raw import MissionRaw

    # The importer hangs off a System: connect a ground station to an
    # autopilot in this process, over loopback.
    ap = Mavsdk(Configuration.create_with_component_type(ComponentType.AUTOPILOT))
    gcs = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    gcs.add_any_connection(f"udpin://127.0.0.1:{port}")
    ap.add_any_connection(f"udpout://127.0.0.1:{port}")
    system = gcs.first_autopilot(10.0)
    if system is None:
        print(json.dumps({"error": "no autopilot system for the importer"}), flush=True)
        return 2
    data = MissionRaw(system).import_qgroundcontrol_mission(path)
    items = [item_dict(i) for i in data.mission_items]
    print(json.dumps(nan_to_none({"items": items})), flush=True)
    return 0


if __name__ == "__main__":
    if len(sys.argv) >= 4 and sys.argv[1] == "vehicle":
        sys.exit(vehicle(int(sys.argv[2]), float(sys.argv[3])))
    if len(sys.argv) == 3 and sys.argv[1] == "import":
        sys.exit(import_plan(sys.argv[2]))
    print(__doc__, file=sys.stderr)
    sys.exit(2)
