#!/usr/bin/env python3
"""Writes scenes/bench/bodies-{0,1,10,100}.toml: 262,144 particles of snow
(a 1 m x 0.125 m x 1 m slab at h = 1/64, 8 per cell) with 0, 1, 10 or 100
granite balls pressing into it, for `firn bench --scene ... --phases` (what
the rigid bodies cost: docs/benchmarks.md)."""

from pathlib import Path

HEAD = """# {count} rigid ball(s) pressing into 262,144 particles of snow: the
# benchmark of what rigid bodies cost (scripts/make-body-bench.py writes it).
format = 1
name = "bodies-{count}"

[domain]
min = [0.0, 0.0, 0.0]
max = [1.0, 0.5, 1.0]
cell_size = 0.015625

[time]
duration = 0.5
fps = 24

[solver]
transfer = "apic"

[materials.snow]
preset = "snow"

[[bodies]]
shape = "box"
center = [0.5, 0.0625, 0.5]
size = [1.0, 0.125, 1.0]
material = "snow"
"""

BALL = """
[[rigid_bodies]]
shape = "sphere"
center = [{x:.3f}, {y:.3f}, {z:.3f}]
radius = {radius}
density = 2600.0
velocity = [0.0, -1.0, 0.0]
"""


def centres(count):
    """Ball centres on a square lattice over the slab, as many as asked."""
    side = 1
    while side * side < count:
        side += 1
    spacing = 1.0 / side
    for index in range(count):
        row, column = divmod(index, side)
        yield (0.5 + column) * spacing, (0.5 + row) * spacing


def main():
    folder = Path(__file__).resolve().parent.parent / "scenes" / "bench"
    radius = 0.04
    for count in (0, 1, 10, 100):
        text = HEAD.format(count=count)
        for x, z in centres(count):
            text += BALL.format(x=x, y=0.125 + radius + 0.005, z=z, radius=radius)
        (folder / f"bodies-{count}.toml").write_text(text)


if __name__ == "__main__":
    main()
