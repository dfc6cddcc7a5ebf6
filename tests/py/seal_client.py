"""A fleet node's seal made by nothing but Python's `cryptography` and eclipse-zenoh: reads the
node's certificate and Ed25519 key as `mrmm pki issue` wrote them (PKCS#8 v1 PEM), signs a
message the way docs/security.md describes (layout in net/src/security/seal.rs), and publishes
it through ENDPOINT.

usage: seal_client.py ENDPOINT CA CERT KEY ROLE ID KEYEXPR PAYLOAD [SIGNING_KEY]
CERT and KEY open the mutual-TLS link and name the sender; the seal is signed with KEY, or with
SIGNING_KEY when given (a forgery: another node's key). Prints one JSON line:
{"published": true, "matched": bool, "attachment_bytes": N}.
"""
import hashlib
import json
import struct
import sys
import threading
import time

from cryptography import x509
from cryptography.hazmat.primitives import serialization
from fleet_session import open_session

ROLES = {"operator": 0, "central": 1, "robot": 2, "host": 3, "planner": 4, "router": 5}


def seal(key, cert_der, role, node_id, key_expr, payload):
    """The attachment: magic, flags (signed), role, id, time, certificate, Ed25519 signature over
    SHA-256 of the domain, role, id, time, key expression and payload."""
    t_ms = int(time.time() * 1000)
    ident = node_id.encode()
    digest = hashlib.sha256()
    digest.update(b"mrmm-seal/1\0")
    digest.update(bytes([ROLES[role], len(ident)]) + ident)
    digest.update(struct.pack("<Q", t_ms))
    digest.update(struct.pack("<Q", len(key_expr.encode())) + key_expr.encode())
    digest.update(payload)
    signature = key.sign(digest.digest())
    return (b"MS1" + bytes([1, ROLES[role], len(ident)]) + ident + struct.pack("<Q", t_ms)
            + struct.pack("<H", len(cert_der)) + cert_der + signature)


def main():
    endpoint, ca, cert, key_path, role, node_id, key_expr, payload = sys.argv[1:9]
    signing = sys.argv[9] if len(sys.argv) > 9 else key_path
    with open(signing, "rb") as f:
        key = serialization.load_pem_private_key(f.read(), password=None)
    with open(cert, "rb") as f:
        cert_der = x509.load_pem_x509_certificate(f.read()).public_bytes(serialization.Encoding.DER)
    att = seal(key, cert_der, role, node_id, key_expr, payload.encode())
    with open_session(endpoint, ca, cert, key_path) as session:
        pub = session.declare_publisher(key_expr)
        # Published once a subscriber is routed to (Zenoh's matching status), within 10 s.
        matched = threading.Event()
        listener = pub.declare_matching_listener(lambda status: matched.set() if status.matching else None)
        if pub.matching_status.matching:
            matched.set()
        ok = matched.wait(10.0)
        pub.put(payload, attachment=att)
        listener.undeclare()
    print(json.dumps({"published": True, "matched": ok, "attachment_bytes": len(att)}))


if __name__ == "__main__":
    main()
