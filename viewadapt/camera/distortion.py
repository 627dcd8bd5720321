"""Lens distortion: undistorting a camera's frames, and distorting synthetic ones.

OpenCV's lens model (Brown-Conrady radial and tangential terms, optionally thin-prism and
tilt terms; the model of ``cv2.projectPoints``) maps a normalised image point ``(x, y)``
of the pinhole camera to its distorted position, then ``K`` to pixels. A calibration file
with ``dist`` keeps ``K, R, t`` for the *undistorted* frame, so a detector built for the
pinhole camera reads frames corrected by :class:`Undistortion` (new camera matrix = ``K``).

References
----------
.. [1] D. C. Brown, "Decentering distortion of lenses", Photogrammetric Engineering 32(3),
   1966.
.. [2] R. Hartley and A. Zisserman, *Multiple View Geometry in Computer Vision*, 2nd ed.,
   2004, Sec. 7.4 (radial distortion).
"""

from __future__ import annotations

import cv2
import numpy as np


__all__ = ["DISTORTION_SIZES", "Undistortion", "distort_image", "distort_points",
           "check_distortion"]

#: Iterations and tolerance (normalised coordinates) of ``cv2.undistortPointsIter``, which
#: inverts the distortion model by fixed-point iteration.
_UNDISTORT_CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12)


def check_distortion(dist) -> np.ndarray:
    """``dist`` as a (D,) float64 array, ``D`` in 4, 5, 8, 12, 14; a one-line ValueError
    otherwise (a count OpenCV does not accept, or non-finite values)."""
    try:
        a = np.asarray(dist, dtype=np.float64).ravel()
    except (TypeError, ValueError):
        raise ValueError("dist must be 4, 5, 8, 12 or 14 numbers (OpenCV distortion "
                         "coefficients)") from None
    if a.size not in DISTORTION_SIZES:
        raise ValueError(f"dist must be 4, 5, 8, 12 or 14 numbers (OpenCV distortion "
                         f"coefficients), got {a.size}")
    if not np.all(np.isfinite(a)):
        raise ValueError("dist has non-finite values (NaN or infinity)")
    return a


def _check_K(K) -> np.ndarray:
    K = np.asarray(K, dtype=np.float64)
    if K.shape != (3, 3) or not np.all(np.isfinite(K)):
        raise ValueError(f"K must be a finite 3x3 matrix, got shape {K.shape}")
    return K


