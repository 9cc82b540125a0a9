#!/usr/bin/env python3
"""Writes a treaded tyre as a closed triangle mesh (Wavefront OBJ).

Usage: python3 scripts/make-tyre.py [OUT.obj]
       (default: assets/meshes/tyre.obj, the mesh of scenes/wheel-rut.toml)

The tyre's axis is y and its centre the origin, in metres. Its running
surface is a carcass of radius CARCASS with rounded shoulders, on which
LUGS chevron-shaped lugs (V-shaped bars across the tread, the point of the
V leading when the tyre rolls towards +x turning about -z, as placed in the
wheel scene) stand LUG_HEIGHT proud. The surface is one height field r(θ, y)
over a θ by y grid wrapped round the axis, closed by a flat disc on each
side, so the mesh is watertight with every triangle counter-clockwise seen
from outside. An even number of lugs makes the pattern symmetric under a
half turn, so the centre of the mesh's bounding box (where firn places and
turns a mesh collider) is on the axis; the script checks that.

Plain Python 3, no packages; the same output every run.
"""

import math
import sys

CARCASS = 0.225  # radius of the tyre under the lugs, m
LUG_HEIGHT = 0.025  # how far a lug stands proud of the carcass, m
WIDTH = 0.14  # tread width along the axis, m
SHOULDER = 0.015  # radius of the rounded shoulders, m
LUGS = 16  # lugs round the tyre (even: see above)
LUG_WIDTH = 0.04  # width of a lug along the tread at its top, m
CHEVRON = 0.03  # how far a lug's ends trail its middle along the tread, m
STEPS_AROUND = 384  # grid columns round the tyre
STEPS_ACROSS = 28  # grid rows across the tread


def shoulder_drop(y):
    """How far the rounded shoulder lowers the surface at axial offset y."""
    inner = WIDTH / 2 - SHOULDER
    over = abs(y) - inner
    if over <= 0:
        return 0.0
    return SHOULDER - math.sqrt(max(SHOULDER * SHOULDER - over * over, 0.0))


def on_lug(theta, y):
    """Whether the tread at angle theta and axial offset y is under a lug."""
    outer = CARCASS + LUG_HEIGHT
    pitch = 2 * math.pi / LUGS
    # The lug's middle line trails by CHEVRON at the edges: a V across.
    trail = CHEVRON * abs(y) / (WIDTH / 2) / outer
    phase = (theta - trail) % pitch
    distance = min(phase, pitch - phase) * outer
    return distance <= LUG_WIDTH / 2


def radius(theta, y):
    """The tyre's radius at angle theta and axial offset y."""
    lug = LUG_HEIGHT if on_lug(theta, y) else 0.0
    return CARCASS + lug - shoulder_drop(y)


def tyre():
    """The tyre's vertices (x, y, z) and triangles (0-based, outward CCW)."""
    thetas = [2 * math.pi * i / STEPS_AROUND for i in range(STEPS_AROUND)]
    ys = [-WIDTH / 2 + WIDTH * j / STEPS_ACROSS for j in range(STEPS_ACROSS + 1)]
    vertices = []
    for theta in thetas:
        for y in ys:
            r = radius(theta, y)
            vertices.append((r * math.cos(theta), y, r * math.sin(theta)))
    rows = len(ys)

    def at(i, j):
        return (i % STEPS_AROUND) * rows + j

    triangles = []
    for i in range(STEPS_AROUND):
        for j in range(rows - 1):
            # Along +y, then round θ: (∂y × ∂θ) points out of the tyre.
            a, b, c, d = at(i, j), at(i, j + 1), at(i + 1, j + 1), at(i + 1, j)
            triangles += [(a, b, c), (a, c, d)]
    low, high = len(vertices), len(vertices) + 1
    vertices += [(0.0, ys[0], 0.0), (0.0, ys[-1], 0.0)]
    for i in range(STEPS_AROUND):
        triangles.append((low, at(i, 0), at(i + 1, 0)))
        triangles.append((high, at(i + 1, rows - 1), at(i, rows - 1)))
    return vertices, triangles


def check(vertices, triangles):
    """Fails unless every edge is shared by two triangles running it both
    ways (closed and consistently oriented), the volume is positive
    (outward) and the bounding box is centred on the axis; returns the
    volume."""
    edges = {}
    for triangle in triangles:
        for k in range(3):
            edge = (triangle[k], triangle[(k + 1) % 3])
            edges[edge] = edges.get(edge, 0) + 1
    for (a, b), count in edges.items():
        assert count == 1 and edges.get((b, a)) == 1, f"edge {a}-{b} is not closed"
    volume = 0.0
    for a, b, c in triangles:
        (ax, ay, az), (bx, by, bz), (cx, cy, cz) = vertices[a], vertices[b], vertices[c]
        # The signed volume of the tetrahedron from the origin: a · (b × c) / 6.
        volume += (ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz) + az * (bx * cy - by * cx)) / 6
    assert volume > 0, f"the triangles face inwards (volume {volume})"
    for axis in range(3):
        values = [v[axis] for v in vertices]
        assert abs(max(values) + min(values)) < 1e-9, f"bounding box off centre on axis {axis}"
    return volume


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "assets/meshes/tyre.obj"
    vertices, triangles = tyre()
    volume = check(vertices, triangles)
    with open(out, "w", encoding="ascii") as file:
        file.write("# A treaded tyre made by scripts/make-tyre.py: axis y, metres.\n")
        for x, y, z in vertices:
            file.write(f"v {x:.5f} {y:.5f} {z:.5f}\n")
        for a, b, c in triangles:
            file.write(f"f {a + 1} {b + 1} {c + 1}\n")
    print(f"{out}: {len(vertices)} vertices, {len(triangles)} triangles, {volume * 1e3:.2f} litres")


if __name__ == "__main__":
    main()
