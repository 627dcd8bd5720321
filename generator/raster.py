"""A fast rasteriser back-end (pyrender, OpenGL via EGL or OSMesa) for quick runs and tests.

Same interface as :class:`generator.blender.BlenderRenderer` and the same geometry
(:mod:`generator.meshes`, :mod:`generator.body`), so cameras, boxes and homographies are
identical; the look is simpler: procedural materials become small tiling textures made in
numpy, lighting is direct (the sun, or one overhead light for the ceiling lights indoors) plus an
ambient term for the sky, no global illumination, no denoiser; shadows (a 2048^2 shadow
map over the whole scene) are off by default because they halve the speed on llvmpipe.
Anti-aliasing: pyrender's 4x multisampled framebuffer (and optionally ``supersample``).

Needs ``pip install pyrender`` (PyOpenGL) and an EGL (Mesa) or OSMesa library
(``PYOPENGL_PLATFORM`` is set to ``egl`` unless already set).
"""

from __future__ import annotations

import colorsys
import math
import os
from pathlib import Path

import numpy as np

from viewadapt.io.files import atomic_write_bytes

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
try:
    import pyrender
    import trimesh
except ImportError as exc:  # pragma: no cover - exercised where pyrender is missing
    raise ImportError("the pyrender back-end needs pyrender and PyOpenGL with EGL or OSMesa: "
                      f"pip install pyrender ({exc})") from exc

from .body import MATERIAL_SLOTS, PersonMesh
from .layout import SceneLayout
from .meshes import layout_meshes, room_shell, world_uv
from .specs import MaterialSpec, PersonSpec

__all__ = ["RasterRenderer", "material_texture", "pyrender_version"]

_TEX = 64


def pyrender_version() -> str:
    from importlib import metadata

    return metadata.version("pyrender")


def _srgb(lin):
    lin = np.clip(np.asarray(lin, dtype=np.float64), 0, 1)
    return np.where(lin <= 0.0031308, lin * 12.92, 1.055 * lin ** (1 / 2.4) - 0.055)


def _smooth_noise(rng, n=_TEX, cells=8):
    """Tileable value noise in [0, 1], (n, n)."""
    g = rng.random((cells, cells))
    x = np.arange(n) * cells / n
    i0 = np.floor(x).astype(int)
    f = x - i0
    f = f * f * (3 - 2 * f)
    i1 = (i0 + 1) % cells
    a = g[np.ix_(i0, i0)] * (1 - f)[None, :] + g[np.ix_(i0, i1)] * f[None, :]
    b = g[np.ix_(i1, i0)] * (1 - f)[None, :] + g[np.ix_(i1, i1)] * f[None, :]
    return a * (1 - f)[:, None] + b * f[:, None]


def material_texture(spec: MaterialSpec, seed: int = 0):
    """One period of a material's pattern as an sRGB uint8 tile and its period in metres.

    Returns
    -------
    (tile (64, 64, 3) uint8, period_u, period_v)
    """
    rng = np.random.default_rng(seed)
    c = [np.asarray(x) for x in spec.colors]
    n = _TEX
    u = (np.arange(n) + 0.5) / n
    U, V = np.meshgrid(u, u)
    s = spec.scale
    p = spec.pattern
    if p == "flat":
        img = np.broadcast_to(c[0], (n, n, 3))
        pu = pv = 1.0
    elif p == "checker":
        m = ((U < 0.5) ^ (V < 0.5)).astype(float)[..., None]
        img = m * c[0] + (1 - m) * c[1]
        pu = pv = 2 * s
    elif p in ("brick", "tiles"):
        rows = 2
        row = np.floor(V * rows)
        shift = np.where(row % 2 == 1, 0.5, 0.0) if p == "brick" else 0.0
        uu = (U + shift) % 1.0
        vv = (V * rows) % 1.0
        mortar = ((uu < 0.04) | (vv < 0.08)).astype(float)[..., None]
        tone = rng.random((rows, 2))[row.astype(int), (np.floor(uu * 2)).astype(int)][..., None]
        body = tone * c[0] + (1 - tone) * c[1 % len(c)]
        img = mortar * c[-1] + (1 - mortar) * body
        pu, pv = 2 * s, s * (1.0 if p == "brick" else 2.0)
    elif p == "noise":
        m = np.clip(_smooth_noise(rng) * 2.2 - 0.6, 0, 1)[..., None]
        img = m * c[0] + (1 - m) * c[1]
        pu = pv = 8 * s
    elif p == "voronoi":
        pts = rng.random((12, 2))
        d = np.full((n, n), np.inf)
        lab = np.zeros((n, n), int)
        for k, (px, py) in enumerate(pts):
            for ox in (-1, 0, 1):
                for oy in (-1, 0, 1):
                    dd = (U - px - ox) ** 2 + (V - py - oy) ** 2
                    better = dd < d
                    d[better] = dd[better]
                    lab[better] = k
        m = rng.random(12)[lab][..., None]
        img = m * c[0] + (1 - m) * c[1]
        pu = pv = 3.5 * s
    elif p in ("wave", "stripes"):
        m = (U < 0.5).astype(float)[..., None] if p == "stripes" else \
            (0.5 + 0.5 * np.sin(2 * np.pi * (U + 0.15 * _smooth_noise(rng))))[..., None]
        img = m * c[0] + (1 - m) * c[1]
        pu = pv = s
    else:  # pragma: no cover
        raise ValueError(p)
    tile = np.round(_srgb(img) * 255).astype(np.uint8)
    return np.ascontiguousarray(tile), pu, pv


