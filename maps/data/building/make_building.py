#!/usr/bin/env python3
"""Draws mrmm's demo building (building.pgm + building.yaml), a Nav2 / map_server map: 40 x 24 m
at 0.1 m per cell, an east-west corridor, five offices to the north, a hall and two labs to the
south, doors 1.2 m wide, a few pillars; outside the walls is unknown, as map_saver writes it.
Run it again to redraw (plain Python 3, no packages)."""

RES = 0.1
W, H = 420, 260                      # cells; the map's lower-left corner is at (-21, -13) m
OX, OY = -21.0, -13.0
FREE, WALL, UNKNOWN = 254, 0, 205

grid = [[UNKNOWN] * W for _ in range(H)]  # grid[row][col], row 0 at the bottom


def cell(x, y):
    return int(round((x - OX) / RES)), int(round((y - OY) / RES))


def rect(x0, y0, x1, y1, v):
    c0, r0 = cell(x0, y0)
    c1, r1 = cell(x1, y1)
    for r in range(max(r0, 0), min(r1, H)):
        for c in range(max(c0, 0), min(c1, W)):
            grid[r][c] = v


def hwall(x0, x1, y, doors=()):
    rect(x0, y - 0.1, x1, y + 0.1, WALL)
    for d in doors:
        rect(d - 0.6, y - 0.1, d + 0.6, y + 0.1, FREE)


def vwall(x, y0, y1, doors=()):
    rect(x - 0.1, y0, x + 0.1, y1, WALL)
    for d in doors:
        rect(x - 0.1, d - 0.6, x + 0.1, d + 0.6, FREE)


# Inside of the building, then its outer walls (entrance on the west end of the corridor).
rect(-20, -12, 20, 12, FREE)
hwall(-20.1, 20.1, 12)
hwall(-20.1, 20.1, -12)
vwall(-20, -12, 12, doors=(0.0,))
vwall(20, -12, 12)
# The corridor, y in [-1.5, 1.5]: offices north, hall and labs south.
hwall(-20, 20, 1.5, doors=(-16, -8, 0, 8, 16))
hwall(-20, 20, -1.5, doors=(-14, -6, 5, 15))
for x in (-12, -4, 4, 12):
    vwall(x, 1.5, 12)
vwall(0, -12, -1.5)
vwall(10, -12, -1.5, doors=(-7.0,))
# Pillars in the hall, a table in each lab.
for x, y in ((-14, -6), (-8, -6), (-14, -9), (-8, -9)):
    rect(x - 0.3, y - 0.3, x + 0.3, y + 0.3, WALL)
rect(3, -8, 7, -6.5, WALL)
rect(13, -8, 17, -6.5, WALL)

with open("building.pgm", "wb") as f:
    f.write(b"P5\n# mrmm demo building, drawn by make_building.py\n%d %d\n255\n" % (W, H))
    for r in range(H - 1, -1, -1):  # image row 0 is the top of the map
        f.write(bytes(grid[r]))
with open("building.yaml", "w") as f:
    f.write("image: building.pgm\nmode: trinary\nresolution: 0.1\norigin: [-21.0, -13.0, 0.0]\n"
            "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n")
