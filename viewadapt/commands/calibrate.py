"""The ``viewadapt calibrate`` command: a calibration file from ground-point correspondences."""

from __future__ import annotations

import errno
import importlib.util
import json
import os
import sys
from pathlib import Path

import numpy as np

from viewadapt.camera.calibrate import GroundCalibration, calibrate_from_ground_points
from viewadapt.camera.distortion import check_distortion
from viewadapt.io.calibration import read_correspondences
from viewadapt.io.files import RunError, UserError, atomic_write_text, check_broken_link

__all__ = ["register", "cmd_calibrate", "calibration_text"]

#: ``--height`` warns when the recovered height differs from it by more than this fraction.
HEIGHT_TOLERANCE = 0.05


def calibration_text(result: GroundCalibration, suffix: str, n_points: int) -> str:
    """The calibration file of ``result`` as YAML (``.yaml``/``.yml``) or JSON (``.json``).

    ``image_size, K, R, t`` (and ``dist``) as :func:`~viewadapt.io.read_calibration`
    and :func:`~viewadapt.io.read_distortion` read them, full float precision; then the
    informational ``reprojection_error_px`` (RMS), ``camera_height_m``, ``tilt_deg``,
    ``focal`` (``"estimated"`` or ``"given"``) and ``correspondences``.
    """
    cam = result.camera
    d = {"image_size": [int(v) for v in cam.image_size],
         "K": [[float(v) for v in row] for row in cam.K],
         "R": [[float(v) for v in row] for row in cam.R],
         "t": [float(v) for v in cam.t]}
    if result.dist is not None:
        d["dist"] = [float(v) for v in result.dist]
    d.update(reprojection_error_px=round(result.reprojection_error_px, 6),
             camera_height_m=round(result.camera_height_m, 6),
             tilt_deg=round(result.tilt_deg, 6),
             focal="estimated" if result.focal_estimated else "given",
             correspondences=int(n_points))
    if suffix == ".json":                                 # one line per key
        return "{\n" + ",\n".join(f"  {json.dumps(k)}: {json.dumps(v)}"
                                   for k, v in d.items()) + "\n}\n"
    import yaml

    head = ("# viewadapt calibrate: world metres, Z up, ground Z = 0; x_cam = R X + t "
            "(OpenCV)\n")
    return head + yaml.safe_dump(d, sort_keys=False, default_flow_style=None, width=100)


def _numbers(text, option: str, counts, what: str) -> tuple:
    """``"a,b"`` -> floats; a one-line ValueError naming ``option`` otherwise."""
    try:
        vals = tuple(float(v) for v in str(text).split(","))
    except ValueError:
        raise ValueError(f"{option} must be {what}, got {text!r}") from None
    if len(vals) not in counts or not all(np.isfinite(v) for v in vals):
        raise ValueError(f"{option} must be {what}, got {text!r}")
    return vals


def _output_path(out: Path, overwrite: bool) -> tuple[Path, str]:
    """``out`` and its suffix, if the calibration file can be written there (one-line
    errors, before any work): a known suffix, not a directory, not a broken symbolic link,
    not an existing file without ``overwrite``, and the nearest existing folder above it a
    writable folder (missing folders are made)."""
    suffix = out.suffix.lower()
    if suffix not in (".yaml", ".yml", ".json"):
        raise ValueError(f"--out {out}: the calibration file must end in .yaml, .yml or .json")
    check_broken_link(out)
    if out.is_dir():
        raise ValueError(f"--out {out} is a directory; give a file name (.yaml or .json)")
    if out.exists() and not overwrite:
        raise UserError(f"--out {out} exists; pass --overwrite to replace it")
    parent = out.parent
    while not parent.exists():
        parent = parent.parent
    if not parent.is_dir():
        raise UserError(f"cannot write {out}: {parent} is a file, not a folder")
    if not os.access(parent, os.W_OK):
        raise UserError(f"cannot write {out}: permission denied ({parent} is not writable)")
    if suffix != ".json":
        if importlib.util.find_spec("yaml") is None:
            raise ValueError("writing YAML needs PyYAML (pip install pyyaml); or write --out "
                             "as .json")
    return out, suffix


#: errors writing a file that the path given causes (exit 2); others (a full disk) exit 1
_PATH_ERRORS = {errno.EACCES: "permission denied", errno.EPERM: "permission denied",
                errno.EROFS: "read-only file system"}


def _write_error(out: Path, exc: OSError) -> Exception:
    """The one-line error of a failed write of ``out`` (no errno, no temporary name)."""
    why = _PATH_ERRORS.get(exc.errno)
    if why is not None:
        return UserError(f"cannot write {out}: {why}")
    if exc.errno in (errno.ENOENT, errno.ENOTDIR, errno.EEXIST):
        return UserError(f"cannot write {out}: its folder cannot be made or does not accept "
                         f"files ({(exc.strerror or str(exc)).lower()})")
    return RunError(f"cannot write {out}: {(exc.strerror or str(exc)).lower()}")


