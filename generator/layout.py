"""Scene layout in numpy: prefabs expanded into primitives, clutter placed, rays cast.

A :class:`SceneLayout` is what Blender builds (one mesh per material) and what the sampler
uses to keep sight lines clear and to compute occlusion in the surveillance frames, so the
two always agree. The layout depends only on the scene spec (its ``layout_seed``), never on
the dataset seed: a scene is the same place in every dataset.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .specs import ObjectSpec, SceneSpec

__all__ = ["Primitive", "SceneLayout", "layout_scene", "expand_object", "ray_cast",
           "segments_clear", "footprint_distance", "PREFAB_SIZES", "NON_OCCLUDING"]

#: Default bounding-box size (sx, sy, sz) of each prefab, used by random clutter.
PREFAB_SIZES = {
    "box": (0.6, 0.6, 0.6), "cylinder": (0.5, 0.5, 0.9), "sphere": (0.6, 0.6, 0.6),
    "cone": (0.5, 0.5, 0.8), "marking": (1.2, 0.2, 0.004), "disc": (0.7, 0.7, 0.004),
    "bench": (1.6, 0.5, 0.85), "table": (1.2, 0.8, 0.75), "desk": (1.4, 0.7, 0.75),
    "chair": (0.5, 0.5, 0.9), "tree": (3.0, 3.0, 5.5), "bush": (1.2, 1.2, 0.9),
    "lamp_post": (0.3, 0.3, 4.5), "bollard": (0.2, 0.2, 0.9), "car": (4.2, 1.8, 1.5),
    "shelf": (1.8, 0.45, 1.9), "pillar": (0.5, 0.5, 3.0), "planter": (1.0, 1.0, 1.0),
    "bin": (0.5, 0.5, 0.9), "bag": (0.45, 0.25, 0.4), "suitcase": (0.45, 0.28, 0.7),
    "crate": (0.6, 0.4, 0.35), "pallet": (1.2, 1.0, 0.15), "kerb": (3.0, 0.2, 0.15),
    "sign": (0.6, 0.1, 2.4), "barrier": (2.0, 0.1, 1.0), "bike_rack": (2.0, 0.6, 0.8),
    "stall": (2.5, 1.5, 2.4), "umbrella": (2.2, 2.2, 2.3), "sofa": (2.0, 0.9, 0.85),
    "fountain": (4.0, 4.0, 1.6), "railing": (3.0, 0.08, 1.0), "counter": (2.5, 0.7, 1.05),
    "pole": (0.1, 0.1, 2.5), "cone_marker": (0.35, 0.35, 0.6), "poster": (0.8, 0.02, 1.2),
    "door": (1.0, 0.05, 2.1), "step": (2.0, 0.35, 0.17),
}
#: Flat things that never hide a person (markings on the ground, posters on a wall).
NON_OCCLUDING = {"marking", "disc", "poster", "door"}
SHAPES = ("box", "cylinder", "sphere", "cone")


@dataclass(frozen=True)
class Primitive:
    """A box, vertical cylinder, ellipsoid or cone.

    ``center`` is the centre of its bounding box, ``size`` its full extents before the
    rotation ``yaw`` (radians, counter-clockwise about +Z); ``rand`` in [0, 1) drives the
    per-object colour jitter; ``occluder`` says whether it can hide a person.
    """

    shape: str
    center: tuple[float, float, float]
    size: tuple[float, float, float]
    yaw: float
    material: str
    occluder: bool = True
    rand: float = 0.0
    name: str = ""


@dataclass(frozen=True)
class SceneLayout:
    """Primitives of a scene plus the arrays used by the ray caster."""

    spec: SceneSpec
    primitives: tuple[Primitive, ...]
    _arrays: dict = field(default_factory=dict, compare=False, repr=False)

    def occluder_arrays(self):
        """(shape_code (N,), centre (N, 3), half (N, 3), yaw (N,)) of the occluders."""
        if "occ" not in self._arrays:
            occ = [p for p in self.primitives if p.occluder]
            code = np.array([SHAPES.index(p.shape) for p in occ], dtype=np.int64)
            ctr = np.array([p.center for p in occ], dtype=np.float64).reshape(-1, 3)
            half = np.array([p.size for p in occ], dtype=np.float64).reshape(-1, 3) / 2
            yaw = np.array([p.yaw for p in occ], dtype=np.float64)
            self._arrays["occ"] = (code, ctr, half, yaw)
        return self._arrays["occ"]


# --------------------------------------------------------------------------- prefabs


def _rot(yaw):
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s], [s, c]])


def expand_object(obj: ObjectSpec, rand: float = 0.0, name: str = "") -> list[Primitive]:
    """Expand one object (primitive or prefab) into primitives, in world coordinates."""
    sx, sy, sz = obj.size
    yaw = np.deg2rad(obj.yaw_deg)
    m1 = obj.material
    m2 = obj.material2 or obj.material
    R = _rot(yaw)
    x0, y0 = obj.position
    z0 = obj.z
    parts: list[tuple] = []   # (shape, local centre (x, y, z-from-base), size, material, occl)

    def add(shape, cx, cy, cz, px, py, pz, mat=m1, occ=True):
        parts.append((shape, (cx, cy, cz), (px, py, pz), mat, occ))

    t = obj.type
    if t in SHAPES:
        add(t, 0, 0, sz / 2, sx, sy, sz)
    elif t == "marking":      # decals: a per-object lift < 1 mm avoids coplanar overlaps
        add("box", 0, 0, 0.003 + 0.001 * rand, sx, sy, 0.004, occ=False)
    elif t == "disc":
        add("cylinder", 0, 0, 0.003 + 0.001 * rand, sx, sy, 0.004, occ=False)
    elif t in ("poster", "door"):
        add("box", 0, 0, sz / 2, sx, sy, sz, occ=False)
    elif t == "bench":
        seat = 0.45 * sz / 0.85
        add("box", 0, 0, seat, sx, sy * 0.8, 0.05)
        add("box", 0, sy * 0.42, (seat + sz) / 2 + 0.05, sx, 0.05, sz - seat - 0.1)
        for u in (-0.42, 0.42):
            add("box", u * sx, 0, seat / 2, 0.06, sy * 0.8, seat, m2)
    elif t in ("table", "desk", "counter"):
        add("box", 0, 0, sz - 0.025, sx, sy, 0.05)
        if t == "counter":
            add("box", 0, 0, (sz - 0.05) / 2, sx * 0.98, sy * 0.9, sz - 0.05, m2)
        elif t == "desk":
            for u in (-0.47, 0.47):
                add("box", u * sx, 0, (sz - 0.05) / 2, 0.04, sy * 0.95, sz - 0.05, m2)
            add("box", 0, sy * 0.45, sz * 0.55, sx * 0.9, 0.02, sz * 0.6, m2)
        else:
            for u in (-0.45, 0.45):
                for v in (-0.42, 0.42):
                    add("cylinder", u * sx, v * sy, (sz - 0.05) / 2, 0.05, 0.05, sz - 0.05, m2)
    elif t == "chair":
        seat = 0.5 * sz
        add("box", 0, 0, seat, sx, sy, 0.05)
        add("box", 0, sy * 0.45, seat + (sz - seat) / 2, sx, 0.05, sz - seat)
        for u in (-0.42, 0.42):
            for v in (-0.42, 0.42):
                add("box", u * sx, v * sy, seat / 2, 0.04, 0.04, seat, m2)
    elif t == "tree":
        trunk_h = sz * 0.45
        add("cylinder", 0, 0, trunk_h / 2, 0.08 * sx, 0.08 * sx, trunk_h, m1)
        add("sphere", 0, 0, sz - sx * 0.5, sx, sy, min(sx, sz * 0.7), m2)
    elif t == "bush":
        add("sphere", 0, 0, sz / 2, sx, sy, sz)
    elif t == "lamp_post":
        add("cylinder", 0, 0, sz / 2, 0.12, 0.12, sz, m1)
        add("box", 0, 0, sz + 0.1, sx * 1.6, sy, 0.2, m2)
    elif t in ("bollard", "pole", "bin"):
        add("cylinder", 0, 0, sz / 2, sx, sy, sz)
        if t == "bin":
            add("cylinder", 0, 0, sz + 0.02, sx * 1.05, sy * 1.05, 0.04, m2)
    elif t == "car":
        add("box", 0, 0, 0.25 + sz * 0.2, sx, sy, sz * 0.4)
        add("box", -0.05 * sx, 0, 0.25 + sz * 0.55, sx * 0.55, sy * 0.9, sz * 0.32, m2)
        for u in (-0.32, 0.32):
            for v in (-0.45, 0.45):
                add("cylinder", u * sx, v * sy, 0.3, 0.6, 0.2, 0.6, m2)
    elif t == "shelf":
        add("box", 0, sy * 0.45, sz / 2, sx, sy * 0.1, sz)
        for k in range(4):
            z = 0.1 + k * (sz - 0.15) / 3.5
            add("box", 0, 0, z, sx, sy, 0.03)
            for j in range(5):
                add("box", (j - 2) * sx / 5.3, -0.05 * sy, z + 0.14, sx / 7, sy * 0.6, 0.24, m2)
    elif t == "pillar":
        add("box", 0, 0, sz / 2, sx, sy, sz)
    elif t == "planter":
        add("box", 0, 0, sz * 0.25, sx, sy, sz * 0.5)
        add("sphere", 0, 0, sz * 0.65, sx * 0.95, sy * 0.95, sz * 0.7, m2)
    elif t in ("bag", "crate", "suitcase", "step", "kerb"):
        add("box", 0, 0, sz / 2, sx, sy, sz)
        if t == "suitcase":
            add("box", 0, 0, sz + 0.1, 0.04, 0.04, 0.2, m2)
    elif t == "pallet":
        add("box", 0, 0, sz - 0.012, sx, sy, 0.025)
        for v in (-0.45, 0, 0.45):
            add("box", 0, v * sy, (sz - 0.025) / 2, sx, 0.1, sz - 0.025, m2)
    elif t == "sign":
        add("cylinder", 0, 0, sz / 2, 0.06, 0.06, sz, m2)
        add("box", 0, 0, sz - 0.3, sx, 0.03, 0.6, m1)
    elif t in ("barrier", "railing"):
        for u in (-0.48, 0.48):
            add("box", u * sx, 0, sz / 2, 0.06, max(sy, 0.06), sz, m2)
        add("box", 0, 0, sz - 0.04, sx, max(sy, 0.06), 0.08)
        if t == "barrier":
            add("box", 0, 0, sz * 0.45, sx, 0.03, sz * 0.3)
    elif t == "bike_rack":
        for j in range(5):
            add("box", (j - 2) * sx / 5, 0, sz / 2, 0.05, sy, sz, m1)
    elif t == "stall":
        add("box", 0, 0, 0.45, sx, sy, 0.9)
        for u in (-0.48, 0.48):
            for v in (-0.48, 0.48):
                add("cylinder", u * sx, v * sy, sz / 2, 0.05, 0.05, sz, m1)
        add("box", 0, 0, sz, sx * 1.1, sy * 1.1, 0.08, m2)
    elif t == "umbrella":
        add("cylinder", 0, 0, sz / 2, 0.05, 0.05, sz, m1)
        add("cone", 0, 0, sz - 0.2, sx, sy, 0.4, m2)
    elif t == "sofa":
        add("box", 0, 0, 0.22, sx, sy, 0.44)
        add("box", 0, sy * 0.4, sz / 2 + 0.1, sx, sy * 0.2, sz - 0.2)
        for u in (-0.46, 0.46):
            add("box", u * sx, 0, 0.32, sx * 0.08, sy, 0.64)
    elif t == "cone_marker":
        add("box", 0, 0, 0.015, sx, sy, 0.03, m2)
        add("cone", 0, 0, sz / 2 + 0.015, sx * 0.8, sy * 0.8, sz - 0.03)
    elif t == "fountain":
        add("cylinder", 0, 0, 0.25, sx, sy, 0.5)
        add("cylinder", 0, 0, 0.505, sx * 0.9, sy * 0.9, 0.01, m2, False)
        add("cylinder", 0, 0, sz / 2, sx * 0.12, sy * 0.12, sz, m1)
    else:  # pragma: no cover - OBJECT_TYPES and this list are kept in sync by a test
        raise ValueError(f"no prefab for object type {t!r}")

    if obj.type in NON_OCCLUDING:
        parts = [(s, c, p, m, False) for (s, c, p, m, _) in parts]
    out = []
    for k, (shape, (cx, cy, cz), size, mat, occ) in enumerate(parts):
        wx, wy = R @ np.array([cx, cy]) + np.array([x0, y0])
        out.append(Primitive(shape, (float(wx), float(wy), float(z0 + cz)),
                             tuple(float(v) for v in size), float(yaw), mat, occ,
                             float(rand), f"{name}.{k}" if name else ""))
    return out


def _footprint_radius(size) -> float:
    return 0.5 * float(np.hypot(size[0], size[1]))


def _rect_distance(x, y, rects) -> float:
    """Ground distance from (x, y) to the nearest oriented rectangle (cx, cy, hx, hy, yaw)."""
    if not rects:
        return np.inf
    r = np.asarray(rects, dtype=np.float64)
    c, s = np.cos(r[:, 4]), np.sin(r[:, 4])
    dx, dy = x - r[:, 0], y - r[:, 1]
    lx, ly = c * dx + s * dy, -s * dx + c * dy
    return float(np.hypot(np.maximum(np.abs(lx) - r[:, 2], 0),
                          np.maximum(np.abs(ly) - r[:, 3], 0)).min())


def layout_scene(spec: SceneSpec) -> SceneLayout:
    """Expand a scene spec: fixed objects, then seeded random clutter, into primitives.

    Random clutter keeps ``min_gap`` from every standing object (oriented footprints);
    flat markings may overlap each other and sit at slightly different heights so that
    overlapping ones do not z-fight.
    """
    rng = np.random.default_rng(spec.layout_seed)
    prims: list[Primitive] = []
    rects: list[tuple] = []     # footprints of standing objects
    for i, obj in enumerate(spec.objects):
        prims += expand_object(obj, float(rng.random()), f"obj{i}")
        if obj.type not in NON_OCCLUDING:
            rects.append((obj.position[0], obj.position[1], obj.size[0] / 2,
                          obj.size[1] / 2, np.deg2rad(obj.yaw_deg)))
    for ci, cl in enumerate(spec.clutter):
        xmin, ymin, xmax, ymax = cl.region
        n_done = 0
        for _ in range(cl.count * 30):
            if n_done >= cl.count:
                break
            t = cl.types[int(rng.integers(len(cl.types)))]
            f = rng.uniform(*cl.scale)
            base = PREFAB_SIZES[t]
            flat = t in NON_OCCLUDING
            size = (base[0] * f, base[1] * f, base[2] if flat else base[2] * f)
            yaw = (rng.uniform(0, 360) if cl.yaw == "random"
                   else 90.0 * int(rng.integers(4)))
            x, y = rng.uniform(xmin, xmax), rng.uniform(ymin, ymax)
            mat = cl.materials[int(rng.integers(len(cl.materials)))]
            mat2 = cl.materials[int(rng.integers(len(cl.materials)))]
            rand = float(rng.random())
            z = float(rng.uniform(0.0, 0.003)) if flat else 0.0
            if not flat and _rect_distance(x, y, rects) < _footprint_radius(size) + cl.min_gap:
                continue
            obj = ObjectSpec(type=t, position=(float(x), float(y)), size=size, yaw_deg=yaw,
                             z=z, material=mat, material2=mat2)
            prims += expand_object(obj, rand, f"clutter{ci}_{n_done}")
            if not flat:
                rects.append((x, y, size[0] / 2, size[1] / 2, np.deg2rad(yaw)))
            n_done += 1
    return SceneLayout(spec, tuple(prims))


# --------------------------------------------------------------------------- ray casting


def _to_local(points, centre, half, yaw):
    """World (..., 3) -> local unit coordinates of each primitive, broadcast (..., N, 3)."""
    c, s = np.cos(yaw), np.sin(yaw)
    d = points[..., None, :] - centre
    lx = (c * d[..., 0] + s * d[..., 1]) / half[:, 0]
    ly = (-s * d[..., 0] + c * d[..., 1]) / half[:, 1]
    lz = d[..., 2] / half[:, 2]
    return np.stack([lx, ly, lz], axis=-1)


def _dir_to_local(dirs, half, yaw):
    c, s = np.cos(yaw), np.sin(yaw)
    dx = (c * dirs[..., None, 0] + s * dirs[..., None, 1]) / half[:, 0]
    dy = (-s * dirs[..., None, 0] + c * dirs[..., None, 1]) / half[:, 1]
    dz = dirs[..., None, 2] / np.broadcast_to(half[:, 2], dx.shape)
    return np.stack([dx, dy, dz], axis=-1)


def _hit_unit(o, d, code):
    """Entry distance of rays ``o + t d`` into unit primitives (local coords); inf if none.

    Shapes: 0 box ``|x|,|y|,|z| <= 1``; 1 cylinder and 3 cone (bounded by their cylinder)
    ``x^2 + y^2 <= 1, |z| <= 1``; 2 ellipsoid ``|p| <= 1``. A ray starting inside gives 0.
    """
    inf = np.inf
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        # slabs (box; and the z-slab of cylinders)
        inv = 1.0 / d
        t1 = (-1.0 - o) * inv
        t2 = (1.0 - o) * inv
        tlo = np.where(np.isnan(t1), -inf, np.minimum(t1, t2))
        thi = np.where(np.isnan(t2), inf, np.maximum(t1, t2))
        # a zero direction component: inside the slab -> (-inf, inf), outside -> empty
        zero = d == 0
        inside = np.abs(o) <= 1
        tlo = np.where(zero, np.where(inside, -inf, inf), tlo)
        thi = np.where(zero, np.where(inside, inf, -inf), thi)
        box_in = tlo.max(-1)
        box_out = thi.min(-1)
        t_box = np.where(box_in <= box_out, np.maximum(box_in, 0.0), inf)
        t_box = np.where(box_out < 0, inf, t_box)

        # infinite cylinder x^2 + y^2 = 1, clipped by the z slab
        a = d[..., 0] ** 2 + d[..., 1] ** 2
        b = 2 * (o[..., 0] * d[..., 0] + o[..., 1] * d[..., 1])
        c = o[..., 0] ** 2 + o[..., 1] ** 2 - 1
        disc = b * b - 4 * a * c
        sq = np.sqrt(np.maximum(disc, 0))
        c_in = np.where(a > 0, (-b - sq) / (2 * a), np.where(c <= 0, -inf, inf))
        c_out = np.where(a > 0, (-b + sq) / (2 * a), np.where(c <= 0, inf, -inf))
        c_in = np.where((a > 0) & (disc < 0), inf, c_in)
        c_out = np.where((a > 0) & (disc < 0), -inf, c_out)
        lo = np.maximum(c_in, tlo[..., 2])
        hi = np.minimum(c_out, thi[..., 2])
        t_cyl = np.where((lo <= hi) & (hi >= 0), np.maximum(lo, 0.0), inf)

        # unit sphere
        a = (d * d).sum(-1)
        b = 2 * (o * d).sum(-1)
        c = (o * o).sum(-1) - 1
        disc = b * b - 4 * a * c
        sq = np.sqrt(np.maximum(disc, 0))
        s_in = (-b - sq) / (2 * a)
        s_out = (-b + sq) / (2 * a)
        t_sph = np.where((disc >= 0) & (s_out >= 0), np.maximum(s_in, 0.0), inf)
    return np.where(code == 0, t_box, np.where(code == 2, t_sph, t_cyl))


def ray_cast(layout: SceneLayout, origins, directions, *, chunk: int = 4096) -> np.ndarray:
    """Distance along each ray to the first occluding primitive (``inf`` if none).

    Parameters
    ----------
    origins, directions : (M, 3) array_like
        Rays ``o + t d``, ``t >= 0`` (``t`` is in units of ``|d|``).

    Returns
    -------
    t : (M,) ndarray
    """
    o = np.asarray(origins, dtype=np.float64).reshape(-1, 3)
    d = np.asarray(directions, dtype=np.float64).reshape(-1, 3)
    o = np.broadcast_to(o, d.shape) if len(o) == 1 else o
    code, ctr, half, yaw = layout.occluder_arrays()
    out = np.full(len(d), np.inf)
    if len(code) == 0:
        return out
    for i in range(0, len(d), chunk):
        lo = _to_local(o[i:i + chunk], ctr, half, yaw)
        ld = _dir_to_local(d[i:i + chunk], half, yaw)
        t = _hit_unit(lo, ld, code)
        out[i:i + chunk] = t.min(-1)
    return out


def segments_clear(layout: SceneLayout, starts, ends, margin: float = 0.0) -> bool:
    """True if no occluder (grown by ``margin`` metres) cuts any segment ``start -> end``."""
    s = np.asarray(starts, dtype=np.float64).reshape(-1, 3)
    e = np.asarray(ends, dtype=np.float64).reshape(-1, 3)
    s = np.broadcast_to(s, e.shape) if len(s) == 1 else s
    code, ctr, half, yaw = layout.occluder_arrays()
    if len(code) == 0:
        return True
    # cull: keep occluders whose bounding circle comes near some segment's ground track
    radius = np.linalg.norm(half[:, :2], axis=1) + margin + 1e-6
    a, d = s[:, :2], e[:, :2] - s[:, :2]
    dd = np.maximum((d * d).sum(1), 1e-12)
    rel = ctr[:, None, :2] - a[None]                       # (N, M, 2)
    u = np.clip((rel * d[None]).sum(-1) / dd[None], 0.0, 1.0)
    gap = np.linalg.norm(rel - u[..., None] * d[None], axis=-1)
    keep = (gap < radius[:, None]).any(1)
    if not keep.any():
        return True
    code, ctr, half, yaw = code[keep], ctr[keep], half[keep], yaw[keep]
    lo = _to_local(s, ctr, half + margin, yaw)
    ld = _dir_to_local(e - s, half + margin, yaw)
    t = _hit_unit(lo, ld, code)
    return bool(np.all(t > 1.0))


def footprint_distance(layout: SceneLayout, xy) -> float:
    """Ground distance from ``xy`` to the nearest occluder footprint (0 if inside one)."""
    code, ctr, half, yaw = layout.occluder_arrays()
    if len(code) == 0:
        return np.inf
    p = np.asarray(xy, dtype=np.float64)
    c, s = np.cos(yaw), np.sin(yaw)
    dx, dy = p[0] - ctr[:, 0], p[1] - ctr[:, 1]
    lx, ly = c * dx + s * dy, -s * dx + c * dy
    box = np.hypot(np.maximum(np.abs(lx) - half[:, 0], 0), np.maximum(np.abs(ly) - half[:, 1], 0))
    # cylinders/spheres/cones: ellipse footprint, approximated by its mean radius
    rad = np.maximum(np.hypot(lx, ly) - half[:, :2].mean(1), 0)
    d = np.where(code == 0, box, rad)
    # objects lifted off the ground (crowns, canopies) above 2.2 m do not block feet
    low = (ctr[:, 2] - half[:, 2]) < 2.2
    d = np.where(low, d, np.inf)
    return float(d.min()) if len(d) else np.inf
