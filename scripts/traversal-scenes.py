#!/usr/bin/env python3
"""Writes the two scenes the BVH traversal's ordering was measured on (README, "The traversal
and the bounce loop of 2026-12-05"): the Cornell box of configs/scenes/cornell.toml with its
two boxes replaced by

- `knot.toml`: a torus knot of 786 432 triangles (4096 segments, 96 sides), a large mesh whose
  queries go deep into the tree;
- `grid.toml`: a 10x10x10 grid of small cubes (12 000 triangles), where every ray passes many
  boxes before its hit, so the order children are visited in decides how many are skipped.

    python3 scripts/traversal-scenes.py OUT_DIR
    lucid render OUT_DIR/knot.toml --spp 32 -o knot.exr
"""

import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: traversal-scenes.py OUT_DIR")
    out = sys.argv[1]
    with open(os.path.join(HERE, "..", "configs", "scenes", "cornell.toml")) as f:
        cornell = f.read()
    marker = "[[shapes]]  # small box"
    if marker not in cornell:
        sys.exit(f"error: configs/scenes/cornell.toml: no '{marker}' to replace")
    room = cornell[: cornell.index(marker)]
    knot = room + (
        '[[shapes]]\ntype = "torus_knot"\nmaterial = "white"\np = 2\nq = 3\nradius = 0.55\n'
        "minor_radius = 0.15\nsegments = 4096\nsides = 96\n"
    )
    n = 10
    cubes = []
    for x in range(n):
        for y in range(n):
            for z in range(n):
                c = [-0.8 + 1.6 * i / (n - 1) for i in (x, y, z)]
                cubes.append(
                    '[[shapes]]\ntype = "cube"\nmaterial = "white"\n'
                    f"matrix = [[0.05, 0.0, 0.0, {c[0]:.4f}], [0.0, 0.05, 0.0, {c[1]:.4f}], "
                    f"[0.0, 0.0, 0.05, {c[2]:.4f}], [0.0, 0.0, 0.0, 1.0]]\n"
                )
    os.makedirs(out, exist_ok=True)
    for name, text in (("knot.toml", knot), ("grid.toml", room + "\n".join(cubes))):
        path = os.path.join(out, name)
        with open(path + ".tmp", "w") as f:
            f.write(text)
        os.replace(path + ".tmp", path)
        print(f"wrote {path}")


if __name__ == "__main__":
    main()