def cmd_calibrate(args) -> int:
    """Calibrate a camera from a correspondences CSV and write the calibration file."""
    out, suffix = _output_path(Path(args.out), args.overwrite_file)
    w, h = _numbers(args.image_size, "--image-size", (2,), "W,H: two positive whole "
                    "numbers of pixels")
    if not (w == int(w) > 0 and h == int(h) > 0):
        raise ValueError(f"--image-size must be W,H: two positive whole numbers of pixels, "
                         f"got {args.image_size!r}")
    focal = None
    if args.focal is not None:
        focal = _numbers(args.focal, "--focal", (1, 2), "F or FX,FY in pixels")
        if any(f <= 0 for f in focal):
            raise ValueError(f"--focal must be positive pixels, got {args.focal!r}")
    pp = (None if args.principal_point is None else
          _numbers(args.principal_point, "--principal-point", (2,), "CX,CY in pixels"))
    dist = None
    if args.dist is not None:
        dist = check_distortion(_numbers(args.dist, "--dist", (4, 5, 8, 12, 14),
                                         "4, 5, 8, 12 or 14 comma-separated OpenCV "
                                         "coefficients (k1,k2,p1,p2[,k3...])"))
    if args.height is not None:
        (height,) = _numbers(args.height, "--height", (1,), "metres")
        if height <= 0:
            raise ValueError(f"--height must be positive metres, got {args.height!r}")
    uv, XY = read_correspondences(args.points)
    outside = ((uv[:, 0] < -0.5) | (uv[:, 0] > w - 0.5) | (uv[:, 1] < -0.5)
               | (uv[:, 1] > h - 0.5))
    if outside.any():
        print(f"warning: {int(outside.sum())} of {len(uv)} image points lie outside the "
              f"{int(w)}x{int(h)} image (first: u={uv[outside][0, 0]:g}, "
              f"v={uv[outside][0, 1]:g}): check --image-size and the u, v columns",
              file=sys.stderr)
    try:
        result = calibrate_from_ground_points(uv, XY, (int(w), int(h)), focal=focal,
                                              principal_point=pp, dist=dist)
    except ValueError as exc:
        raise ValueError(f"{args.points}: {exc}") from None
    text = calibration_text(result, suffix, len(uv))
    try:
        atomic_write_text(out, text)
    except OSError as exc:
        raise _write_error(out, exc) from None
    fx, fy = result.focal_px
    focal_text = f"{fx:.1f}" if fx == fy else f"{fx:.1f},{fy:.1f}"
    print(f"camera {result.camera_height_m:.3f} m above the ground, tilted "
          f"{result.tilt_deg:.2f} deg below the horizontal, focal {focal_text} px "
          f"({'estimated' if result.focal_estimated else 'given'}), RMS reprojection error "
          f"{result.reprojection_error_px:.3f} px over {len(uv)} points; wrote {out}")
    if args.height is not None:
        rel = result.camera_height_m / height - 1
        if abs(rel) > HEIGHT_TOLERANCE:
            print(f"warning: the recovered height {result.camera_height_m:.3f} m differs from "
                  f"--height {height:g} m by {100 * rel:+.1f} % (more than "
                  f"{100 * HEIGHT_TOLERANCE:g} %): check the points, their units and the focal "
                  "length", file=sys.stderr)
    return 0


def register(sub, common) -> None:
    """Add ``calibrate`` to the ``viewadapt`` parser ``sub``.

    ``common`` (the shared options) is not a parent here: its ``--out`` is a directory and
    its ``--overwrite`` makes ``viewadapt.cli.main`` check and claim ``--out`` as one, while
    this command writes a single file; it has its own ``--out`` and ``--overwrite``.
    """
    p = sub.add_parser(
        "calibrate", help="calibrate a camera from image <-> ground-plane points",
        description="Recover a fixed camera's K, R, t from >= 4 image <-> ground-plane "
                    "point correspondences (CSV with columns u, v, X, Y: pixels and metres on "
                    "the ground Z = 0, as CAVIAR ships them): the ground homography by the "
                    "normalised DLT, the focal length from it when not given (square pixels, "
                    "zero skew, known principal point; Zhang 2000), the pose from K^-1 H, "
                    "then R, t (and the estimated focal) refined by minimising the "
                    "reprojection error. Writes the calibration file `viewadapt detect` "
                    "reads (YAML or JSON: image_size, K, R, t [, dist]) with the RMS "
                    "reprojection error, camera height and tilt, and prints them.")
    p.add_argument("points", type=Path, help="correspondences CSV: u, v, X, Y")
    p.add_argument("--image-size", required=True, metavar="W,H",
                   help="frame width and height, pixels")
    p.add_argument("--out", type=Path, required=True,
                   help="calibration file to write (.yaml, .yml or .json)")
    p.add_argument("--overwrite", dest="overwrite_file", action="store_true",
                   help="replace an existing --out file")
    p.add_argument("--focal", metavar="F[,FY]",
                   help="known focal length in pixels, F or FX,FY (estimated from the "
                        "points when omitted, assuming square pixels)")
    p.add_argument("--principal-point", metavar="CX,CY",
                   help="principal point in pixels (the image centre when omitted: "
                        "(W-1)/2, (H-1)/2)")
    p.add_argument("--dist", metavar="K1,K2,P1,P2[,K3...]",
                   help="OpenCV lens distortion coefficients of the frames (4, 5, 8, 12 or "
                        "14): the image points are undistorted before estimating, K, R, t "
                        "describe the undistorted frame, and dist is written to the file. "
                        "Write it with '=' when k1 is negative: --dist=-0.2,0.05,0,0,0")
    p.add_argument("--height", metavar="METRES",
                   help="the camera height if known: warn when the recovered one differs by "
                        f"more than {100 * HEIGHT_TOLERANCE:g} %%")
    p.set_defaults(func=cmd_calibrate)
