"""Opens a compressed mrmm payload with Python's standard zstd module (`backports.zstd` before
Python 3.14), as any client of the fleet can, and writes the JSON inside to standard output.

usage: unzstd.py FILE
"""
import sys

try:
    from compression import zstd
except ImportError:
    from backports import zstd

with open(sys.argv[1], "rb") as f:
    sys.stdout.buffer.write(zstd.decompress(f.read()))
