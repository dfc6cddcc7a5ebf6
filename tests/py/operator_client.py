"""An operator with nothing but eclipse-zenoh (the ecosystem's own Python client) and a
certificate: queries the fleet status and sends a goto over mutual TLS, as any Zenoh client can.

usage: operator_client.py ENDPOINT CA CERT KEY ROBOT
Prints one JSON line: {"status": <answer or null>, "goto": <answer>, "goto_error": <error or null>}.
"""
import json
import sys

import zenoh


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
    conf = zenoh.Config()
    for k, v in [
        ("mode", "client"),
        ("connect/endpoints", [endpoint]),
        ("scouting/multicast/enabled", False),
        ("transport/link/tls/root_ca_certificate", ca),
        ("transport/link/tls/connect_certificate", cert),
        ("transport/link/tls/connect_private_key", key),
        ("transport/link/tls/enable_mtls", True),
        ("transport/link/tls/verify_name_on_connect", False),
    ]:
        conf.insert_json5(k, json.dumps(v))
    with zenoh.open(conf) as session:
        _, status = ask(session, "mrmm/system/status")
        kind, goto = ask(session, "mrmm/system/cmd/robot/goto", {"robot": robot, "x": 4.0, "y": -7.0})
        print(json.dumps({"status": status, "goto": goto if kind == "ok" else None, "goto_error": goto if kind == "error" else None}))


if __name__ == "__main__":
    main()
