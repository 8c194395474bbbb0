"""Arenas from map files: ROS ``map_server`` occupancy maps and YAML lists of shapes.

:func:`load_map` reads a shipped map by name (:data:`MAPS`: ``warehouse``, ``office``,
``maze``) or any file, and returns a :class:`MapArena`: the static geometry as the range sensor
and pymunk want it (``circles (nc, 3)`` and ``segments (ns, 4)`` in world metres, for
:func:`~wheelgym.world.k_ranges`, :func:`~wheelgym.world.k_clearance` and
:func:`~wheelgym.world.build_space`), an occupancy grid, and a sampler of start and goal poses
in free space that are reachable from each other.

Two file formats, both YAML (read with ``yaml.safe_load`` semantics, aliases refused):

**ROS map** (``map_server`` / ``nav2_map_server``)::

    image: warehouse.pgm        # relative to the YAML's folder; PGM/PPM (P2, P3, P5, P6, read
                                # here), PNG, BMP, ... (read by pygame's SDL_image, as ROS 1)
    resolution: 0.05            # m per cell
    origin: [-7.25, -5.25, 0.0] # pose (m, m, rad) of the lower-left corner of the image
    occupied_thresh: 0.65       # occupancy probability above which a cell is occupied
    free_thresh: 0.196          # ... below which it is free
    negate: 0                   # optional (default 0): 1 swaps black and white
    mode: trinary               # optional: trinary (default), scale or raw

A pixel's value p is the mean of its colour channels (8 bits; PGM/PPM of another maxval are
scaled to 0..255); with ``negate`` p becomes 255 - p. Then, as ROS 1 ``map_server``:

| mode    | cell value (``cells``, int8)                                                   |
|---------|--------------------------------------------------------------------------------|
| trinary | occ = (255 - p) / 255: 100 if occ > occupied_thresh, 0 if occ < free_thresh,   |
|         | else -1 (unknown)                                                              |
| scale   | as trinary, but in between: 1 + trunc(98 (occ - free) / (occupied - free)), or |
|         | -1 where the pixel's alpha is 0                                                |
| raw     | p itself where 0 <= p <= 100, else -1 (nav2's rule)                            |

A cell is *solid* (an obstacle) when unknown (-1) or >= 50; outside the image is solid too.
Image row 0 is the top (largest y), as in ROS: cell ``cells[i, j]`` (row i from the top,
column j) has its centre at ``origin + R(yaw) @ ((j + 1/2) res, (H - i - 1/2) res)``.
The geometry is the boundary between solid and free cells, as maximal straight segments
(collinear neighbouring cell edges merged), oriented with the solid side on the left.

**Shapes map**::

    bounds: [-4.8, -4.8, 4.8, 4.8]  # xmin, ymin, xmax, ymax (m): walls; outside is solid
    resolution: 0.05                # optional (default 0.05): grid for sampling (m per cell)
    shapes:
      - {type: box, center: [1.0, 2.0], size: [0.5, 2.0], yaw: 0.3}   # yaw optional (rad)
      - {type: circle, center: [0.0, 0.0], radius: 0.3}
      - {type: polygon, points: [[0, 0], [1, 0], [0, 1]]}              # simple polygon

Boxes and polygons become their edges (counter-clockwise), circles stay circles, and the
bounds give four walls. ``cells`` is the grid over the bounds: 100 where the cell's centre lies
inside a shape (or beyond the bounds), else 0.

Shipped maps (:data:`MAPS`; written by ``mapdata/make_maps.py``, 0.05 m cells):

| name      | format          | extent (m)  | cells     | segments | circles |
|-----------|-----------------|-------------|-----------|----------|---------|
| warehouse | ROS map, PGM    | 14.5 x 10.5 | 290 x 210 | 54       | 0       |
| office    | ROS map, PGM    | 12.5 x 9.5  | 250 x 190 | 134      | 0       |
| maze      | shapes YAML     | 9.6 x 9.6   | 192 x 192 | 68       | 1       |

Every malformed file (missing or unknown field, bad type or value, unreadable or corrupt
image, YAML alias) raises ``ValueError`` with one line naming the file and the field.
"""

from __future__ import annotations

import dataclasses
import math
import os
from pathlib import Path
from typing import Any, NoReturn

import numpy as np
from numba import njit

from wheelgym import safe_yaml
from wheelgym.safe_yaml import one_line
from wheelgym.world.arena import World

__all__ = ["MAPS", "MapArena", "grid_edges", "grid_rects", "k_surface_dist", "load_map",
           "occupancy", "read_netpbm", "write_pgm"]

#: Shipped maps: name -> YAML file (``wheelgym/world/mapdata/``, made by ``make_maps.py`` there).
MAPS: dict[str, Path] = {
    name: Path(__file__).with_name("mapdata") / f"{name}.yaml"
    for name in ("warehouse", "office", "maze")
}

#: Largest grid accepted (cells), so a typo in a resolution cannot exhaust memory.
MAX_CELLS = 16_000_000

