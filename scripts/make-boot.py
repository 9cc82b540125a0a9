#!/usr/bin/env python3
"""Writes the boot of scenes/boot-print.toml: a deforming mesh sequence of a
boot that lands heel first, presses flat into the snow, drags back a little,
rolls onto its toe (the sole bends at the ball of the foot) and lifts off.

    python3 scripts/make-boot.py [FOLDER]     (default: assets/meshes/boot)

One binary PLY per mesh frame, frame_0001.ply onwards, at 12 frames per
second from t = 0; every file has the same vertices and triangles, only the
positions move, as firn's mesh sequences require. The boot is a subdivided
box bent into shape: 28 cm long, 10 cm wide at the ball, an ankle shaft
22 cm tall at the heel, the forefoot 8 cm tall, and tread bars 6 mm deep
across the sole. Plain Python 3, no packages.
"""

import math
import os
import struct
import sys

LENGTH = 0.28
WIDTH = 0.10
BALL = 0.72  # where the sole bends, as a fraction of the length
TREAD = 0.006
RATE = 12.0
DURATION = 1.5
# Where the boot is in scenes/boot-print.toml: the heel's x at rest, the
# foot's middle in z, and the snow's surface.
HEEL_X = 0.12
MIDDLE_Z = 0.2
SURFACE_Y = 0.1

# (time s, tilt of the heel part in degrees about the ball, tilt of the
# forefoot, height of the ball above the snow's surface, shift along x).
# Positive tilts raise the toe; negative ones raise the heel.
KEYS = [
    (0.00, 15.0, 15.0, 0.07, 0.00),
    (0.30, 8.0, 8.0, 0.005, 0.00),
    (0.50, 0.0, 0.0, -0.035, 0.00),
    (0.80, 0.0, 0.0, -0.05, -0.01),
    (1.05, -20.0, 0.0, -0.045, -0.01),
    (1.30, -30.0, -10.0, 0.03, 0.03),
    (1.50, -30.0, -10.0, 0.12, 0.06),
]


def smoothstep(s):
    s = min(max(s, 0.0), 1.0)
    return s * s * (3.0 - 2.0 * s)


def pose(t):
    """The key values at time t, eased between keys."""
    if t <= KEYS[0][0]:
        return KEYS[0][1:]
    for a, b in zip(KEYS, KEYS[1:]):
        if t <= b[0]:
            s = smoothstep((t - a[0]) / (b[0] - a[0]))
            return tuple(x + (y - x) * s for x, y in zip(a[1:], b[1:]))
    return KEYS[-1][1:]


def surface_grid(nx, ny, nz):
    """The surface of a box subdivided nx × ny × nz, as points (u, v, w) in
    [0, 1]³ and outward quads; each point appears once."""
    index = {}
    points = []

    def at(i, j, k):
        key = (i, j, k)
        if key not in index:
            index[key] = len(points)
            points.append((i / nx, j / ny, k / nz))
        return index[key]

    quads = []
    for i in range(nx):
        for k in range(nz):
            quads.append((at(i, 0, k), at(i + 1, 0, k), at(i + 1, 0, k + 1), at(i, 0, k + 1)))
            quads.append((at(i, ny, k), at(i, ny, k + 1), at(i + 1, ny, k + 1), at(i + 1, ny, k)))
    for i in range(nx):
        for j in range(ny):
            quads.append((at(i, j, 0), at(i, j + 1, 0), at(i + 1, j + 1, 0), at(i + 1, j, 0)))
            quads.append((at(i, j, nz), at(i + 1, j, nz), at(i + 1, j + 1, nz), at(i, j + 1, nz)))
    for j in range(ny):
        for k in range(nz):
            quads.append((at(0, j, k), at(0, j, k + 1), at(0, j + 1, k + 1), at(0, j + 1, k)))
            quads.append((at(nx, j, k), at(nx, j + 1, k), at(nx, j + 1, k + 1), at(nx, j, k + 1)))
    return points, quads


def rest_shape(u, v, w):
    """A point of the unit box placed on the boot at rest: x along the foot
    from the heel, y up from the sole, z across."""
    x = LENGTH * u
    height = 0.08 + 0.14 * (1.0 - smoothstep((u - 0.25) / 0.2))
    # Rounded heel and toe: the width shrinks towards both ends.
    ends = min(u, 1.0 - u) / 0.18
    width = WIDTH * (0.55 + 0.45 * math.sqrt(min(ends, 1.0)))
    z = (w - 0.5) * width
    y = v * height
    if v == 0.0 and math.sin(2.0 * math.pi * 9.0 * u) > 0.0:
        y -= TREAD
    return x, y, z


def placed(point, heel_tilt, fore_tilt, height, shift):
    """The rest point bent at the ball and moved: the part behind the ball
    turns by heel_tilt about the ball, the forefoot by fore_tilt, blended
    over a short zone so the mesh bends smoothly."""
    x, y, z = point
    ball = BALL * LENGTH
    blend = smoothstep((x - ball + 0.02) / 0.04)
    angle = math.radians(heel_tilt + (fore_tilt - heel_tilt) * blend)
    dx, dy = x - ball, y
    c, s = math.cos(angle), math.sin(angle)
    return (
        HEEL_X + ball + c * dx - s * dy + shift,
        SURFACE_Y + s * dx + c * dy + height,
        MIDDLE_Z + z,
    )


def write_ply(path, vertices, triangles):
    header = (
        "ply\nformat binary_little_endian 1.0\ncomment firn boot (scripts/make-boot.py)\n"
        f"element vertex {len(vertices)}\nproperty float x\nproperty float y\nproperty float z\n"
        f"element face {len(triangles)}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    with open(path + ".part", "wb") as out:
        out.write(header.encode("ascii"))
        for v in vertices:
            out.write(struct.pack("<3f", *v))
        for t in triangles:
            out.write(struct.pack("<B3i", 3, *t))
    os.replace(path + ".part", path)


def main():
    folder = sys.argv[1] if len(sys.argv) > 1 else "assets/meshes/boot"
    os.makedirs(folder, exist_ok=True)
    points, quads = surface_grid(28, 4, 8)
    rest = [rest_shape(*p) for p in points]
    triangles = [t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))]
    count = int(round(DURATION * RATE)) + 1
    for frame in range(count):
        keys = pose(frame / RATE)
        vertices = [placed(p, *keys) for p in rest]
        write_ply(os.path.join(folder, f"frame_{frame + 1:04d}.ply"), vertices, triangles)
    print(f"{count} frames of {len(points)} vertices, {len(triangles)} triangles in {folder}")


if __name__ == "__main__":
    main()