def _jitter_colors(spec: MaterialSpec, rand):
    """Per-face colour factors for hue/value jitter (multiplied with the texture)."""
    if spec.hue_jitter <= 0 and spec.value_jitter <= 0:
        return None
    base = np.asarray(spec.colors[0])
    out = np.empty((len(rand), 3))
    h0, s0, v0 = colorsys.rgb_to_hsv(*np.clip(base, 1e-4, 1))
    for i, r in enumerate(rand):
        h = (h0 + (r - 0.5) * 2 * spec.hue_jitter) % 1.0
        v = v0 * (1 + ((r * 7.31) % 1 - 0.5) * 2 * spec.value_jitter)
        rgb = np.asarray(colorsys.hsv_to_rgb(h, s0, min(max(v, 0), 1)))
        out[i] = rgb / np.maximum(base, 1e-3)
    return np.clip(out, 0, 4)


class RasterRenderer:
    """pyrender scene reused for every render of a process (see the module docstring)."""

    def __init__(self, *, n_slots: int = 6, supersample: int = 1, shadows: bool = False,
                 **_ignored):
        self.supersample = supersample
        self.shadows = shadows
        self.scene = pyrender.Scene(bg_color=[0.6, 0.7, 0.8, 1.0],
                                    ambient_light=[0.3, 0.3, 0.3])
        self.cam_node = None
        self.sun_node = self.scene.add(pyrender.DirectionalLight(color=np.ones(3),
                                                                 intensity=3.0))
        self._scene_nodes: list = []
        self._person_nodes: list = []
        self._scene_id = None
        self._renderers: dict = {}
        self._size = (64, 128, 1)
        self.n_slots = n_slots

    # ---------------------------------------------------------------- scene

    def _material(self, spec: MaterialSpec, seed: int):
        tile, pu, pv = material_texture(spec, seed)
        tex = pyrender.Texture(source=tile, source_channels="RGB",
                               sampler=pyrender.Sampler(wrapS=10497, wrapT=10497))
        mat = pyrender.MetallicRoughnessMaterial(
            baseColorTexture=tex, metallicFactor=spec.metallic * 0.5,
            roughnessFactor=max(spec.roughness, 0.3), doubleSided=False)
        return mat, pu, pv

    def _add_mesh(self, verts, tris, mat, period, colors=None, smooth=False):
        tri = np.asarray(tris)
        v = np.asarray(verts, dtype=np.float64)[tri.ravel()]       # unshared corners
        tv = np.asarray(verts)[tri]
        fn = np.cross(tv[:, 1] - tv[:, 0], tv[:, 2] - tv[:, 0])
        fn /= np.maximum(np.linalg.norm(fn, axis=1, keepdims=True), 1e-12)
        uv = world_uv(v, np.repeat(fn, 3, axis=0)) / np.array(period)
        kw = {}
        if colors is not None:
            kw["color_0"] = np.repeat(colors, 3, axis=0).astype(np.float32)
        # pyrender draws solid meshes sorted by the distance of the node origin to the
        # camera, ties in set order (memory addresses): give every mesh its own origin
        # (its centroid) so that the order, and coplanar decals, are deterministic
        origin = v.mean(0)
        v = v - origin
        prim = pyrender.Primitive(positions=v.astype(np.float32),
                                  normals=np.repeat(fn, 3, axis=0).astype(np.float32),
                                  texcoord_0=uv.astype(np.float32),
                                  indices=np.arange(len(v)).reshape(-1, 3), material=mat,
                                  **kw)
        pose = np.eye(4)
        pose[:3, 3] = origin
        node = self.scene.add(pyrender.Mesh([prim]), pose=pose)
        self._scene_nodes.append(node)

    def load_scene(self, layout: SceneLayout) -> None:
        spec = layout.spec
        if self._scene_id == spec.id:
            return
        # a fresh pyrender scene per scene (the GL context is kept: deleting an EGL context
        # terminates the display shared by every other context of the process)
        self.scene = pyrender.Scene(bg_color=[0.6, 0.7, 0.8, 1.0],
                                    ambient_light=[0.3, 0.3, 0.3])
        self.sun_node = self.scene.add(pyrender.DirectionalLight(color=np.ones(3),
                                                                 intensity=3.0))
        self.cam_node = None
        self._person_nodes = []
        self._scene_nodes = []
        mats = {name: self._material(m, k) for k, (name, m) in
                enumerate(sorted(spec.materials.items()))}
        gx, gy = spec.ground_size
        q = np.array([[-gx / 2, -gy / 2, 0], [gx / 2, -gy / 2, 0], [gx / 2, gy / 2, 0],
                      [-gx / 2, gy / 2, 0]])
        m, pu, pv = mats[spec.ground_material]
        self._add_mesh(q, [[0, 1, 2], [0, 2, 3]], m, (pu, pv))
        shell = room_shell(spec)
        if shell is not None:
            for (v, f), mname in zip(shell, (spec.shell.wall_material,
                                             spec.shell.ceiling_material)):
                m, pu, pv = mats[mname]
                self._add_mesh(v, f, m, (pu, pv))      # single-sided: cut away from outside
        for mname, (v, f, rand, sharp) in layout_meshes(layout).items():
            m, pu, pv = mats[mname]
            jit = _jitter_colors(spec.materials[mname], rand)
            self._add_mesh(v, f, m, (pu, pv), colors=jit)
        self._scene_id = spec.id
        self._indoor = spec.lighting.sun is None

    # ---------------------------------------------------------------- lighting

    def set_lighting(self, lighting) -> None:
        """Sun -> directional light with a shadow map; indoors the ceiling lights become one
        directional light from above (pyrender sums lights in set order, so several lights
        would not be bit-reproducible); sky -> ambient and background colour."""
        sun = self.sun_node.light
        if not math.isnan(lighting.sun_elevation) and lighting.sun_strength > 0:
            el, az = lighting.sun_elevation, lighting.sun_azimuth
            sun.color = np.asarray(lighting.sun_color)
            sun.intensity = lighting.sun_strength * 0.9
        elif lighting.area_strengths:
            el, az = math.radians(75.0), math.radians(30.0)
            w = np.asarray(lighting.area_strengths)
            sun.color = (np.asarray(lighting.area_colors) * w[:, None]).sum(0) / w.sum()
            sun.intensity = float(np.mean(w)) / 250.0
        else:
            el, az = math.pi / 2 - 0.1, 0.0
            sun.intensity = 0.0
        d = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
        x = np.cross([0.0, 0.0, 1.0], d)
        x /= np.linalg.norm(x)
        y = np.cross(d, x)
        pose = np.eye(4)
        pose[:3, 0], pose[:3, 1], pose[:3, 2] = x, y, d
        self.scene.set_pose(self.sun_node, pose)
        sky = np.asarray(lighting.sky_horizon) * 0.5 + np.asarray(lighting.sky_zenith) * 0.5
        if self._indoor:
            amb = np.full(3, 0.35) * (sun.intensity / 2.0 + 0.3)
        else:
            amb = sky * lighting.sky_strength * 0.35
        self.scene.ambient_light = np.clip(amb, 0, 2)
        self.scene.bg_color = np.append(_srgb(sky * max(lighting.sky_strength, 0.05)), 1.0)
        self._exposure = 2.0 ** lighting.exposure

    # ---------------------------------------------------------------- persons

    def set_persons(self, persons) -> None:
        for node in self._person_nodes:
            self.scene.remove_node(node)
        self._person_nodes = []
        if len(persons) > self.n_slots:
            raise ValueError(f"{len(persons)} persons but only {self.n_slots} slots")
        for mesh, person, xy, rot in persons:
            self._person_nodes.append(self.scene.add(self._person_mesh(mesh, person),
                                                     pose=_pose(xy, rot)))

    def _person_mesh(self, mesh: PersonMesh, person: PersonSpec):
        acc = dict(person.accessories)
        colors = {"skin": person.skin, "top": person.top.color,
                  "bottom": (person.top.color if person.top.kind == "dress"
                             else person.bottom.color),
                  "shoes": person.shoes, "eyes": tuple(0.25 * c for c in person.skin),
                  "hair": person.hair.color, "acc1": acc.get("backpack", (0.1, 0.1, 0.1)),
                  "acc2": acc.get("shoulder_bag", acc.get("handbag", (0.1, 0.1, 0.1))),
                  "cap": acc.get("cap", (0.1, 0.1, 0.1))}
        if person.top.pattern != "flat":     # no textures on persons: blend the 2 colours
            colors["top"] = tuple(0.65 * np.asarray(person.top.color)
                                  + 0.35 * np.asarray(person.top.color2))
        prims = []

        def add(v, f, slot):
            if len(f) == 0:
                return
            tm = trimesh.Trimesh(v, f, process=False)
            mat = pyrender.MetallicRoughnessMaterial(
                baseColorFactor=np.append(colors[MATERIAL_SLOTS[slot]], 1.0),
                metallicFactor=0.0, roughnessFactor=0.7, doubleSided=False)
            prims.append(pyrender.Primitive(
                positions=tm.vertices.astype(np.float32),
                normals=tm.vertex_normals.astype(np.float32),
                indices=np.asarray(f), material=mat))

        for slot in np.unique(mesh.face_material):
            add(mesh.vertices, mesh.faces[mesh.face_material == slot], int(slot))
        if mesh.hair_visible:
            add(mesh.hair_vertices, mesh.hair_faces, MATERIAL_SLOTS.index("hair"))
        for v, f, slot, vis in mesh.parts.values():
            if vis:
                add(v, f, slot)
        return pyrender.Mesh(prims)

    # ---------------------------------------------------------------- camera & render

    def set_camera(self, K, R, t, width: int, height: int, supersample: int = 1) -> None:
        s = max(int(supersample), self.supersample)
        A = np.array([[s, 0, (s - 1) / 2.0], [0, s, (s - 1) / 2.0], [0, 0, 1.0]])
        Kh = A @ np.asarray(K, dtype=np.float64)
        # pyrender's principal point is in pixel-edge coordinates (image spans [0, W])
        cam = pyrender.IntrinsicsCamera(fx=Kh[0, 0], fy=Kh[1, 1], cx=Kh[0, 2] + 0.5,
                                        cy=Kh[1, 2] + 0.5, znear=0.05, zfar=2000.0)
        pose = np.eye(4)
        R = np.asarray(R, dtype=np.float64)
        pose[:3, :3] = R.T @ np.diag([1.0, -1.0, -1.0])
        pose[:3, 3] = -R.T @ np.asarray(t, dtype=np.float64)
        if self.cam_node is not None:
            self.scene.remove_node(self.cam_node)
        self.cam_node = self.scene.add(cam, pose=pose)
        self._size = (width, height, s)

    def _renderer(self, w, h):
        # one GL context for every size (scene objects bind to a single context)
        r = self._renderers.get("gl")
        if r is None:
            r = self._renderers["gl"] = pyrender.OffscreenRenderer(w, h)
        if (r.viewport_width, r.viewport_height) != (w, h):
            r.viewport_width, r.viewport_height = w, h
        return r

    def render(self, path, *, samples: int = 1, seed: int = 0,
               transparent: bool = False) -> None:
        import cv2

        w, h, s = self._size
        flags = pyrender.RenderFlags.NONE
        if self.shadows and self.sun_node.light.intensity > 0:
            flags |= pyrender.RenderFlags.SHADOWS_DIRECTIONAL
        if transparent:
            flags |= pyrender.RenderFlags.RGBA
        color, _ = self._renderer(w * s, h * s).render(self.scene, flags=flags)
        img = color.astype(np.float32)
        if not transparent:
            img = np.clip(img * getattr(self, "_exposure", 1.0), 0, 255)
        if s > 1:
            img = cv2.resize(img, (w, h), interpolation=cv2.INTER_AREA)
        img = np.round(img).astype(np.uint8)
        code = cv2.COLOR_RGBA2BGRA if transparent else cv2.COLOR_RGB2BGR
        ok, buf = cv2.imencode(".png", cv2.cvtColor(img, code))
        if not ok:  # pragma: no cover
            raise RuntimeError(f"could not encode {path}")
        atomic_write_bytes(Path(path), buf.tobytes())

    def close(self) -> None:
        """Release the GL context (do this once, at the end of the process)."""
        for r in self._renderers.values():
            r.delete()
        self._renderers = {}


def _pose(xy, rot):
    c, s = math.cos(rot), math.sin(rot)
    return np.array([[c, -s, 0, xy[0]], [s, c, 0, xy[1]], [0, 0, 1, 0], [0, 0, 0, 1.0]])
