"""Candidate detection windows in world space (Wang et al. 2017, Sec. 5.1).

A calibrated camera lets the detector search the *ground plane* instead of the image: a
grid of ground positions with a real-world stride, each carrying a person of an assumed
height, projected into the frame. This replaces the image pyramid's pixel stride and
scale steps. The paper's rule (Sec. 5.1, "Detection window selection"):

.. math:: \\Delta = 8 \\times \\frac{h}{96} \\approx 0.146\\ \\text{m} \\quad (h = 1.75\\ \\text{m}),

the canonical window's 8-px cell stride at the canonical scale of ``h / 96`` metres per
pixel; windows closer than 1 px in the image to an already kept window are dropped, which
keeps the count finite towards the horizon.

Each window keeps its own homography (canonical 64x128 window -> frame, the planar person
model of :func:`viewadapt.geometry.window_to_image_homography`), from which its adapted
detector is built (:mod:`viewadapt.detect`).

Notes
-----
Departures and choices, all parameters:

* The grid is axis-aligned in a *camera-aligned* ground frame (origin below the camera,
  first axis along the ground projection of the optical axis), so grid rows are lines of
  constant forward distance.
* Windows are kept near-to-far: a grid position is dropped when its window's feet point
  lies within ``min_separation`` px of the feet point of an already kept window of the same
  person height (the paper's "no closer than 1 pixel apart").
* The whole canonical window (64x128, its 16-px margins included) must lie inside the
  frame, as for any sliding-window detector.
* ``min_person_height_px`` (default :data:`MIN_PERSON_HEIGHT_PX`) drops persons smaller
  than that in the image: a 64x128-window detector with 8-px cells cannot see them, and
  the 1-px rule alone would keep windows a few pixels tall just below the horizon. Set 0
  to keep them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry import (
    PERSON_HEIGHT_M, WINDOW_CORNERS, WINDOW_FEET, WINDOW_HEAD, WINDOW_HEIGHT,
    WINDOW_PERSON_HEIGHT_PX, WINDOW_WIDTH, Camera,
    map_points, window_to_plane,
)

__all__ = [
    "GROUND_STRIDE_M",
    "check_ground_stride",
    "MIN_PERSON_HEIGHT_PX",
    "PERSON_BOX_WINDOW",
    "CandidateWindows",
    "check_ground_visible",
    "window_homographies",
    "select_candidate_windows",
    "person_boxes",
    "window_scale",
    "detector_window_homography",
    "distort_pixels",
    "windows_through_lens",
    "homographies_through_lens",
]

#: The paper's real-world stride, ``8 * 1.75 / 96`` metres (Sec. 5.1).
GROUND_STRIDE_M = 8.0 * PERSON_HEIGHT_M / WINDOW_PERSON_HEIGHT_PX
#: Persons shorter than this in the image, px, get no candidate window: the smallest person
#: the evaluation protocol counts (:func:`~viewadapt.detect.evaluation.ground_truth_rows`'
#: ``min_height``; shorter ones are ignored, so a window of one can only be a false
#: positive or find an ignored person) and OpenCV's 64x128 detector upsampled 4x sees
#: (96 / 4). (Before 2026-12-05: 16 px; measured effect in docs/real_footage.md.)
MIN_PERSON_HEIGHT_PX = 24.0

#: The person's box inside the canonical window, ``(x0, y0, x1, y1)`` in continuous pixel
#: coordinates (pixel centres at integers): 96 px from head (y = 15.5) to feet
#: (y = 111.5), 0.41 x 96 px wide around the centre line x = 31.5 (the Caltech aspect).
PERSON_BOX_WINDOW = (WINDOW_HEAD[0] - 0.205 * WINDOW_PERSON_HEIGHT_PX, WINDOW_HEAD[1],
                     WINDOW_FEET[0] + 0.205 * WINDOW_PERSON_HEIGHT_PX, WINDOW_FEET[1])



@dataclass(frozen=True)
class CandidateWindows:
    """World-space candidate windows of one camera.

    Attributes
    ----------
    ground_xy : (N, 2) ndarray
        Where each person stands, world metres.
    person_height : (N,) ndarray
        Assumed person height of each window, metres.
    homographies : (N, 3, 3) ndarray
        Canonical 64x128 window -> frame pixels, ``H[:, 2, 2] == 1``.
    image_size : (int, int)
        ``(width, height)`` of the frame.
    grid_index : (N, 2) int ndarray
        ``(forward, lateral)`` index of each window on its height's ground grid.
    camera : Camera or None
        The camera the windows were selected for (its frame pixels, not those of an
        upsampled band): what an object model other than the plane maps through
        (:func:`~viewadapt.detect.templates.window_mapping`).
    dist : (D,) ndarray or None
        The lens the frame is seen through (OpenCV coefficients of ``camera.K``) when the
        homographies were fitted through it (:func:`windows_through_lens`); None: pinhole.
    """

    ground_xy: np.ndarray
    person_height: np.ndarray
    homographies: np.ndarray
    image_size: tuple
    grid_index: np.ndarray
    camera: object = None
    dist: object = None

    def __len__(self) -> int:
        return int(self.ground_xy.shape[0])

    @property
    def feet(self) -> np.ndarray:
        """(N, 2) image position of each window's feet point."""
        return map_points(self.homographies, WINDOW_FEET)

    @property
    def scale(self) -> np.ndarray:
        """(N,) frame pixels per canonical-window pixel: :func:`window_scale`."""
        return window_scale(self.homographies)

    def person_boxes(self) -> np.ndarray:
        """(N, 4) ``(x, y, w, h)`` image bounding box of each window's person box."""
        return person_boxes(self.homographies)

    def window_corners(self) -> np.ndarray:
        """(N, 4, 2) image position of the canonical window's corners."""
        return map_points(self.homographies, WINDOW_CORNERS)

    def subset(self, index) -> "CandidateWindows":
        """The windows selected by ``index`` (boolean mask or integer array)."""
        return CandidateWindows(self.ground_xy[index], self.person_height[index],
                                self.homographies[index], self.image_size,
                                self.grid_index[index], self.camera, self.dist)


