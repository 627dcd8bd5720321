"""Does ``viewadapt calibrate`` recover a frame camera well enough to detect with?

``python -m benchmark.studies.calibration_roundtrip --data DIR --out DIR [--points 6] [--noise 0.5]
[--draws 20] [--phases 4] [--model M] [--seed S] [--jobs N]``

Measured on a dataset's own calibrated frames. For every frame camera (one per scene):

1. ``--points`` ground points (``Z = 0``) are chosen over the ground the camera sees: a
   jittered grid of pixels over the lower two thirds of the image (inside a 5 % margin,
   at least :data:`MIN_DEPRESSION_DEG` below the horizon), each cast onto the ground by
   the true camera; no three of four on one line.
2. Their pixels (the true camera's projection) get Gaussian noise of ``--noise`` px per
   coordinate -- a person clicking the points -- and are written as the ``u, v, X, Y``
   CSV ``viewadapt calibrate`` reads, then read back with its reader.
3. The camera is recovered by the function the command runs
   (:func:`viewadapt.camera.calibrate_from_ground_points`, principal point the image
   centre as the command's default), once with the true focal length given (``--focal``)
   and once with none (estimated).

``--draws`` repeats steps 1-3 with new points and new noise. Reported per draw: the
recovered camera height's error (%), the tilt's (degrees), the estimated focal length's
(%), the camera centre's distance from the true one (m) and the RMS reprojection error;
over the draws, the median and 95th percentile of their magnitudes.

Detector check (:mod:`benchmark.studies.calibration_lamr`): the adapted HOG detector
(:class:`viewadapt.detect.FrameDetector`, persons 1.65 and 1.85 m as ``bench frames``) runs
on every frame with the true camera and with the recovered cameras of the first draw (focal
known; focal estimated) -- of the first ``--detector-draws`` draws, for their spread (0:
no detector check) -- all with the same source model (``--model``, or trained as ``bench
frames`` does); each is
evaluated against the same ground truth (:func:`benchmark.frames.methods.evaluate_method`), the
LAMR differences with a paired bootstrap over frames. Each camera's candidate windows are
scored at ``--phases`` x ``--phases`` offsets of their ground grid and its LAMR is the mean
over them: where a grid falls on the ground is arbitrary, and on a few dozen frames it
moves a LAMR by several hundredths, as much as a small calibration error does.

The bars: height within :data:`HEIGHT_BAR_PCT` %, tilt within
:data:`TILT_BAR_DEG` degrees -- judged on the 95th percentile over all cameras and draws,
with no failed calibration -- and the first draw's LAMR within
:data:`benchmark.studies.calibration_lamr.LAMR_BAR` of the true camera's.

Outputs (``--out``): ``calibration_roundtrip.csv`` (every camera, draw and focal mode),
``calibration_summary.csv`` (medians and 95th percentiles), ``calibration_lamr.csv`` (LAMR
over all frames per camera variant and draw), ``calibration_detector.csv`` (the same per
camera, with counts), ``calibration_roundtrip.md``, ``run.json``, the correspondences
``points/<camera>/draw_NN.csv`` and the first draw's calibration files
``calibrations/<camera>_focal-{known,estimated}.yaml``. The true cameras' operators are
cached in ``--cache`` (default ``OUT/cache``).
"""

from __future__ import annotations

import argparse
import json
import re
import time
from pathlib import Path

import numpy as np
import pandas as pd

from viewadapt.camera import calibrate_from_ground_points
from viewadapt.camera.calibrate import camera_height_and_tilt
from viewadapt.commands.calibrate import calibration_text
from viewadapt.io.calibration import read_correspondences
from viewadapt.io import SourceDetectors
from viewadapt.io.files import (
    UserError, atomic_output_dir, atomic_write_text, check_output_dir, claim_output_dir,
    run_metadata,
)
from viewadapt.geometry import Camera

from benchmark.studies.calibration_lamr import (
    FOCAL_MODES, LAMR_BAR, PERSON_HEIGHTS, detector_check, detector_markdown, fmt_number,
    met_text, summarize_lamr,
)
from benchmark.frames.methods import load_frames
from benchmark.recipes import PAPER_RECIPE
from benchmark.studies import report_error