class Undistortion:
    """Undistort frames of one camera: ``cv2.initUndistortRectifyMap`` once, then
    ``cv2.remap`` (bilinear) per frame.

    The undistorted frame has the camera matrix ``K`` itself (no rescaling or cropping),
    so its pixel ``p`` shows what the distorted frame shows at
    ``K distort(K^{-1} p)``.

    Parameters
    ----------
    K : (3, 3) array_like
        Camera matrix the coefficients refer to (and of the undistorted frame).
    dist : (D,) array_like
        OpenCV distortion coefficients, ``D`` in 4, 5, 8, 12, 14.
    image_size : (width, height)
        Size of the frames (distorted and undistorted alike).
    border_value : float
        Value of undistorted pixels whose source lies outside the frame (default 0).

    Attributes
    ----------
    map_x, map_y : (height, width) float32 ndarray
        Where each undistorted pixel is read from in the distorted frame.
    """

    def __init__(self, K, dist, image_size, *, border_value: float = 0.0):
        self.K = _check_K(K)
        self.dist = check_distortion(dist)
        w, h = (int(v) for v in image_size)
        if w <= 0 or h <= 0:
            raise ValueError(f"image_size must be positive, got {image_size!r}")
        self.image_size = (w, h)
        self.border_value = float(border_value)
        self.map_x, self.map_y = cv2.initUndistortRectifyMap(
            self.K, self.dist, None, self.K, (w, h), cv2.CV_32FC1)

    def __call__(self, img: np.ndarray) -> np.ndarray:
        """The undistorted frame.

        Parameters
        ----------
        img : (height, width[, C]) ndarray
            A distorted frame of ``image_size``.

        Returns
        -------
        (height, width[, C]) ndarray of ``img``'s dtype.
        """
        img = np.asarray(img)
        if (img.shape[1], img.shape[0]) != self.image_size:
            raise ValueError(f"frame is {img.shape[1]}x{img.shape[0]} px, the undistortion "
                             f"is for {self.image_size[0]}x{self.image_size[1]}")
        return cv2.remap(img, self.map_x, self.map_y, cv2.INTER_LINEAR,
                         borderMode=cv2.BORDER_CONSTANT, borderValue=self.border_value)

    def undistort_points(self, points) -> np.ndarray:
        """Distorted pixels (N, 2) -> their undistorted pixels (N, 2) (``cv2.undistortPoints``
        with ``P = K``, iterated to 1e-12)."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 1, 2)
        return cv2.undistortPointsIter(p, self.K, self.dist, None, self.K,
                                       _UNDISTORT_CRITERIA).reshape(-1, 2)


def distort_image(img: np.ndarray, K, dist, *, border_value: float = 0.0) -> np.ndarray:
    """A synthetically distorted frame of the undistorted ``img`` (same size, same ``K``).

    Each pixel ``q`` of the distorted frame is read (bilinear, ``cv2.remap``) from the
    undistorted pixel ``K undistort(K^{-1} q)``, the inverse of the lens model found by
    ``cv2.undistortPointsIter`` (``cv2.undistortPoints`` with ``P = K``, iterated to
    1e-12) over the pixel grid. So a point the lens model (``cv2.projectPoints``) sends to
    ``q`` appears at ``q``; :class:`Undistortion` inverts it.

    Parameters
    ----------
    img : (height, width[, C]) ndarray
        An undistorted frame with camera matrix ``K``.
    K : (3, 3) array_like
    dist : (D,) array_like
        OpenCV distortion coefficients.
    border_value : float
        Value of pixels whose source lies outside ``img``.

    Returns
    -------
    (height, width[, C]) ndarray of ``img``'s dtype.
    """
    K = _check_K(K)
    dist = check_distortion(dist)
    img = np.asarray(img)
    h, w = img.shape[:2]
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float64)
    grid = np.stack([xs.ravel(), ys.ravel()], axis=1).reshape(-1, 1, 2)
    src = cv2.undistortPointsIter(grid, K, dist, None, K, _UNDISTORT_CRITERIA).reshape(h, w, 2)
    return cv2.remap(img, src[..., 0].astype(np.float32), src[..., 1].astype(np.float32),
                     cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                     borderValue=float(border_value))


def distort_points(points, K, dist) -> np.ndarray:
    """Undistorted pixels (N, 2) -> where the lens puts them in the distorted frame (N, 2).

    The inverse of :meth:`Undistortion.undistort_points`: each pixel ``p`` of the
    undistorted frame (camera matrix ``K``) goes to ``K distort(K^{-1} p)``, OpenCV's lens
    model applied to the normalised point (``cv2.projectPoints`` of ``(x, y, 1)`` with no
    rotation or translation).

    Parameters
    ----------
    points : (N, 2) array_like
    K : (3, 3) array_like
    dist : (D,) array_like
        OpenCV distortion coefficients.
    """
    K = _check_K(K)
    dist = check_distortion(dist)
    p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    if len(p) == 0:
        return np.zeros((0, 2))
    xy = np.linalg.solve(K, np.c_[p, np.ones(len(p))].T).T
    xy = xy[:, :2] / xy[:, 2:]
    obj = np.c_[xy, np.ones(len(xy))]
    return cv2.projectPoints(obj, np.zeros(3), np.zeros(3), K, dist)[0].reshape(-1, 2)


#: How many distortion coefficients OpenCV accepts: (k1, k2, p1, p2[, k3[, k4, k5, k6[, s1,
#: s2, s3, s4[, tau_x, tau_y]]]]).
DISTORTION_SIZES = (4, 5, 8, 12, 14)
