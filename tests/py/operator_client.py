"""An operator with nothing but eclipse-zenoh (the ecosystem's own Python client) and a
certificate: queries the fleet status and sends a goto over mutual TLS, as any Zenoh client can;
then asks for a robot that does not exist and acts on the error's code, not its words.

usage: operator_client.py ENDPOINT CA CERT KEY ROBOT
Prints one JSON line: {"status": <answer or null>, "goto": <answer>, "goto_error": <error or null>,
"unknown": {"code": <code>, "then": <what the client did>}}.
"""
import json
import sys
import time

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


def command(session, key, payload, tries=5):
    """A command as an API client sends one: an error is read by its code (docs/api.md) — busy is
    asked again a moment later, not_found and invalid are the caller's to fix, conflict is the
    fleet's state. Returns (answer, code, what was done)."""
    for _ in range(tries):
        kind, answer = ask(session, key, payload)
        if kind != "error":
            return answer, None, "done"
        error = json.loads(answer)
        code = error.get("code")
        if code == "busy":
            time.sleep(1.0)
            continue
        then = {"not_found": "check the name", "invalid": "fix the request", "conflict": "change the fleet first"}.get(code, "give up")
        return error, code, then
    return None, "busy", "gave up after retries"


def main():
    endpoint, ca, cert, key, robot = sys.argv[1:6]
    with open_session(endpoint, ca, cert, key) as session:
        _, status = ask(session, "mrmm/system/status")
        kind, goto = ask(session, "mrmm/system/cmd/robot/goto", {"robot": robot, "x": 4.0, "y": -7.0})
        _, code, then = command(session, "mrmm/system/cmd/robot/goto", {"robot": "nobody", "x": 1.0, "y": 1.0})
        print(json.dumps({
            "status": status,
            "goto": goto if kind == "ok" else None,
            "goto_error": goto if kind == "error" else None,
            "unknown": {"code": code, "then": then},
        }))


if __name__ == "__main__":
    main()
