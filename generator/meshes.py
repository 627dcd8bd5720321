"""Scene geometry as numpy triangles (shared by the Blender and pyrender back-ends).

Primitives are unit meshes scaled, rotated by their yaw and moved to their centre; meshes
are grouped by material (one draw/object per material). UVs are world metres from a box
projection by the face normal, so procedural textures have the same scale everywhere.
"""

from __future__ import annotations

import math

import numpy as np

from .body import box_mesh, sphere_mesh
from .layout import SceneLayout

__all__ = ["primitive_triangles", "layout_meshes", "world_uv", "quad_triangles",
           "room_shell"]


def primitive_triangles(shape: str, n_seg: int = 16):
    """Unit primitive in [-0.5, 0.5]^3: (V, 3) vertices, (T, 3) triangles, smooth flag."""
    if shape == "box":
        v, f = box_mesh()
        return v, f, False
    if shape == "sphere":
        v, f = sphere_mesh(16, 10)
        return v * 0.5, f, True
    ang = np.linspace(0, 2 * np.pi, n_seg, endpoint=False)
    ring = np.stack([0.5 * np.cos(ang), 0.5 * np.sin(ang)], 1)
    if shape == "cylinder":
        bot = np.column_stack([ring, np.full(n_seg, -0.5)])
        top = np.column_stack([ring, np.full(n_seg, 0.5)])
        v = np.vstack([bot, top, [[0, 0, -0.5], [0, 0, 0.5]]])
        f = []
        for j in range(n_seg):
            k = (j + 1) % n_seg
            f += [(j, k, n_seg + k), (j, n_seg + k, n_seg + j)]
            f += [(2 * n_seg, k, j), (2 * n_seg + 1, n_seg + j, n_seg + k)]
        return v, np.array(f, dtype=np.int32), True
    if shape == "cone":
        bot = np.column_stack([ring, np.full(n_seg, -0.5)])
        v = np.vstack([bot, [[0, 0, 0.5], [0, 0, -0.5]]])
        f = []
        for j in range(n_seg):
            k = (j + 1) % n_seg
            f += [(j, k, n_seg), (n_seg + 1, k, j)]
        return v, np.array(f, dtype=np.int32), True
    raise ValueError(shape)


_UNIT = {s: primitive_triangles(s) for s in ("box", "sphere", "cylinder", "cone")}


def world_uv(corners, normals):
    """Per-corner UVs in metres from a box projection by the face normal."""
    ax = np.abs(normals).argmax(1)
    u = np.where(ax == 0, corners[:, 1], corners[:, 0])
    v = np.where(ax == 2, corners[:, 1], corners[:, 2])
    return np.stack([u, v], 1)


def layout_meshes(layout: SceneLayout):
    """Primitives grouped by material -> (verts, tris, face_rand, sharp) in world metres."""
    groups: dict[str, list] = {}
    for p in layout.primitives:
        v, f, smooth = _UNIT[p.shape]
        c, s = math.cos(p.yaw), math.sin(p.yaw)
        Rz = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
        wv = (v * np.asarray(p.size)) @ Rz.T + np.asarray(p.center)
        groups.setdefault(p.material, []).append((wv, f, p.rand, not smooth))
    out = {}
    for mat, items in groups.items():
        verts, tris, rand, sharp = [], [], [], []
        off = 0
        for wv, f, r, sh in items:
            verts.append(wv)
            tris.append(f + off)
            rand.append(np.full(len(f), r))
            sharp.append(np.full(len(f), sh))
            off += len(wv)
        out[mat] = (np.vstack(verts), np.vstack(tris), np.concatenate(rand),
                    np.concatenate(sharp))
    return out


def quad_triangles(corners, inward=False):
    f = np.array([[0, 1, 2], [0, 2, 3]])
    return corners, (f[:, ::-1] if inward else f)


# --------------------------------------------------------------------------- renderer




def room_shell(spec):
    """Walls and ceiling of an indoor scene, normals inwards: (walls, ceiling) each as
    (vertices, triangles), or None without a shell."""
    if spec.shell is None:
        return None
    sx, sy, sz = spec.shell.size
    cx, cy = spec.shell.center
    x0, x1, y0, y1 = cx - sx / 2, cx + sx / 2, cy - sy / 2, cy + sy / 2
    walls = [
        [[x0, y0, 0], [x1, y0, 0], [x1, y0, sz], [x0, y0, sz]],
        [[x1, y0, 0], [x1, y1, 0], [x1, y1, sz], [x1, y0, sz]],
        [[x1, y1, 0], [x0, y1, 0], [x0, y1, sz], [x1, y1, sz]],
        [[x0, y1, 0], [x0, y0, 0], [x0, y0, sz], [x0, y1, sz]],
    ]
    verts, tris = [], []
    for k, w in enumerate(walls):
        verts.append(np.array(w, dtype=float))
        tris.append(np.array([[0, 2, 1], [0, 3, 2]]) + 4 * k)
    ceil = np.array([[x0, y0, sz], [x1, y0, sz], [x1, y1, sz], [x0, y1, sz]], dtype=float)
    return ((np.vstack(verts), np.vstack(tris)), (ceil, np.array([[0, 2, 1], [0, 3, 2]])))
