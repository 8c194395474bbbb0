"""Map files (wheelgym.world.maps): cells from pixels, boundary segments, sensor agreement with
pymunk, reachable start and goal, one-line errors, the shipped maps."""

from __future__ import annotations

import filecmp
import importlib.util
import math
import struct
import zlib
from pathlib import Path

import numpy as np
import pymunk
import pytest
from scipy import ndimage

from wheelgym.world import (
    MAPS,
    MapArena,
    World,
    build_space,
    k_clearance,
    k_ranges,
    load_map,
    pymunk_ranges,
)
from wheelgym.world.maps import write_pgm

# ---------------------------------------------------------------------------------------------
# helpers
# ---------------------------------------------------------------------------------------------

#: 3 x 4 (non-square: a transposed or flipped grid shows) grey pixels around the thresholds
PIX = np.array([[0, 89, 90, 150], [204, 205, 206, 254], [255, 40, 60, 128]], dtype=np.uint8)
#: ROS trinary cells of PIX for occupied_thresh 0.65, free_thresh 0.196, worked out by hand:
#: occ = (255 - p) / 255, e.g. 89 -> 0.651 (occupied), 205 -> 0.19608 (unknown), 206 -> 0.192
TRINARY = np.array([[100, 100, -1, -1], [-1, -1, 0, 0], [0, 100, 100, -1]])
TRINARY_NEG = np.array([[0, -1, -1, -1], [100, 100, 100, 100], [100, 0, -1, -1]])


def _png(path: Path, pixels: np.ndarray, color_type: int) -> None:
    """An 8-bit PNG (grey 0, RGB 2, RGBA 6), filter 0 on every row."""
    h, w = pixels.shape[:2]
    raw = b"".join(b"\x00" + np.ascontiguousarray(pixels[i]).tobytes() for i in range(h))

    def chunk(tag: bytes, data: bytes) -> bytes:
        return (struct.pack(">I", len(data)) + tag + data
                + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF))

    path.write_bytes(b"\x89PNG\r\n\x1a\n"
                     + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, color_type, 0, 0, 0))
                     + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def _ros_yaml(path: Path, image: str, **over) -> Path:
    fields = {"image": image, "resolution": 0.5, "origin": "[1.0, -2.0, 0.0]",
              "occupied_thresh": 0.65, "free_thresh": 0.196, "negate": 0, **over}
    path.write_text("".join(f"{k}: {v}\n" for k, v in fields.items() if v is not None))
    return path


def _ros_scalar(p: float, alpha: int, negate: bool, occ_th: float, free_th: float,
                mode: str) -> int:
    """ROS 1 map_server's rule for one pixel, written out as in image_loader.cpp."""
    if negate:
        p = 255.0 - p
    if mode == "raw":
        v = round(p)
        return v if 0 <= v <= 100 else -1
    occ = (255.0 - p) / 255.0
    if occ > occ_th:
        return 100
    if occ < free_th:
        return 0
    if mode == "trinary" or alpha < 1:
        return -1
    return int(1 + 98 * (occ - free_th) / (occ_th - free_th))


def _pack(world: World) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """One row of the navigate task's per-row arrays (at least one circle slot)."""
    C = np.zeros((1, max(1, len(world.circles)), 3))
    C[0, : len(world.circles)] = world.circles
    return (C, np.array([len(world.circles)]), world.segments[None].copy(),
            np.array([len(world.segments)]))


def _random_grid_map(tmp_path: Path, seed: int, shape=(11, 15), p_solid=0.45) -> MapArena:
    rng = np.random.default_rng(seed)
    pix = np.where(rng.random(shape) < p_solid, 0, 254).astype(np.uint8)
    write_pgm(tmp_path / f"g{seed}.pgm", pix)
    return load_map(_ros_yaml(tmp_path / f"g{seed}.yaml", f"g{seed}.pgm",
                              origin="[-3.0, 1.5, 0.0]", resolution=0.25))


# ---------------------------------------------------------------------------------------------
# cells equal the image's pixels
# ---------------------------------------------------------------------------------------------