def window_scale(homographies) -> np.ndarray:
    """(N,) frame pixels per canonical-window pixel under each homography: the image
    length of the window's head-to-feet line / 96 (what picks a window's cell size)."""
    H = np.asarray(homographies, dtype=np.float64).reshape(-1, 3, 3)
    return np.linalg.norm(map_points(H, WINDOW_FEET) - map_points(H, WINDOW_HEAD), axis=1) \
        / WINDOW_PERSON_HEIGHT_PX


def detector_window_homography(window) -> np.ndarray:
    """(3, 3) homography from a detector's window of ``window = (width, height)`` px to the
    canonical 64x128 window, for a detector whose window is the canonical one scaled
    (the person in the same place, e.g. Daimler's 48x96): pixel centres
    ``x' = k x + (k - 1) / 2``, ``k = 64 / width = 128 / height``; ``ValueError`` for a
    window of another shape."""
    w, h = (int(v) for v in window)
    k = WINDOW_WIDTH / w
    if w <= 0 or h <= 0 or abs(WINDOW_HEIGHT / h - k) > 1e-12:
        raise ValueError(f"a detector window must have the canonical window's shape "
                         f"({WINDOW_WIDTH}:{WINDOW_HEIGHT}), got {w}x{h}")
    c = (k - 1.0) / 2.0
    return np.array([[k, 0.0, c], [0.0, k, c], [0.0, 0.0, 1.0]])


def person_boxes(homographies) -> np.ndarray:
    """Image bounding boxes ``(x, y, w, h)`` of :data:`PERSON_BOX_WINDOW` under each
    homography.

    Parameters
    ----------
    homographies : (N, 3, 3) array_like

    Returns
    -------
    (N, 4) ndarray
    """
    H = np.asarray(homographies, dtype=np.float64).reshape(-1, 3, 3)
    x0, y0, x1, y1 = PERSON_BOX_WINDOW
    q = map_points(H, np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]]))
    lo, hi = q.min(axis=1), q.max(axis=1)
    return np.concatenate([lo, hi - lo], axis=1)


def _camera_ground_frame(camera: Camera):
    """Origin below the camera and unit axes (forward, left) of the camera-aligned grid."""
    C = camera.center
    fwd = camera.R[2].copy()          # optical axis in world coordinates
    fwd[2] = 0.0
    n = np.linalg.norm(fwd)
    if n < 1e-9:                      # looking straight down: use the image's "up" direction
        fwd = -camera.R[1].copy()
        fwd[2] = 0.0
        n = np.linalg.norm(fwd)
    fwd /= n
    left = np.array([-fwd[1], fwd[0], 0.0])
    return np.array([C[0], C[1], 0.0]), fwd, left