_NETPBM_SUFFIXES = (".pgm", ".ppm", ".pnm")
_ROS_KEYS = ("image", "resolution", "origin", "occupied_thresh", "free_thresh", "negate", "mode")
_SHAPES_KEYS = ("bounds", "resolution", "shapes")
_SHAPE_KEYS = {
    "box": ("type", "center", "size", "yaw"),
    "circle": ("type", "center", "radius"),
    "polygon": ("type", "points"),
}


# --------------------------------------------------------------------------------------------
# errors and YAML
# --------------------------------------------------------------------------------------------

def _fail(path: Path | str, field: str, msg: str) -> NoReturn:
    raise ValueError(one_line(f"{path}: field {field!r}: {msg}")) from None


def _short(v: Any) -> str:
    s = one_line(repr(v))
    return s if len(s) <= 60 else s[:57] + "..."


def _read_yaml(path: Path) -> Any:
    return safe_yaml.load(path, "map file")


# --------------------------------------------------------------------------------------------
# value checks: each returns the clean value or raises naming the file and field
# --------------------------------------------------------------------------------------------

def _num(path: Path, field: str, v: Any, lo: float | None = None, lo_open: bool = False,
         hi: float | None = None) -> float:
    if isinstance(v, str):  # YAML 1.1 reads 5e-2 as a string; ROS's parser takes it
        try:
            v = float(v)
        except ValueError:
            _fail(path, field, f"expected a number, got {_short(v)}")
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        _fail(path, field, f"expected a number, got {_short(v)}")
    x = float(v)
    if not math.isfinite(x):
        _fail(path, field, f"expected a finite number, got {_short(v)}")
    if lo is not None and (x < lo or (lo_open and x == lo)):
        _fail(path, field, f"must be {'>' if lo_open else '>='} {lo}, got {_short(v)}")
    if hi is not None and x > hi:
        _fail(path, field, f"must be <= {hi}, got {_short(v)}")
    return x


def _vec(path: Path, field: str, v: Any, n: int, what: str) -> np.ndarray:
    if not isinstance(v, (list, tuple)) or len(v) != n:
        _fail(path, field, f"expected {what} ({n} numbers), got {_short(v)}")
    return np.array([_num(path, f"{field}[{k}]", x) for k, x in enumerate(v)])


def _mapping(path: Path, field: str, v: Any, keys: tuple[str, ...],
             required: tuple[str, ...]) -> dict:
    if not isinstance(v, dict):
        _fail(path, field, f"expected a mapping, got {_short(v)}")
    prefix = "" if field == "<top>" else f"{field}."
    for k in v:
        if k not in keys:
            _fail(path, f"{prefix}{k}", f"unknown field (valid: {', '.join(keys)})")
    for k in required:
        if k not in v:
            _fail(path, f"{prefix}{k}", "missing")
    return v


# --------------------------------------------------------------------------------------------
# images
# --------------------------------------------------------------------------------------------

def read_netpbm(path: str | Path) -> tuple[np.ndarray, int]:
    """Pixels of a PGM or PPM file (P2, P5 grey; P3, P6 colour) and its maxval.

    Returns ``(pixels, maxval)``: ``pixels (H, W)`` (grey) or ``(H, W, 3)`` (colour), uint16,
    row 0 the top of the picture. Raises ``ValueError`` (one line, without the path) for a bad
    header or pixel data, ``OSError`` when the file cannot be read.
    """
    data = Path(path).read_bytes()
    magic = data[:2]
    if magic not in (b"P2", b"P3", b"P5", b"P6"):
        raise ValueError(f"bad PGM header: magic number must be P2, P3, P5 or P6, got "
                         f"{_short(magic)}")
    pos = 2
    fields = []
    for name in ("width", "height", "maxval"):
        while pos < len(data) and (data[pos:pos + 1].isspace() or data[pos:pos + 1] == b"#"):
            if data[pos:pos + 1] == b"#":
                end = data.find(b"\n", pos)
                pos = len(data) if end < 0 else end + 1
            else:
                pos += 1
        start = pos
        while pos < len(data) and data[pos:pos + 1].isdigit():
            pos += 1
        if start == pos or pos - start > 9:
            raise ValueError(f"bad PGM header: {name} is not a number "
                             f"(got {_short(data[start:start + 8])})")
        fields.append(int(data[start:pos]))
    w, h, maxval = fields
    if w < 1 or h < 1 or w * h > MAX_CELLS:
        raise ValueError(f"bad PGM header: size {w} x {h} must be at least 1 x 1 and at most "
                         f"{MAX_CELLS} pixels")
    if not 1 <= maxval <= 65535:
        raise ValueError(f"bad PGM header: maxval must be in 1..65535, got {maxval}")
    ch = 3 if magic in (b"P3", b"P6") else 1
    n = w * h * ch
    if pos >= len(data) or not data[pos:pos + 1].isspace():
        raise ValueError("bad PGM header: no whitespace after maxval")
    if magic in (b"P5", b"P6"):
        raw = data[pos + 1:]
        size = 2 if maxval > 255 else 1
        if len(raw) < n * size:
            raise ValueError(f"truncated pixel data: {w} x {h} needs {n * size} bytes, found "
                             f"{len(raw)}")
        pix = np.frombuffer(raw, dtype=">u2" if size == 2 else np.uint8, count=n)
    else:
        body = b"\n".join(line.split(b"#", 1)[0] for line in data[pos:].splitlines())
        tokens = body.split()
        if len(tokens) != n:
            raise ValueError(f"pixel data: {w} x {h} needs {n} values, found {len(tokens)}")
        try:
            pix = np.array([int(t) for t in tokens], dtype=np.int64)
        except ValueError:
            raise ValueError("pixel data: values must be decimal integers") from None
        if pix.min() < 0:
            raise ValueError("pixel data: negative value")
    if int(pix.max()) > maxval:
        raise ValueError(f"pixel data: value {int(pix.max())} exceeds maxval {maxval}")
    pix = pix.astype(np.uint16).reshape((h, w, 3) if ch == 3 else (h, w))
    return pix, maxval


