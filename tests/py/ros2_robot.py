"""A stand-in ROS 2 robot for mrmm's tests, on the ecosystem's own rmw_zenoh implementation in
Python (zenoh-ros2-sdk, by a robot vendor) — no mrmm code.

It runs the robot's Zenoh router (as rmw_zenohd would, loopback only), subscribes to /cmd_vel
(geometry_msgs/msg/Twist), integrates a unicycle that keeps its last command (no watchdog of its
own: a robot mrmm forgets to stop runs away) and publishes /odom (nav_msgs/msg/Odometry).

Message definitions come from rosbags' ROS 2 Jazzy type store, written as .msg files for the SDK
(it cannot download them here); the SDK computes the type hashes itself.

Output: one JSON object per line on stdout. Input: one command per line on stdin:
  graph            -> {"event": "graph", "cmd_vel": {...}, "odom": {...}} (ros2 topic info -v)
  state            -> {"event": "state", ...}
  garbage          publishes malformed payloads on /odom's key
  wrong_odom       declares a second /odom publisher with another type hash
  pause_odom / resume_odom
  hashes T1 T2 ... -> {"event": "hashes", "sdk": {...}, "rosbags": {...}}
  rihs             -> {"event": "rihs", ...} service and action hashes derived by rihs.py
  tokens           -> {"event": "tokens", "keys": [...]} (every graph liveliness token)
  nav2 ok|reject|abort|recover   how the Nav2 stand-in treats goals (with --nav2)

With --nav2 it is also a Nav2 navigator: the NavigateToPose action on /navigate_to_pose, made of
the SDK's service servers (send_goal, get_result, cancel_goal) and its publisher (feedback at
10 Hz: distance left, recoveries). An accepted goal is driven to by the stand-in's own controller
(as Nav2's would) and succeeds within 0.1 m; `abort` aborts goals after half a second of driving;
`recover` holds the robot in place running a recovery every 0.3 s (a blocked path) until the mode
changes. The SDK would name an action's services' nested types as if they were a package's
services (wrong hashes), so the navigator announces the hashes rosidl gives Jazzy's
NavigateToPose, derived with rosbags by rihs.py (`rihs` prints them; tests/ros2.rs checks them
against a real ROS 2 build's).
"""

import argparse
import json
import math
import os
import sys
import tempfile
import threading
import time

import numpy as np
import zenoh
from rosbags.typesys import Stores, get_typestore

import rihs

STORE = get_typestore(Stores.ROS2_JAZZY)


def msg_text(typename):
    """A .msg definition of `typename` from rosbags' field definitions (no comments)."""
    consts, fields = STORE.fielddefs[typename]
    lines = [f"{t} {n}={v}" for n, t, v in consts]

    def spell(node):
        kind, detail = node
        if kind.name == "BASE":
            name, bound = detail
            return f"{name}<={bound}" if bound else name
        if kind.name == "NAME":
            return detail
        if kind.name == "ARRAY":
            sub, count = detail
            return f"{spell(sub)}[{count}]"
        if kind.name == "SEQUENCE":
            sub, bound = detail
            return f"{spell(sub)}[<={bound}]" if bound else f"{spell(sub)}[]"
        raise ValueError(f"{typename}: field kind {kind}")

    for name, node in fields:
        lines.append(f"{spell(node)} {name}")
    return "\n".join(lines) + "\n"


def write_definitions(root, typenames):
    """Writes `typenames` and everything they use as <root>/<pkg>/msg/<Name>.msg."""
    todo, done = list(typenames), set()
    while todo:
        t = todo.pop()
        if t in done:
            continue
        done.add(t)
        pkg, _, name = t.split("/")
        os.makedirs(os.path.join(root, pkg, "msg"), exist_ok=True)
        with open(os.path.join(root, pkg, "msg", f"{name}.msg"), "w") as f:
            f.write(msg_text(t))
        for _, node in STORE.fielddefs[t][1]:
            while node[0].name in ("ARRAY", "SEQUENCE"):
                node = node[1][0]
            if node[0].name == "NAME":
                todo.append(node[1])