def check_ground_visible(camera: Camera, image_size) -> np.ndarray:
    """Check that the ground plane ``Z = 0`` is in view; return the ground points seen.

    Parameters
    ----------
    camera : Camera
    image_size : (width, height)

    Returns
    -------
    (P, 2) ndarray
        World ``(X, Y)`` of the sampled image-border pixels whose rays hit the ground in
        front of the camera.

    Raises
    ------
    ValueError
        If the camera centre is at or below the ground (the ground plane is behind the
        camera), or if no pixel ray of the frame meets the ground (the horizon lies below
        the whole frame: the camera sees only sky).
    """
    w, h = _check_size(image_size)
    C = camera.center
    if C[2] <= 0:
        raise ValueError(f"the camera centre is {C[2]:.3g} m from the ground plane, at or "
                         "below it: the ground plane is behind the camera (check the sign "
                         "of t or of the camera height)")
    xs = np.linspace(-0.5, w - 0.5, 33)
    ys = np.linspace(-0.5, h - 0.5, 25)
    border = np.concatenate([np.stack([xs, np.full_like(xs, ys[0])], 1),
                             np.stack([xs, np.full_like(xs, ys[-1])], 1),
                             np.stack([np.full_like(ys, xs[0]), ys], 1),
                             np.stack([np.full_like(ys, xs[-1]), ys], 1),
                             np.stack(np.meshgrid(xs, ys), -1).reshape(-1, 2)])
    rays = np.c_[border, np.ones(len(border))] @ np.linalg.inv(camera.K).T @ camera.R
    down = rays[:, 2] < -1e-9
    if not down.any():
        raise ValueError("no pixel of the frame sees the ground plane: the horizon lies "
                         "below the whole frame (the camera looks above the horizon; check "
                         "the tilt and the rotation R)")
    lam = -C[2] / rays[down, 2]
    return C[:2] + lam[:, None] * rays[down, :2]


def _check_size(image_size):
    try:
        w, h = (int(image_size[0]), int(image_size[1]))
    except (TypeError, ValueError, IndexError):
        raise ValueError(f"image_size must be (width, height), got {image_size!r}") from None
    if w < WINDOW_WIDTH // 4 or h < WINDOW_HEIGHT // 4:
        raise ValueError(f"image_size {w}x{h} is too small for person windows")
    return w, h


def window_homographies(camera: Camera, ground_xy, person_height=PERSON_HEIGHT_M) -> np.ndarray:
    """Window-to-image homographies of many ground positions at once.

    Vectorised :func:`viewadapt.geometry.window_to_image_homography`: the person plane at
    ``P`` is vertical with horizontal axis :math:`e_u = g \\times e_z`, ``g`` the unit
    ground direction from the camera to ``P``, and

    .. math:: H = K\\,[R e_u \\;\\; R e_z \\;\\; R P + t]\\; M_{window \\to plane}(h)

    (Wang et al. 2017, Sec. 3.1).

    Parameters
    ----------
    camera : Camera
    ground_xy : (N, 2) array_like
        World positions on the ground.
    person_height : float or (N,) array_like
        Metres.

    Returns
    -------
    H : (N, 3, 3) ndarray with ``H[:, 2, 2] == 1``.

    Raises
    ------
    ValueError
        If a position is directly below the camera or its person plane is behind it.
    """
    P = np.asarray(ground_xy, dtype=np.float64).reshape(-1, 2)
    n = P.shape[0]
    hgt = np.broadcast_to(np.asarray(person_height, dtype=np.float64), (n,))
    if np.any(~np.isfinite(hgt)) or np.any(hgt <= 0):
        raise ValueError("person heights must be positive metres")
    C = camera.center
    g = P - C[:2]
    gn = np.linalg.norm(g, axis=1)
    if np.any(gn < 1e-9):
        raise ValueError("a ground position lies directly below the camera: its person "
                         "plane is undefined")
    g /= gn[:, None]
    e_u = np.stack([g[:, 1], -g[:, 0], np.zeros(n)], 1)          # g x up
    P3 = np.c_[P, np.zeros(n)]
    cam_u = e_u @ camera.R.T                                      # (N, 3)
    cam_z = np.broadcast_to(camera.R[:, 2], (n, 3))
    cam_p = P3 @ camera.R.T + camera.t
    centre_z = cam_p[:, 2] + 0.5 * hgt * cam_z[:, 2]
    if np.any(centre_z <= 0):
        raise ValueError("a person plane lies behind the camera")
    M = np.stack([cam_u, cam_z, cam_p], axis=2)                   # (N, 3, 3) columns
    s = hgt / WINDOW_PERSON_HEIGHT_PX
    W2P = np.zeros((n, 3, 3))
    base = window_to_plane(WINDOW_PERSON_HEIGHT_PX)   # 1 m per canonical pixel
    W2P[:, 0, 0] = s
    W2P[:, 0, 2] = s * base[0, 2]
    W2P[:, 1, 1] = -s
    W2P[:, 1, 2] = s * base[1, 2]
    W2P[:, 2, 2] = 1.0
    H = camera.K @ M @ W2P
    return H / H[:, 2:3, 2:3]