def write_pgm(path: str | Path, pixels: np.ndarray, comment: str | None = None,
              plain: bool = False) -> None:
    """Write 8-bit grey ``pixels (H, W)`` (row 0 the top) as a binary P5 (``plain``: P2) PGM."""
    pix = np.asarray(pixels)
    if pix.ndim != 2 or pix.dtype != np.uint8:
        raise ValueError(f"pixels must be a 2-d uint8 array, got {pix.dtype} {pix.shape}")
    h, w = pix.shape
    head = "P2\n" if plain else "P5\n"
    if comment:
        head += "".join(f"# {line}\n" for line in comment.splitlines())
    head += f"{w} {h}\n255\n"
    if plain:
        body = "\n".join(" ".join(str(int(v)) for v in row) for row in pix) + "\n"
        Path(path).write_bytes(head.encode() + body.encode())
    else:
        Path(path).write_bytes(head.encode() + pix.tobytes())


def _read_image(yaml_path: Path, img: Path) -> tuple[np.ndarray, np.ndarray | None]:
    """Grey value (H, W) float in 0..255 (mean of colour channels) and alpha (H, W) or None."""
    if img.suffix.lower() in _NETPBM_SUFFIXES:
        try:
            pix, maxval = read_netpbm(img)
        except OSError as e:
            _fail(yaml_path, "image", f"cannot read {img}: {e.strerror or e}")
        except ValueError as e:
            _fail(yaml_path, "image", f"{img}: {e}")
        pix = pix.astype(np.float64)
        if maxval != 255:
            pix = np.round(pix * (255.0 / maxval))
        grey = pix.mean(axis=2) if pix.ndim == 3 else pix
        return grey, None
    if not img.is_file():
        _fail(yaml_path, "image", f"cannot read {img}: no such file")
    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    import pygame

    try:
        surf = pygame.image.load(str(img))
    except (pygame.error, OSError, ValueError) as e:
        _fail(yaml_path, "image", f"cannot decode {img}: {e}")
    w, h = surf.get_size()
    if w * h > MAX_CELLS:
        _fail(yaml_path, "image", f"{img}: {w} x {h} is more than {MAX_CELLS} pixels")
    rgba = np.frombuffer(pygame.image.tobytes(surf, "RGBA"), np.uint8).reshape(h, w, 4)
    grey = rgba[..., :3].astype(np.float64).mean(axis=2)
    has_alpha = bool(surf.get_flags() & pygame.SRCALPHA) or surf.get_masks()[3] != 0
    return grey, (rgba[..., 3].copy() if has_alpha else None)


def occupancy(grey: np.ndarray, alpha: np.ndarray | None, negate: bool, occupied_thresh: float,
              free_thresh: float, mode: str = "trinary") -> np.ndarray:
    """ROS ``map_server``'s cell values (int8, table in the module docstring) of an image."""
    p = 255.0 - grey if negate else grey
    if mode == "raw":
        v = np.round(p)
        return np.where((v >= 0) & (v <= 100), v, -1).astype(np.int8)
    occ = (255.0 - p) / 255.0
    cells = np.full(p.shape, -1, dtype=np.int8)
    if mode == "scale":
        ratio = (occ - free_thresh) / (occupied_thresh - free_thresh)
        cells[:] = np.trunc(1.0 + 98.0 * np.clip(ratio, 0.0, 1.0)).astype(np.int8)
        if alpha is not None:
            cells[alpha == 0] = -1
    cells[occ > occupied_thresh] = 100
    cells[occ < free_thresh] = 0
    return cells


# --------------------------------------------------------------------------------------------
# geometry of a grid
# --------------------------------------------------------------------------------------------

