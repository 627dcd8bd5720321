"""Camera calibration from image <-> ground-plane point correspondences.

A fixed surveillance camera is calibrated from a few points of known ground position
(metres on the ground plane ``Z = 0``) and their pixels, the way the CAVIAR dataset ships
its cameras: the ground-to-image homography ``H ~ K [r1 r2 t]`` (Zhang 2000, eq. (2))
gives the pose once ``K`` is known, and -- with square pixels, zero skew and a known
principal point -- ``H`` also gives the focal length (Zhang 2000, Sec. 2.3). Everything
is then refined by minimising the reprojection error.

:func:`calibrate_from_ground_points` is the entry point; :func:`find_ground_homography`,
:func:`estimate_focal_from_homography` and :func:`decompose_ground_homography` are its
steps.

References
----------
.. [1] Z. Zhang, "A flexible new technique for camera calibration", IEEE TPAMI 22(11),
   2000.
.. [2] R. Hartley and A. Zisserman, *Multiple View Geometry in Computer Vision*, 2nd ed.,
   Cambridge University Press, 2004.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from viewadapt.camera.checks import check_calibration
from viewadapt.camera.distortion import check_distortion
from viewadapt.geometry import Camera

__all__ = [
    "GroundCalibration",
    "calibrate_from_ground_points",
    "find_ground_homography",
    "estimate_focal_from_homography",
    "decompose_ground_homography",
    "camera_height_and_tilt",
]

#: Relative size of the smallest to the largest spread of the points below which they count
#: as collinear (singular values of the centred, normalised point sets).
COLLINEAR_RATIO = 1e-3
#: Relative size of the (normalised) DLT system's second-smallest singular value below which
#: the points (nearly) fail to determine a homography (Hartley & Zisserman 2004, Sec. 4.1.3:
#: e.g. three of four points on one line, or within 0.1 % of their spread of one).
DEGENERATE_DLT_RATIO = 1e-3
#: An estimated focal length is refused when the optical axis it implies is within this
#: many degrees of the vertical: the image plane is then (nearly) parallel to the ground,
#: where ``h31 = h32 = 0`` and Zhang's (2000, Sec. 2.3) constraints say nothing about ``f``.
NEAR_VERTICAL_DEG = 2.0
#: An estimated focal length is refused when one pixel of image noise moves it by more than
#: this fraction (first-order standard deviation from the refinement's Jacobian, Hartley &
#: Zisserman 2004, Sec. 5.2): the points then hardly constrain it.
MAX_FOCAL_SENSITIVITY = 0.2


@dataclass(frozen=True)
class GroundCalibration:
    """A camera recovered from ground-point correspondences.

    Attributes
    ----------
    camera : Camera
        ``K, R, t`` in the project's convention (OpenCV, world Z up, ground ``Z = 0``),
        describing the undistorted image when ``dist`` is given.
    dist : (D,) ndarray or None
        The OpenCV distortion coefficients the image points were corrected with.
    reprojection_error_px : float
        RMS over the points of the distance between each observed pixel and its ground
        point projected by the refined camera (through ``dist`` when given), pixels.
    camera_height_m : float
        Height of the camera centre above the ground, metres.
    tilt_deg : float
        Angle of the optical axis below the horizontal, degrees.
    focal_estimated : bool
        Whether the focal length was estimated (else given).
    homography : (3, 3) ndarray
        The ground-to-image homography ``[X, Y, 1] -> [u, v, 1]`` of the refined camera
        (undistorted pixels), ``H[2, 2] = 1``.
    """

    camera: Camera
    dist: np.ndarray | None
    reprojection_error_px: float
    camera_height_m: float
    tilt_deg: float
    focal_estimated: bool
    homography: np.ndarray

    @property
    def focal_px(self) -> tuple[float, float]:
        """``(fx, fy)`` of ``camera.K``, pixels."""
        return float(self.camera.K[0, 0]), float(self.camera.K[1, 1])


def _points(value, name: str, n: int | None = None) -> np.ndarray:
    """``value`` as an (N, 2) float64 array of finite numbers, or a one-line ValueError."""
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"the {name} must be an (N, 2) array of numbers") from None
    if a.ndim != 2 or a.shape[1] != 2:
        raise ValueError(f"the {name} must be an (N, 2) array, got shape {a.shape}")
    if n is not None and len(a) != n:
        raise ValueError(f"{len(a)} {name} for {n} image points")
    bad = ~np.isfinite(a).all(axis=1)
    if bad.any():
        raise ValueError(f"the {name} have non-finite values (NaN or infinity) at point(s) "
                         f"{', '.join(str(i) for i in np.flatnonzero(bad)[:5])}")
    return a


def _normalizing_transform(p: np.ndarray) -> np.ndarray:
    """Similarity ``T`` moving the centroid of ``p`` to 0, mean distance sqrt(2).

    Hartley & Zisserman (2004), Sec. 4.4.4, the normalisation of the DLT.
    """
    c = p.mean(axis=0)
    d = np.sqrt(((p - c) ** 2).sum(axis=1)).mean()
    s = np.sqrt(2.0) / d if d > 0 else 1.0
    return np.array([[s, 0.0, -s * c[0]], [0.0, s, -s * c[1]], [0.0, 0.0, 1.0]])


def _check_spread(p: np.ndarray, name: str) -> None:
    """A one-line ValueError if the points of ``p`` are (nearly) collinear."""
    c = p - p.mean(axis=0)
    sv = np.linalg.svd(c, compute_uv=False)
    if sv[0] == 0 or sv[1] / sv[0] < COLLINEAR_RATIO:
        ratio = 0.0 if sv[0] == 0 else sv[1] / sv[0]
        raise ValueError(f"the {name} are (nearly) collinear (spread ratio {ratio:.2g} < "
                         f"{COLLINEAR_RATIO:g}): a homography needs points spread over the "
                         "plane, no three of four on one line")


def find_ground_homography(image_points, ground_points) -> np.ndarray:
    """The homography from ground-plane points to their pixels, by the normalised DLT.

    .. math:: \\lambda [u, v, 1]^T = H [X, Y, 1]^T

    solved in the least-squares sense of the algebraic error over the normalised points
    (Hartley & Zisserman 2004, Algorithm 4.2); exact for exact correspondences.

    Parameters
    ----------
    image_points : (N, 2) array_like
        Pixels ``(u, v)``, pixel centres at integer coordinates.
    ground_points : (N, 2) array_like
        Ground positions ``(X, Y)``, metres (``Z = 0``).

    Returns
    -------
    H : (3, 3) ndarray, scaled to unit Frobenius norm with ``H[2, 2] >= 0``.

    Raises
    ------
    ValueError
        Fewer than 4 points, non-finite values, (nearly) collinear points or a point
        configuration that does not determine ``H`` (one line each).
    """
    uv = _points(image_points, "image points")
    XY = _points(ground_points, "ground points", n=len(uv))
    if len(uv) < 4:
        raise ValueError(f"a ground homography needs at least 4 point correspondences, got "
                         f"{len(uv)}")
    _check_spread(XY, "ground points")
    _check_spread(uv, "image points")
    Ti, Tg = _normalizing_transform(uv), _normalizing_transform(XY)
    x = uv @ Ti[:2, :2].T + Ti[:2, 2]
    X = XY @ Tg[:2, :2].T + Tg[:2, 2]
    n = len(x)
    A = np.zeros((2 * n, 9))
    Xh = np.column_stack([X, np.ones(n)])
    # Hartley & Zisserman (2004), eq. (4.3): two rows of x_i x (H X_i) = 0 per point
    A[0::2, 3:6] = -Xh
    A[0::2, 6:9] = x[:, 1:2] * Xh
    A[1::2, 0:3] = Xh
    A[1::2, 6:9] = -x[:, 0:1] * Xh
    _, sv, Vt = np.linalg.svd(A)
    sv = np.r_[sv, np.zeros(9 - len(sv))]                # 4 points: 8 rows, 9 unknowns
    if sv[7] / sv[0] < DEGENERATE_DLT_RATIO:             # a second null vector
        raise ValueError(f"the points (nearly) fail to determine a homography (condition "
                         f"{sv[7] / sv[0]:.2g} < {DEGENERATE_DLT_RATIO:g}): too many of them on "
                         "or near one line, or repeated points")
    Hn = Vt[-1].reshape(3, 3)
    H = np.linalg.inv(Ti) @ Hn @ Tg                      # denormalise (H&Z Alg. 4.2 (iii))
    H /= np.linalg.norm(H)
    return -H if H[2, 2] < 0 else H


def estimate_focal_from_homography(H, principal_point) -> float:
    """The focal length of square pixels with zero skew, from a plane's homography.

    With ``K = [[f, 0, cx], [0, f, cy], [0, 0, 1]]`` and ``H ~ K [r1 r2 t]``, the columns
    ``h1, h2`` of ``H`` satisfy Zhang's (2000, Sec. 2.3, eqs. (3), (4)) constraints

    .. math:: h_1^T \\omega h_2 = 0, \\qquad h_1^T \\omega h_1 = h_2^T \\omega h_2,
              \\qquad \\omega = K^{-T} K^{-1},

    which, after moving the principal point to the origin, are linear in ``a = 1/f^2``
    (``omega = diag(a, a, 1)``); ``a`` is their least-squares solution.

    Parameters
    ----------
    H : (3, 3) array_like
        Ground-to-image homography (any scale).
    principal_point : (2,) array_like
        ``(cx, cy)``, pixels.

    Returns
    -------
    f : float, pixels.

    Raises
    ------
    ValueError
        When the constraints give no positive, finite ``f^2`` (the image plane parallel to
        the ground, e.g. a camera looking straight down, or inconsistent points).
    """
    H = np.asarray(H, dtype=np.float64)
    cx, cy = (float(v) for v in principal_point)
    Hc = np.array([[1.0, 0.0, -cx], [0.0, 1.0, -cy], [0.0, 0.0, 1.0]]) @ H
    Hc /= np.linalg.norm(Hc)
    h1, h2 = Hc[:, 0], Hc[:, 1]
    # Zhang (2000), eqs. (3) and (4) with omega = diag(a, a, 1): A a + b = 0
    A = np.array([h1[0] * h2[0] + h1[1] * h2[1],
                  h1[0] ** 2 + h1[1] ** 2 - h2[0] ** 2 - h2[1] ** 2])
    b = np.array([h1[2] * h2[2], h1[2] ** 2 - h2[2] ** 2])
    denom = float(A @ A)
    a = -float(A @ b) / denom if denom > 0 else np.nan
    if not np.isfinite(a) or a <= 0:
        what = "infinite" if np.isfinite(a) and a == 0 else "not a positive real number"
        raise ValueError(f"the focal length estimated from the ground homography is {what} "
                         f"(1/f^2 = {a:.3g}): degenerate, e.g. the image plane parallel to "
                         "the ground (camera looking straight down) or inconsistent points; "
                         "give the focal length (--focal)")
    return float(1.0 / np.sqrt(a))


def decompose_ground_homography(H, K, ground_points=None) -> tuple[np.ndarray, np.ndarray]:
    """Rotation and translation of the camera whose ground homography is ``H``.

    ``K^{-1} H = lambda [r1 r2 t]`` (Zhang 2000, Sec. 3.1): ``lambda`` normalises ``r1`` and
    ``r2`` (their mean length), ``r3 = r1 x r2``, and ``[r1 r2 r3]`` is replaced by the
    nearest rotation (SVD, ``det R = +1``; Zhang 2000, Appendix C). Of the two signs of
    ``lambda`` the one that puts the ground points (default the origin) in front of the
    camera is kept.

    Parameters
    ----------
    H : (3, 3) array_like
        Ground-to-image homography.
    K : (3, 3) array_like
        Intrinsics.
    ground_points : (N, 2) array_like, optional
        Points that must lie in front of the camera.

    Returns
    -------
    R : (3, 3) ndarray
        World-to-camera rotation.
    t : (3,) ndarray
        ``x_cam = R X + t``.
    """
    M = np.linalg.solve(np.asarray(K, dtype=np.float64), np.asarray(H, dtype=np.float64))
    lam = 2.0 / (np.linalg.norm(M[:, 0]) + np.linalg.norm(M[:, 1]))
    pts = (np.zeros((1, 2)) if ground_points is None
           else np.asarray(ground_points, dtype=np.float64))
    depth = (pts @ M[2, :2] + M[2, 2]) * lam             # third row of [r1 r2 t] [X, Y, 1]
    if np.median(depth) < 0:
        lam = -lam
    r1, r2, t = lam * M[:, 0], lam * M[:, 1], lam * M[:, 2]
    Rm = np.column_stack([r1, r2, np.cross(r1, r2)])
    U, _, Vt = np.linalg.svd(Rm)                          # the nearest rotation (Zhang 2000,
    R = U @ Vt                                            # Appendix C)
    if np.linalg.det(R) < 0:                              # cannot happen: det Rm > 0
        R = U @ np.diag([1.0, 1.0, -1.0]) @ Vt
    return R, t


def camera_height_and_tilt(R, t) -> tuple[float, float]:
    """``(height, tilt)``: the centre's ``Z = (-R^T t)_z`` (metres) and the optical axis'
    angle below the horizontal (degrees; the axis in world coordinates is ``R[2]``)."""
    R = np.asarray(R, dtype=np.float64)
    centre = -R.T @ np.asarray(t, dtype=np.float64)
    axis = R[2] / np.linalg.norm(R[2])
    return float(centre[2]), float(np.degrees(np.arcsin(np.clip(-axis[2], -1.0, 1.0))))


def _check_not_vertical(R, t) -> None:
    """Refuse an estimated focal length whose camera looks (nearly) straight down."""
    _, tilt = camera_height_and_tilt(R, t)
    if abs(tilt) > 90.0 - NEAR_VERTICAL_DEG:
        raise ValueError(f"the optical axis is {90 - abs(tilt):.2g} degrees from the vertical: "
                         "the image plane is (nearly) parallel to the ground (camera looking "
                         "straight down), a degenerate configuration for estimating the focal "
                         "length; give it (--focal)")


def _undistort(uv, K, dist):
    if dist is None:
        return uv
    out = cv2.undistortPointsIter(uv.reshape(-1, 1, 2), K, dist, None, K,
                                  (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100,
                                   1e-12))
    return out.reshape(-1, 2)


def _intrinsics(f, pp) -> np.ndarray:
    fx, fy = f
    return np.array([[fx, 0.0, pp[0]], [0.0, fy, pp[1]], [0.0, 0.0, 1.0]])


def _project(X3, rvec, t, K, dist):
    if dist is None:
        R = cv2.Rodrigues(rvec)[0]
        cam = X3 @ R.T + t
        uvw = cam @ K.T
        return uvw[:, :2] / uvw[:, 2:3]
    p, _ = cv2.projectPoints(X3, rvec, t, K, dist)
    return p.reshape(-1, 2)


def _refine(uv, X3, K, R, t, dist, estimate_focal: bool):
    """Minimise the reprojection error over ``(rvec, t[, f])`` (Zhang 2000, Sec. 3.2)."""
    from scipy.optimize import least_squares

    rvec0 = cv2.Rodrigues(R)[0].ravel()
    pp = K[:2, 2].copy()
    f0 = float(K[0, 0])

    def unpack(x):
        Kx = _intrinsics((x[6], x[6]), pp) if estimate_focal else K
        return x[:3], x[3:6], Kx

    def residuals(x):
        rvec, tx, Kx = unpack(x)
        return (_project(X3, rvec, tx, Kx, dist) - uv).ravel()

    x0 = np.r_[rvec0, t, [f0] if estimate_focal else []]
    scale = np.r_[np.ones(3), np.maximum(np.abs(t).max(), 1.0) * np.ones(3),
                  [f0] if estimate_focal else []]
    sol = least_squares(residuals, x0, method="lm", x_scale=scale, xtol=1e-15, ftol=1e-15,
                        gtol=1e-15, max_nfev=200 * len(x0))
    r0 = residuals(x0)
    x = sol.x if np.all(np.isfinite(sol.x)) and 2 * sol.cost <= r0 @ r0 else x0
    rvec, tx, Kx = unpack(x)
    sensitivity = np.nan
    if estimate_focal:
        # first-order covariance of the parameters for unit pixel noise (Hartley &
        # Zisserman 2004, Sec. 5.2, backward propagation): Sigma = (J^T J)^-1
        J = sol.jac if x is sol.x else _numeric_jacobian(residuals, x)
        try:
            cov = np.linalg.inv(J.T @ J)
            sensitivity = float(np.sqrt(max(cov[-1, -1], 0.0)))
        except np.linalg.LinAlgError:
            sensitivity = np.inf
    return Kx, cv2.Rodrigues(rvec)[0], tx, sensitivity


def _numeric_jacobian(fun, x, rel: float = 1e-7) -> np.ndarray:
    f0 = fun(x)
    J = np.empty((f0.size, x.size))
    for i in range(x.size):
        dx = rel * max(abs(x[i]), 1.0)
        xp = x.copy()
        xp[i] += dx
        J[:, i] = (fun(xp) - f0) / dx
    return J


def calibrate_from_ground_points(image_points, ground_points, image_size, *, focal=None,
                                 principal_point=None, dist=None) -> GroundCalibration:
    """Calibrate a camera from image <-> ground-plane point correspondences.

    1. The ground-to-image homography by the normalised DLT
       (:func:`find_ground_homography`), from the image points corrected for ``dist``.
    2. Without ``focal``: ``f`` from the homography assuming square pixels, zero skew and
       the principal point given (default the image centre ``((w-1)/2, (h-1)/2)``)
       (:func:`estimate_focal_from_homography`; with ``dist`` steps 1-2 are iterated, since
       undistorting the points needs ``K``).
    3. ``R, t`` from ``K^{-1} H`` (:func:`decompose_ground_homography`).
    4. ``R, t`` and the estimated ``f`` refined by minimising the squared reprojection error
       (Levenberg-Marquardt, ``scipy.optimize.least_squares``; Zhang 2000, Sec. 3.2),
       projecting through ``dist`` when given, i.e. measured in the observed image.

    Parameters
    ----------
    image_points : (N, 2) array_like
        Observed pixels ``(u, v)`` (pixel centres at integers), ``N >= 4``.
    ground_points : (N, 2) array_like
        Their ground positions ``(X, Y)``, metres; ``Z = X x Y`` is taken as up.
    image_size : (width, height)
    focal : float or (2,) array_like, optional
        Known ``f`` or ``(fx, fy)``, pixels; estimated when omitted.
    principal_point : (2,) array_like, optional
        ``(cx, cy)``, pixels; default the image centre.
    dist : (D,) array_like, optional
        OpenCV distortion coefficients (``D`` in 4, 5, 8, 12, 14) of the observed image.

    Returns
    -------
    GroundCalibration

    Raises
    ------
    ValueError
        One line: fewer than 4 points, non-finite values, (nearly) collinear points, a
        degenerate focal estimate, a camera recovered below the ground, or a result that
        fails :func:`~viewadapt.io.calibration.check_calibration`.
    """
    w, h = (int(v) for v in image_size)
    if w <= 0 or h <= 0:
        raise ValueError(f"image_size must be two positive numbers of pixels, got {image_size!r}")
    uv = _points(image_points, "image points")
    XY = _points(ground_points, "ground points", n=len(uv))
    if len(uv) < 4:
        raise ValueError(f"calibration needs at least 4 image <-> ground point "
                         f"correspondences, got {len(uv)}")
    pp = (np.array([(w - 1) / 2.0, (h - 1) / 2.0]) if principal_point is None
          else np.asarray(principal_point, dtype=np.float64).reshape(2))
    if not (np.all(np.isfinite(pp)) and -0.5 <= pp[0] <= w - 0.5 and -0.5 <= pp[1] <= h - 0.5):
        raise ValueError(f"the principal point ({pp[0]:g}, {pp[1]:g}) must lie inside the "
                         f"{w}x{h} image")
    if dist is not None:
        dist = check_distortion(dist)
        if not dist.any():
            dist = None
    estimate = focal is None
    if estimate:
        H = find_ground_homography(uv, XY)
        f = estimate_focal_from_homography(H, pp)
        for _ in range(50 if dist is not None else 0):     # undistortion needs K: iterate
            H = find_ground_homography(_undistort(uv, _intrinsics((f, f), pp), dist), XY)
            f_new = estimate_focal_from_homography(H, pp)
            done = abs(f_new - f) <= 1e-12 * f
            f = f_new
            if done:
                break
        K = _intrinsics((f, f), pp)
    else:
        fxy = np.broadcast_to(np.asarray(focal, dtype=np.float64).ravel(), (2,)) \
            if np.size(focal) in (1, 2) else None
        if fxy is None or not np.all(np.isfinite(fxy)) or np.any(fxy <= 0):
            raise ValueError(f"the focal length must be one or two positive numbers of "
                             f"pixels, got {focal!r}")
        K = _intrinsics(fxy, pp)
        H = find_ground_homography(_undistort(uv, K, dist), XY)
    R, t = decompose_ground_homography(H, K, XY)
    X3 = np.column_stack([XY, np.zeros(len(XY))])
    if estimate:
        _check_not_vertical(R, t)
    K, R, t, sensitivity = _refine(uv, X3, K, R, t, dist, estimate)
    if estimate and not K[0, 0] > 0:
        raise ValueError(f"the refined focal length is not positive ({K[0, 0]:.3g} px): "
                         "degenerate configuration; give the focal length (--focal)")
    if estimate:
        _check_not_vertical(R, t)                          # the refinement may drift there
    if estimate and not sensitivity <= MAX_FOCAL_SENSITIVITY * K[0, 0]:
        raise ValueError(f"the points hardly determine the focal length (a 1 px error in "
                         f"the image points changes it by {100 * sensitivity / K[0, 0]:.3g} %, "
                         f"more than {100 * MAX_FOCAL_SENSITIVITY:g} %): nearly degenerate, "
                         "e.g. the image plane (nearly) parallel to the ground or the points "
                         "too close together; give the focal length (--focal)")
    height, tilt = camera_height_and_tilt(R, t)
    if height <= 0:
        raise ValueError(f"the recovered camera lies {-height:.3g} m below the ground: the "
                         "ground axes are mirrored (Z = X x Y must point up; swap X and Y or "
                         "negate one of them)")
    cam = check_calibration(K, R, t, (w, h), name="recovered calibration")
    res = _project(X3, cv2.Rodrigues(cam.R)[0], cam.t, cam.K, dist) - uv
    rms = float(np.sqrt((res ** 2).sum(axis=1).mean()))
    Hg = cam.K @ np.column_stack([cam.R[:, 0], cam.R[:, 1], cam.t])
    return GroundCalibration(cam, None if dist is None else dist.copy(), rms, height, tilt,
                             estimate, Hg / Hg[2, 2])