def check_ground_stride(stride) -> tuple:
    """``(forward, lateral)`` metres of a ground-grid stride given as one number or a pair;
    ValueError for anything but positive finite metres."""
    try:
        v = np.atleast_1d(np.asarray(stride, dtype=np.float64)) if not isinstance(
            stride, (str, bytes, bool)) else np.array([np.nan])
    except (TypeError, ValueError):
        v = np.array([np.nan])
    if v.ndim != 1 or len(v) not in (1, 2) or not np.all(np.isfinite(v)) or np.any(v <= 0):
        raise ValueError(f"stride must be positive metres, one or a (forward, lateral) pair, "
                         f"got {stride!r}")
    return (float(v[0]), float(v[-1]))


def select_candidate_windows(camera: Camera, image_size=None, *,
                             person_heights=(PERSON_HEIGHT_M,), stride: float = GROUND_STRIDE_M,
                             min_separation: float = 1.0,
                             min_person_height_px: float = MIN_PERSON_HEIGHT_PX,
                             max_distance: float = 200.0,
                             grid_phase=(0.0, 0.0)) -> CandidateWindows:
    """World-space candidate windows of a calibrated camera (Wang et al. 2017, Sec. 5.1).

    Parameters
    ----------
    camera : Camera
    image_size : (width, height), optional
        Defaults to ``camera.image_size``.
    person_heights : sequence of float
        Assumed person heights, metres; each gets its own set of windows.
    stride : float or (2,) float
        Ground-grid stride, metres (default the paper's ``8 * 1.75 / 96``); a pair gives
        the strides along the camera's forward and left axes (e.g. a lateral stride of
        half: windows twice as dense across the view; docs/real_footage.md measures it).
    min_separation : float
        Minimum image distance, px, between the feet points of two kept windows of the same
        height (the paper's 1 px).
    min_person_height_px : float
        Drop windows whose person is shorter than this in the image (see the module Notes).
    max_distance : float
        Ground distance from the camera beyond which nothing is searched, metres.
    grid_phase : (2,) float
        Offset of the grid from the point below the camera, in strides along its forward
        and left axes, each in ``[0, 1)``. The grid's origin is arbitrary; scoring the same
        frames at several phases measures how much a result depends on where the windows
        happen to fall.

    Returns
    -------
    CandidateWindows
        Ordered by height, then near to far.

    Raises
    ------
    ValueError
        For a camera that does not see the ground (:func:`check_ground_visible`), bad
        parameters, or when no window fits in the frame.
    """
    if image_size is None:
        if camera.image_size is None:
            raise ValueError("image_size is needed (the camera has none)")
        image_size = camera.image_size
    w, h = _check_size(image_size)
    sf, sl = check_ground_stride(stride)
    if not np.isfinite(min_separation) or min_separation < 0:
        raise ValueError(f"min_separation must be >= 0 px, got {min_separation!r}")
    heights = np.atleast_1d(np.asarray(person_heights, dtype=np.float64))
    if heights.size == 0 or np.any(~np.isfinite(heights)) or np.any(heights <= 0):
        raise ValueError(f"person_heights must be positive metres, got {person_heights!r}")
    phase = np.asarray(grid_phase, dtype=np.float64)
    if phase.shape != (2,) or not np.all((phase >= 0) & (phase < 1)):
        raise ValueError(f"grid_phase must be two fractions of a stride in [0, 1), got "
                         f"{grid_phase!r}")
    seen = check_ground_visible(camera, (w, h))
    origin, fwd, left = _camera_ground_frame(camera)
    origin = origin + sf * phase[0] * fwd + sl * phase[1] * left
    rel = seen - origin[:2]
    f_seen, l_seen = rel @ fwd[:2], rel @ left[:2]
    f_lo = max(float(f_seen.min()), -max_distance)
    f_hi = min(float(f_seen.max()), max_distance)
    l_lo = max(float(l_seen.min()), -max_distance)
    l_hi = min(float(l_seen.max()), max_distance)
    i_range = np.arange(np.floor(f_lo / sf), np.ceil(f_hi / sf) + 1).astype(np.int64)
    j_range = np.arange(np.floor(l_lo / sl), np.ceil(l_hi / sl) + 1).astype(np.int64)
    if i_range.size * j_range.size > 20_000_000:
        raise ValueError("the visible ground holds more than 2e7 grid positions: lower "
                         "max_distance or raise the stride")
    parts = []
    C = camera.center
    for hgt in heights:
        kept_xy, kept_ij, kept_H = [], [], []
        occupied: dict = {}
        for i in i_range:                                  # near to far, row by row
            ii = np.full(j_range.size, i)
            xy = origin[:2] + (i * sf) * fwd[:2] + np.outer(j_range * sl, left[:2])
            ok = np.linalg.norm(xy - C[:2], axis=1) > max(0.5, 1e-6)
            cam_z = (np.c_[xy, np.full(len(xy), 0.5 * hgt)] @ camera.R.T + camera.t)[:, 2]
            ok &= cam_z > 0.05
            # the whole person must be in front of the camera
            ok &= (np.c_[xy, np.zeros(len(xy))] @ camera.R.T + camera.t)[:, 2] > 0.05
            ok &= (np.c_[xy, np.full(len(xy), hgt)] @ camera.R.T + camera.t)[:, 2] > 0.05
            if not ok.any():
                continue
            xy, jj, ii = xy[ok], j_range[ok], ii[ok]
            H = window_homographies(camera, xy, hgt)
            inside = _corners_inside(H, w, h)
            feet = map_points(H, WINDOW_FEET)
            tall = np.linalg.norm(feet - map_points(H, WINDOW_HEAD), axis=1) >= min_person_height_px
            if min_person_height_px > 0 and not tall.any():
                break                                      # farther rows are smaller still
            sel = np.flatnonzero(inside & tall)
            for k in sel:                                  # greedy 1-px thinning
                if min_separation > 0 and _too_close(occupied, feet[k], min_separation):
                    continue
                if min_separation > 0:
                    key = (int(np.floor(feet[k, 0] / min_separation)),
                           int(np.floor(feet[k, 1] / min_separation)))
                    occupied.setdefault(key, []).append(feet[k])
                kept_xy.append(xy[k])
                kept_ij.append((i, jj[k]))
                kept_H.append(H[k])
        if kept_xy:
            parts.append((np.array(kept_xy), np.full(len(kept_xy), hgt), np.array(kept_H),
                          np.array(kept_ij, dtype=np.int64)))
    if not parts:
        raise ValueError(f"no candidate window fits in the {w}x{h} frame for this "
                         "calibration (persons would be cut by the frame border, smaller "
                         f"than {min_person_height_px:g} px, or beyond the horizon)")
    return CandidateWindows(np.concatenate([p[0] for p in parts]),
                            np.concatenate([p[1] for p in parts]),
                            np.concatenate([p[2] for p in parts]), (w, h),
                            np.concatenate([p[3] for p in parts]), camera)


