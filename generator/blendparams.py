"""What the Cycles renderer sets, computed in plain Python and numpy (no Blender here).

:mod:`generator.blender` (the one module that talks to Blender) applies these values: the
scene and Cycles settings, a camera's Blender parameters, the sun's orientation, the static
meshes of a scene with their materials, the arrays a Blender mesh is filled from, a person's
pose and the colours and garment patterns of its material slots. Keeping them here leaves
the Blender module to Blender calls, and lets them be checked without Blender.

Cameras: an OpenCV camera (``x`` right, ``y`` down, ``z`` forward, ``x ~ K (R X + t)``) becomes
a Blender camera (looking down ``-Z``, ``+Y`` up) with world rotation
``R^T diag(1, -1, -1)``, horizontal sensor fit, ``lens = f_x * sensor_width / W`` and shifts
``shift_x = ((W - 1) / 2 - c_x) / W``, ``shift_y = (c_y - (H - 1) / 2) / W`` (pixel centres at
integer coordinates; Blender shifts are fractions of the fitted sensor side). A test renders
an emissive sphere and checks its centroid against ``Camera.project`` (< 0.5 px).
"""

from __future__ import annotations

import math

import numpy as np

from .layout import SceneLayout
from .meshes import layout_meshes, quad_triangles, room_shell, world_uv
from .specs import MaterialSpec, PersonSpec

__all__ = ["GARMENT_PATTERNS", "OUTSIDE_MATERIAL", "camera_to_blender", "garment_params",
           "mesh_arrays", "pattern_texture", "person_pose", "person_roughness", "scene_parts",
           "scene_settings", "slot_colors", "sun_matrix"]

#: The garment pattern textures a top/bottom material mixes, in node-creation order.
GARMENT_PATTERNS = ("stripes", "checker", "noise", "dots")

#: Neutral ground around an indoor room, so that nothing looks into the void.
OUTSIDE_MATERIAL = MaterialSpec("outside", "noise", ((0.18, 0.18, 0.17), (0.12, 0.12, 0.12)),
                                scale=0.5, roughness=0.9)

_PERSON_ROUGHNESS = {"skin": 0.5, "eyes": 0.2, "hair": 0.45, "shoes": 0.35}


def scene_settings(*, threads: int, light_tree: bool, fast_gi: bool, max_bounces: int,
                   denoise: bool) -> list[tuple[str, object]]:
    """Scene settings, in the order they are set: ``(attribute path below the scene, value)``
    (e.g. ``("cycles.max_bounces", 4)``)."""
    out = [
        ("render.engine", "CYCLES"),
        ("cycles.device", "CPU"),
        ("cycles.use_adaptive_sampling", False),
        ("cycles.use_light_tree", light_tree),
        ("cycles.use_fast_gi", fast_gi),
        ("cycles.fast_gi_method", "REPLACE"),
        ("cycles.max_bounces", max_bounces),
        ("cycles.diffuse_bounces", min(2, max_bounces)),
        ("cycles.glossy_bounces", min(2, max_bounces)),
        ("cycles.transmission_bounces", 0),
        ("cycles.volume_bounces", 0),
        ("cycles.transparent_max_bounces", 12),
        ("cycles.caustics_reflective", False),
        ("cycles.caustics_refractive", False),
        ("cycles.blur_glossy", 1.0),
        ("cycles.use_denoising", denoise),
        ("cycles.denoiser", "OPENIMAGEDENOISE"),
        ("cycles.denoising_input_passes", "RGB_ALBEDO_NORMAL"),
        ("cycles.denoising_prefilter", "FAST"),
        ("cycles.use_animated_seed", False),
        ("cycles.seed", 0),
        ("render.threads_mode", "FIXED" if threads else "AUTO"),
    ]
    if threads:
        out.append(("render.threads", threads))
    out += [
        ("render.use_persistent_data", False),
        ("render.film_transparent", False),
        ("render.resolution_percentage", 100),
        ("render.image_settings.file_format", "PNG"),
        ("render.image_settings.color_mode", "RGB"),
        ("render.image_settings.color_depth", "8"),
        ("render.image_settings.compression", 15),
        ("render.use_file_extension", False),
        ("view_settings.view_transform", "Standard"),
        ("view_settings.look", "None"),
        ("display_settings.display_device", "sRGB"),
    ]
    return out


