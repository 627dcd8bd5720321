"""Depth maps of triangle meshes and the exact pixel correspondences between two views.

A *depth map* holds, per sample of a regular pixel grid, the camera-frame ``z`` of the
nearest surface along the sample's ray (NaN where the ray misses the mesh). From it and
the camera every sample's 3-D surface point follows (:func:`backproject`), and from two
views of the same surface, where each visible point of one lands in the other and whether
it is visible there (:func:`view_correspondence`). The generator stores a depth map beside
every person crop; :mod:`viewadapt.objectmodel` renders its mean-body surface the same way.

Sample ``(i, j)`` of a grid sits at pixel ``(x0 + j step, y0 + i step)`` (pixel centres at
integer coordinates, :mod:`viewadapt.geometry`); the default grid is the image's pixels.
"""

from __future__ import annotations

import numpy as np

from ._validation import check_finite
from .geometry import Camera

__all__ = ["surface_depth", "backproject", "view_correspondence", "project_with_depth",
           "hidden_by"]


def _check_grid(shape, origin, step):
    if len(shape) != 2 or int(shape[0]) != shape[0] or int(shape[1]) != shape[1] or \
            shape[0] < 1 or shape[1] < 1:
        raise ValueError(f"grid shape must be two positive integers (n_y, n_x), got {shape!r}")
    if not np.isfinite(step) or step <= 0:
        raise ValueError(f"step must be a positive number of pixels, got {step!r}")
    return (int(shape[0]), int(shape[1])), (float(origin[0]), float(origin[1])), float(step)


def surface_depth(vertices, faces, camera: Camera, shape, *, origin=(0.0, 0.0),
                  step: float = 1.0, near: float = 1e-3) -> np.ndarray:
    """Z-buffer of a triangle mesh seen by ``camera``, sampled on a regular pixel grid.

    Parameters
    ----------
    vertices : (V, 3) array_like
        World coordinates, metres.
    faces : (F, 3) int array_like
    camera : Camera
    shape : (n_y, n_x)
        Samples down and across (an image's ``(height, width)`` for its pixel grid).
    origin : (2,) array_like
        Pixel coordinates of sample ``(0, 0)``.
    step : float
        Sample spacing in pixels.
    near : float
        Triangles with a vertex closer than this (metres, camera ``z``) are skipped.

    Returns
    -------
    (n_y, n_x) float64 camera-frame depths, NaN where no triangle covers the sample.
    """
    from ._kernels import rasterize_depth

    (ny, nx), (x0, y0), step = _check_grid(shape, origin, step)
    V = check_finite(vertices, "vertices")
    F = np.asarray(faces)
    if V.ndim != 2 or V.shape[1] != 3:
        raise ValueError(f"vertices must have shape (V, 3), got {V.shape}")
    if F.ndim != 2 or F.shape[1] != 3 or not np.issubdtype(F.dtype, np.integer):
        raise ValueError(f"faces must be an integer array of shape (F, 3), got {F.shape} {F.dtype}")
    if F.size and (F.min() < 0 or F.max() >= len(V)):
        raise ValueError("faces index vertices that do not exist")
    cam = V @ camera.R.T + camera.t
    z = cam[:, 2]
    keep = (z[F] > near).all(axis=1)
    F = np.ascontiguousarray(F[keep], dtype=np.int64)
    uvw = cam @ camera.K.T
    with np.errstate(divide="ignore", invalid="ignore"):
        uv = np.ascontiguousarray(uvw[:, :2] / uvw[:, 2:3])
    out = np.full((ny, nx), np.inf)
    rasterize_depth(uv, np.ascontiguousarray(z), F, x0, y0, step, out)
    out[~np.isfinite(out)] = np.nan
    return out


def _rays(camera: Camera, shape, origin, step):
    ny, nx = shape
    ys, xs = np.mgrid[0:ny, 0:nx].astype(np.float64)
    pix = np.stack([origin[0] + xs * step, origin[1] + ys * step, np.ones_like(xs)], -1)
    return pix @ np.linalg.inv(camera.K).T            # camera-frame rays with z = 1