def _runs(code: np.ndarray) -> list[tuple[int, int, int, int]]:
    """Runs of equal non-zero values along each row of ``code``: (row, start, stop, value)."""
    rows, cols = code.shape
    c = np.zeros((rows, cols + 2), dtype=code.dtype)
    c[:, 1:-1] = code
    change = c[:, 1:] != c[:, :-1]
    out = []
    for r in np.flatnonzero(change.any(axis=1)):
        idx = np.flatnonzero(change[r])
        for a, b in zip(idx[:-1], idx[1:], strict=True):
            if code[r, a] != 0:
                out.append((int(r), int(a), int(b), int(code[r, a])))
    return out


def grid_edges(solid: np.ndarray) -> np.ndarray:
    """Boundary of the solid cells as maximal straight segments, in cell units.

    ``solid (H, W)`` is in image orientation (row 0 the top); outside it counts as solid. The
    segments ``(S, 4)`` are in the grid's frame (x along columns, y up, the lower-left corner
    at 0) and run with the solid side on their left; a segment lies only between a solid and a
    free cell, and collinear neighbours with the solid on the same side are merged.
    """
    h, w = solid.shape
    p = np.ones((h + 2, w + 2), dtype=bool)
    p[1:-1, 1:-1] = solid
    segs = []
    up, dn = p[:-1, 1:-1], p[1:, 1:-1]  # cells above and below horizontal line k
    code = np.where(up != dn, np.where(up, 1, 2), 0)
    for k, a, b, v in _runs(code):
        y = h - k
        segs.append((a, y, b, y) if v == 1 else (b, y, a, y))  # solid above: run towards +x
    left, right = p[1:-1, :-1], p[1:-1, 1:]  # cells left and right of vertical line m
    code = np.where(left != right, np.where(left, 1, 2), 0).T
    for m, a, b, v in _runs(code):
        segs.append((m, h - b, m, h - a) if v == 1 else (m, h - a, m, h - b))
    return np.array(segs, dtype=np.float64).reshape(-1, 4)


def grid_rects(solid: np.ndarray) -> np.ndarray:
    """Solid cells merged into rectangles ``(K, 4)``: rows ``[i0, i1)``, columns ``[j0, j1)``."""
    rects = []
    open_: dict[tuple[int, int], int] = {}
    h = solid.shape[0]
    for i in range(h + 1):
        runs = set()
        if i < h:
            runs = {(a, b) for _, a, b, _ in _runs(solid[i:i + 1].astype(np.int8))}
        for key in [k for k in open_ if k not in runs]:
            rects.append((open_.pop(key), key[0], i, key[1]))
        for key in runs:
            open_.setdefault(key, i)
    return np.array(sorted(rects), dtype=np.int64).reshape(-1, 4)


# --------------------------------------------------------------------------------------------
# compiled helpers
# --------------------------------------------------------------------------------------------

@njit(cache=True)
def k_surface_dist(pts, circles, segs, out):  # pragma: no cover - compiled
    """``k_clearance``'s distance for many points against one geometry: ``out (P,)`` (m), from
    each point to the nearest circle surface (negative inside a circle) or segment."""
    for i in range(pts.shape[0]):
        px = pts[i, 0]
        py = pts[i, 1]
        best = np.inf
        for j in range(circles.shape[0]):
            d = math.hypot(px - circles[j, 0], py - circles[j, 1]) - circles[j, 2]
            if d < best:
                best = d
        for j in range(segs.shape[0]):
            sx = segs[j, 0]
            sy = segs[j, 1]
            ex = segs[j, 2] - sx
            ey = segs[j, 3] - sy
            ll = ex * ex + ey * ey
            u = ((px - sx) * ex + (py - sy) * ey) / ll if ll > 0.0 else 0.0
            u = min(max(u, 0.0), 1.0)
            d = math.hypot(px - sx - u * ex, py - sy - u * ey)
            if d < best:
                best = d
        out[i] = best


@njit(cache=True)
def _k_label(mask, labels):  # pragma: no cover - compiled
    """4-connected components of ``mask`` (flood fill): ``labels`` 0.. (-1 off the mask)."""
    h, w = mask.shape
    stack = np.empty(h * w, dtype=np.int64)
    labels[:, :] = -1
    n = 0
    for s in range(h * w):
        i0 = s // w
        j0 = s - i0 * w
        if not mask[i0, j0] or labels[i0, j0] >= 0:
            continue
        labels[i0, j0] = n
        stack[0] = s
        top = 1
        while top > 0:
            top -= 1
            c = stack[top]
            i = c // w
            j = c - i * w
            for k in range(4):
                a = i + (1 if k == 0 else (-1 if k == 1 else 0))
                b = j + (1 if k == 2 else (-1 if k == 3 else 0))
                if 0 <= a < h and 0 <= b < w and mask[a, b] and labels[a, b] < 0:
                    labels[a, b] = n
                    stack[top] = a * w + b
                    top += 1
        n += 1
    return n


