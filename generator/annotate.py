"""Boxes and visibility from geometry (numpy + OpenCV, no Blender).

Coordinates follow :mod:`viewadapt.geometry`: pixel centres at integer coordinates, so an
image of width ``W`` spans ``[-0.5, W - 0.5]``. A box is ``[x, y, w, h]`` in those continuous
coordinates (``x, y`` the top-left corner), the same frame as ``H_window_to_image``.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from viewadapt.geometry import Camera

from .layout import SceneLayout, ray_cast

__all__ = ["person_to_world", "silhouette_box", "fit_silhouette_intrinsics", "person_mask",
           "mask_box", "frame_annotations"]

_SHIFT = 4   # sub-pixel bits for cv2.fillPoly


def person_to_world(points, ground_xy, rotation: float) -> np.ndarray:
    """Person-local points (..., 3) -> world, given the ground position and yaw."""
    c, s = math.cos(rotation), math.sin(rotation)
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return np.asarray(points) @ R.T + np.array([ground_xy[0], ground_xy[1], 0.0])


def silhouette_box(points_world, camera: Camera, width: int, height: int):
    """Box of the projected points clipped to the image; ``None`` if it misses the image.

    Parameters
    ----------
    points_world : (N, 3) array_like
    camera : Camera
    width, height : int

    Returns
    -------
    [x, y, w, h] list of float, or None.
    """
    uv = camera.project(points_world)
    x0, y0 = uv.min(0)
    x1, y1 = uv.max(0)
    x0, x1 = max(x0, -0.5), min(x1, width - 0.5)
    y0, y1 = max(y0, -0.5), min(y1, height - 0.5)
    if x1 <= x0 or y1 <= y0:
        return None
    return [float(x0), float(y0), float(x1 - x0), float(y1 - y0)]


def fit_silhouette_intrinsics(camera: Camera, points_world, width: int = 64,
                              height: int = 128, person_px: float = 96.0) -> np.ndarray:
    """Intrinsics that frame the projected silhouette INRIA-style (for ``framing="silhouette"``).

    The silhouette's height becomes ``person_px`` and its box centre the window centre;
    returns the new (3, 3) ``K`` (the rotation and centre are unchanged).
    """
    uv = camera.project(points_world)
    (x0, y0), (x1, y1) = uv.min(0), uv.max(0)
    s = person_px / max(y1 - y0, 1e-6)
    cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
    A = np.array([[s, 0, (width - 1) / 2.0 - s * cx], [0, s, (height - 1) / 2.0 - s * cy],
                  [0, 0, 1.0]])
    return A @ camera.K


def person_mask(triangles_world, camera: Camera, width: int, height: int,
                pad: int = 0) -> np.ndarray:
    """Binary mask of projected triangles, on a canvas padded by ``pad`` pixels each side.

    Triangles behind the camera are dropped (persons in frames are in front of it).
    """
    tri = np.asarray(triangles_world, dtype=np.float64).reshape(-1, 3)
    cam = tri @ camera.R.T + camera.t
    front = (cam[:, 2] > 1e-3).reshape(-1, 3).all(1)
    tri = tri.reshape(-1, 3, 3)[front].reshape(-1, 3)
    mask = np.zeros((height + 2 * pad, width + 2 * pad), np.uint8)
    if len(tri) == 0:
        return mask.astype(bool)
    uv = camera.project(tri) + pad
    pts = np.round(uv * (1 << _SHIFT)).astype(np.int64)
    lim = (1 << 30)
    pts = np.clip(pts, -lim, lim).astype(np.int32).reshape(-1, 3, 2)
    cv2.fillPoly(mask, list(pts), 1, lineType=cv2.LINE_8, shift=_SHIFT)
    return mask.astype(bool)


def mask_box(mask: np.ndarray, offset: float = 0.0):
    """[x, y, w, h] of a mask's pixels (pixel-centre convention), or None if empty."""
    ys, xs = np.nonzero(mask)
    if len(xs) == 0:
        return None
    return [float(xs.min() - 0.5 - offset), float(ys.min() - 0.5 - offset),
            float(xs.max() - xs.min() + 1), float(ys.max() - ys.min() + 1)]


def frame_annotations(camera: Camera, width: int, height: int, persons, layout: SceneLayout,
                      *, pad: int = 64, depth_tolerance: float = 0.35) -> list[dict]:
    """Full and visible boxes and occlusion of each person in a frame.

    Parameters
    ----------
    persons : list of (triangles_world (T, 3, 3), points_world (N, 3), ground_xy)
    layout : SceneLayout
        Occluding primitives are ray cast per pixel.

    Returns
    -------
    list of dict per person: ``bbox`` (full extent, unclipped), ``bbox_visible`` (or None),
    ``occlusion`` (fraction of the silhouette hidden by objects or closer persons, counting
    only pixels inside the image), ``truncation`` (fraction outside the image), ``area``,
    ``area_visible`` (pixels).

    Notes
    -----
    Person depth per pixel is approximated by the depth of the person's vertical axis; a
    scene surface closer than that by more than ``depth_tolerance`` metres hides the pixel.
    """
    C = camera.center
    Kinv = np.linalg.inv(camera.K)
    depth = []
    masks = []
    for tris, pts, xy in persons:
        g = np.array([xy[0], xy[1], 0.9])
        depth.append(float((camera.R @ g + camera.t)[2]))
        masks.append(person_mask(tris, camera, width, height, pad=pad))
    order = np.argsort(depth)                # near to far
    taken = np.zeros((height, width), bool)
    results: list[dict | None] = [None] * len(persons)
    for i in order:
        tris, pts, xy = persons[i]
        full = masks[i]
        inner = full[pad:pad + height, pad:pad + width]
        area = int(full.sum())
        vis = inner & ~taken
        ys, xs = np.nonzero(vis)
        if len(xs):
            rays = np.stack([xs, ys, np.ones_like(xs)], 1).astype(np.float64) @ Kinv.T
            d_world = rays @ camera.R                # camera -> world directions
            t_hit = ray_cast(layout, C[None], d_world)
            # distance along each ray to the person's vertical axis plane
            axis = np.array([xy[0], xy[1], 0.0])
            n = axis - C
            n[2] = 0.0
            n /= max(np.linalg.norm(n), 1e-9)
            t_person = ((axis - C) @ n) / np.maximum(d_world @ n, 1e-9)
            scale = np.linalg.norm(d_world, axis=1)
            hidden = t_hit < t_person - depth_tolerance / scale
            vis[ys[hidden], xs[hidden]] = False
        taken |= inner
        uv = camera.project(pts)
        (x0, y0), (x1, y1) = uv.min(0), uv.max(0)
        a_vis = int(vis.sum())
        results[i] = {
            "bbox": [float(x0), float(y0), float(x1 - x0), float(y1 - y0)],
            "bbox_visible": mask_box(vis),
            "occlusion": float(1.0 - a_vis / int(inner.sum())) if inner.sum() else 1.0,
            "truncation": float(1.0 - inner.sum() / area) if area else 1.0,
            "area": area, "area_visible": a_vis,
        }
    return results
