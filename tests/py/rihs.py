"""RIHS01 type hashes of ROS 2 services and actions, as rosidl computes them (REP-2011), on
rosbags' type store: rosbags hashes messages; a service is hashed here as the message rosidl makes
of it (fields request_message, response_message, event_message; the event holds a
service_msgs/ServiceEventInfo and bounded sequences of one request and one response), an action's
send_goal/get_result services and feedback message likewise, under the action's own names
(pkg/action/Name_Goal, not pkg/msg/...).

rosbags 0.11's Jazzy store spells ServiceEventInfo.client_gid `char[16]`; ROS 2 Jazzy's is
`uint8[16]` (the type hash 41bcbbe0… that generated code expects), so that one message is
replaced here. tests/ros2.rs checks the results against hashes from real ROS 2 builds.
"""

from rosbags.typesys import Stores, get_typestore, get_types_from_msg

SERVICE_EVENT_INFO = "uint8 event_type\nbuiltin_interfaces/Time stamp\nuint8[16] client_gid\nint64 sequence_number\n"


def store():
    st = get_typestore(Stores.ROS2_JAZZY)
    st.fielddefs.update(get_types_from_msg(SERVICE_EVENT_INFO, "service_msgs/msg/ServiceEventInfo"))
    return st


def _rename(types, renames):
    """rosbags files every parsed type under pkg/msg/: move them (and references) to their names."""

    def walk(node):
        if isinstance(node, tuple):
            return tuple(walk(x) for x in node)
        if isinstance(node, list):
            return [walk(x) for x in node]
        return renames.get(node, node) if isinstance(node, str) else node

    return {renames.get(k, k): walk(v) for k, v in types.items()}


def _parse(st, defs, renames):
    """Registers {full name: definition} (names may be pkg/srv/… or pkg/action/…)."""
    raw = {}
    for name, text in defs.items():
        pkg, _, short = name.split("/")
        raw.update(get_types_from_msg(text, f"{pkg}/msg/{short}"))
    st.fielddefs.update(_rename(raw, renames))


def _names(defs):
    out = {}
    for name in defs:
        pkg, _, short = name.split("/")
        out[f"{pkg}/msg/{short}"] = name
    return out


def service_defs(name, request, response):
    """The four types rosidl makes of service `name` (pkg/srv/Name or pkg/action/Name_SendGoal)."""
    short = name.split("/")[-1]
    return {
        f"{name}_Request": request,
        f"{name}_Response": response,
        f"{name}_Event": f"service_msgs/ServiceEventInfo info\n{short}_Request[<=1] request\n{short}_Response[<=1] response\n",
        name: f"{short}_Request request_message\n{short}_Response response_message\n{short}_Event event_message\n",
    }


def service_hash(name, request, response):
    st = store()
    defs = service_defs(name, request, response)
    _parse(st, defs, _names(defs))
    return st.hash_rihs01(name)


def action_hashes(name, goal, result, feedback):
    """{"send_goal", "get_result", "feedback"} hashes of action `name` (pkg/action/Name), from
    the three parts of its .action file. Nested types are spelled as in the .action file."""
    st = store()
    short = name.split("/")[-1]
    defs = {
        f"{name}_Goal": goal,
        f"{name}_Result": result,
        f"{name}_Feedback": feedback,
        f"{name}_FeedbackMessage": f"unique_identifier_msgs/UUID goal_id\n{short}_Feedback feedback\n",
    }
    defs.update(service_defs(f"{name}_SendGoal", f"unique_identifier_msgs/UUID goal_id\n{short}_Goal goal\n", "bool accepted\nbuiltin_interfaces/Time stamp\n"))
    defs.update(service_defs(f"{name}_GetResult", "unique_identifier_msgs/UUID goal_id\n", f"int8 status\n{short}_Result result\n"))
    _parse(st, defs, _names(defs))
    return {
        "send_goal": st.hash_rihs01(f"{name}_SendGoal"),
        "get_result": st.hash_rihs01(f"{name}_GetResult"),
        "feedback": st.hash_rihs01(f"{name}_FeedbackMessage"),
    }