def camera_to_blender(K, R, t, width: int, height: int, sensor_width: float = 36.0):
    """Blender camera parameters of an OpenCV camera (see the module docstring).

    Returns
    -------
    dict with ``matrix_world`` (4, 4), ``lens``, ``sensor_width``, ``shift_x``, ``shift_y``,
    ``pixel_aspect`` (``f_y / f_x``).
    """
    K = np.asarray(K, dtype=np.float64)
    R = np.asarray(R, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)
    M = np.eye(4)
    M[:3, :3] = R.T @ np.diag([1.0, -1.0, -1.0])
    M[:3, 3] = -R.T @ t
    return {"matrix_world": M, "lens": K[0, 0] * sensor_width / width,
            "sensor_width": sensor_width,
            "shift_x": ((width - 1) / 2.0 - K[0, 2]) / width,
            "shift_y": (K[1, 2] - (height - 1) / 2.0) / width,
            "pixel_aspect": K[1, 1] / K[0, 0]}


def pattern_texture(spec: MaterialSpec) -> dict | None:
    """The texture node of a scene material's pattern (None for ``flat``).

    Returns
    -------
    dict with ``node`` (the node type), ``props`` (node properties) and ``inputs`` (input
    socket default values), each in the order they are set. The texture reads world-metre
    UVs; ``spec.scale`` is the pattern's period in metres.
    """
    c, s, p = spec.colors, spec.scale, spec.pattern
    if p == "flat":
        return None
    if p in ("brick", "tiles"):
        return {"node": "ShaderNodeTexBrick", "props": {"offset": 0.5 if p == "brick" else 0.0},
                "inputs": {"Scale": 1.0, "Brick Width": s,
                           "Row Height": s * (0.5 if p == "brick" else 1.0),
                           "Mortar Size": 0.012 * max(1.0, s / 0.5),
                           "Color1": (*c[0], 1), "Color2": (*c[1 % len(c)], 1),
                           "Mortar": (*c[-1], 1)}}
    if p == "checker":
        return {"node": "ShaderNodeTexChecker", "props": {},
                "inputs": {"Scale": 1.0 / s, "Color1": (*c[0], 1), "Color2": (*c[1], 1)}}
    if p == "noise":
        return {"node": "ShaderNodeTexNoise", "props": {},
                "inputs": {"Scale": 1.0 / s, "Detail": 6.0}}
    if p == "voronoi":
        return {"node": "ShaderNodeTexVoronoi", "props": {}, "inputs": {"Scale": 1.0 / s}}
    if p in ("wave", "stripes"):
        # Blender's wave period is 1/(scale) in texture units times 1 (bands along X)
        return {"node": "ShaderNodeTexWave", "props": {"wave_type": "BANDS",
                                                       "bands_direction": "X"},
                "inputs": {"Scale": 1.0 / s, "Distortion": 3.0 if p == "wave" else 0.0,
                           "Detail": 2.0 if p == "wave" else 0.0}}
    raise ValueError(p)  # pragma: no cover - validated in specs


def sun_matrix(elevation: float, azimuth: float) -> np.ndarray:
    """World matrix (4, 4) of a sun lamp (it shines down its ``-Z``) at ``elevation`` and
    ``azimuth`` (radians): its ``+Z`` points towards the sun."""
    el, az = elevation, azimuth
    z = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
    x = np.cross([0.0, 0.0, 1.0], z)
    x = x / np.linalg.norm(x) if np.linalg.norm(x) > 1e-9 else np.array([1.0, 0, 0])
    y = np.cross(z, x)
    M = np.eye(4)
    M[:3, 0], M[:3, 1], M[:3, 2] = x, y, z
    return M


def person_pose(xy, rotation: float) -> np.ndarray:
    """World matrix (4, 4) of a person standing at ground point ``xy``, turned by
    ``rotation`` (radians) about the vertical."""
    c, s = math.cos(rotation), math.sin(rotation)
    return np.array([[c, -s, 0, xy[0]], [s, c, 0, xy[1]], [0, 0, 1, 0], [0, 0, 0, 1.0]])


