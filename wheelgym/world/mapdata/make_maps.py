"""Write the shipped maps of :mod:`wheelgym.world.maps` (run this file with python).

| map       | format            | size (m)    | cells     | what                                   |
|-----------|-------------------|-------------|-----------|----------------------------------------|
| warehouse | ROS map, PGM (P5) | 14.5 x 10.5 | 290 x 210 | rack rows and aisles, pillars, pallets |
| office    | ROS map, PGM (P5) | 12.5 x 9.5  | 250 x 190 | corridor, five rooms, doors, furniture |
| maze      | shapes YAML       | 9.6 x 9.6   | 192 x 192 | 6 x 6 maze of 1.6 m cells, a hall      |

Everything is deterministic (the maze from a fixed seed), so running this again reproduces the
files byte for byte (tests/world/test_maps.py checks it). The images use ROS map_saver's grey
levels: 254 free, 0 occupied, 205 unknown (thresholds 0.65 and 0.196).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from wheelgym.world.maps import write_pgm

HERE = Path(__file__).resolve().parent
RES = 0.05
FREE, OCC, UNKNOWN = 254, 0, 205


class Canvas:
    """An 8-bit map image drawn in metres: ``origin`` is the lower-left corner's position."""

    def __init__(self, width: float, height: float, origin: tuple[float, float]) -> None:
        self.w = round(width / RES)
        self.h = round(height / RES)
        self.origin = origin
        self.pix = np.full((self.h, self.w), UNKNOWN, dtype=np.uint8)

    def _col(self, x: float) -> int:
        return round((x - self.origin[0]) / RES)

    def _row(self, y: float) -> int:  # image row of the cell line at y (row 0 the top)
        return self.h - round((y - self.origin[1]) / RES)

    def rect(self, x0: float, y0: float, x1: float, y1: float, value: int = OCC) -> None:
        """Fill the axis-aligned rectangle [x0, x1] x [y0, y1] (snapped to the cell lines)."""
        self.pix[self._row(y1):self._row(y0), self._col(x0):self._col(x1)] = value

    def disc(self, cx: float, cy: float, r: float, value: int = OCC) -> None:
        """Fill the cells whose centres lie within ``r`` of (cx, cy)."""
        jj, ii = np.meshgrid(np.arange(self.w), np.arange(self.h))
        x = self.origin[0] + (jj + 0.5) * RES
        y = self.origin[1] + (self.h - ii - 0.5) * RES
        self.pix[np.hypot(x - cx, y - cy) <= r] = value

    def save(self, out: Path, name: str, comment: str) -> None:
        write_pgm(out / f"{name}.pgm", self.pix, comment=comment)
        (out / f"{name}.yaml").write_text(
            f"# {comment}\n# written by make_maps.py\n"
            f"image: {name}.pgm\nresolution: {RES}\n"
            f"origin: [{self.origin[0]}, {self.origin[1]}, 0.0]\n"
            "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\nmode: trinary\n")


def warehouse() -> Canvas:
    """14 x 10 m hall: three rack rows split by a cross aisle, pillars, pallets, a loading bay."""
    c = Canvas(14.5, 10.5, (-7.25, -5.25))
    c.rect(-7.0, -5.0, 7.0, 5.0, OCC)          # outer walls, 0.15 m thick
    c.rect(-6.85, -4.85, 6.85, 4.85, FREE)
    for y0, y1 in ((-3.1, -2.1), (-0.5, 0.5), (2.1, 3.1)):  # rack rows, 1.6-1.75 m aisles
        c.rect(-5.0, y0, -0.8, y1)
        c.rect(0.8, y0, 4.5, y1)
        yc = 0.5 * (y0 + y1)
        c.rect(-0.2, yc - 0.2, 0.2, yc + 0.2)  # a pillar in the cross aisle on each row
    c.rect(5.85, -4.2, 6.85, -3.0)             # pallets in the loading bay
    c.rect(5.85, 3.4, 6.85, 4.6)
    c.rect(-3.0, -4.85, -2.0, -4.45)           # boxes along the south wall
    c.rect(-6.85, 3.9, -6.25, 4.85)            # a cabinet in the north-west corner
    return c


def office() -> Canvas:
    """12 x 9 m floor: an east-west corridor, three rooms north, two south, 1.4 m doors."""
    c = Canvas(12.5, 9.5, (-6.25, -4.75))
    c.rect(-6.0, -4.5, 6.0, 4.5, OCC)          # outer walls, 0.1 m thick
    c.rect(-5.9, -4.4, 5.9, 4.4, FREE)
    c.rect(-5.9, 0.8, 5.9, 0.9)                # corridor walls (corridor 1.6 m wide)
    c.rect(-5.9, -0.9, 5.9, -0.8)
    for x0, x1 in ((-4.7, -3.3), (-0.7, 0.7), (3.3, 4.7)):   # doors of the north rooms
        c.rect(x0, 0.8, x1, 0.9, FREE)
    for x0, x1 in ((-3.5, -2.1), (2.6, 4.0)):                # doors of the south rooms
        c.rect(x0, -0.9, x1, -0.8, FREE)
    c.rect(-2.05, 0.9, -1.95, 4.4)             # room walls
    c.rect(1.95, 0.9, 2.05, 4.4)
    c.rect(0.95, -4.4, 1.05, -0.9)
    c.rect(-4.7, 3.25, -3.3, 3.95)             # north-west office: desk, cabinet
    c.rect(-5.9, 1.5, -5.4, 2.5)
    c.rect(-1.6, 3.25, 1.6, 3.95)              # north office: two desks side by side
    c.disc(4.0, 2.8, 0.5)                      # kitchen: round table, counter
    c.rect(5.3, 1.3, 5.9, 4.4)
    c.rect(-4.6, -3.4, -1.8, -2.2)             # open-plan office: desk island, printer
    c.rect(0.3, -4.4, 0.9, -3.8)
    c.rect(2.5, -3.3, 4.5, -2.3)               # meeting room table
    c.disc(5.5, 0.0, 0.25)                     # a plant at the corridor's east end
    return c