NAV2_DEFINITIONS = {
    # nav2_msgs/action/NavigateToPose (Jazzy), split as rosidl splits an action.
    "nav2_msgs/msg/NavigateToPose_Goal": "geometry_msgs/PoseStamped pose\nstring behavior_tree\n",
    "nav2_msgs/msg/NavigateToPose_Result": "uint16 NONE=0\nuint16 UNKNOWN=9000\nuint16 error_code\nstring error_msg\n",
    "nav2_msgs/msg/NavigateToPose_Feedback": (
        "geometry_msgs/PoseStamped current_pose\nbuiltin_interfaces/Duration navigation_time\n"
        "builtin_interfaces/Duration estimated_time_remaining\nint16 number_of_recoveries\nfloat32 distance_remaining\n"
    ),
    "nav2_msgs/action/NavigateToPose_FeedbackMessage": "unique_identifier_msgs/UUID goal_id\nnav2_msgs/NavigateToPose_Feedback feedback\n",
}
# The three parts of Jazzy's NavigateToPose.action (constants left out: they are not hashed).
NAVIGATE_TO_POSE = tuple(NAV2_DEFINITIONS[f"nav2_msgs/msg/NavigateToPose_{p}"] for p in ("Goal", "Result", "Feedback"))
SEND_GOAL = ("unique_identifier_msgs/UUID goal_id\nnav2_msgs/NavigateToPose_Goal goal\n", "bool accepted\nbuiltin_interfaces/Time stamp\n")
GET_RESULT = ("unique_identifier_msgs/UUID goal_id\n", "int8 status\nnav2_msgs/NavigateToPose_Result result\n")
CANCEL_GOAL = (
    "action_msgs/GoalInfo goal_info\n",
    "int8 ERROR_NONE=0\nint8 ERROR_REJECTED=1\nint8 ERROR_UNKNOWN_GOAL_ID=2\nint8 ERROR_GOAL_TERMINATED=3\nint8 return_code\naction_msgs/GoalInfo[] goals_canceling\n",
)
SUCCEEDED, CANCELED, ABORTED = 4, 5, 6


def derived_hashes():
    """What rihs.py derives: the rmw_zenoh design document's example service, action_msgs'
    CancelGoal and Jazzy's NavigateToPose."""
    return {
        "add_two_ints": rihs.service_hash("example_interfaces/srv/AddTwoInts", "int64 a\nint64 b\n", "int64 sum\n"),
        "cancel_goal": rihs.service_hash("action_msgs/srv/CancelGoal", *CANCEL_GOAL),
        "navigate_to_pose": rihs.action_hashes("nav2_msgs/action/NavigateToPose", *NAVIGATE_TO_POSE),
    }


def write_nav2_definitions(root):
    for t, text in NAV2_DEFINITIONS.items():
        pkg, kind, name = t.split("/")
        os.makedirs(os.path.join(root, pkg, kind), exist_ok=True)
        with open(os.path.join(root, pkg, kind, f"{name}.msg"), "w") as f:
            f.write(text)


def nav2_control(st, dt):
    """The stand-in navigator's controller: turn towards the goal and drive (called under the lock)."""
    g = st["goal"]
    dx, dy = g["x"] - st["x"], g["y"] - st["y"]
    dist = math.hypot(dx, dy)
    g["driven"] += dt
    g["dist"] = dist
    if st["nav2"] == "recover":
        st["v"], st["omega"] = 0.0, 0.0
        g["recovering"] += dt
        if g["recovering"] >= 0.3:
            g["recovering"] = 0.0
            g["recoveries"] += 1
    elif st["nav2"] == "abort" and g["driven"] > 0.5:
        finish(st, ABORTED)
    elif dist < 0.1:
        finish(st, SUCCEEDED)
    else:
        err = math.atan2(math.sin(math.atan2(dy, dx) - st["theta"]), math.cos(math.atan2(dy, dx) - st["theta"]))
        st["omega"] = max(-1.5, min(1.5, 2.0 * err))
        st["v"] = min(0.5, dist) * max(0.0, math.cos(err))