@pytest.mark.parametrize("plain", [False, True], ids=["P5", "P2"])
@pytest.mark.parametrize("negate", [0, 1])
def test_pgm_cells_equal_the_pixels(tmp_path, plain, negate):
    write_pgm(tmp_path / "m.pgm", PIX, comment="test map", plain=plain)
    m = load_map(_ros_yaml(tmp_path / "m.yaml", "m.pgm", negate=negate))
    assert m.kind == "image" and m.cells.dtype == np.int8
    np.testing.assert_array_equal(m.cells, TRINARY_NEG if negate else TRINARY)
    np.testing.assert_array_equal(m.solid, m.cells != 0)


@pytest.mark.parametrize("mode", ["trinary", "scale", "raw"])
@pytest.mark.parametrize("negate", [0, 1])
def test_png_cells_follow_the_ros_rule_per_pixel(tmp_path, mode, negate):
    rng = np.random.default_rng(3)
    grey = rng.integers(0, 256, (7, 9)).astype(np.uint8)
    grey[0, :4] = [0, 89, 205, 254]
    _png(tmp_path / "g.png", grey, 0)
    m = load_map(_ros_yaml(tmp_path / "g.yaml", "g.png", negate=negate, mode=mode))
    want = [[_ros_scalar(float(v), 255, bool(negate), 0.65, 0.196, mode) for v in row]
            for row in grey]
    np.testing.assert_array_equal(m.cells, want)
    if mode == "trinary":
        np.testing.assert_array_equal(m.cells[0, :4], [0, -1, 100, 100] if negate
                                      else [100, 100, -1, 0])


def test_png_colour_is_the_channel_mean_and_transparent_is_unknown_in_scale_mode(tmp_path):
    rgba = np.zeros((2, 3, 4), dtype=np.uint8)
    rgba[..., 3] = 255
    rgba[0, 0, :3] = (255, 255, 0)        # mean 170: occ 0.333, between the thresholds
    rgba[0, 1, :3] = (30, 0, 0)           # mean 10: occupied
    rgba[0, 2, :3] = (254, 254, 254)      # free
    rgba[1] = rgba[0]
    rgba[1, :, 3] = 0                     # transparent row
    _png(tmp_path / "c.png", rgba, 6)
    _png(tmp_path / "c3.png", np.ascontiguousarray(rgba[..., :3]), 2)
    m = load_map(_ros_yaml(tmp_path / "c.yaml", "c.png", mode="scale"))
    mid = _ros_scalar(170.0, 255, False, 0.65, 0.196, "scale")
    assert 1 <= mid <= 99
    np.testing.assert_array_equal(m.cells, [[mid, 100, 0], [-1, 100, 0]])
    m3 = load_map(_ros_yaml(tmp_path / "c3.yaml", "c3.png", mode="scale"))
    np.testing.assert_array_equal(m3.cells, [[mid, 100, 0], [mid, 100, 0]])


def test_pgm_of_another_maxval_is_scaled_to_8_bits(tmp_path):
    (tmp_path / "s.pgm").write_bytes(b"P2\n# comment\n3 1 # inline comment\n15\n15 0 12\n")
    m = load_map(_ros_yaml(tmp_path / "s.yaml", "s.pgm"))
    np.testing.assert_array_equal(m.cells, [[0, 100, -1]])  # 12 -> 204: unknown
    big = np.array([[65535, 0]], dtype=">u2").tobytes()
    (tmp_path / "b.pgm").write_bytes(b"P5 2 1 65535\n" + big)
    np.testing.assert_array_equal(load_map(_ros_yaml(tmp_path / "b.yaml", "b.pgm")).cells,
                                  [[0, 100]])


