"""A Zenoh session of a secure mrmm fleet, with nothing but eclipse-zenoh: a client of ENDPOINT
over mutual TLS with the fleet's CA and a node's certificate and key (fleet certificates carry no
address, so names are not verified on connect)."""
import json

import zenoh


def open_session(endpoint, ca, cert, key):
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
    return zenoh.open(conf)
