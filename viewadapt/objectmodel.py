"""Object models: how a person's pixels move between two views.

Wang et al. (2017) model a person as a vertical plane, so two views are related by a
homography. Their conclusion proposes "more complex 3D models"; this module offers one next
to the plane, usable with no target data and no renderer at run time:

* :class:`PlaneModel` -- the paper's person plane (the map between views is a homography).
* :class:`SurfaceOfRevolution` -- a mean body: a surface of revolution ``r(z)`` about the
  person's vertical axis (:meth:`SurfaceOfRevolution.mean_body` reads the profile measured on
  anny's neutral adult by ``python -m generator.meanbody``). A surface of revolution looks
  the same from every azimuth, so it needs no estimate of the person's orientation.

:func:`view_mapping` turns a model, two cameras and the person's ground positions into the
point mapping ``source pixels -> target pixels`` that :mod:`viewadapt.mapping` builds ``G``
from: each source pixel's ray meets the model (the body surface; off the body, the person
plane behind it), the point moves with the person to the target placement, and is
projected; points the model hides in the target view are undefined.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .geometry import (
    PERSON_HEIGHT_M, Camera, crop_camera, crop_homography, elevation_homography,
    window_to_image_homography,
)
from .mapping import GridMapping, homography_mapping
from .surface import hidden_by, project_with_depth, surface_depth

__all__ = ["PlaneModel", "SurfaceOfRevolution", "OBJECT_MODELS", "object_model",
           "view_mapping", "crop_view_mapping", "correspondence_mapping"]


@dataclass(frozen=True)
class PlaneModel:
    """The paper's planar person: the vertical plane through the ground position, facing the
    camera."""

    name: str = "plane"


@dataclass(frozen=True)
class SurfaceOfRevolution:
    """A person as a surface of revolution about the vertical axis through its ground point.

    Parameters
    ----------
    height_fraction, radius_fraction : sequences of float
        The profile: radius at each height, both as fractions of the person's height;
        heights increasing from near 0 to 1 (the crown, where the radius should be 0).
    name : str
    """

    height_fraction: tuple
    radius_fraction: tuple
    name: str = "body"

    def __post_init__(self):
        z = np.asarray(self.height_fraction, dtype=np.float64)
        r = np.asarray(self.radius_fraction, dtype=np.float64)
        if z.ndim != 1 or z.shape != r.shape or len(z) < 2:
            raise ValueError("the profile needs matching 1-D height and radius lists (>= 2)")
        if not (np.isfinite(z).all() and np.isfinite(r).all()) or (r < 0).any() or \
                np.any(np.diff(z) <= 0) or z[0] < 0 or z[-1] > 1:
            raise ValueError("the profile needs increasing heights in [0, 1] and radii >= 0")
        object.__setattr__(self, "height_fraction", tuple(float(v) for v in z))
        object.__setattr__(self, "radius_fraction", tuple(float(v) for v in r))

    @classmethod
    def mean_body(cls) -> "SurfaceOfRevolution":
        """The shipped mean-body profile (``viewadapt/data/mean_body.json``)."""
        from .io.packaged import read_packaged_json   # here: viewadapt.io sits above

        doc = read_packaged_json("mean_body.json")
        return cls(tuple(doc["height_fraction"]), tuple(doc["radius_fraction"]), "body")

    def mesh(self, person_height: float = PERSON_HEIGHT_M, segments: int = 48):
        """(V, 3) vertices and (F, 3) faces, person-local (axis at the origin, feet at 0)."""
        z = np.asarray(self.height_fraction) * person_height
        r = np.asarray(self.radius_fraction) * person_height
        phi = np.arange(segments) * 2 * np.pi / segments
        ring = np.stack([np.cos(phi), np.sin(phi)], -1)
        V = np.concatenate([np.column_stack([r[k] * ring, np.full(segments, z[k])])
                            for k in range(len(z))])
        faces = []
        for k in range(len(z) - 1):
            a = k * segments + np.arange(segments)
            b = k * segments + (np.arange(segments) + 1) % segments
            faces += [np.stack([a, b, b + segments], -1), np.stack([a, b + segments,
                                                                    a + segments], -1)]
        return V, np.concatenate(faces).astype(np.int64)


#: the models by name, as the command line takes them
OBJECT_MODELS = ("plane", "body")


def object_model(name: str):
    """A model by name: ``"plane"`` or ``"body"`` (the shipped mean body)."""
    if name == "plane":
        return PlaneModel()
    if name == "body":
        return SurfaceOfRevolution.mean_body()
    raise ValueError(f"object model must be one of {OBJECT_MODELS}, got {name!r}")


def _azimuth(v):
    return float(np.arctan2(v[1], v[0]))


def _placement(source_camera, target_camera, source_ground, target_ground):
    """World -> world rigid motion taking the person from its source to its target place,
    turned so that it shows the target camera the side it showed the source camera."""
    Ps = np.array([source_ground[0], source_ground[1], 0.0])
    Pt = np.array([target_ground[0], target_ground[1], 0.0])
    a = _azimuth(target_camera.center - Pt) - _azimuth(source_camera.center - Ps)
    c, s = np.cos(a), np.sin(a)
    Rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return lambda X: (X - Ps) @ Rz.T + Pt


def view_mapping(model, source_camera: Camera, target_camera: Camera, *,
                 source_ground=(0.0, 0.0), target_ground=(0.0, 0.0),
                 person_height: float = PERSON_HEIGHT_M, window=(64, 128), step: float = 0.5,
                 source_H=None, target_H=None, tolerance: float = 0.03):
    """The mapping ``source-window pixels -> target pixels`` of a person under ``model``.

    Parameters
    ----------
    model : PlaneModel or SurfaceOfRevolution
    source_camera, target_camera : Camera
        Cameras of the source window's image and the target image.
    source_ground, target_ground : (2,) array_like
        The person's ground position in each view's world.
    person_height : float
        The model's height, metres.
    window : (width, height)
        The source window's size (pixels); its pixels are those of ``source_camera``.
    step : float
        Sample spacing of the returned :class:`~viewadapt.mapping.GridMapping` (surface
        models), pixels.
    source_H, target_H : (3, 3) array_like, optional
        Plane model only: window -> image homographies of the person plane, when they are
        not ``window_to_image_homography(camera, ground, person_height)``; its mapping is
        ``target_H @ inv(source_H)``.
    tolerance : float
        Metres by which the model must be in front of a point to hide it in the target view.

    Returns
    -------
    A callable mapping: a homography mapping for the plane, else a ``GridMapping`` that is
    NaN where the model hides the point in the target view or the window leaves the grid.
    """
    if isinstance(model, PlaneModel):
        Hs = (window_to_image_homography(source_camera, source_ground, person_height)
              if source_H is None else np.asarray(source_H, float))
        Ht = (window_to_image_homography(target_camera, target_ground, person_height)
              if target_H is None else np.asarray(target_H, float))
        return homography_mapping(Ht @ np.linalg.inv(Hs))
    if not isinstance(model, SurfaceOfRevolution):
        raise TypeError(f"unknown object model {model!r}")
    w, h = window
    # samples cover the window's outer edge [-0.5, w - 0.5] x [-0.5, h - 0.5]
    nx, ny = int(round(w / step)) + 1, int(round(h / step)) + 1
    origin = (-0.5, -0.5)
    V, F = model.mesh(person_height)
    Ps = np.array([source_ground[0], source_ground[1], 0.0])
    depth = surface_depth(V + Ps, F, source_camera, (ny, nx), origin=origin, step=step)
    ys, xs = np.mgrid[0:ny, 0:nx].astype(np.float64)
    pix = np.stack([origin[0] + xs * step, origin[1] + ys * step, np.ones_like(xs)], -1)
    rays = pix @ np.linalg.inv(source_camera.K).T @ source_camera.R   # world directions
    C = source_camera.center
    # off the body: the person plane (vertical, through the ground point, facing the camera)
    g = Ps - C
    g[2] = 0.0
    g /= np.linalg.norm(g)
    lam_plane = (g @ (Ps - C)) / (rays @ g)              # rays have camera z = 1
    lam = np.where(np.isfinite(depth), depth, lam_plane)
    X = C + rays * lam[..., None]
    move = _placement(source_camera, target_camera, source_ground, target_ground)
    Xt = move(X)
    uv, zt = project_with_depth(Xt, target_camera)
    # hidden in the target view: the model's depth there is nearer by more than tolerance
    Pt = np.array([target_ground[0], target_ground[1], 0.0])
    sz = target_camera.image_size or (int(np.nanmax(uv[..., 0])) + 2,
                                      int(np.nanmax(uv[..., 1])) + 2)
    dt = surface_depth(V + Pt, F, target_camera, (sz[1], sz[0]))
    hidden, _ = hidden_by(dt, uv, zt, tolerance)
    uv[hidden] = np.nan
    return GridMapping(uv, origin, step)


def _framed_camera(elevation, distance, person_height, framing) -> Camera:
    """The crop camera at ``elevation``, its intrinsics reframed as ``framing`` frames it."""
    cam = crop_camera(elevation, distance=distance, person_height=person_height)
    if framing == "plane":
        return cam
    kw = dict(distance=distance, person_height=person_height)
    N = crop_homography(elevation, framing=framing, **kw) @ np.linalg.inv(
        crop_homography(elevation, **kw))
    return Camera(N @ cam.K, cam.R, cam.t, cam.image_size)


def crop_view_mapping(model, source_elevation: float, target_elevation: float, *,
                      distance: float = 10.0, person_height: float = PERSON_HEIGHT_M,
                      framing: str = "plane", step: float = 0.5):
    """:func:`view_mapping` for the dataset's crops: source-elevation crop pixels ->
    target-elevation crop pixels (the person at the origin, both cameras on one azimuth).
    For the plane model this is :func:`viewadapt.geometry.elevation_homography`'s map."""
    if isinstance(model, PlaneModel):
        return homography_mapping(elevation_homography(
            source_elevation, target_elevation, distance=distance,
            person_height=person_height, framing=framing))
    cs = _framed_camera(source_elevation, distance, person_height, framing)
    ct = _framed_camera(target_elevation, distance, person_height, framing)
    return view_mapping(model, cs, ct, person_height=person_height, step=step)