def test_cell_centres_follow_origin_and_resolution(tmp_path):
    write_pgm(tmp_path / "m.pgm", PIX)
    m = load_map(_ros_yaml(tmp_path / "m.yaml", "m.pgm"))
    h, w = PIX.shape
    xy = m.cell_centers()
    for i in range(h):
        for j in range(w):  # row 0 is the top: the largest y
            assert tuple(xy[i, j]) == (1.0 + (j + 0.5) * 0.5, -2.0 + (h - i - 0.5) * 0.5)
            assert tuple(int(v) for v in m.cell_index(xy[i, j])) == (i, j)
            assert bool(m.inside(xy[i, j])) == bool(m.solid[i, j])
    assert m.bounds == (1.0, -2.0, 3.0, -0.5)
    assert m.inside(np.array([[0.9, -1.0], [3.1, -1.0], [2.0, -0.4]])).all()  # off the map
    rot = load_map(_ros_yaml(tmp_path / "r.yaml", "m.pgm",
                             origin=f"[1.0, -2.0, {math.pi / 2!r}]"))
    local = np.array([(0 + 0.5) * 0.5, (h - 0 - 0.5) * 0.5])  # cell (0, 0)
    np.testing.assert_allclose(rot.cell_centers()[0, 0], [1.0 - local[1], -2.0 + local[0]],
                               atol=1e-15)
    i, j = rot.cell_index(rot.cell_centers())
    np.testing.assert_array_equal(i, np.arange(h)[:, None] + 0 * j)


# ---------------------------------------------------------------------------------------------
# the boundary segments
# ---------------------------------------------------------------------------------------------

def _crossings(pts: np.ndarray, segs: np.ndarray, ang: float = 0.4321) -> np.ndarray:
    """How many segments a ray from each point (generic direction) crosses."""
    d = np.array([math.cos(ang), math.sin(ang)])
    s0, e = segs[None, :, :2], segs[None, :, 2:] - segs[None, :, :2]
    w = s0 - pts[:, None, :]
    den = d[0] * e[..., 1] - d[1] * e[..., 0]
    t = (w[..., 0] * e[..., 1] - w[..., 1] * e[..., 0]) / den
    u = (w[..., 0] * d[1] - w[..., 1] * d[0]) / den
    return np.count_nonzero((t > 0) & (u >= 0) & (u < 1), axis=1)


@pytest.mark.parametrize("seed", range(4))
def test_segments_enclose_exactly_the_solid_cells(tmp_path, seed):
    m = _random_grid_map(tmp_path, seed)
    res, segs, solid = m.resolution, m.segments, m.solid
    centres = m.cell_centers().reshape(-1, 2)
    # parity: outside the image counts as solid, so a free cell sees an odd number of edges
    odd = _crossings(centres, segs) % 2 == 1
    np.testing.assert_array_equal(odd, ~solid.ravel())
    # no segment passes through a cell: every centre is at least res/2 from every segment
    C, nc, S, ns = _pack(m.world(np.zeros(3), np.zeros(3)))
    clear = np.zeros(len(centres))
    k_clearance(centres, np.repeat(C, len(centres), 0), np.repeat(nc, len(centres)),
                np.repeat(S, len(centres), 0), np.repeat(ns, len(centres)), clear)
    assert clear.min() >= 0.5 * res - 1e-12
    # each segment has solid on its left and free on its right, along its whole length
    d = segs[:, 2:] - segs[:, :2]
    length = np.hypot(d[:, 0], d[:, 1])
    normal = np.stack([-d[:, 1], d[:, 0]], axis=1) / length[:, None]
    for f in (0.01, 0.5, 0.99):
        mid = segs[:, :2] + f * d
        assert m.inside(mid + 1e-6 * normal).all()
        assert not m.inside(mid - 1e-6 * normal).any()
    # together they cover every solid/free cell edge once: total length equals the count
    p = np.ones((solid.shape[0] + 2, solid.shape[1] + 2), dtype=bool)
    p[1:-1, 1:-1] = solid
    n_edges = np.count_nonzero(p[1:, 1:-1] != p[:-1, 1:-1]) + np.count_nonzero(
        p[1:-1, 1:] != p[1:-1, :-1])
    assert math.isclose(length.sum(), n_edges * res, rel_tol=1e-12)
    # maximal: no segment continues another with the same direction
    u = d / length[:, None]
    for k in range(len(segs)):
        joined = np.all(np.abs(segs[:, :2] - segs[k, 2:]) < 1e-12, axis=1)
        same = np.all(np.abs(u - u[k]) < 1e-12, axis=1)
        assert not np.any(joined & same), f"segment {k} could be merged"


