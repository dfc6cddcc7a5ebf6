"""How close the fleet's robots come to each other, as an outside client sees it: with nothing but
eclipse-zenoh, asks the fleet's robots (`mrmm/system/robots`) five times a second and measures
every two robots' distance at every sample.

usage: closest_robots.py ENDPOINT SECONDS [CA CERT KEY]
Prints one JSON line: {"samples": n, "closest": metres, "pair": [a, b], "at": seconds,
"moved": {robot: metres driven}}.
"""
import itertools
import json
import math
import sys
import time

import zenoh

from fleet_session import open_session


def plain_session(endpoint):
    conf = zenoh.Config()
    for k, v in [("mode", "client"), ("connect/endpoints", [endpoint]), ("scouting/multicast/enabled", False)]:
        conf.insert_json5(k, json.dumps(v))
    return zenoh.open(conf)


def robots(session):
    for reply in session.get("mrmm/system/robots", timeout=2.0):
        if reply.ok is not None:
            return json.loads(reply.ok.payload.to_string())
    return None


def main():
    endpoint, seconds = sys.argv[1], float(sys.argv[2])
    session = open_session(endpoint, *sys.argv[3:6]) if len(sys.argv) >= 6 else plain_session(endpoint)
    closest, pair, at, samples = math.inf, None, None, 0
    last, moved = {}, {}
    start = time.monotonic()
    with session:
        while time.monotonic() - start < seconds:
            views = robots(session)
            if views:
                samples += 1
                poses = {v["id"]: (v["pose"]["x"], v["pose"]["y"]) for v in views if v.get("status") != "lost" and v.get("pose")}
                for (a, pa), (b, pb) in itertools.combinations(sorted(poses.items()), 2):
                    d = math.dist(pa, pb)
                    if d < closest:
                        closest, pair, at = d, [a, b], time.monotonic() - start
                for r, p in poses.items():
                    if r in last:
                        moved[r] = moved.get(r, 0.0) + math.dist(last[r], p)
                    last[r] = p
            time.sleep(0.2)
    print(json.dumps({"samples": samples, "closest": closest, "pair": pair, "at": at, "moved": moved}))


if __name__ == "__main__":
    main()