def correspondence_mapping(depth_source, camera_source: Camera, depth_target,
                           camera_target: Camera, *, fallback=None, tolerance: float = 0.05):
    """The exact mapping of one rendered instance: source pixels -> target pixels.

    Built from the two views' depth maps (:func:`viewadapt.surface.view_correspondence`):
    body pixels visible in the target view go where their surface point projects; body
    pixels hidden there are undefined (NaN); pixels off the body, and a one-pixel ring
    around the image (so that the grid covers the pixels' outer edges), follow
    ``fallback`` (a homography, e.g. the instance's person plane), or are undefined.

    Returns
    -------
    GridMapping on the pixel grid padded by one sample, origin ``(-1, -1)``, step 1.
    """
    from .surface import view_correspondence

    ds = np.asarray(depth_source, dtype=np.float64)
    uv, visible = view_correspondence(ds, camera_source, depth_target, camera_target,
                                      tolerance=tolerance)
    h, w = ds.shape
    ys, xs = np.mgrid[-1:h + 1, -1:w + 1].astype(np.float64)
    pts = np.stack([xs, ys], -1)
    out = np.full((h + 2, w + 2, 2), np.nan)
    if fallback is not None:
        fb = fallback if callable(fallback) else homography_mapping(fallback)
        out[:] = fb(pts)
    inner = out[1:-1, 1:-1]
    on_body = np.isfinite(ds)
    inner[on_body] = np.nan
    inner[visible] = uv[visible]
    return GridMapping(out, (-1.0, -1.0), 1.0)