def test_solid_rectangles_cover_exactly_the_solid_cells(tmp_path):
    m = _random_grid_map(tmp_path, 7)
    covered = np.zeros(m.cells.shape, dtype=int)
    centres = m.cell_centers()
    for poly in m.polygons:  # axis-aligned here (yaw 0)
        lo, hi = poly.min(axis=0), poly.max(axis=0)
        covered += ((centres[..., 0] > lo[0]) & (centres[..., 0] < hi[0])
                    & (centres[..., 1] > lo[1]) & (centres[..., 1] < hi[1]))
    np.testing.assert_array_equal(covered, m.solid.astype(int))


def _compare_with_pymunk(m: MapArena, rng: np.random.Generator, n: int = 40) -> float:
    w = m.world(np.zeros(3), np.zeros(3))
    space = build_space(w)
    C, nc, S, ns = _pack(w)
    lo, hi = np.array(m.bounds[:2]), np.array(m.bounds[2:])
    worst, done = 0.0, 0
    while done < n:
        p = rng.uniform(lo, hi)
        if not m.is_free(p[None], 1e-3)[0]:
            continue
        pose = np.array([p[0], p[1], rng.uniform(-math.pi, math.pi)])
        ref = np.zeros(16)
        pymunk_ranges(space, pose, 16, 3.0, ref)
        out = np.zeros((1, 16))
        k_ranges(pose[None], C, nc, S, ns, 3.0, out)
        worst = max(worst, float(np.max(np.abs(out[0] - ref))))
        clear = np.zeros(1)
        k_clearance(pose[None], C, nc, S, ns, clear)
        q = space.point_query_nearest((float(p[0]), float(p[1])), 100.0, pymunk.ShapeFilter())
        assert abs(q.distance - clear[0]) < 1e-9
        assert m.surface_distance(p) == clear[0]  # the same arithmetic as k_clearance
        done += 1
    return worst


@pytest.mark.parametrize("name", sorted(MAPS))
def test_compiled_ranges_equal_pymunk_on_shipped_maps(name):
    assert _compare_with_pymunk(load_map(name), np.random.default_rng(1)) < 1e-9


def test_compiled_ranges_equal_pymunk_on_a_random_grid(tmp_path):
    m = _random_grid_map(tmp_path, 11, shape=(30, 40), p_solid=0.2)
    assert _compare_with_pymunk(m, np.random.default_rng(2)) < 1e-9


# ---------------------------------------------------------------------------------------------
# shapes maps
# ---------------------------------------------------------------------------------------------

SHAPES = """\
bounds: [-2.0, -1.0, 3.0, 2.0]
resolution: 0.1
shapes:
  - {type: box, center: [0.0, 0.0], size: [1.0, 0.4], yaw: 0.5}
  - {type: circle, center: [2.0, 1.0], radius: 0.3}
  - {type: polygon, points: [[-1.5, 1.5], [-1.5, 0.5], [-0.5, 1.5]]}   # clockwise
"""


def test_shapes_map_geometry_and_cells(tmp_path):
    (tmp_path / "s.yaml").write_text(SHAPES)
    m = load_map(tmp_path / "s.yaml")
    assert m.kind == "shapes" and m.cells.shape == (30, 50) and m.bounds == (-2.0, -1.0, 3.0, 2.0)
    assert len(m.segments) == 4 + 4 + 3 and m.circles.tolist() == [[2.0, 1.0, 0.3]]
    xy = m.cell_centers()
    # cells: a centre inside a shape is occupied; worked out independently here
    c, s = math.cos(0.5), math.sin(0.5)
    bx, by = c * xy[..., 0] + s * xy[..., 1], -s * xy[..., 0] + c * xy[..., 1]
    box = (np.abs(bx) < 0.5) & (np.abs(by) < 0.2)
    disc = np.hypot(xy[..., 0] - 2.0, xy[..., 1] - 1.0) < 0.3
    tri = (xy[..., 0] > -1.5) & (xy[..., 1] < 1.5) & (xy[..., 1] - 0.5 > xy[..., 0] + 1.5)
    np.testing.assert_array_equal(m.cells, np.where(box | disc | tri, 100, 0))
    # polygons turn counter-clockwise (solid on the left of every edge)
    for poly in m.polygons:
        q = np.roll(poly, -1, axis=0)
        assert np.sum(poly[:, 0] * q[:, 1] - q[:, 0] * poly[:, 1]) > 0
    assert _compare_with_pymunk(m, np.random.default_rng(4)) < 1e-9