def maze_yaml(n: int = 6, cell: float = 1.6, wall: float = 0.12, seed: int = 7) -> str:
    """A perfect ``n`` x ``n`` maze (depth-first search), a 2 x 2 hall with a round pillar in the
    middle, and hexagonal columns in two dead ends, as a shapes YAML."""
    rng = np.random.default_rng(seed)
    # walls[0][r, c]: wall on the south side of cell (r, c) for r >= 1; walls[1][r, c]: west side
    south = np.ones((n + 1, n), dtype=bool)
    west = np.ones((n, n + 1), dtype=bool)
    seen = np.zeros((n, n), dtype=bool)
    stack = [(0, 0)]
    seen[0, 0] = True
    while stack:
        r, c = stack[-1]
        nbrs = [(r + dr, c + dc) for dr, dc in ((1, 0), (-1, 0), (0, 1), (0, -1))
                if 0 <= r + dr < n and 0 <= c + dc < n and not seen[r + dr, c + dc]]
        if not nbrs:
            stack.pop()
            continue
        r2, c2 = nbrs[int(rng.integers(len(nbrs)))]
        if r2 != r:
            south[max(r, r2), c] = False
        else:
            west[r, max(c, c2)] = False
        seen[r2, c2] = True
        stack.append((r2, c2))
    h0 = n // 2 - 1  # the hall: cells h0, h0 + 1 in both directions
    south[h0 + 1, h0:h0 + 2] = False
    west[h0:h0 + 2, h0 + 1] = False
    lo = round(-n * cell / 2, 6)
    hi = -lo
    shapes = []

    def box(x0: float, y0: float, x1: float, y1: float) -> None:
        x0, y0, x1, y1 = max(x0, lo), max(y0, lo), min(x1, hi), min(y1, hi)
        shapes.append(f"  - {{type: box, center: [{round((x0 + x1) / 2, 6)}, "
                      f"{round((y0 + y1) / 2, 6)}], size: [{round(x1 - x0, 6)}, "
                      f"{round(y1 - y0, 6)}]}}")

    t = wall / 2
    for r in range(1, n):  # inner east-west walls, merged along runs
        c = 0
        while c < n:
            if south[r, c]:
                c1 = c
                while c1 < n and south[r, c1]:
                    c1 += 1
                y = round(lo + r * cell, 6)
                box(lo + c * cell - t, y - t, lo + c1 * cell + t, y + t)
                c = c1
            else:
                c += 1
    for k in range(1, n):  # inner north-south walls
        r = 0
        while r < n:
            if west[r, k]:
                r1 = r
                while r1 < n and west[r1, k]:
                    r1 += 1
                x = round(lo + k * cell, 6)
                box(x - t, lo + r * cell - t, x + t, lo + r1 * cell + t)
                r = r1
            else:
                r += 1
    shapes.append("  - {type: circle, center: [0.0, 0.0], radius: 0.35}")
    walls = lambda r, c: (int(south[r, c]) + int(south[r + 1, c]) + int(west[r, c])  # noqa: E731
                          + int(west[r, c + 1]))
    dead = [(r, c) for r in range(n) for c in range(n) if walls(r, c) == 3
            and not (h0 <= r <= h0 + 1 and h0 <= c <= h0 + 1)]
    for r, c in dead[:: max(1, len(dead) // 2)][:2]:
        cx, cy = lo + (c + 0.5) * cell, lo + (r + 0.5) * cell
        pts = ", ".join(f"[{round(cx + 0.25 * math.cos(a), 6)}, "
                        f"{round(cy + 0.25 * math.sin(a), 6)}]" for a in np.arange(6) * math.pi / 3)
        shapes.append(f"  - {{type: polygon, points: [{pts}]}}")
    return (f"# {n} x {n} maze of {cell} m cells ({wall} m walls), a hall in the middle with a\n"
            "# round pillar, hexagonal columns in two dead ends; written by make_maps.py\n"
            f"bounds: [{lo}, {lo}, {hi}, {hi}]\nresolution: {RES}\nshapes:\n"
            + "\n".join(shapes) + "\n")


def main(out: Path = HERE) -> None:
    """Write warehouse.{yaml,pgm}, office.{yaml,pgm} and maze.yaml into ``out``."""
    warehouse().save(out, "warehouse", "warehouse: 14 x 10 m, three rack rows, loading bay east")
    office().save(out, "office", "office: 12 x 9 m, corridor, five rooms with furniture")
    (out / "maze.yaml").write_text(maze_yaml())


if __name__ == "__main__":
    main()
