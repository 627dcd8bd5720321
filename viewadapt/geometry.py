"""Camera and planar-object geometry (Wang et al. 2017, Sec. 3.1).

Conventions
-----------
* World: metres, right-handed, ``Z`` up, the ground is ``Z = 0``.
* Camera: OpenCV convention, ``x_cam = R @ X + t``; camera ``x`` right, ``y`` down, ``z``
  forward; intrinsics ``K``.
* Images: pixel *centres* at integer coordinates (the convention of ``cv2.warpPerspective``),
  so pixel ``(row i, col j)`` covers ``[j - 0.5, j + 0.5] x [i - 0.5, i + 0.5]``.
* Canonical window (INRIA, Dalal & Triggs 2005): 64 x 128 pixels, the person 96 px tall with
  16 px margins; at ``person_height`` metres tall the window's scale is
  ``person_height / 96`` metres per pixel. Feet at ``y = 111.5``, head at ``y = 15.5``,
  centre line at ``x = 31.5``.
* Planar object model: the person is the vertical plane through its ground position,
  perpendicular to the ground projection of the camera->object ray.

Homographies here map *homogeneous pixel coordinates* ``[x, y, 1]``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ._validation import check_elevation, check_finite, check_homography

__all__ = [
    "WINDOW_WIDTH",
    "WINDOW_HEIGHT",
    "WINDOW_PERSON_HEIGHT_PX",
    "WINDOW_CENTRE",
    "WINDOW_FEET",
    "WINDOW_HEAD",
    "WINDOW_CORNERS",
    "PERSON_HEIGHT_M",
    "Camera",
    "look_at_rotation",
    "camera_from_pose",
    "apply_homography",
    "map_points",
    "homography_jacobian",
    "window_to_plane",
    "person_plane_axes",
    "window_to_image_homography",
    "check_distance",
    "crop_camera",
    "crop_homography",
    "elevation_homography",
    "frame_transfer_homography",
]

WINDOW_WIDTH = 64
WINDOW_HEIGHT = 128
WINDOW_PERSON_HEIGHT_PX = 96
PERSON_HEIGHT_M = 1.75
#: The canonical window's landmarks, pixel coordinates with pixel centres at integers: its
#: centre, the person's feet and head (96 px apart, centred, on the centre line) and the
#: window's outer corners (clockwise from the top left).
WINDOW_CENTRE = np.array([(WINDOW_WIDTH - 1) / 2.0, (WINDOW_HEIGHT - 1) / 2.0])
WINDOW_FEET = np.array([WINDOW_CENTRE[0], (WINDOW_HEIGHT + WINDOW_PERSON_HEIGHT_PX) / 2.0 - 0.5])
WINDOW_HEAD = WINDOW_FEET - np.array([0.0, WINDOW_PERSON_HEIGHT_PX])
WINDOW_CORNERS = np.array([[-0.5, -0.5], [WINDOW_WIDTH - 0.5, -0.5],
                           [WINDOW_WIDTH - 0.5, WINDOW_HEIGHT - 0.5],
                           [-0.5, WINDOW_HEIGHT - 0.5]])
for _a in (WINDOW_CENTRE, WINDOW_FEET, WINDOW_HEAD, WINDOW_CORNERS):
    _a.setflags(write=False)
del _a
_UP = np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class Camera:
    """A pinhole camera ``x ~ K (R X + t)``.

    Parameters
    ----------
    K : (3, 3) ndarray
        Intrinsics.
    R : (3, 3) ndarray
        World-to-camera rotation.
    t : (3,) ndarray
        World-to-camera translation; the centre is ``-R.T @ t``.
    """

    K: np.ndarray
    R: np.ndarray
    t: np.ndarray
    image_size: tuple[int, int] | None = field(default=None)  # (width, height), optional

    def __post_init__(self):
        K = check_finite(self.K, "K")
        R = check_finite(self.R, "R")
        t = check_finite(self.t, "t").reshape(-1)
        if K.shape != (3, 3) or R.shape != (3, 3) or t.shape != (3,):
            raise ValueError(
                f"camera needs K (3, 3), R (3, 3), t (3,); got {K.shape}, {R.shape}, {t.shape}"
            )
        if abs(np.linalg.det(K)) < 1e-12:
            raise ValueError("K is singular")
        if not np.allclose(R @ R.T, np.eye(3), atol=1e-8) or np.linalg.det(R) < 0:
            raise ValueError("R must be a proper rotation (R R^T = I, det R = +1)")
        object.__setattr__(self, "K", K)
        object.__setattr__(self, "R", R)
        object.__setattr__(self, "t", t)

    @property
    def center(self) -> np.ndarray:
        """(3,) camera centre in world coordinates."""
        return -self.R.T @ self.t

    @property
    def P(self) -> np.ndarray:
        """(3, 4) projection matrix ``K [R | t]``."""
        return self.K @ np.hstack([self.R, self.t[:, None]])

    def project(self, points) -> np.ndarray:
        """Project world points.

        Parameters
        ----------
        points : (..., 3) array_like

        Returns
        -------
        (..., 2) ndarray of pixel coordinates. Points behind the camera raise ``ValueError``.
        """
        X = check_finite(points, "points")
        cam = X @ self.R.T + self.t
        if np.any(cam[..., 2] <= 0):
            raise ValueError("some points lie behind the camera")
        uvw = cam @ self.K.T
        return uvw[..., :2] / uvw[..., 2:3]

    def to_dict(self) -> dict:
        return {"K": self.K.tolist(), "R": self.R.tolist(), "t": self.t.tolist(),
                "image_size": None if self.image_size is None else list(self.image_size)}

    @classmethod
    def from_dict(cls, d: dict) -> "Camera":
        size = d.get("image_size")
        return cls(np.asarray(d["K"]), np.asarray(d["R"]), np.asarray(d["t"]),
                   None if size is None else tuple(size))


def _intrinsics(focal, principal_point) -> np.ndarray:
    f = np.broadcast_to(np.asarray(focal, dtype=np.float64), (2,))
    cx, cy = principal_point
    if np.any(f <= 0):
        raise ValueError(f"focal length must be positive, got {focal!r}")
    return np.array([[f[0], 0.0, cx], [0.0, f[1], cy], [0.0, 0.0, 1.0]])


def look_at_rotation(forward, roll: float = 0.0) -> np.ndarray:
    """World-to-camera rotation for a camera looking along ``forward`` with Z up.

    Parameters
    ----------
    forward : (3,) array_like
        Viewing direction in world coordinates (need not be unit length). Must not be
        vertical (the image's "up" would be undefined).
    roll : float
        Rotation of the camera about its optical axis, radians, clockwise in the image.

    Returns
    -------
    R : (3, 3) ndarray, rows are the camera ``x`` (right), ``y`` (down), ``z`` (forward)
        axes in world coordinates.
    """
    z = check_finite(forward, "forward")
    n = np.linalg.norm(z)
    if n == 0:
        raise ValueError("forward direction is zero")
    z = z / n
    x = np.cross(z, _UP)
    if np.linalg.norm(x) < 1e-9:
        raise ValueError("forward direction is vertical: the camera's up direction is undefined")
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    R = np.stack([x, y, z])
    c, s = np.cos(roll), np.sin(roll)
    Rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return Rz @ R


def camera_from_pose(*, focal, principal_point, height: float, tilt: float,
                     azimuth: float = 0.0, roll: float = 0.0, position_xy=(0.0, 0.0),
                     image_size=None) -> Camera:
    """A camera mounted at ``height`` metres, looking ``tilt`` radians below horizontal.

    Parameters
    ----------
    focal : float or (2,) array_like
        Focal length in pixels (``fx``, ``fy``).
    principal_point : (2,) array_like
        ``(cx, cy)`` in pixels.
    height : float
        Camera centre height above the ground, metres (> 0).
    tilt : float
        Angle of the optical axis below the horizontal, radians, in ``[0, pi/2)``.
    azimuth : float
        Direction of the optical axis' ground projection, radians counter-clockwise from +X.
    roll : float
        Rotation about the optical axis, radians.
    position_xy : (2,) array_like
        Camera ground position.
    """
    tilt = check_elevation(tilt, "tilt")
    if not np.isfinite(height) or height <= 0:
        raise ValueError(f"camera height must be a positive number of metres, got {height!r}")
    forward = np.array([np.cos(tilt) * np.cos(azimuth), np.cos(tilt) * np.sin(azimuth),
                        -np.sin(tilt)])
    R = look_at_rotation(forward, roll)
    C = np.array([position_xy[0], position_xy[1], height], dtype=np.float64)
    return Camera(_intrinsics(focal, principal_point), R, -R @ C, image_size)


def apply_homography(H, points) -> np.ndarray:
    """Map pixel coordinates through ``H``.

    Parameters
    ----------
    H : (3, 3) array_like
    points : (..., 2) array_like

    Returns
    -------
    (..., 2) ndarray. Points sent to infinity (``w == 0``) raise ``ValueError``.
    """
    H = np.asarray(H, dtype=np.float64)
    p = np.asarray(points, dtype=np.float64)
    uvw = p @ H[:, :2].T + H[:, 2]
    w = uvw[..., 2:3]
    if np.any(np.abs(w) < 1e-12):
        raise ValueError("a point maps to infinity under the homography")
    return uvw[..., :2] / w


def map_points(homographies, points) -> np.ndarray:
    """Map points through a stack of homographies.

    Parameters
    ----------
    homographies : (N, 3, 3) array_like
    points : (P, 2) or (2,) array_like

    Returns
    -------
    (N, P, 2) ndarray, or (N, 2) for a single point.
    """
    H = np.asarray(homographies, dtype=np.float64).reshape(-1, 3, 3)
    pts = np.asarray(points, dtype=np.float64)
    single = pts.ndim == 1
    pts = np.atleast_2d(pts)
    uvw = np.einsum("nij,pj->npi", H[:, :, :2], pts) + H[:, None, :, 2]
    out = uvw[..., :2] / uvw[..., 2:3]
    return out[:, 0] if single else out


def homography_jacobian(H, points) -> np.ndarray:
    """Jacobian of the map ``p -> H(p)`` at each point.

    .. math:: J = \\frac{1}{w} \\begin{bmatrix} h_1 - h_7 x' & h_2 - h_8 x' \\\\
              h_4 - h_7 y' & h_5 - h_8 y' \\end{bmatrix}

    with ``(x', y') = H(p)`` and ``w = h_7 x + h_8 y + h_9`` (Wang et al. 2017, the matrix
    inside eq. (3), up to the positive factor ``1/w`` that eq. (3) drops).

    Parameters
    ----------
    H : (3, 3) array_like
    points : (..., 2) array_like

    Returns
    -------
    J : (..., 2, 2) ndarray, ``J[..., i, j] = d out_i / d in_j``.
    """
    H = np.asarray(H, dtype=np.float64)
    p = np.asarray(points, dtype=np.float64)
    uvw = p @ H[:, :2].T + H[:, 2]
    w = uvw[..., 2]
    xo, yo = uvw[..., 0] / w, uvw[..., 1] / w
    J = np.empty(p.shape[:-1] + (2, 2))
    J[..., 0, 0] = (H[0, 0] - H[2, 0] * xo) / w
    J[..., 0, 1] = (H[0, 1] - H[2, 1] * xo) / w
    J[..., 1, 0] = (H[1, 0] - H[2, 0] * yo) / w
    J[..., 1, 1] = (H[1, 1] - H[2, 1] * yo) / w
    return J


# --------------------------------------------------------------------------- object plane


def window_to_plane(person_height: float = PERSON_HEIGHT_M) -> np.ndarray:
    """Affine map from canonical-window pixels to object-plane metres ``(u, z)``.

    ``u`` runs along the plane's horizontal axis (image right), ``z`` is height above the
    ground. Returns (3, 3) ``M`` with ``[u, z, 1] = M @ [x, y, 1]``.
    """
    if not np.isfinite(person_height) or person_height <= 0:
        raise ValueError(f"person_height must be positive metres, got {person_height!r}")
    s = person_height / WINDOW_PERSON_HEIGHT_PX
    cx, y_feet = WINDOW_FEET                            # (31.5, 111.5)
    return np.array([[s, 0.0, -s * cx], [0.0, -s, s * y_feet], [0.0, 0.0, 1.0]])


def person_plane_axes(camera_center, ground_position) -> tuple[np.ndarray, np.ndarray]:
    """Unit axes ``(e_u, e_z)`` of the person plane at ``ground_position``.

    The plane is vertical and perpendicular to the ground projection of the ray from the
    camera centre to the person; ``e_u`` points to the camera's right, ``e_z`` up.
    """
    C = np.asarray(camera_center, dtype=np.float64)
    P = np.asarray(ground_position, dtype=np.float64)
    g = np.array([P[0] - C[0], P[1] - C[1], 0.0])
    n = np.linalg.norm(g)
    if n < 1e-9:
        raise ValueError("the person stands directly below the camera: the plane is undefined")
    g /= n
    return np.cross(g, _UP), _UP.copy()


def window_to_image_homography(camera: Camera, ground_position,
                               person_height: float = PERSON_HEIGHT_M) -> np.ndarray:
    """Homography from the canonical 64x128 window to ``camera``'s image.

    Parameters
    ----------
    camera : Camera
    ground_position : (2,) or (3,) array_like
        Where the person stands (``Z = 0``), world metres.
    person_height : float
        Height assumed for the person, metres (96 px in the window).

    Returns
    -------
    H : (3, 3) ndarray with ``H[2, 2] == 1``.
    """
    P = np.zeros(3)
    gp = np.asarray(ground_position, dtype=np.float64).reshape(-1)
    P[: min(3, gp.size)] = gp[:3]
    P[2] = 0.0
    e_u, e_z = person_plane_axes(camera.center, P)
    # World point of plane coordinates (u, z): X = P + u e_u + z e_z  (affine in (u, z)).
    Mplane = np.column_stack([e_u, e_z, P])            # (3, 3): [u, z, 1] -> X
    Mh = np.vstack([Mplane, [0.0, 0.0, 1.0]])          # (4, 3): homogeneous world point
    # Check the plane is in front of the camera (centre and feet).
    centre_world = P + 0.5 * person_height * e_z
    if (camera.R @ centre_world + camera.t)[2] <= 0:
        raise ValueError("the person plane lies behind the camera")
    H = camera.P @ Mh @ window_to_plane(person_height)
    return check_homography(H, "window-to-image homography")


# ----------------------------------------------------------------------------- crop case


def check_distance(distance: float, person_height: float = PERSON_HEIGHT_M) -> float:
    """The crop camera's distance (:func:`crop_camera`), returned unchanged once checked.

    Raises ``ValueError`` unless it is finite and larger than ``person_height / 2``, the
    distance from the person's centre to the head and to the feet: the camera must stand
    off the person it frames.
    """
    if not np.isfinite(distance) or distance <= person_height / 2:
        raise ValueError(
            f"distance must be finite and exceed half the person height ({person_height / 2} "
            f"m), got {distance!r}"
        )
    return distance


def crop_camera(elevation: float, *, distance: float = 10.0,
                person_height: float = PERSON_HEIGHT_M, azimuth: float = 0.0) -> Camera:
    """The dataset camera for one elevation: the paper's cropped-window set-up.

    The person stands at the world origin. The camera sits ``distance`` metres from the
    person's centre (``person_height / 2`` above the ground), on the ray that rises
    ``elevation`` radians above horizontal, and looks at that centre. Its intrinsics are
    the same at every elevation and make the 64x128 image *the* crop: the aim point maps to
    the window centre ``(31.5, 63.5)`` and, at elevation 0, a ``person_height`` plane spans
    96 px (INRIA). At higher elevations the person appears foreshortened and keystoned in
    the same window.

    Parameters
    ----------
    elevation : float
        Radians in ``[0, pi/2)``.
    distance : float
        Camera-to-person-centre distance, metres. Larger distances approach an affine view.
    azimuth : float
        Direction from the person to the camera, radians counter-clockwise from -Y (the
        default puts the camera on the -Y side looking towards +Y).
    """
    elevation = check_elevation(elevation)
    distance = check_distance(distance, person_height)
    f = WINDOW_PERSON_HEIGHT_PX * distance / person_height
    K = _intrinsics(f, ((WINDOW_WIDTH - 1) / 2.0, (WINDOW_HEIGHT - 1) / 2.0))
    centre = np.array([0.0, 0.0, person_height / 2.0])
    horiz = np.array([np.sin(azimuth), -np.cos(azimuth), 0.0])   # person -> camera, ground
    C = centre + distance * (np.cos(elevation) * horiz + np.sin(elevation) * _UP)
    R = look_at_rotation(centre - C)
    return Camera(K, R, -R @ C, (WINDOW_WIDTH, WINDOW_HEIGHT))


def crop_homography(elevation: float, *, distance: float = 10.0,
                    person_height: float = PERSON_HEIGHT_M, framing: str = "plane") -> np.ndarray:
    """Homography from the canonical window (the person plane) to the crop at ``elevation``.

    ``framing="plane"`` (the paper's set-up): the crop camera at ``distance`` aimed at the
    person's centre, the same intrinsics at every elevation; at elevation 0 this is the
    identity (up to float rounding). ``framing="silhouette"``: that crop rescaled and
    shifted so that the projected person (head to feet, the planar model's stand-in for the
    silhouette) is 96 px tall and centred in the window, as the generator's silhouette
    framing does with the rendered body.
    """
    cam = crop_camera(elevation, distance=distance, person_height=person_height)
    H = window_to_image_homography(cam, (0.0, 0.0), person_height)
    if framing == "plane":
        return H
    if framing != "silhouette":
        raise ValueError(f"framing must be 'plane' or 'silhouette', got {framing!r}")
    cx, y_feet = WINDOW_FEET
    ends = apply_homography(H, np.array([WINDOW_HEAD, WINDOW_FEET]))
    k = WINDOW_PERSON_HEIGHT_PX / abs(ends[1, 1] - ends[0, 1])
    centre = ends.mean(axis=0)
    N = np.array([[k, 0.0, cx - k * centre[0]],
                  [0.0, k, y_feet - WINDOW_PERSON_HEIGHT_PX / 2.0 - k * centre[1]],
                  [0.0, 0.0, 1.0]])
    return N @ H


def elevation_homography(source_elevation: float, target_elevation: float, *,
                         distance: float = 10.0,
                         person_height: float = PERSON_HEIGHT_M,
                         framing: str = "plane") -> np.ndarray:
    """``H_st``: source-view crop pixels -> target-view crop pixels, through the person plane.

    Wang et al. (2017), Sec. 3.1: ``u_1 = H_1 H_2^{-1} u_2``. Here
    ``H_st = H_t H_s^{-1}`` with ``H_e`` the plane-to-crop homography at elevation ``e``
    (:func:`crop_homography`; ``framing`` says how the crops were framed).
    """
    kw = dict(distance=distance, person_height=person_height, framing=framing)
    Hs = crop_homography(source_elevation, **kw)
    Ht = crop_homography(target_elevation, **kw)
    return check_homography(Ht @ np.linalg.inv(Hs), "H_st")


# ---------------------------------------------------------------------- full-frame case


def frame_transfer_homography(camera: Camera, ground_position, source_elevation: float = 0.0,
                              *, distance: float = 10.0,
                              person_height: float = PERSON_HEIGHT_M) -> np.ndarray:
    """``H_st`` from a source-elevation crop to the frame, for a person at ``ground_position``.

    Composes the frame's window-to-image homography with the inverse of the source crop's
    plane-to-crop homography, so a detector trained on ``source_elevation`` crops can be
    adapted to any position in a calibrated frame.
    """
    Hs = crop_homography(source_elevation, distance=distance, person_height=person_height)
    Ht = window_to_image_homography(camera, ground_position, person_height)
    return check_homography(Ht @ np.linalg.inv(Hs), "H_st")