def _corners_inside(H, w: int, h: int) -> np.ndarray:
    """(N,) whether each window's canonical corners, mapped by ``H``, lie in a ``w x h``
    frame (pixel centres at integers, so its edges at -0.5 and w - 0.5, h - 0.5)."""
    c = map_points(H, WINDOW_CORNERS)
    return np.all((c[..., 0] >= -0.5) & (c[..., 0] <= w - 0.5)
                  & (c[..., 1] >= -0.5) & (c[..., 1] <= h - 0.5), axis=1)


def _too_close(occupied: dict, p, d: float) -> bool:
    cx, cy = int(np.floor(p[0] / d)), int(np.floor(p[1] / d))
    for dx in (-1, 0, 1):
        for dy in (-1, 0, 1):
            for q in occupied.get((cx + dx, cy + dy), ()):
                if (q[0] - p[0]) ** 2 + (q[1] - p[1]) ** 2 < d * d:
                    return True
    return False


#: Window points (a 5 x 9 grid over the canonical 64x128 window) whose positions through the
#: lens the homography of a window seen through it is fitted to.
_LENS_FIT_POINTS = np.stack(np.meshgrid(np.linspace(-0.5, WINDOW_WIDTH - 0.5, 5),
                                        np.linspace(-0.5, WINDOW_HEIGHT - 0.5, 9)),
                            -1).reshape(-1, 2)