def backproject(depth, camera: Camera, *, origin=(0.0, 0.0), step: float = 1.0) -> np.ndarray:
    """World points of a depth map's samples: (n_y, n_x, 3), NaN where the depth is NaN."""
    d = np.asarray(depth, dtype=np.float64)
    if d.ndim != 2:
        raise ValueError(f"depth must be a 2-D map, got shape {d.shape}")
    shape, origin, step = _check_grid(d.shape, origin, step)
    if np.any(d[np.isfinite(d)] <= 0):
        raise ValueError("depth must be positive (camera z) where it is defined")
    Xc = _rays(camera, shape, origin, step) * d[..., None]
    return (Xc - camera.t) @ camera.R                  # R^T (x_cam - t), row-wise


def project_with_depth(points, camera: Camera) -> tuple[np.ndarray, np.ndarray]:
    """Pixels and camera depths of world points: ``((..., 2), (...,))``; NaN propagates,
    points at or behind the camera give NaN."""
    X = np.asarray(points, dtype=np.float64)
    cam = X @ camera.R.T + camera.t
    z = cam[..., 2]
    uvw = cam @ camera.K.T
    with np.errstate(divide="ignore", invalid="ignore"):
        uv = uvw[..., :2] / uvw[..., 2:3]
    bad = ~(z > 0)
    uv[bad] = np.nan
    return uv, np.where(bad, np.nan, z)


def view_correspondence(depth_source, camera_source: Camera, depth_target,
                        camera_target: Camera, *, tolerance: float = 0.05) -> tuple:
    """Where each surface pixel of the source view lands in the target view.

    Parameters
    ----------
    depth_source, depth_target : (h, w) and (h', w') array_like
        Depth maps of the same surface (same pose, same world frame) on each image's pixel
        grid, NaN off the surface.
    camera_source, camera_target : Camera
    tolerance : float
        A source point counts as visible in the target view unless the target's depth map,
        at the nearest pixel, has a surface closer than the point by more than this
        (metres). Points that land outside the target image are not visible.

    Returns
    -------
    target_xy : (h, w, 2) ndarray
        Target-view pixel of each source pixel's surface point (NaN off the surface).
    visible : (h, w) bool ndarray
        On the surface in the source view and visible in the target view.
    """
    ds = np.asarray(depth_source, dtype=np.float64)
    dt = np.asarray(depth_target, dtype=np.float64)
    if ds.ndim != 2 or dt.ndim != 2:
        raise ValueError(f"depth maps must be 2-D, got shapes {ds.shape} and {dt.shape}")
    if not np.isfinite(ds).any():
        raise ValueError("the source depth map is empty: no surface pixel to correspond")
    if not tolerance > 0:
        raise ValueError(f"tolerance must be positive metres, got {tolerance!r}")
    X = backproject(ds, camera_source)
    uv, z = project_with_depth(X, camera_target)
    hidden, inside = hidden_by(dt, uv, z, tolerance)
    return uv, inside & ~hidden


def hidden_by(depth, uv, z, tolerance: float):
    """Which points, at pixels ``uv`` and camera depths ``z`` of a view, a surface with
    depth map ``depth`` (that view's pixel grid) hides: its depth at the nearest pixel is
    nearer than the point by more than ``tolerance``. Returns ``(hidden, inside)`` bool
    arrays (``inside``: the point lands in the image)."""
    d = np.asarray(depth, dtype=np.float64)
    h, w = d.shape
    on = np.isfinite(uv).all(axis=-1)
    j = np.rint(np.where(on, uv[..., 0], -1)).astype(np.int64)
    i = np.rint(np.where(on, uv[..., 1], -1)).astype(np.int64)
    inside = on & (j >= 0) & (j < w) & (i >= 0) & (i < h)
    d_there = np.full(on.shape, np.nan)
    d_there[inside] = d[i[inside], j[inside]]
    return np.isfinite(d_there) & (d_there < z - tolerance), inside