def scene_parts(layout: SceneLayout) -> list[tuple]:
    """The static meshes of a scene, in creation order.

    Returns
    -------
    list of ``(object name, mesh name, vertices, triangles, material, face_rand, sharp)``;
    ``material`` is a name in the scene spec's materials, or ``"__outside"``
    (:data:`OUTSIDE_MATERIAL`, the ground around a room); ``face_rand`` / ``sharp`` are the
    per-face attributes of the objects' meshes (None for ground, shell and outside).
    """
    spec = layout.spec
    gx, gy = spec.ground_size
    q = np.array([[-gx / 2, -gy / 2, 0], [gx / 2, -gy / 2, 0], [gx / 2, gy / 2, 0],
                  [-gx / 2, gy / 2, 0]])
    v, f = quad_triangles(q)
    parts = [("ground", "ground", v, f, spec.ground_material, None, None)]
    shell = room_shell(spec)
    if shell is not None:
        (wv, wf), (cv, cf) = shell
        parts.append(("walls", "walls", wv, wf, spec.shell.wall_material, None, None))
        parts.append(("ceiling", "ceiling", cv, cf, spec.shell.ceiling_material, None, None))
        out = np.array([[-150, -150, -0.02], [150, -150, -0.02], [150, 150, -0.02],
                        [-150, 150, -0.02]])
        v, f = quad_triangles(out)
        parts.append(("outside", "outside", v, f, "__outside", None, None))
    for mname, (v, f, rand, sharp) in layout_meshes(layout).items():
        parts.append((f"geo_{mname}", f"{spec.id}_{mname}", v, f, mname, rand, sharp))
    return parts


def mesh_arrays(verts, tris, *, face_rand=None, sharp=None, uv: bool = True) -> dict:
    """The flat arrays a Blender triangle mesh is filled from (``foreach_set``).

    Keys: ``co`` (float32, 3 per vertex), ``vertex_index`` (int32, 3 per triangle),
    ``loop_start`` (int32, 1 per triangle); with ``uv`` also ``uv`` (float32, 2 per corner:
    world-metre UVs, :func:`generator.meshes.world_uv`); ``prim_rand`` (float32) and
    ``sharp_face`` (bool) per triangle when given.
    """
    n_tris = len(tris)
    out = {"co": np.asarray(verts, dtype=np.float32).ravel(),
           "vertex_index": np.asarray(tris, dtype=np.int32).ravel(),
           "loop_start": np.arange(0, 3 * n_tris, 3, dtype=np.int32)}
    if uv:
        corners = np.asarray(verts)[np.asarray(tris).ravel()]
        tri_v = np.asarray(verts)[np.asarray(tris)]
        fn = np.cross(tri_v[:, 1] - tri_v[:, 0], tri_v[:, 2] - tri_v[:, 0])
        out["uv"] = world_uv(corners, np.repeat(fn, 3, axis=0)).astype(np.float32).ravel()
    if face_rand is not None:
        out["prim_rand"] = np.asarray(face_rand, dtype=np.float32)
    if sharp is not None:
        out["sharp_face"] = np.asarray(sharp, dtype=bool)
    return out


def person_roughness(role: str) -> float:
    """Principled roughness of a person material slot."""
    return _PERSON_ROUGHNESS.get(role, 0.75)


def slot_colors(person: PersonSpec) -> dict:
    """Base colours (linear RGB) of a person's plain material slots (all but the garments)."""
    acc = dict(person.accessories)
    return {"skin": person.skin, "shoes": person.shoes,
            "eyes": tuple(0.25 * c for c in person.skin), "hair": person.hair.color,
            "acc1": acc.get("backpack", (0.1, 0.1, 0.1)),
            "acc2": acc.get("shoulder_bag", acc.get("handbag", (0.1, 0.1, 0.1))),
            "cap": acc.get("cap", (0.1, 0.1, 0.1))}


def garment_params(person: PersonSpec) -> dict:
    """The ``top`` and ``bottom`` garment materials: ``color``, ``color2``, ``scale`` (of the
    pattern, metres) and ``weights`` (1 for the garment's pattern in
    :data:`GARMENT_PATTERNS`, else 0). A dress is both top and bottom."""
    out = {}
    for name, g in (("top", person.top), ("bottom", person.bottom)):
        if name == "bottom" and person.top.kind == "dress":
            g = person.top
        out[name] = {"color": g.color, "color2": g.color2, "scale": g.pattern_scale,
                     "weights": {key: 1.0 if g.pattern == key else 0.0
                                 for key in GARMENT_PATTERNS}}
    return out