def distort_pixels(points, K, dist) -> np.ndarray:
    """Pixels of the pinhole camera ``K`` -> where a lens with OpenCV coefficients ``dist``
    images them (the forward lens model,
    :func:`viewadapt.camera.distortion.distort_points`, keeping the points' shape).

    Parameters
    ----------
    points : (..., 2) array_like
    K : (3, 3) array_like
    dist : (D,) array_like, ``D`` in 4, 5, 8, 12, 14

    Returns
    -------
    (..., 2) ndarray
    """
    from ..camera.distortion import distort_points

    p = np.asarray(points, dtype=np.float64)
    return distort_points(p.reshape(-1, 2), K, dist).reshape(p.shape)


def windows_through_lens(windows: CandidateWindows, K, dist) -> tuple:
    """The candidate windows as a distorted frame shows them: each window's homography
    refitted to where the lens puts its points.

    A window's pixels under the pinhole homography ``H`` land, through the lens, at
    ``distort(H p)``; over one window the lens is smooth, so a homography fitted (least
    squares, ``cv2.findHomography``) to a 5 x 9 grid of the window's points stands in for
    it, and the adapted detector scores the distorted frame itself, with no per-frame
    undistortion (the alternative :class:`~viewadapt.camera.Undistortion` is measured
    against in ``benchmark.studies.distortion_study``). The person's ground position is the
    window's own, unchanged.

    Parameters
    ----------
    windows : CandidateWindows
        Selected for the pinhole camera (``K`` of the undistorted frame).
    K : (3, 3) array_like
    dist : (D,) array_like
        OpenCV distortion coefficients.

    Returns
    -------
    (CandidateWindows, keep)
        The windows whose distorted corners stay inside the frame, with the fitted
        homographies and the lens (``dist``; ``camera`` kept: an object model other than
        the plane maps through the camera, then the lens), and the (N,) bool mask of
        ``windows`` they are.
    """
    w, h = windows.image_size
    fitted = homographies_through_lens(windows.homographies, K, dist)
    keep = _corners_inside(fitted, w, h)
    if not keep.any():
        raise ValueError("no candidate window stays inside the frame through the lens")
    out = CandidateWindows(windows.ground_xy[keep], windows.person_height[keep], fitted[keep],
                           windows.image_size, windows.grid_index[keep], windows.camera,
                           np.asarray(dist, np.float64).copy())
    return out, keep


def homographies_through_lens(homographies, K, dist) -> np.ndarray:
    """(N, 3, 3) homographies fitted (least squares, ``cv2.findHomography``) to where the
    lens puts a 5 x 9 grid of each pinhole window's points (:func:`windows_through_lens`)."""
    import cv2

    H = np.asarray(homographies, np.float64).reshape(-1, 3, 3)
    fitted = np.empty_like(H)
    seen = distort_pixels(map_points(H, _LENS_FIT_POINTS), K, dist)      # (N, P, 2)
    for k in range(len(H)):
        G, _ = cv2.findHomography(_LENS_FIT_POINTS, seen[k], 0)
        if G is None:
            raise ValueError("the lens model folds a candidate window over itself: check "
                             "the distortion coefficients")
        fitted[k] = G / G[2, 2]
    return fitted