def finish(st, status):
    """Ends the running goal with `status` (called under the lock): the robot stops, the result goes out."""
    g = st["goal"]
    st["goal"], st["v"], st["omega"] = None, 0.0, 0.0
    g["status"] = status
    emit(event="result", status=status, x=st["x"], y=st["y"], t=time.time())
    if g["waiting"] is not None:
        g["reply"](g["waiting"], status)
        g["waiting"] = None


def serve_nav2(at, st, lock):
    """NavigateToPose on /navigate_to_pose from three SDK service servers (queue mode, so a
    result can be answered when the goal ends)."""
    from zenoh_ros2_sdk import ROS2ServiceServer
    from zenoh_ros2_sdk.session import ZenohSession

    # The action's own messages first, so that its services' messages can nest them.
    mgr = ZenohSession.get_instance(at["router_ip"], at["router_port"])
    for t in NAV2_DEFINITIONS:
        mgr.register_message_type(None, t)

    hashes = derived_hashes()
    nav = hashes["navigate_to_pose"]

    def server(name, srv_type, defs, type_hash):
        return ROS2ServiceServer(service_name=f"/navigate_to_pose/_action/{name}", srv_type=srv_type, request_definition=defs[0],
                                 response_definition=defs[1], node_name="bt_navigator", mode="queue", type_hash=type_hash, **at)

    send = server("send_goal", "nav2_msgs/action/NavigateToPose_SendGoal", SEND_GOAL, nav["send_goal"])
    result = server("get_result", "nav2_msgs/action/NavigateToPose_GetResult", GET_RESULT, nav["get_result"])
    cancel = server("cancel_goal", "action_msgs/srv/CancelGoal", CANCEL_GOAL, hashes["cancel_goal"])
    types = send.session_mgr.store.types
    Time = types["builtin_interfaces/msg/Time"]
    goals = {}

    def reply_result(key, status):
        Result = result.session_mgr.register_message_type(None, "nav2_msgs/msg/NavigateToPose_Result")
        result.send_response(key, result.response_msg_class(status=status, result=Result(error_code=9000 if status == ABORTED else 0, error_msg="stand-in" if status == ABORTED else "")))

    def on_send():
        while True:
            key, req = send.take_request()
            gid = bytes(req.goal_id.uuid)
            p = req.goal.pose.pose.position
            now = time.time()
            with lock:
                accept = st["nav2"] != "reject"
                if accept:
                    if st["goal"] is not None:
                        finish(st, CANCELED)
                    g = {"id": gid, "x": float(p.x), "y": float(p.y), "driven": 0.0, "status": None, "waiting": None, "reply": reply_result,
                         "dist": 0.0, "recovering": 0.0, "recoveries": 0}
                    goals[gid] = g
                    st["goal"] = g
                    st["goals"] += 1
            send.send_response(key, send.response_msg_class(accepted=accept, stamp=Time(sec=int(now), nanosec=0)))
            emit(event="goal", accepted=accept, x=float(p.x), y=float(p.y), frame=req.goal.pose.header.frame_id, t=now)

    def on_result():
        while True:
            key, req = result.take_request()
            with lock:
                g = goals.get(bytes(req.goal_id.uuid))
                if g is None:
                    reply_result(key, 0)
                elif g["status"] is not None:
                    reply_result(key, g["status"])
                else:
                    g["waiting"] = key

    def on_cancel():
        GoalInfo = cancel.session_mgr.register_message_type(None, "action_msgs/msg/GoalInfo")
        while True:
            key, req = cancel.take_request()
            gid = bytes(req.goal_info.goal_id.uuid)
            with lock:
                g = goals.get(gid)
                if g is None:
                    code = 2
                elif g["status"] is not None:
                    code = 3
                else:
                    code = 0
                    st["cancels"] += 1
                    finish(st, CANCELED)
            canceling = [GoalInfo(goal_id=req.goal_info.goal_id, stamp=req.goal_info.stamp)] if code == 0 else []
            cancel.send_response(key, cancel.response_msg_class(return_code=code, goals_canceling=canceling))
            emit(event="cancel", code=code, t=time.time())

    from zenoh_ros2_sdk import ROS2Publisher

    fb = ROS2Publisher(topic="/navigate_to_pose/_action/feedback", msg_type="nav2_msgs/action/NavigateToPose_FeedbackMessage", node_name="bt_navigator",
                       type_hash=nav["feedback"], **at)
    UUID = mgr.register_message_type(None, "unique_identifier_msgs/msg/UUID")
    Feedback = mgr.register_message_type(None, "nav2_msgs/msg/NavigateToPose_Feedback")
    PoseStamped = mgr.register_message_type(None, "geometry_msgs/msg/PoseStamped")
    Header = mgr.register_message_type(None, "std_msgs/msg/Header")
    Pose = mgr.register_message_type(None, "geometry_msgs/msg/Pose")
    Point = mgr.register_message_type(None, "geometry_msgs/msg/Point")
    Quat = mgr.register_message_type(None, "geometry_msgs/msg/Quaternion")
    Duration = mgr.register_message_type(None, "builtin_interfaces/msg/Duration")

    def feedback():
        while True:
            time.sleep(0.1)
            with lock:
                g = st["goal"]
                if g is None:
                    continue
                gid, x, y, dist, rec, driven = g["id"], st["x"], st["y"], g["dist"], g["recoveries"], g["driven"]
            pose = PoseStamped(header=Header(stamp=Time(sec=int(time.time()), nanosec=0), frame_id="map"),
                               pose=Pose(position=Point(x=x, y=y, z=0.0), orientation=Quat(x=0.0, y=0.0, z=0.0, w=1.0)))
            fb.publish(goal_id=UUID(uuid=np.frombuffer(gid, dtype=np.uint8)),
                       feedback=Feedback(current_pose=pose, navigation_time=Duration(sec=int(driven), nanosec=0),
                                         estimated_time_remaining=Duration(sec=int(dist / 0.5), nanosec=0),
                                         number_of_recoveries=rec, distance_remaining=float(dist)))

    threading.Thread(target=feedback, daemon=True).start()
    for f in (on_send, on_result, on_cancel):
        threading.Thread(target=f, daemon=True).start()
    emit(event="nav2_ready", send_goal=send.keyexpr, get_result=result.keyexpr, cancel_goal=cancel.keyexpr, feedback=fb.keyexpr)