# ---------------------------------------------------------------------------------------------
# start and goal
# ---------------------------------------------------------------------------------------------

@pytest.mark.parametrize("name", sorted(MAPS))
@pytest.mark.parametrize("radius", [0.33, 0.55])
def test_start_and_goal_are_free_reachable_and_reproducible(name, radius):
    m = load_map(name)
    # an independent reachability check: scipy's 4-connected labelling of the cells whose
    # centres keep the robot clear, and the straight line from the pose to its cell centre
    passable = m.clearance_grid() >= radius + 0.5 * m.resolution
    labels, _ = ndimage.label(passable)
    rng = np.random.default_rng(5)
    poses = []
    for _ in range(25):
        start, goal = m.sample_start_goal(rng, radius)
        poses.append((start, goal))
        assert m.is_free(np.stack([start[:2], goal[:2]]), radius + m.clearance).all()
        assert math.hypot(*(goal[:2] - start[:2])) >= m.min_goal_dist
        (i0, i1), (j0, j1) = m.cell_index(np.stack([start[:2], goal[:2]]))
        assert labels[i0, j0] > 0 and labels[i0, j0] == labels[i1, j1]
        assert -math.pi <= start[2] <= math.pi and -math.pi <= goal[2] <= math.pi
    rng = np.random.default_rng(5)
    again = [m.sample_start_goal(rng, radius) for _ in range(25)]
    for (s, g), (s2, g2) in zip(poses, again, strict=True):
        np.testing.assert_array_equal(s, s2)
        np.testing.assert_array_equal(g, g2)
    assert len({tuple(s.round(9)) for s, _ in poses}) == 25


def test_sampling_on_a_rotated_map_stays_free(tmp_path):
    pix = np.full((60, 80), 254, dtype=np.uint8)
    pix[20:40, 30:50] = 0
    write_pgm(tmp_path / "r.pgm", pix)
    m = load_map(_ros_yaml(tmp_path / "r.yaml", "r.pgm", resolution=0.1,
                           origin="[2.0, -1.0, 0.7]"))
    rng = np.random.default_rng(0)
    for _ in range(20):
        start, goal = m.sample_start_goal(rng, 0.3, min_dist=2.0)
        assert m.is_free(np.stack([start[:2], goal[:2]]), 0.3 + m.clearance).all()
    assert _compare_with_pymunk(m, rng, n=20) < 1e-9


def test_generate_gives_a_world_like_the_random_arena():
    m = load_map("office", min_goal_dist=4.0, clearance=0.2)
    w = m.generate(np.random.default_rng(0), 0.36)
    w2 = load_map("office", min_goal_dist=4.0, clearance=0.2).generate(
        np.random.default_rng(0), 0.36)
    np.testing.assert_array_equal(w.start, w2.start)
    assert math.hypot(*(w.goal[:2] - w.start[:2])) >= 4.0
    C, nc, S, ns = _pack(w)
    clear = np.zeros(2)
    k_clearance(np.stack([w.start, w.goal]), np.repeat(C, 2, 0), np.repeat(nc, 2),
                np.repeat(S, 2, 0), np.repeat(ns, 2), clear)
    assert clear.min() >= 0.36 + 0.2
    assert (m.max_circles, m.max_segments) == (len(w.circles), len(w.segments))
    w.segments[0] = 0.0  # a copy: the map keeps its geometry
    assert m.segments[0].any()


