"""An operator with nothing but eclipse-zenoh (the ecosystem's own Python client) and a
certificate: queries the fleet status and sends a goto over mutual TLS, as any Zenoh client can.

usage: operator_client.py ENDPOINT CA CERT KEY ROBOT
Prints one JSON line: {"status": <answer or null>, "goto": <answer>, "goto_error": <error or null>}.
"""
import json
import sys

from fleet_session import open_session


def ask(session, key, payload=None):
    """The first answer of `key`: ("ok", value) or ("error", message), or (None, None)."""
    kwargs = {"timeout": 4.0}
    if payload is not None:
        kwargs["payload"] = json.dumps(payload)
    for reply in session.get(key, **kwargs):
        if reply.ok is not None:
            return "ok", json.loads(reply.ok.payload.to_string())
        return "error", reply.err.payload.to_string()
    return None, None


def main():
    endpoint, ca, cert, key, robot = sys.argv[1:6]
    with open_session(endpoint, ca, cert, key) as session:
        _, status = ask(session, "mrmm/system/status")
        kind, goto = ask(session, "mrmm/system/cmd/robot/goto", {"robot": robot, "x": 4.0, "y": -7.0})
        print(json.dumps({"status": status, "goto": goto if kind == "ok" else None, "goto_error": goto if kind == "error" else None}))


if __name__ == "__main__":
    main()