def emit(**kw):
    sys.stdout.write(json.dumps(kw) + "\n")
    sys.stdout.flush()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--port", type=int, required=True, help="the robot's router listens here")
    ap.add_argument("--x", type=float, default=0.0)
    ap.add_argument("--y", type=float, default=0.0)
    ap.add_argument("--theta", type=float, default=0.0)
    ap.add_argument("--odom-hz", type=float, default=30.0)
    ap.add_argument("--nav2", action="store_true", help="also serve Nav2's NavigateToPose action")
    args = ap.parse_args()

    # The robot's router, as rmw_zenohd: loopback only, no multicast scouting.
    conf = zenoh.Config()
    conf.insert_json5("mode", '"router"')
    conf.insert_json5("listen/endpoints", json.dumps([f"tcp/127.0.0.1:{args.port}"]))
    conf.insert_json5("scouting/multicast/enabled", "false")
    router = zenoh.open(conf)

    # The SDK's own session (peer, connecting to the router above), loopback only.
    os.environ["ZENOH_CONFIG_OVERRIDE"] = 'scouting/multicast/enabled=false;listen/endpoints=["tcp/127.0.0.1:0"]'
    msgdir = tempfile.mkdtemp(prefix="ros2-msgs-")
    write_definitions(msgdir, ["geometry_msgs/msg/Twist", "nav_msgs/msg/Odometry", "geometry_msgs/msg/PoseWithCovarianceStamped", "sensor_msgs/msg/BatteryState"])
    if args.nav2:
        write_definitions(msgdir, ["geometry_msgs/msg/PoseStamped", "action_msgs/msg/GoalInfo", "unique_identifier_msgs/msg/UUID", "builtin_interfaces/msg/Duration"])
        write_nav2_definitions(msgdir)
    from zenoh_ros2_sdk import ROS2Publisher, ROS2Subscriber, get_registry
    from zenoh_ros2_sdk.discovery import get_topic_info

    registry = get_registry(msgdir)
    at = {"router_ip": "127.0.0.1", "router_port": args.port}

    lock = threading.Lock()
    st = {"x": args.x, "y": args.y, "theta": args.theta, "v": 0.0, "omega": 0.0, "twists": 0, "zeros": 0, "moving": False, "odom": True,
          "goal": None, "nav2": "ok", "goals": 0, "cancels": 0, "battery": None}

    def on_twist(msg):
        v, w = float(msg.linear.x), float(msg.angular.z)
        with lock:
            st["twists"] += 1
            st["v"], st["omega"] = v, w
            if v == 0.0 and w == 0.0:
                st["zeros"] += 1
                if st["moving"]:
                    st["moving"] = False
                    emit(event="zero", t=time.time(), x=st["x"], y=st["y"])
            elif not st["moving"]:
                st["moving"] = True
                emit(event="moving", t=time.time(), v=v, omega=w)

    sub = ROS2Subscriber(topic="/cmd_vel", msg_type="geometry_msgs/msg/Twist", callback=on_twist, node_name="standin_base", **at)
    odom = ROS2Publisher(topic="/odom", msg_type="nav_msgs/msg/Odometry", node_name="standin_odometry", **at)
    # The robot's battery driver: sensor_msgs/BatteryState once a second, once told its state.
    batt = ROS2Publisher(topic="/battery_state", msg_type="sensor_msgs/msg/BatteryState", node_name="standin_battery", **at)
    types = odom.session_mgr.store.types
    Header, Time = types["std_msgs/msg/Header"], types["builtin_interfaces/msg/Time"]
    PoseWC, Pose = types["geometry_msgs/msg/PoseWithCovariance"], types["geometry_msgs/msg/Pose"]
    Point, Quat = types["geometry_msgs/msg/Point"], types["geometry_msgs/msg/Quaternion"]
    TwistWC, Twist, Vec3 = types["geometry_msgs/msg/TwistWithCovariance"], types["geometry_msgs/msg/Twist"], types["geometry_msgs/msg/Vector3"]

    stop = threading.Event()

    def publish_battery(percentage, status):
        now = time.time()
        none = np.zeros(0, dtype=np.float32)
        batt.publish(header=Header(stamp=Time(sec=int(now), nanosec=int((now % 1) * 1e9)), frame_id="base_link"), voltage=24.5, temperature=float("nan"),
                     current=-1.5, charge=float("nan"), capacity=float("nan"), design_capacity=20.0, percentage=percentage, power_supply_status=status,
                     power_supply_health=1, power_supply_technology=2, present=True, cell_voltage=none, cell_temperature=none, location="base", serial_number="standin-1")

    def physics():
        dt = 1.0 / args.odom_hz
        nxt = time.monotonic()
        ticks = 0
        while not stop.is_set():
            ticks += 1
            with lock:
                battery = st["battery"]
            if battery is not None and ticks % max(1, int(args.odom_hz)) == 0:
                publish_battery(*battery)
            with lock:
                if st["goal"] is not None:
                    nav2_control(st, dt)
                st["theta"] = math.atan2(math.sin(st["theta"] + st["omega"] * dt), math.cos(st["theta"] + st["omega"] * dt))
                st["x"] += st["v"] * dt * math.cos(st["theta"])
                st["y"] += st["v"] * dt * math.sin(st["theta"])
                x, y, th, v, w, send = st["x"], st["y"], st["theta"], st["v"], st["omega"], st["odom"]
            if send:
                now = time.time()
                odom.publish(
                    header=Header(stamp=Time(sec=int(now), nanosec=int((now % 1) * 1e9)), frame_id="odom"),
                    child_frame_id="base_link",
                    pose=PoseWC(pose=Pose(position=Point(x=x, y=y, z=0.0), orientation=Quat(x=0.0, y=0.0, z=math.sin(th / 2), w=math.cos(th / 2))), covariance=np.zeros(36)),
                    twist=TwistWC(twist=Twist(linear=Vec3(x=v, y=0.0, z=0.0), angular=Vec3(x=0.0, y=0.0, z=w)), covariance=np.zeros(36)),
                )
            nxt += dt
            time.sleep(max(0.0, nxt - time.monotonic()))

    threading.Thread(target=physics, daemon=True).start()
    if args.nav2:
        serve_nav2(at, st, lock)
    emit(event="ready", odom_key=odom.keyexpr, cmd_vel_key=sub.keyexpr if hasattr(sub, "keyexpr") else None)

    def info(topic):
        t = get_topic_info(topic, verbose=True, timeout=1.0, **at)
        if t is None:
            return None
        ends = lambda eps: [{"node": e.node_name, "namespace": e.node_namespace, "type": e.topic_type, "hash": e.type_hash} for e in eps]
        return {"types": t.topic_types, "publishers": ends(t.publishers), "subscribers": ends(t.subscribers)}

    for line in sys.stdin:
        cmd = line.split()
        if not cmd:
            continue
        if cmd[0] == "graph":
            emit(event="graph", cmd_vel=info("/cmd_vel"), odom=info("/odom"), battery_state=info("/battery_state"))
        elif cmd[0] == "state":
            with lock:
                emit(event="state", **{k: st[k] for k in ("x", "y", "theta", "v", "omega", "twists", "zeros", "goals", "cancels")})
        elif cmd[0] == "garbage":
            session = odom.session_mgr.session
            for payload in [b"", b"\x00\x01\x00\x00\x01", b"\x07\x07\x00\x00" + b"\xff" * 300, b"\x00\x01\x00\x00" + b"\xff\xff\xff\xff" * 100]:
                session.put(odom.keyexpr, payload)
            emit(event="garbage_sent", count=4)
        elif cmd[0] == "wrong_odom":
            # A node that speaks /odom with another type hash (another ROS 2 distribution).
            wrong = ROS2Publisher(topic="/odom", msg_type="nav_msgs/msg/Odometry", node_name="old_distro_odometry", type_hash="RIHS01_" + "0" * 64, **at)
            emit(event="wrong_odom", key=wrong.keyexpr)
        elif cmd[0] == "pause_odom":
            with lock:
                st["odom"] = False
            emit(event="odom_paused")
        elif cmd[0] == "resume_odom":
            with lock:
                st["odom"] = True
            emit(event="odom_resumed")
        elif cmd[0] == "battery" and len(cmd) == 3:
            # battery PERCENTAGE STATUS: published from now on, once a second (STATUS 1: charging).
            with lock:
                st["battery"] = (float(cmd[1]), int(cmd[2]))
            publish_battery(float(cmd[1]), int(cmd[2]))
            emit(event="battery", percentage=float(cmd[1]), status=int(cmd[2]))
        elif cmd[0] == "tokens":
            keys = [str(r.ok.key_expr) for r in router.liveliness().get("@ros2_lv/**", timeout=2.0) if r.ok is not None]
            emit(event="tokens", keys=keys)
        elif cmd[0] == "nav2" and len(cmd) == 2 and cmd[1] in ("ok", "reject", "abort", "recover"):
            with lock:
                st["nav2"] = cmd[1]
            emit(event="nav2_mode", mode=cmd[1])
        elif cmd[0] == "hashes":
            from zenoh_ros2_sdk.utils import get_type_hash, load_dependencies_recursive
            sdk, bags = {}, {}
            for t in cmd[1:]:
                text = open(registry.get_msg_file_path(t)).read()
                deps = load_dependencies_recursive(t, text, registry)
                sdk[t] = get_type_hash(t, msg_definition=text, dependencies=deps)
                bags[t] = STORE.hash_rihs01(t)
            emit(event="hashes", sdk=sdk, rosbags=bags)
        elif cmd[0] == "rihs":
            emit(event="rihs", **derived_hashes())
        else:
            emit(event="error", error=f"unknown command {cmd[0]!r}")
    stop.set()
    router.close()


if __name__ == "__main__":
    main()