def test_no_room_for_the_robot_raises(tmp_path):
    write_pgm(tmp_path / "t.pgm", np.full((8, 8), 254, dtype=np.uint8))
    m = load_map(_ros_yaml(tmp_path / "t.yaml", "t.pgm", resolution=0.1))
    with pytest.raises(ValueError, match="no two reachable free poses"):
        m.sample_start_goal(np.random.default_rng(0), 0.5)


# ---------------------------------------------------------------------------------------------
# malformed files
# ---------------------------------------------------------------------------------------------

ROS_OK = {"image": "m.pgm", "resolution": 0.05, "origin": "[0.0, 0.0, 0.0]",
          "occupied_thresh": 0.65, "free_thresh": 0.196, "negate": 0}

BAD_ROS = [  # (override, field named in the message)
    ({"resolution": None}, "resolution"),                 # missing
    ({"origin": None}, "origin"),
    ({"image": None}, "image"),
    ({"resolution": "abc"}, "resolution"),                # bad type
    ({"resolution": -0.05}, "resolution"),
    ({"resolution": "true"}, "resolution"),
    ({"origin": "[0.0, 0.0]"}, "origin"),
    ({"origin": "[0.0, x, 0.0]"}, "origin[1]"),
    ({"occupied_thresh": 1.5}, "occupied_thresh"),
    ({"free_thresh": 0.7}, "free_thresh"),
    ({"negate": 2}, "negate"),
    ({"mode": "binary"}, "mode"),
    ({"image": "[1, 2]"}, "image"),
    ({"image": "nothere.pgm"}, "image"),                  # missing image
    ({"image": "bad.pgm"}, "image"),                      # bad PGM header
    ({"image": "short.pgm"}, "image"),                    # truncated pixels
    ({"image": "plain.pgm"}, "image"),                    # P2 value over maxval
    ({"image": "bad.png"}, "image"),                      # not a PNG
    ({"occupied_threshold": 0.65}, "occupied_threshold"),  # unknown field (a typo)
]


@pytest.mark.parametrize(("over", "field"), BAD_ROS, ids=[f"{f}-{i}" for i, (_, f)
                                                          in enumerate(BAD_ROS)])
def test_malformed_ros_map_gives_one_line_naming_file_and_field(tmp_path, over, field):
    write_pgm(tmp_path / "m.pgm", PIX)
    (tmp_path / "bad.pgm").write_bytes(b"P7\n3 4\n255\n" + bytes(12))
    (tmp_path / "short.pgm").write_bytes(b"P5\n4 3\n255\n" + bytes(5))
    (tmp_path / "plain.pgm").write_bytes(b"P2\n2 1\n15\n3 16\n")
    (tmp_path / "bad.png").write_bytes(b"\x89PNG\r\n\x1a\nnot really")
    fields = {**ROS_OK, **over}
    path = tmp_path / "map.yaml"
    path.write_text("".join(f"{k}: {v}\n" for k, v in fields.items() if v is not None))
    with pytest.raises(ValueError) as e:
        load_map(path)
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith(str(path)) and f"field '{field}'" in msg, msg


BAD_SHAPES = [  # (text, field)
    ("shapes: []\n", "bounds"),
    ("bounds: [0, 0, 1, 1]\n", "shapes"),
    ("# nothing\n", "<top>"),
    ("bounds: [0, 0, -1, 1]\nshapes: []\n", "bounds"),
    ("bounds: [0, 0, 1]\nshapes: []\n", "bounds"),
    ("bounds: [0, 0, 1, 1]\nshapes: {a: 1}\n", "shapes"),
    ("bounds: [0, 0, 1, 1]\nshapes: [{type: triangle}]\n", "shapes[0].type"),
    ("bounds: [0, 0, 1, 1]\nshapes: [3]\n", "shapes[0]"),
    ("bounds: [0, 0, 1, 1]\nshapes: [{type: circle, center: [0, 0], radius: -1}]\n",
     "shapes[0].radius"),
    ("bounds: [0, 0, 1, 1]\nshapes: [{type: circle, center: [0, 0]}]\n", "shapes[0].radius"),
    ("bounds: [0, 0, 1, 1]\nshapes: [{type: box, center: [0, 0], size: [0, 1]}]\n",
     "shapes[0].size"),
    ("bounds: [0, 0, 1, 1]\nshapes: [{type: box, center: [0, 0], size: [1, 1], colour: 1}]\n",
     "shapes[0].colour"),
    ("bounds: [0, 0, 1, 1]\nshapes: [{type: polygon, points: [[0, 0], [1, 1], [1, 0], "
     "[0, 1]]}]\n", "shapes[0].points"),  # crosses itself
    ("bounds: [0, 0, 1, 1]\nshapes: [{type: polygon, points: [[0, 0], [1, 1]]}]\n",
     "shapes[0].points"),
    ("bounds: [0, 0, 1, 1]\nresolution: 1.0e-6\nshapes: []\n", "resolution"),
    ("bounds: &b [0, 0, 1, 1]\nshapes: []\nresolution: *b\n", "resolution"),  # alias
    ("- 1\n- 2\n", "<top>"),
]