def _in_polygon(pts: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Even-odd rule: which of ``pts (P, 2)`` lie inside ``poly (M, 2)``."""
    x, y = pts[:, 0:1], pts[:, 1:2]
    x0, y0 = poly[:, 0], poly[:, 1]
    x1, y1 = np.roll(x0, -1), np.roll(y0, -1)
    crosses = (y0 > y) != (y1 > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        xc = x0 + (y - y0) * (x1 - x0) / (y1 - y0)
    return np.count_nonzero(crosses & (x < xc), axis=1) % 2 == 1


# --------------------------------------------------------------------------------------------
# the arena
# --------------------------------------------------------------------------------------------

@dataclasses.dataclass(eq=False)
class MapArena:
    """A static arena read from a map file, with a sampler of reachable start and goal poses.

    | field         | unit  | meaning                                                          |
    |---------------|-------|------------------------------------------------------------------|
    | name          | -     | shipped name, or the file's stem                                 |
    | path          | -     | the YAML file                                                    |
    | kind          | -     | ``"image"`` (ROS map) or ``"shapes"``                            |
    | cells         | -     | (H, W) int8 occupancy, ROS values (100, 0, -1), row 0 the top    |
    | resolution    | m     | cell side                                                        |
    | origin        | m, rad| (3,) pose of the grid's lower-left corner                        |
    | circles       | m     | (nc, 3) circles (x, y, r)                                        |
    | segments      | m     | (ns, 4) segments (x0, y0, x1, y1), solid side on the left        |
    | polygons      | m     | solid areas to draw: (k, 2) corner arrays, counter-clockwise     |
    | bounds        | m     | (xmin, ymin, xmax, ymax): the walls (shapes), the grid (image)   |
    | min_goal_dist | m     | start-to-goal distance at least                                  |
    | clearance     | m     | free margin around start and goal beyond the robot's radius      |

    The same interface as :class:`~wheelgym.world.Arena` where it matters to the navigate
    task: :meth:`generate`, :attr:`max_circles`, :attr:`max_segments`.
    """

    name: str
    path: Path
    kind: str
    cells: np.ndarray
    resolution: float
    origin: np.ndarray
    circles: np.ndarray
    segments: np.ndarray
    polygons: tuple[np.ndarray, ...]
    bounds: tuple[float, float, float, float]
    min_goal_dist: float = 3.0
    clearance: float = 0.1
    _cache: dict = dataclasses.field(default_factory=dict, init=False, repr=False)

    # ---- layout ------------------------------------------------------------------------------
    @property
    def max_circles(self) -> int:
        return len(self.circles)

    @property
    def max_segments(self) -> int:
        return len(self.segments)

    @property
    def solid(self) -> np.ndarray:
        """(H, W) bool: cells that are obstacles (unknown, or value >= 50)."""
        return (self.cells < 0) | (self.cells >= 50)

    @property
    def center(self) -> np.ndarray:
        """Centre (m) of :attr:`bounds`."""
        b = self.bounds
        return np.array([(b[0] + b[2]) / 2, (b[1] + b[3]) / 2])

    @property
    def half_size(self) -> float:
        """Half the larger side (m) of :attr:`bounds` (a square view around :attr:`center`)."""
        b = self.bounds
        return max(b[2] - b[0], b[3] - b[1]) / 2

    def to_world(self, local: np.ndarray) -> np.ndarray:
        """Grid-frame points (m, lower-left corner at 0) to world points, ``(..., 2)``."""
        local = np.asarray(local, dtype=np.float64)
        ox, oy, yaw = (float(v) for v in self.origin)
        c, s = math.cos(yaw), math.sin(yaw)
        lx, ly = local[..., 0], local[..., 1]
        return np.stack([ox + (c * lx - s * ly), oy + (s * lx + c * ly)], axis=-1)

    def cell_centers(self) -> np.ndarray:
        """World position (m) of every cell's centre, ``(H, W, 2)``."""
        h, w = self.cells.shape
        jj, ii = np.meshgrid(np.arange(w), np.arange(h))
        return self.to_world(np.stack([(jj + 0.5) * self.resolution,
                                       (h - ii - 0.5) * self.resolution], axis=-1))

    def cell_index(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Row and column ``(i, j)`` of the cells holding ``points (..., 2)`` (may be off-grid)."""
        p = np.asarray(points, dtype=np.float64)
        ox, oy, yaw = (float(v) for v in self.origin)
        c, s = math.cos(yaw), math.sin(yaw)
        dx, dy = p[..., 0] - ox, p[..., 1] - oy
        lx, ly = c * dx + s * dy, -s * dx + c * dy
        h = self.cells.shape[0]
        return (h - 1 - np.floor(ly / self.resolution).astype(np.int64),
                np.floor(lx / self.resolution).astype(np.int64))

    # ---- queries -----------------------------------------------------------------------------
    def inside(self, points: np.ndarray) -> np.ndarray:
        """Which ``points (..., 2)`` lie inside an obstacle (or beyond the map)."""
        p = np.asarray(points, dtype=np.float64)
        flat = p.reshape(-1, 2)
        if self.kind == "image":
            i, j = self.cell_index(flat)
            h, w = self.cells.shape
            on = (i >= 0) & (i < h) & (j >= 0) & (j < w)
            out = ~on
            out[on] = self.solid[i[on], j[on]]
        else:
            x0, y0, x1, y1 = self.bounds
            out = ~((flat[:, 0] > x0) & (flat[:, 0] < x1) & (flat[:, 1] > y0)
                    & (flat[:, 1] < y1))
            for cx, cy, r in self.circles:
                out |= np.hypot(flat[:, 0] - cx, flat[:, 1] - cy) < r
            for poly in self.polygons:
                out |= _in_polygon(flat, poly)
        return out.reshape(p.shape[:-1])

    def surface_distance(self, points: np.ndarray) -> np.ndarray:
        """Distance (m) from ``points (..., 2)`` to the nearest surface, as ``k_clearance``."""
        p = np.asarray(points, dtype=np.float64)
        flat = np.ascontiguousarray(p.reshape(-1, 2))
        out = np.empty(len(flat))
        k_surface_dist(flat, np.ascontiguousarray(self.circles),
                        np.ascontiguousarray(self.segments), out)
        return out.reshape(p.shape[:-1])

    def is_free(self, points: np.ndarray, robot_radius: float) -> np.ndarray:
        """Whether a robot's circle of ``robot_radius`` at ``points (..., 2)`` is free."""
        return ~self.inside(points) & (self.surface_distance(points) >= robot_radius)

    def clearance_grid(self) -> np.ndarray:
        """(H, W) distance (m) from each cell's centre to the nearest surface; 0 in solid cells.

        Computed once (exactly, against :attr:`circles` and :attr:`segments`) and kept.
        """
        if "clear" not in self._cache:
            centres = self.cell_centers()
            free = ~self.inside(centres)
            clear = np.zeros(self.cells.shape)
            clear[free] = self.surface_distance(centres[free])
            self._cache["clear"] = clear
        return self._cache["clear"]

    # ---- sampling ----------------------------------------------------------------------------
    def _reach(self, robot_radius: float, clearance: float) -> tuple[np.ndarray, np.ndarray]:
        """Centres (m) of the candidate cells for start and goal, and their component labels."""
        key = ("reach", float(robot_radius), float(clearance))
        if key not in self._cache:
            clear = self.clearance_grid()
            res = self.resolution
            # centres of 4-neighbouring passable cells are res apart, so clearance >= r + res/2
            # keeps the robot's circle clear along the straight line between them
            passable = clear >= robot_radius + 0.5 * res
            labels = np.empty(clear.shape, dtype=np.int64)
            _k_label(passable, labels)
            # a point jittered within its cell is at most res / sqrt(2) from the centre
            cand = np.flatnonzero(clear >= robot_radius + max(clearance, 0.5 * res)
                                  + res / math.sqrt(2.0))
            self._cache[key] = (self.cell_centers().reshape(-1, 2)[cand], labels.ravel()[cand])
        return self._cache[key]

    def sample_start_goal(self, rng: np.random.Generator, robot_radius: float,
                          min_dist: float | None = None, clearance: float | None = None,
                          ) -> tuple[np.ndarray, np.ndarray]:
        """Start and goal poses ``(x, y, yaw)`` in free space, reachable from each other.

        Both have at least ``robot_radius + clearance`` (default :attr:`clearance`) to every
        surface, are at least ``min_dist`` (default :attr:`min_goal_dist`) apart, and are joined
        by a path along which the robot's circle stays clear (4-connected cells whose centres
        have ``robot_radius + res/2`` of clearance: flood fill). A cell is drawn uniformly among
        the candidates, then a uniform point in it and a uniform heading; every draw comes from
        ``rng`` (the same state gives the same poses). Raises ``ValueError`` if no such pair
        exists.
        """
        min_dist = self.min_goal_dist if min_dist is None else float(min_dist)
        clearance = self.clearance if clearance is None else float(clearance)
        xy, lab = self._reach(robot_radius, clearance)
        res = self.resolution
        if len(xy) > 0:
            for _ in range(100):
                k = int(rng.integers(len(xy)))
                far = np.hypot(xy[:, 0] - xy[k, 0], xy[:, 1] - xy[k, 1]) \
                    >= min_dist + res * math.sqrt(2.0)
                goals = np.flatnonzero(far & (lab == lab[k]))
                if len(goals):
                    g = int(goals[int(rng.integers(len(goals)))])
                    return self._pose(rng, xy[k]), self._pose(rng, xy[g])
        raise ValueError(one_line(
            f"{self.path}: no two reachable free poses {min_dist} m apart for a robot of radius "
            f"{robot_radius} m with clearance {clearance} m"))

    def _pose(self, rng: np.random.Generator, centre: np.ndarray) -> np.ndarray:
        jitter = rng.uniform(-0.5 * self.resolution, 0.5 * self.resolution, 2)
        c, s = math.cos(self.origin[2]), math.sin(self.origin[2])
        return np.array([centre[0] + c * jitter[0] - s * jitter[1],
                         centre[1] + s * jitter[0] + c * jitter[1],
                         rng.uniform(-math.pi, math.pi)])

    def world(self, start: np.ndarray, goal: np.ndarray) -> World:
        """A :class:`~wheelgym.world.World` of this map's geometry (copies) and the poses."""
        return World(self.circles.copy(), self.segments.copy(), np.asarray(start, float).copy(),
                     np.asarray(goal, float).copy())

    def generate(self, rng: np.random.Generator, robot_radius: float) -> World:
        """Draw start and goal (:meth:`sample_start_goal`) from ``rng``: as ``Arena.generate``."""
        return self.world(*self.sample_start_goal(rng, robot_radius))


# --------------------------------------------------------------------------------------------
# loading
# --------------------------------------------------------------------------------------------

def load_map(name_or_path: str | os.PathLike, min_goal_dist: float = 3.0,
             clearance: float = 0.1) -> MapArena:
    """Read a map: a shipped name (:data:`MAPS`) or a YAML file (ROS map or shapes).

    ``min_goal_dist`` and ``clearance`` (m) set the sampler's defaults (see :class:`MapArena`).
    Raises ``ValueError`` (one line naming the file and the field) for a malformed file.
    """
    if isinstance(name_or_path, str) and name_or_path in MAPS:
        path, name = MAPS[name_or_path], name_or_path
    else:
        path = Path(name_or_path)
        name = path.stem
        if not path.is_file():
            raise ValueError(one_line(
                f"unknown map {str(name_or_path)!r}: not a shipped map ({', '.join(MAPS)}) "
                "nor an existing file"))
    doc = _read_yaml(path)
    if isinstance(doc, dict) and "image" not in doc and ("shapes" in doc or "bounds" in doc):
        arena = _load_shapes(path, doc)
    elif isinstance(doc, dict) and doc:
        arena = _load_ros(path, doc)
    else:
        _fail(path, "<top>", "expected a mapping with 'image' (a ROS map) or 'shapes' "
              f"(a shapes map), got {_short(doc)}")
    arena.name = name
    arena.min_goal_dist = float(min_goal_dist)
    arena.clearance = float(clearance)
    return arena


def _load_ros(path: Path, doc: dict) -> MapArena:
    _mapping(path, "<top>", doc, _ROS_KEYS,
             ("image", "resolution", "origin", "occupied_thresh", "free_thresh"))
    image = doc["image"]
    if not isinstance(image, str) or not image.strip():
        _fail(path, "image", f"expected a file name, got {_short(image)}")
    res = _num(path, "resolution", doc["resolution"], lo=0.0, lo_open=True)
    origin = _vec(path, "origin", doc["origin"], 3, "[x, y, yaw]")
    occ = _num(path, "occupied_thresh", doc["occupied_thresh"], lo=0.0, hi=1.0)
    free = _num(path, "free_thresh", doc["free_thresh"], lo=0.0, hi=1.0)
    if not free < occ:
        _fail(path, "free_thresh", f"must be below occupied_thresh ({occ}), got {free}")
    negate = doc.get("negate", 0)
    if negate not in (0, 1) or (isinstance(negate, float)):
        _fail(path, "negate", f"expected 0 or 1, got {_short(negate)}")
    mode = doc.get("mode", "trinary")
    if mode not in ("trinary", "scale", "raw"):
        _fail(path, "mode", f"expected one of trinary, scale, raw, got {_short(mode)}")
    img = Path(image)
    if not img.is_absolute():
        img = path.parent / img
    grey, alpha = _read_image(path, img)
    cells = occupancy(grey, alpha, bool(negate), occ, free, mode)
    arena = MapArena(path.stem, path, "image", cells, res, origin, np.zeros((0, 3)),
                     np.zeros((0, 4)), (), (0.0, 0.0, 0.0, 0.0))
    solid = arena.solid
    h, w = cells.shape
    e = grid_edges(solid) * res
    arena.segments = np.concatenate([arena.to_world(e[:, :2]), arena.to_world(e[:, 2:])], axis=1)
    rects = grid_rects(solid)
    i0, j0, i1, j1 = rects.T
    corners = np.stack([np.stack([j0, h - i1], axis=-1), np.stack([j1, h - i1], axis=-1),
                        np.stack([j1, h - i0], axis=-1), np.stack([j0, h - i0], axis=-1)],
                       axis=1)
    arena.polygons = tuple(arena.to_world(corners * res))
    box = arena.to_world(np.array([[0.0, 0.0], [w * res, 0.0], [w * res, h * res],
                                   [0.0, h * res]]))
    arena.bounds = (float(box[:, 0].min()), float(box[:, 1].min()), float(box[:, 0].max()),
                    float(box[:, 1].max()))
    return arena


def _segments_cross(p: np.ndarray, q: np.ndarray, r: np.ndarray, s: np.ndarray) -> bool:
    """Whether closed segments pq and rs share a point."""
    def orient(a, b, c):
        return np.sign((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))

    def on(a, b, c):
        return (min(a[0], b[0]) <= c[0] <= max(a[0], b[0])
                and min(a[1], b[1]) <= c[1] <= max(a[1], b[1]))

    o1, o2, o3, o4 = orient(p, q, r), orient(p, q, s), orient(r, s, p), orient(r, s, q)
    if o1 != o2 and o3 != o4:
        return True
    return bool((o1 == 0 and on(p, q, r)) or (o2 == 0 and on(p, q, s))
                or (o3 == 0 and on(r, s, p)) or (o4 == 0 and on(r, s, q)))


def _polygon(path: Path, field: str, v: Any) -> np.ndarray:
    if not isinstance(v, (list, tuple)) or not 3 <= len(v) <= 10000:
        _fail(path, field, f"expected a list of 3 to 10000 points [x, y], got {_short(v)}")
    pts = np.array([_vec(path, f"{field}[{k}]", p, 2, "[x, y]") for k, p in enumerate(v)])
    n = len(pts)
    nxt = np.roll(pts, -1, axis=0)
    if np.any(np.all(pts == nxt, axis=1)):
        _fail(path, field, "two consecutive points coincide")
    if n <= 200:  # O(n^2) simplicity check; larger polygons are trusted
        for a in range(n):
            for b in range(a + 2, n):
                if a == 0 and b == n - 1:
                    continue
                if _segments_cross(pts[a], nxt[a], pts[b], nxt[b]):
                    _fail(path, field, f"the polygon crosses itself (edges {a} and {b})")
    area = 0.5 * float(np.sum(pts[:, 0] * nxt[:, 1] - nxt[:, 0] * pts[:, 1]))
    if area == 0.0:
        _fail(path, field, "the polygon has no area")
    return pts if area > 0 else pts[::-1].copy()


def _load_shapes(path: Path, doc: dict) -> MapArena:
    _mapping(path, "<top>", doc, _SHAPES_KEYS, ("bounds", "shapes"))
    b = _vec(path, "bounds", doc["bounds"], 4, "[xmin, ymin, xmax, ymax]")
    if not (b[0] < b[2] and b[1] < b[3]):
        _fail(path, "bounds", f"need xmin < xmax and ymin < ymax, got {b.tolist()}")
    res = _num(path, "resolution", doc.get("resolution", 0.05), lo=0.0, lo_open=True)
    w = int(math.ceil((b[2] - b[0]) / res - 1e-9))
    h = int(math.ceil((b[3] - b[1]) / res - 1e-9))
    if w * h > MAX_CELLS:
        _fail(path, "resolution", f"{res} m gives {w} x {h} cells, more than {MAX_CELLS}")
    shapes = doc["shapes"]
    if not isinstance(shapes, list):
        _fail(path, "shapes", f"expected a list of shapes, got {_short(shapes)}")
    circles, polys = [], []
    for k, s in enumerate(shapes):
        f = f"shapes[{k}]"
        if not isinstance(s, dict):
            _fail(path, f, f"expected a mapping with a type, got {_short(s)}")
        kind = s.get("type")
        if kind not in _SHAPE_KEYS:
            _fail(path, f"{f}.type", f"expected one of {', '.join(_SHAPE_KEYS)}, got "
                  f"{_short(kind)}")
        keys = _SHAPE_KEYS[kind]
        _mapping(path, f, s, keys, tuple(x for x in keys if x != "yaw"))
        if kind == "circle":
            c = _vec(path, f"{f}.center", s["center"], 2, "[x, y]")
            r = _num(path, f"{f}.radius", s["radius"], lo=0.0, lo_open=True)
            circles.append((c[0], c[1], r))
        elif kind == "box":
            c = _vec(path, f"{f}.center", s["center"], 2, "[x, y]")
            size = _vec(path, f"{f}.size", s["size"], 2, "[width, height]")
            if np.any(size <= 0):
                _fail(path, f"{f}.size", f"must be > 0, got {size.tolist()}")
            yaw = _num(path, f"{f}.yaw", s.get("yaw", 0.0))
            hx, hy = size / 2
            co, si = math.cos(yaw), math.sin(yaw)
            polys.append(np.array([(c[0] + co * px - si * py, c[1] + si * px + co * py)
                                   for px, py in ((hx, -hy), (hx, hy), (-hx, hy), (-hx, -hy))]))
        else:
            polys.append(_polygon(path, f"{f}.points", s["points"]))
    x0, y0, x1, y1 = (float(v) for v in b)
    walls = [(x0, y0, x0, y1), (x0, y1, x1, y1), (x1, y1, x1, y0), (x1, y0, x0, y0)]
    segs = walls + [(*p[k], *p[(k + 1) % len(p)]) for p in polys for k in range(len(p))]
    arena = MapArena(path.stem, path, "shapes", np.zeros((h, w), dtype=np.int8), res,
                     np.array([x0, y0, 0.0]), np.array(circles, dtype=np.float64).reshape(-1, 3),
                     np.array(segs, dtype=np.float64).reshape(-1, 4), tuple(polys),
                     (x0, y0, x1, y1))
    arena.cells[arena.inside(arena.cell_centers())] = 100
    return arena