__all__ = ["HEIGHT_BAR_PCT", "TILT_BAR_DEG", "MIN_DEPRESSION_DEG", "group_cameras",
           "choose_ground_points", "write_correspondences", "calibrate_draws",
           "ERROR_COLUMNS", "summarize_draws", "run_calibration_roundtrip", "main"]

#: the bars: recovered camera height within this many percent of the true one
HEIGHT_BAR_PCT = 2.0
#: ... the tilt within this many degrees (the detector's: :data:`calibration_lamr.LAMR_BAR`)
TILT_BAR_DEG = 0.5
#: a chosen pixel's ray must point at least this far below the horizon (degrees)
MIN_DEPRESSION_DEG = 3.0
#: the points lie in the image below this fraction of its height ...
TOP_FRACTION = 1.0 / 3.0
#: ... and at least this fraction of the width / height away from its borders
MARGIN_FRACTION = 0.05
#: a point moves at most this fraction of its grid cell from the cell's centre
JITTER_FRACTION = 0.35


# ----------------------------------------------------------------------------- cameras


def group_cameras(frames) -> dict:
    """The frames of each camera, named by their scene.

    Parameters
    ----------
    frames : list of FrameRecord

    Returns
    -------
    dict
        ``name -> list of FrameRecord`` in the frames' order; ``name`` is the scene id, with
        ``#k`` appended when a scene's frames have more than one camera.
    """
    by_scene: dict = {}
    for f in frames:
        key = json.dumps(f.camera.to_dict(), sort_keys=True)
        by_scene.setdefault(f.scene_id, {}).setdefault(key, []).append(f)
    out = {}
    for scene, cams in by_scene.items():
        for k, group in enumerate(cams.values()):
            out[scene if len(cams) == 1 else f"{scene}#{k}"] = group
    return out


