"""A camera from what a user can measure: pose and lens estimation.

* :mod:`~viewadapt.camera.calibrate` -- a camera from image <-> ground-plane points (Zhang
  2000).
* :mod:`~viewadapt.camera.distortion` -- lens distortion (OpenCV's model): undistorting
  frames and points, distorting images.
* :mod:`~viewadapt.camera.checks` -- intrinsics and pose checked, with one-line errors.
* :mod:`~viewadapt.camera.effects` -- what the sensor and the encoder do to an image (blur,
  vignetting, white balance, noise, tone curve, resolution, JPEG).
"""

from .checks import check_calibration
from .effects import EFFECT_KEYS, CameraEffects, apply_camera_effects
from .distortion import DISTORTION_SIZES, Undistortion, distort_image, check_distortion
from .calibrate import (
    GroundCalibration, calibrate_from_ground_points, find_ground_homography,
    estimate_focal_from_homography, decompose_ground_homography, camera_height_and_tilt,
)

__all__ = [
    "check_calibration", "EFFECT_KEYS", "CameraEffects", "apply_camera_effects", "DISTORTION_SIZES", "Undistortion", "distort_image", "check_distortion",
    "GroundCalibration", "calibrate_from_ground_points", "find_ground_homography",
    "estimate_focal_from_homography", "decompose_ground_homography", "camera_height_and_tilt",
]