@pytest.mark.parametrize(("text", "field"), BAD_SHAPES, ids=[f"{f}-{i}" for i, (_, f)
                                                             in enumerate(BAD_SHAPES)])
def test_malformed_shapes_map_gives_one_line_naming_file_and_field(tmp_path, text, field):
    path = tmp_path / "shapes.yaml"
    path.write_text(text)
    with pytest.raises(ValueError) as e:
        load_map(path)
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith(str(path)) and f"field '{field}'" in msg, msg


def test_alias_in_a_ros_map_and_bad_yaml_are_refused(tmp_path):
    write_pgm(tmp_path / "m.pgm", PIX)
    path = tmp_path / "a.yaml"
    path.write_text("image: m.pgm\nresolution: &r 0.05\norigin: [0.0, 0.0, 0.0]\n"
                    "occupied_thresh: *r\nfree_thresh: 0.01\n")
    with pytest.raises(ValueError, match=r"field 'occupied_thresh': YAML aliases are not "
                                         r"allowed .*line 4") as e:
        load_map(path)
    assert str(e.value).startswith(str(path))
    path.write_text("image: [m.pgm\n")
    with pytest.raises(ValueError, match="not valid YAML") as e:
        load_map(path)
    assert "\n" not in str(e.value) and str(e.value).startswith(str(path))


def test_unknown_map_name_lists_the_shipped_maps():
    with pytest.raises(ValueError, match="warehouse, office, maze"):
        load_map("wherehouse")


# ---------------------------------------------------------------------------------------------
# the shipped maps
# ---------------------------------------------------------------------------------------------

#: name: (kind, cells (H, W), segments, circles) as documented in the report and make_maps.py
SHIPPED = {"warehouse": ("image", (210, 290), 54, 0), "office": ("image", (190, 250), 134, 0),
           "maze": ("shapes", (192, 192), 68, 1)}


@pytest.mark.parametrize("name", sorted(MAPS))
def test_every_shipped_map_loads(name):
    m = load_map(name)
    kind, shape, ns, nc = SHIPPED[name]
    assert (m.name, m.kind, m.cells.shape, len(m.segments), len(m.circles)) == (
        name, kind, shape, ns, nc)
    assert m.resolution == 0.05 and 8.0 <= m.bounds[2] - m.bounds[0] <= 16.0
    assert m.segments.shape == (ns, 4) and m.circles.shape == (nc, 3)
    assert load_map(MAPS[name]).segments.tolist() == m.segments.tolist()
    build_space(m.world(np.zeros(3), np.ones(3)))
    # every robot of the package fits somewhere with the default start-to-goal distance
    m.sample_start_goal(np.random.default_rng(0), 0.55)


def test_make_maps_reproduces_the_shipped_files(tmp_path):
    script = Path(MAPS["maze"]).parent / "make_maps.py"
    spec = importlib.util.spec_from_file_location("_make_maps", script)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    mod.main(tmp_path)
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == ["maze.yaml", "office.pgm", "office.yaml", "warehouse.pgm", "warehouse.yaml"]
    for n in names:
        assert filecmp.cmp(tmp_path / n, script.parent / n, shallow=False), n