def _grid_shape(n_points: int, aspect: float) -> tuple[int, int]:
    """(rows, cols) of a grid of at least ``n_points`` cells, cells about square."""
    rows = max(2, int(round(np.sqrt(n_points / aspect))))
    rows = min(rows, max(2, n_points // 2))
    return rows, int(np.ceil(n_points / rows))


def choose_ground_points(camera: Camera, n_points: int, rng: np.random.Generator, *,
                         top_fraction: float = TOP_FRACTION,
                         margin_fraction: float = MARGIN_FRACTION,
                         jitter_fraction: float = JITTER_FRACTION):
    """Ground points spread over what the camera sees, and their exact pixels.

    Pixels on a jittered grid over the image region ``u`` in ``[m_w, w - 1 - m_w]``, ``v``
    in ``[v_top, h - 1 - m_h]`` (``m`` the margins; ``v_top`` the larger of
    ``top_fraction (h - 1)`` and the horizon's lowest row at the region's sides plus
    ``2 MIN_DEPRESSION_DEG`` of view) are cast onto the ground ``Z = 0`` by ``camera``:

    .. math:: X = C + s\\, R^T K^{-1} [u, v, 1]^T, \\qquad s = -C_z / (R^T K^{-1} [u, v, 1]^T)_z

    The grid has about square cells, at least two rows and two columns (the points span
    both image directions, near and far, left and right); ``n_points`` of its cells are
    drawn at random and each point lies within ``jitter_fraction`` of a cell from the
    cell's centre, so that no line holds three of four of them.

    Parameters
    ----------
    camera : Camera
        With its ``image_size``; looking down onto the ground.
    n_points : int
        At least 4.
    rng : numpy.random.Generator
    top_fraction, margin_fraction, jitter_fraction : float

    Returns
    -------
    image_points : (N, 2) ndarray
        The ground points projected by ``camera`` (pixels; equal to the grid pixels up to
        rounding).
    ground_points : (N, 2) ndarray
        ``(X, Y)``, metres.

    Raises
    ------
    ValueError
        Fewer than 4 points, or too little ground below the horizon in the region.
    """
    if isinstance(n_points, bool) or int(n_points) != n_points or n_points < 4:
        raise ValueError(f"a calibration needs at least 4 ground points, got {n_points!r}")
    n_points = int(n_points)
    w, h = camera.image_size
    Kinv = np.linalg.inv(camera.K)
    # the ray of pixel x points down where l . x < 0, l = K^-T R e_z (the horizon line)
    line = Kinv.T @ camera.R[:, 2]

    def depression(uv):
        d = (np.c_[uv, np.ones(len(uv))] @ Kinv.T) @ camera.R        # world directions
        return np.degrees(np.arcsin(-d[:, 2] / np.linalg.norm(d, axis=1)))

    u0, u1 = margin_fraction * (w - 1), (1 - margin_fraction) * (w - 1)
    v0, v1 = top_fraction * (h - 1), (1 - margin_fraction) * (h - 1)
    # move the top below the horizon where it crosses the region (the horizon row at the
    # region's sides, plus the rows it takes to look MIN_DEPRESSION_DEG further down)
    if abs(line[1]) > 1e-12:
        v_h = max(-(line[0] * u + line[2]) / line[1] for u in (u0, u1))
        f = camera.K[1, 1]
        v0 = max(v0, v_h + f * np.tan(np.radians(2 * MIN_DEPRESSION_DEG)))
    if v1 - v0 < 0.1 * (h - 1):
        raise ValueError(f"the camera sees too little ground below the horizon in the lower "
                         f"part of its {w}x{h} image to place calibration points")
    rows, cols = _grid_shape(n_points, (u1 - u0) / (v1 - v0))
    cells = np.sort(rng.choice(rows * cols, size=n_points, replace=False))
    r, c = np.divmod(cells, cols)
    jit = rng.uniform(-jitter_fraction, jitter_fraction, size=(n_points, 2))
    uv = np.column_stack([u0 + (c + 0.5 + jit[:, 0]) * (u1 - u0) / cols,
                          v0 + (r + 0.5 + jit[:, 1]) * (v1 - v0) / rows])
    if np.any(depression(uv) < MIN_DEPRESSION_DEG):
        raise ValueError("some calibration points lie (nearly) at or above the horizon: the "
                         "camera sees too little ground in the lower part of its image")
    rays = (np.c_[uv, np.ones(len(uv))] @ Kinv.T) @ camera.R
    C = camera.center
    s = -C[2] / rays[:, 2]
    XY = (C + s[:, None] * rays)[:, :2]
    return camera.project(np.c_[XY, np.zeros(len(XY))]), XY


def write_correspondences(path, image_points, ground_points) -> Path:
    """Write the ``u,v,X,Y`` CSV ``viewadapt calibrate`` reads, every float exactly
    (``repr``), atomically; return the path."""
    lines = ["u,v,X,Y"] + [f"{u!r},{v!r},{X!r},{Y!r}" for (u, v), (X, Y)
                           in zip(np.asarray(image_points, float).tolist(),
                                  np.asarray(ground_points, float).tolist())]
    atomic_write_text(path, "\n".join(lines) + "\n")
    return Path(path)


# ------------------------------------------------------------------------- calibration


def _true_pose(camera: Camera) -> dict:
    height, tilt = camera_height_and_tilt(camera.R, camera.t)
    w, h = camera.image_size
    return {"true_height_m": height, "true_tilt_deg": tilt,
            "true_focal_px": float(camera.K[0, 0]),
            "principal_point_offset_px": float(np.hypot(camera.K[0, 2] - (w - 1) / 2,
                                                        camera.K[1, 2] - (h - 1) / 2))}


def calibrate_draws(name: str, camera: Camera, *, n_points: int, noise_px: float,
                    n_draws: int, rng: np.random.Generator, points_dir=None):
    """Calibrate ``camera`` back from ``n_draws`` noisy draws of ground points.

    Each draw chooses points (:func:`choose_ground_points`), adds ``N(0, noise_px^2)``
    pixel noise, writes and reads back the CSV (when ``points_dir`` is given), and runs
    :func:`viewadapt.camera.calibrate_from_ground_points` with the true focal length and
    without (the same noisy points).

    Returns
    -------
    rows : pandas.DataFrame
        One row per (draw, focal mode): ``camera, draw, focal, n_points, noise_px``, the
        true pose (``true_height_m, true_tilt_deg, true_focal_px,
        principal_point_offset_px``), the recovered ``height_m, tilt_deg, focal_px``, the
        errors ``height_error_pct, tilt_error_deg, focal_error_pct`` (NaN when the focal
        length was given), ``centre_error_m``, ``reprojection_rms_px`` and ``error`` (the
        calibration's message when it refused the points, else empty).
    calibrations : list of dict
        Per draw, ``focal mode -> GroundCalibration`` (None where it failed).
    """
    truth = _true_pose(camera)
    fxy = (float(camera.K[0, 0]), float(camera.K[1, 1]))
    rows, calibrations = [], []
    for k in range(n_draws):
        uv, XY = choose_ground_points(camera, n_points, rng)
        uv = uv + rng.normal(0.0, noise_px, uv.shape) if noise_px > 0 else uv
        if points_dir is not None:
            path = write_correspondences(Path(points_dir) / f"draw_{k:02d}.csv", uv, XY)
            uv, XY = read_correspondences(path)
        calibrations.append({})
        for mode in FOCAL_MODES:
            row = {"camera": name, "draw": k, "focal": mode, "n_points": n_points,
                   "noise_px": noise_px, **truth}
            try:
                r = calibrate_from_ground_points(uv, XY, camera.image_size,
                                                 focal=fxy if mode == "known" else None)
            except ValueError as exc:
                rows.append(row | {"error": str(exc)})
                calibrations[-1][mode] = None
                continue
            calibrations[-1][mode] = r
            rows.append(row | {
                "height_m": r.camera_height_m, "tilt_deg": r.tilt_deg,
                "focal_px": r.focal_px[0],
                "height_error_pct": 100 * (r.camera_height_m / truth["true_height_m"] - 1),
                "tilt_error_deg": r.tilt_deg - truth["true_tilt_deg"],
                "focal_error_pct": (100 * (r.focal_px[0] / truth["true_focal_px"] - 1)
                                    if mode == "estimated" else np.nan),
                "centre_error_m": float(np.linalg.norm(r.camera.center - camera.center)),
                "reprojection_rms_px": r.reprojection_error_px, "error": ""})
    cols = ["camera", "draw", "focal", "n_points", "noise_px", *truth, "height_m",
            "tilt_deg", "focal_px", "height_error_pct", "tilt_error_deg", "focal_error_pct",
            "centre_error_m", "reprojection_rms_px", "error"]
    df = pd.DataFrame(rows).reindex(columns=cols)
    df["error"] = df["error"].fillna("")
    return df, calibrations


#: the summarised error columns (magnitudes), their short names
ERROR_COLUMNS = {"height_error_pct": "height_pct", "tilt_error_deg": "tilt_deg",
                 "focal_error_pct": "focal_pct", "centre_error_m": "centre_m",
                 "reprojection_rms_px": "rms_px"}


def summarize_draws(draws: pd.DataFrame) -> pd.DataFrame:
    """Median and 95th percentile of each error's magnitude, per camera and focal mode and
    over all cameras (``camera == "all"``), and whether the height and tilt bars hold.

    Returns
    -------
    pandas.DataFrame
        Columns ``camera, focal, n_draws, n_failed``, ``<error>_median`` and ``<error>_p95``
        for ``height_pct, tilt_deg, focal_pct, centre_m, rms_px`` (over the successful
        draws), ``height_within_bar`` and ``tilt_within_bar`` (fraction of all draws, a
        failure counting as outside), ``height_bar_met`` and ``tilt_bar_met`` (p95 within
        the bar and no failure).
    """
    rows = []
    parts = [("all", draws)] + list(draws.groupby("camera", sort=False))
    for cam, d in parts:
        for mode in FOCAL_MODES:
            g = d[d["focal"] == mode]
            ok = g[g["error"] == ""]
            row = {"camera": cam, "focal": mode, "n_draws": len(g),
                   "n_failed": int(len(g) - len(ok))}
            for col, short in ERROR_COLUMNS.items():
                a = ok[col].abs().to_numpy(float)
                a = a[np.isfinite(a)]
                row[f"{short}_median"] = float(np.median(a)) if len(a) else np.nan
                row[f"{short}_p95"] = float(np.percentile(a, 95)) if len(a) else np.nan
            for short, col, bar in (("height", "height_error_pct", HEIGHT_BAR_PCT),
                                    ("tilt", "tilt_error_deg", TILT_BAR_DEG)):
                inside = (ok[col].abs() <= bar).sum()
                row[f"{short}_within_bar"] = float(inside / len(g)) if len(g) else np.nan
                p95 = row[f"{short}_{'pct' if short == 'height' else 'deg'}_p95"]
                row[f"{short}_bar_met"] = bool(row["n_failed"] == 0 and p95 <= bar)
            rows.append(row)
    return pd.DataFrame(rows)


def _file_name(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]", "_", name)


def run_calibration_roundtrip(frames, models, *, n_points: int = 6, noise_px: float = 0.5,
                              n_draws: int = 20, seed: int = 0, points_dir=None,
                              cache_dir=None, n_detector_draws: int = 1, n_boot: int = 500,
                              phases: int = 1, n_jobs: int = 1, detect: bool = True,
                              progress: bool = True):
    """Calibration draws for every camera of ``frames``, then the detector check.

    The draws of camera ``i`` (in :func:`group_cameras` order) use
    ``numpy.random.default_rng([seed, i])``. ``phases`` and ``n_jobs`` are those of
    :func:`benchmark.studies.calibration_lamr.detector_check`.

    Returns
    -------
    draws : pandas.DataFrame
        :func:`calibrate_draws` rows of every camera.
    calibrations : dict
        ``camera name -> list over draws of {focal mode: GroundCalibration or None}``.
    overall, per_camera
        :func:`detector_check`'s results (None, None when ``detect`` is False).
    """
    groups = group_cameras(frames)
    parts, calibrations = [], {}
    for i, (name, group) in enumerate(groups.items()):
        pdir = None if points_dir is None else Path(points_dir) / _file_name(name)
        d, calibrations[name] = calibrate_draws(
            name, group[0].camera, n_points=n_points, noise_px=noise_px, n_draws=n_draws,
            rng=np.random.default_rng([seed, i]), points_dir=pdir)
        parts.append(d)
    draws = pd.concat(parts, ignore_index=True)
    if not detect:
        return draws, calibrations, None, None
    overall, per_camera = detector_check(groups, calibrations, models,
                                         n_detector_draws=min(n_detector_draws, n_draws),
                                         phases=phases, cache_dir=cache_dir, n_boot=n_boot,
                                         seed=seed, n_jobs=n_jobs, progress=progress)
    return draws, calibrations, overall, per_camera


# ----------------------------------------------------------------------------- report


def _markdown(summary: pd.DataFrame, overall: pd.DataFrame, per_camera: pd.DataFrame,
              run: dict) -> str:
    lines = ["# Calibration round trip", "",
             f"{run['n_cameras']} frame cameras of `{run['data']}` ({run['n_frames']} frames); "
             f"{run['points']} ground points per draw over the lower two thirds of the image, "
             f"Gaussian pixel noise {run['noise_px']:g} px, {run['draws']} draws per camera "
             f"(seed {run['seed']}); calibrated by `calibrate_from_ground_points` (principal "
             "point the image centre) with the true focal length given and estimated. "
             "Errors are magnitudes; p95 = 95th percentile over the draws.", "",
             "## Camera recovery, all cameras", "",
             "| focal | draws | failed | height % median | height % p95 | tilt ° median | "
             "tilt ° p95 | focal % median | focal % p95 | centre m median | RMS px median |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    pooled = summary[summary["camera"] == "all"]
    for _, r in pooled.iterrows():
        lines.append(f"| {r['focal']} | {r['n_draws']} | {r['n_failed']} | "
                     f"{fmt_number(r['height_pct_median'])} | {fmt_number(r['height_pct_p95'])} | "
                     f"{fmt_number(r['tilt_deg_median'])} | {fmt_number(r['tilt_deg_p95'])} | "
                     f"{fmt_number(r['focal_pct_median'])} | {fmt_number(r['focal_pct_p95'])} | "
                     f"{fmt_number(r['centre_m_median'])} | {fmt_number(r['rms_px_median'])} |")
    lines += ["", "Bars (95th percentile over all cameras and draws, no failed calibration):",
              ""]
    for _, r in pooled.iterrows():
        lines.append(f"- focal {r['focal']}: height within {HEIGHT_BAR_PCT:g} % "
                     f"{met_text(r['height_bar_met'])} ({100 * r['height_within_bar']:.1f} % of "
                     f"draws within), tilt within {TILT_BAR_DEG:g}° {met_text(r['tilt_bar_met'])} "
                     f"({100 * r['tilt_within_bar']:.1f} % of draws within)")
    lines += ["", "## Per camera", "",
              "| camera | true height m | true tilt ° | true focal px | focal | height % "
              "median | height % p95 | tilt ° median | tilt ° p95 | focal % p95 | failed |",
              "|---|---|---|---|---|---|---|---|---|---|---|"]
    truth = run["cameras"]
    for _, r in summary[summary["camera"] != "all"].iterrows():
        t = truth[r["camera"]]
        lines.append(f"| {r['camera']} | {t['true_height_m']:.3f} | {t['true_tilt_deg']:.2f} | "
                     f"{t['true_focal_px']:.1f} | {r['focal']} | "
                     f"{fmt_number(r['height_pct_median'])} | {fmt_number(r['height_pct_p95'])} | "
                     f"{fmt_number(r['tilt_deg_median'])} | "
                     f"{fmt_number(r['tilt_deg_p95'])} | {fmt_number(r['focal_pct_p95'])} | "
                     f"{r['n_failed']} |")
    if overall is not None:
        lines += detector_markdown(overall, per_camera, model=run["model"],
                                   n_frames=run["n_frames"], n_boot=run["bootstrap"],
                                   n_detector_draws=run["detector_draws"])
    lines += ["", "Not measured here: points clicked on the rendered images by a person (the "
              "pixels are the true camera's projections plus Gaussian noise; the ground "
              "positions are exact), lens distortion, a principal point off the image "
              "centre."]
    return "\n".join(lines) + "\n"


# -------------------------------------------------------------------------------- CLI


def _jsonable(x):
    """``x`` with numpy scalars as Python numbers and NaN / infinity as None."""
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.generic):
        x = x.item()
    if isinstance(x, float) and not np.isfinite(x):
        return None
    return x


class _Parser(argparse.ArgumentParser):
    """argparse with its usage errors in one line (exit code 2)."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message}\n")


def _check_args(args) -> None:
    if args.points < 4:
        raise UserError(f"--points must be at least 4 (a ground homography needs 4 "
                        f"correspondences), got {args.points}")
    if not (np.isfinite(args.noise) and args.noise >= 0):
        raise UserError(f"--noise must be a finite number of pixels >= 0, got {args.noise}")
    if args.draws < 1:
        raise UserError(f"--draws must be at least 1, got {args.draws}")
    if not 0 <= args.detector_draws <= args.draws:
        raise UserError(f"--detector-draws must be in 0..--draws ({args.draws}), got "
                        f"{args.detector_draws}")
    if args.bootstrap < 0:
        raise UserError(f"--bootstrap must be >= 0, got {args.bootstrap}")
    if args.phases < 1:
        raise UserError(f"--phases must be at least 1, got {args.phases}")
    if args.jobs < 1:
        raise UserError(f"--jobs must be at least 1, got {args.jobs}")


def main(argv=None) -> int:
    ap = _Parser(prog="python -m benchmark.studies.calibration_roundtrip",
                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, required=True, help="dataset directory with frames")
    ap.add_argument("--out", type=Path, required=True, help="output directory")
    ap.add_argument("--points", type=int, default=6,
                    help="ground points per calibration (>= 4; default 6)")
    ap.add_argument("--noise", type=float, default=0.5,
                    help="Gaussian pixel noise per coordinate, px (default 0.5)")
    ap.add_argument("--draws", type=int, default=20,
                    help="point and noise draws per camera (default 20)")
    ap.add_argument("--detector-draws", type=int, default=1,
                    help="run the detector with the recovered cameras of this many draws "
                         "(default 1: the first; the bar is judged on the first; 0: no "
                         "detector check, calibration only, no model needed)")
    ap.add_argument("--phases", type=int, default=4,
                    help="score each camera's windows at PHASES x PHASES offsets of their "
                         "ground grid and average the LAMR over them (default 4; 1: the "
                         "default grid only)")
    ap.add_argument("--jobs", type=int, default=1,
                    help="processes for the detector runs (default 1)")
    ap.add_argument("--bootstrap", type=int, default=500,
                    help="paired bootstrap replicates over frames for the LAMR differences "
                         "(default 500; 0: none)")
    ap.add_argument("--model", type=Path, default=None,
                    help="source detectors (models/source_detectors.npz of `viewadapt bench "
                         "frames`); default: train them as bench frames does")
    ap.add_argument("--quick", action="store_true",
                    help="train quickly (tests); ignored with --model")
    ap.add_argument("--cache", type=Path, default=None,
                    help="operator cache of the true cameras (default OUT/cache)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--overwrite", action="store_true",
                    help="write into a non-empty --out that viewadapt did not write")
    try:
        args = ap.parse_args(argv)
    except SystemExit as exc:
        return int(exc.code or 0)
    try:
        _check_args(args)
        check_output_dir(args.out, overwrite=args.overwrite)
        frames = load_frames(args.data)
        for name, group in group_cameras(frames).items():    # room for the points
            try:
                choose_ground_points(group[0].camera, args.points, np.random.default_rng(0))
            except ValueError as exc:
                raise ValueError(f"camera {name}: {exc}") from None
        detect = args.detector_draws > 0
        models = SourceDetectors.load(args.model) if args.model is not None and detect \
            else None
    except (UserError, ValueError, FileNotFoundError) as exc:
        return report_error(ap, exc)
    t0 = time.perf_counter()
    if not detect:
        model_text = None
    elif models is None:
        from benchmark.data import load_dataset
        from benchmark.frames.methods import train_source_detectors

        print("training HOG/SVM and ACF on the dataset's elevation-0 crops ...", flush=True)
        try:
            models = train_source_detectors(load_dataset(args.data), seed=args.seed,
                                            quick=args.quick, recipe=PAPER_RECIPE)
        except (ValueError, FileNotFoundError) as exc:
            return report_error(ap, exc)
        print(f"  trained in {time.perf_counter() - t0:.0f} s", flush=True)
        model_text = f"trained here (seed {args.seed}{', quick' if args.quick else ''})"
    else:
        model_text = f"`{args.model}`"
    claim_output_dir(args.out, overwrite=args.overwrite,
                     command="benchmark.studies.calibration_roundtrip")
    cache = args.cache or (args.out / "cache")
    with atomic_output_dir(args.out, command="benchmark.studies.calibration_roundtrip") as tmp:
        draws, calibrations, overall, per_camera = run_calibration_roundtrip(
            frames, models, n_points=args.points, noise_px=args.noise, n_draws=args.draws,
            seed=args.seed, points_dir=tmp / "points", cache_dir=cache,
            n_detector_draws=args.detector_draws, n_boot=args.bootstrap,
            phases=args.phases, n_jobs=args.jobs, detect=detect)
        summary = summarize_draws(draws)
        groups = group_cameras(frames)
        pooled = summary[summary["camera"] == "all"].set_index("focal")
        run = run_metadata(
            args.seed, data=str(args.data), model=model_text, points=args.points,
            noise_px=args.noise, draws=args.draws, detector_draws=args.detector_draws,
            grid_phases=args.phases ** 2,
            bootstrap=args.bootstrap, person_heights=list(PERSON_HEIGHTS),
            n_cameras=len(groups), n_frames=len(frames),
            cameras={n: _true_pose(g[0].camera) for n, g in groups.items()},
            bars={"height_pct": HEIGHT_BAR_PCT, "tilt_deg": TILT_BAR_DEG, "lamr": LAMR_BAR},
            calibration={m: dict(pooled.loc[m].drop("camera")) for m in FOCAL_MODES},
            detector=None if overall is None else {
                "true_lamr": float(overall.loc[overall["variant"] == "true", "lamr"].iloc[0]),
                **{f"focal {r['focal']}": dict(r.drop("focal"))
                   for _, r in summarize_lamr(overall).iterrows()}},
            seconds=round(time.perf_counter() - t0, 1))
        text = _markdown(summary, overall, per_camera, run)
        for name, per_draw in calibrations.items():
            for mode, r in per_draw[0].items():
                if r is not None:
                    atomic_write_text(tmp / "calibrations" / f"{_file_name(name)}_focal-"
                                      f"{mode}.yaml", calibration_text(r, ".yaml",
                                                                       args.points))
        draws.to_csv(tmp / "calibration_roundtrip.csv", index=False, float_format="%.6g")
        summary.to_csv(tmp / "calibration_summary.csv", index=False, float_format="%.6g")
        if overall is not None:
            per_camera.to_csv(tmp / "calibration_detector.csv", index=False,
                              float_format="%.6g")
            overall.to_csv(tmp / "calibration_lamr.csv", index=False, float_format="%.6g")
        (tmp / "calibration_roundtrip.md").write_text(text)
        (tmp / "run.json").write_text(json.dumps(_jsonable(run), indent=2) + "\n")
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
