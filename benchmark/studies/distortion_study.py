"""Lens distortion: undistort every frame, or map the windows through the lens? Which
detects as well as on pinhole frames, and at what cost?

``python -m benchmark.studies.distortion_study --data DIR --out DIR [--model M]
[--dist k1,k2,p1,p2,k3 ...] [--seed S]``

``viewadapt detect`` corrects a distorted camera by undistorting each frame with maps
computed once (:class:`viewadapt.camera.Undistortion`: ``cv2.remap`` per frame, new camera
matrix = ``K``) and then runs the adapted detector built for the pinhole camera. The
alternative maps every candidate window through the lens model when the adapted operator
is built (:func:`viewadapt.detect.windows.windows_through_lens`: each window's homography
refitted to where the lens puts its pixels) and scores the distorted frame itself, with no
per-frame work.

On a dataset's rendered (pinhole) frames, one camera per ``scene_id``, the adapted HOG/SVM
detector (:class:`viewadapt.detect.FrameDetector`, person heights 1.65 and 1.85 m, as
``bench frames``) runs on

``(a) original``
    the frames as rendered;
``(b) undistorted``
    each frame synthetically distorted with known OpenCV coefficients
    (:func:`viewadapt.camera.distort_image`, relative to the frame's own ``K``), then
    undistorted with :class:`~viewadapt.camera.Undistortion`, as ``detect`` does;
``(c) uncorrected``
    the distorted frames detected as if they were pinhole frames (the cost of ignoring the
    lens);
``(w) lens-windows``
    the distorted frames detected by the detector whose windows are mapped through the lens
    (``FrameDetector(..., lens=dist)``); its boxes, in distorted pixels, are undistorted
    (:func:`undistorted_boxes`) to be scored against the same ground truth;
``(b') edge-restored``
    a control: (b) with the pixels the synthetic render leaves without data (the thin ring
    along the frame's edges where the remaps mix in border fill, see :func:`valid_region`)
    taken from the original frame, so that ``(b') - (a)`` is the loss of the resampling
    alone and ``(b) - (b')`` that of the render's edge, which a real barrel lens does not
    have and which windows mapped through the lens would read from the same distorted
    frame;
``(r1) resampled-once``, ``(r2) resampled-twice``
    controls for the resampling blur with no change of geometry: the original frame
    bilinearly shifted by half a pixel (once, as undistorting real footage resamples it
    once), or shifted by half a pixel and back (twice, the most blur the synthetic
    distortion and the undistortion of (b) can add together).

All three are scored against the frames' ground truth as it is (undistortion returns to
the pinhole frame; for (c) the unchanged boxes measure the harm of ignoring the lens) with
:func:`benchmark.frames.methods.evaluate_method`; log-average miss rates get 95 % intervals and the
paired differences ``(b) - (a)``, ``(c) - (a)`` intervals over the same frame resamples
(:func:`benchmark.studies.frames_intervals.frame_bootstrap`). Per frame, the median milliseconds of
the undistortion and of the detection on the same frames (``time.perf_counter``, one
process) give ``remap / detect``: the most the window-mapping alternative could save. The
share of ground-truth persons whose box (within the frame) has pixels the undistorted
frame has no full data for (border fill of the remap) says what the correction loses at
the frame's edges.

The conclusion (:func:`~benchmark.studies.distortion_report.study_verdict`): keep undistortion if,
on every coefficient set, the paired interval of ``(b) - (a)`` holds 0 and the remap costs
at most :data:`~benchmark.studies.distortion_report.MAX_REMAP_FRACTION` of the detection; or,
failing the first, if ``(b) - (r2)`` holds 0 on every set and ``(r1) - (a)`` holds 0 (the
loss is that of the synthetic render's two resamplings, and one resampling costs nothing
the frames resolve). The summary table, the verdict and the markdown are
:mod:`benchmark.studies.distortion_report`'s; this module measures and runs the command.

Outputs (``--out``): ``distortion_study.csv`` (one row per condition and coefficient set),
``distortion_study.md`` (the table and its conclusion), ``run.json`` (and the operator
cache, ``cache/``, unless ``--cache`` is given).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

from viewadapt.boxes import mapped_boxes
from viewadapt.camera import Undistortion, check_distortion, distort_image
from viewadapt.detect import FrameDetector
from viewadapt.io import SourceDetectors, shipped_model_path
from viewadapt.io.files import UserError, atomic_output_dir, check_output_dir, run_metadata

from benchmark.studies.distortion_report import (
    MAX_REMAP_FRACTION, ONCE, ORIGINAL, TWICE, VALID_WEIGHT, study_markdown, study_verdict,
    summarize_distortion_study,
)
from benchmark.frames.methods import load_frames
from benchmark.studies import report_error

__all__ = ["DEFAULT_DISTORTIONS", "STUDY_HEIGHTS", "MAX_REMAP_FRACTION", "VALID_WEIGHT",
           "REMAP_REPEATS", "parse_distortion", "distortion_label", "valid_region",
           "invalid_box_fractions", "resample_half_pixel", "group_by_scene", "undistorted_boxes",
           "run_distortion_study", "main"]

#: The coefficient sets studied by default, OpenCV's ``[k1, k2, p1, p2, k3]`` relative to
#: each frame's own ``K``: a moderate and a strong barrel lens.
DEFAULT_DISTORTIONS = ((-0.25, 0.08, 0.0, 0.0, 0.0), (-0.4, 0.15, 0.0, 0.0, 0.0))
#: Assumed person heights, metres (those of ``bench frames``).
STUDY_HEIGHTS = (1.65, 1.85)
#: Timed undistortions per frame (it takes about a millisecond: more repeats than detection)
REMAP_REPEATS = 20


def resample_half_pixel(img: np.ndarray, times: int) -> np.ndarray:
    """``img`` bilinearly resampled ``times`` (1 or 2) times at half-pixel offsets.

    Once: read at ``(x + 0.5, y + 0.5)``, a 2x2 box average (the content moves by half a
    pixel). Twice: then read back at ``(x - 0.5, y - 0.5)``: no net shift, the separable
    blur ``[1, 2, 1] / 4``, the most two bilinear resamplings can blur (the kernel of a
    resampling at fractional offset ``u`` has variance ``u (1 - u) <= 1/4`` per axis).
    Edges are replicated.

    Parameters
    ----------
    img : (height, width[, C]) ndarray
    times : {1, 2}

    Returns
    -------
    (height, width[, C]) ndarray of ``img``'s dtype.
    """
    if times not in (1, 2):
        raise ValueError(f"times must be 1 or 2, got {times!r}")
    import cv2

    h, w = img.shape[:2]
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float32)
    out = img
    for d in (0.5, -0.5)[:times]:
        out = cv2.remap(out, xs + d, ys + d, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    return out


def parse_distortion(text: str) -> np.ndarray:
    """Coefficients from ``"k1,k2,p1,p2,k3"`` (4, 5, 8, 12 or 14 comma-separated numbers).

    Parameters
    ----------
    text : str

    Returns
    -------
    (D,) float64 ndarray

    Raises
    ------
    ValueError
        One line naming the option, for anything OpenCV would not take (a wrong count,
        a non-number, NaN or infinity).
    """
    parts = [p.strip() for p in str(text).split(",")]
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise ValueError(f"--dist {text!r}: not comma-separated numbers (k1,k2,p1,p2,k3)") \
            from None
    try:
        return check_distortion(values)
    except ValueError as exc:
        raise ValueError(f"--dist {text!r}: {exc}") from None


def distortion_label(dist) -> str:
    """A short name of a coefficient set, e.g. ``"k1=-0.25 k2=0.08"`` (zero terms left
    out; ``"none"`` when all are zero)."""
    names = ["k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6", "s1", "s2", "s3", "s4",
             "tx", "ty"]
    terms = [f"{n}={v:g}" for n, v in zip(names, np.asarray(dist, float)) if v != 0]
    return " ".join(terms) if terms else "none"


def valid_region(K, dist, image_size) -> np.ndarray:
    """Pixels of the undistorted frame that the synthetic distortion and the undistortion
    fill from image data alone.

    A frame of ones is distorted (:func:`~viewadapt.camera.distort_image`, border 0) and
    undistorted (:class:`~viewadapt.camera.Undistortion`, border 0); a pixel is valid when
    its value is at least :data:`~benchmark.studies.distortion_report.VALID_WEIGHT`, i.e. neither
    remap mixed in border fill.

    Parameters
    ----------
    K : (3, 3) array_like
    dist : (D,) array_like
        OpenCV distortion coefficients.
    image_size : (width, height)

    Returns
    -------
    (height, width) bool ndarray

    Notes
    -----
    With the undistorted frame's camera matrix equal to ``K``, a barrel lens (``k1 < 0``)
    sees more than the pinhole frame, so only a thin ring along the edges is invalid (the
    synthetic render's own border); a pincushion lens (``k1 > 0``) leaves the corners empty.
    """
    w, h = (int(v) for v in image_size)
    ones = np.ones((h, w), np.float32)
    back = Undistortion(K, dist, (w, h))(distort_image(ones, K, dist))
    return back >= VALID_WEIGHT


def invalid_box_fractions(boxes, valid) -> np.ndarray:
    """Share of each box's pixels (the part inside the frame) that are not valid.

    Parameters
    ----------
    boxes : (G, 4) array_like
        ``(x, y, w, h)``, pixels.
    valid : (height, width) bool ndarray
        From :func:`valid_region`.

    Returns
    -------
    (G,) float ndarray in [0, 1]; 0 for a box with no pixel inside the frame.
    """
    h, w = valid.shape
    invalid = np.pad((~valid).astype(np.int64), ((1, 0), (1, 0))).cumsum(0).cumsum(1)
    out = []
    for x, y, bw, bh in np.asarray(boxes, float).reshape(-1, 4):
        x0, y0 = int(np.clip(np.floor(x), 0, w)), int(np.clip(np.floor(y), 0, h))
        x1, y1 = int(np.clip(np.ceil(x + bw), 0, w)), int(np.clip(np.ceil(y + bh), 0, h))
        area = (x1 - x0) * (y1 - y0)
        n = invalid[y1, x1] - invalid[y0, x1] - invalid[y1, x0] + invalid[y0, x0]
        out.append(n / area if area > 0 else 0.0)
    return np.array(out, float)


def undistorted_boxes(dets, undistortion) -> np.ndarray:
    """Detections ``(x, y, w, h, score)`` in distorted-frame pixels -> the same in the
    undistorted frame (:func:`viewadapt.boxes.mapped_boxes` through
    :meth:`Undistortion.undistort_points <viewadapt.camera.Undistortion.undistort_points>`)."""
    return mapped_boxes(dets, undistortion.undistort_points)


def group_by_scene(frames) -> dict:
    """``scene_id -> [frame index, ...]``; a scene whose frames disagree on the camera is
    a ``ValueError`` (the study builds one detector per scene)."""
    groups, cams = {}, {}
    for i, f in enumerate(frames):
        cam = json.dumps(f.camera.to_dict(), sort_keys=True)
        if cams.setdefault(f.scene_id, cam) != cam:
            raise ValueError(f"scene {f.scene_id!r}: its frames have different cameras (the "
                             "study needs one calibrated camera per scene_id)")
        groups.setdefault(f.scene_id, []).append(i)
    return groups


def _timed(fn, repeats):
    """``fn()``'s first result and the median of ``repeats`` wall times, seconds."""
    times, result = [], None
    for r in range(repeats):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
        if r == 0:
            result = out
    return result, float(np.median(times))


def run_distortion_study(frames, models, distortions, *, cache_dir=None,
                         person_heights=STUDY_HEIGHTS, repeats: int = 3,
                         remap_repeats: int = REMAP_REPEATS, log=None) -> dict:
    """Detections of every condition on every frame, their per-frame times and the
    valid-region shares.

    Parameters
    ----------
    frames : list of :class:`benchmark.frames.methods.FrameRecord`
    models : :class:`viewadapt.io.SourceDetectors`
    distortions : list of (D,) ndarray
        OpenCV coefficient sets, each relative to the frames' ``K``.
    cache_dir : path or None
        Operator cache of the :class:`~viewadapt.detect.FrameDetector` s.
    person_heights : sequence of float
    repeats, remap_repeats : int
        Timed runs of each detection and of each undistortion per frame (medians kept).
    log : callable or None
        Called with one line per camera.

    Returns
    -------
    dict
        ``detections``: method -> list of (D, 5) arrays, one per frame (``"(a) original"``,
        ``"(r1) resampled-once"``, ``"(r2) resampled-twice"``,
        ``"(b) undistorted <label>"``, ``"(c) uncorrected <label>"``,
        ``"(b') edge-restored <label>"``, ``"(w) lens-windows <label>"``); ``labels``:
        the sets' labels; ``times``: a
        DataFrame with one row per frame and method (``frame``, ``scene_id``, ``method``,
        ``detect_s``, ``remap_s``); ``coverage``: one row per frame, coefficient set and
        ground-truth person (``invalid_fraction``); ``max_shift_px``: label -> the largest
        displacement of the lens model in each camera's frame, pixels; ``operators``:
        scene -> seconds to build or load the operator, and whether it came from the cache
        (``lens_windows``: the same per coefficient set for the lens-window detectors).
    """
    if repeats < 1 or remap_repeats < 1:
        raise ValueError("repeats must be at least 1")
    labels = [distortion_label(d) for d in distortions]
    if len(set(labels)) != len(labels):
        raise ValueError("--dist: the same coefficient set is given twice")
    methods = [ORIGINAL, ONCE, TWICE] + [f"({c}) {name} {lab}" for lab in labels
                             for c, name in (("b", "undistorted"), ("c", "uncorrected"),
                                             ("b'", "edge-restored"), ("w", "lens-windows"))]
    dets = {m: [None] * len(frames) for m in methods}
    times, coverage, shifts, operators = [], [], {lab: 0.0 for lab in labels}, {}
    for scene, idx in group_by_scene(frames).items():
        cam = frames[idx[0]].camera
        det = FrameDetector(cam, models, person_heights=person_heights, cache_dir=cache_dir)
        t0 = time.perf_counter()
        det.operator("hog")                 # the offline step, not timed per frame
        operators[scene] = {"seconds": round(time.perf_counter() - t0, 2),
                            "from_cache": bool(det.cache_hit.get("hog"))}
        lens = []
        for lab, d in zip(labels, distortions):
            und = Undistortion(cam.K, d, cam.image_size)
            h, w = und.map_x.shape
            ys, xs = np.mgrid[0:h, 0:w]
            shifts[lab] = max(shifts[lab], float(np.hypot(und.map_x - xs, und.map_y - ys).max()))
            through = FrameDetector(cam, models, person_heights=person_heights,
                                    cache_dir=cache_dir, lens=d)
            t0 = time.perf_counter()
            through.operator("hog")
            operators[scene].setdefault("lens_windows", {})[lab] = {
                "seconds": round(time.perf_counter() - t0, 2),
                "from_cache": bool(through.cache_hit.get("hog"))}
            lens.append((lab, d, und, valid_region(cam.K, d, cam.image_size), through))
        for i in idx:
            f = frames[i]
            img = f.image()
            dets[ORIGINAL][i], t = _timed(lambda: det.detect(img, "hog"), repeats)
            times.append(dict(frame=i, scene_id=scene, method=ORIGINAL, detect_s=t,
                              remap_s=np.nan))
            for m, n in ((ONCE, 1), (TWICE, 2)):
                blurred = resample_half_pixel(img, n)
                dets[m][i], t = _timed(lambda: det.detect(blurred, "hog"), repeats)
                times.append(dict(frame=i, scene_id=scene, method=m, detect_s=t,
                                  remap_s=np.nan))
            for lab, d, und, valid, through in lens:
                distorted = distort_image(img, cam.K, d)
                fixed, t_remap = _timed(lambda: und(distorted), remap_repeats)
                m = f"(b) undistorted {lab}"
                dets[m][i], t = _timed(lambda: det.detect(fixed, "hog"), repeats)
                times.append(dict(frame=i, scene_id=scene, method=m, detect_s=t,
                                  remap_s=t_remap))
                m = f"(c) uncorrected {lab}"
                dets[m][i], t = _timed(lambda: det.detect(distorted, "hog"), repeats)
                times.append(dict(frame=i, scene_id=scene, method=m, detect_s=t,
                                  remap_s=np.nan))
                restored = np.where(valid[..., None] if fixed.ndim == 3 else valid, fixed, img)
                m = f"(b') edge-restored {lab}"
                dets[m][i], t = _timed(lambda: det.detect(restored, "hog"), repeats)
                times.append(dict(frame=i, scene_id=scene, method=m, detect_s=t,
                                  remap_s=np.nan))
                m = f"(w) lens-windows {lab}"
                found, t = _timed(lambda: through.detect(distorted, "hog"), repeats)
                dets[m][i] = undistorted_boxes(found, und)
                times.append(dict(frame=i, scene_id=scene, method=m, detect_s=t,
                                  remap_s=np.nan))
                for g, frac in enumerate(invalid_box_fractions(f.gt, valid)):
                    coverage.append(dict(frame=i, scene_id=scene, dist=lab, person=g,
                                         invalid_fraction=frac))
        if log is not None:
            op = operators[scene]
            log(f"{scene}: {len(idx)} frames, {len(det.windows)} windows, operator "
                f"{op['seconds']:.1f} s{' (cache)' if op['from_cache'] else ''}")
    return {"detections": dets, "labels": labels, "times": pd.DataFrame(times),
            "coverage": pd.DataFrame(coverage, columns=["frame", "scene_id", "dist", "person",
                                                        "invalid_fraction"]),
            "max_shift_px": shifts, "operators": operators}


def _split_dist_values(argv) -> list:
    """``--dist A B`` -> ``--dist=A --dist=B``: coefficient lists start with ``-`` and would
    otherwise read as options. A ``--dist`` with no value becomes ``--dist=`` (refused by
    :func:`parse_distortion` in one line)."""
    out, pending, got = [], False, False
    for tok in argv:
        if pending and not tok.startswith("--"):
            out.append(f"--dist={tok}")
            got = True
            continue
        if pending and not got:
            out.append("--dist=")
        pending, got = tok == "--dist", False
        if not pending:
            out.append(tok)
    if pending and not got:
        out.append("--dist=")
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmark.studies.distortion_study",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, required=True,
                    help="dataset directory with frames_coco.json")
    ap.add_argument("--out", type=Path, required=True, help="output directory")
    ap.add_argument("--model", type=Path, default=None,
                    help="source detectors (.npz of `viewadapt bench frames`; default the "
                         "shipped ones)")
    ap.add_argument("--dist", action="append", default=None, metavar="k1,k2,p1,p2,k3",
                    help="one or more OpenCV coefficient sets relative to each frame's K "
                         "(default: " + " ".join(",".join(f"{v:g}" for v in d)
                                                 for d in DEFAULT_DISTORTIONS) + ")")
    ap.add_argument("--repeats", type=int, default=3,
                    help="timed detections per frame and condition (default 3)")
    ap.add_argument("--boot", type=int, default=1000, help="frame resamples (default 1000)")
    ap.add_argument("--cache", type=Path, default=None,
                    help="operator cache directory (default OUT/cache)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the frame resamples")
    ap.add_argument("--overwrite", action="store_true",
                    help="write into a non-empty --out that viewadapt did not write")
    args = ap.parse_args(_split_dist_values(sys.argv[1:] if argv is None else list(argv)))
    try:
        check_output_dir(args.out, overwrite=args.overwrite)
        if args.repeats < 1 or args.boot < 1:
            raise ValueError("--repeats and --boot must be at least 1")
        dists = ([parse_distortion(t) for t in args.dist] if args.dist is not None
                 else [np.array(d, float) for d in DEFAULT_DISTORTIONS])
        labels = [distortion_label(d) for d in dists]
        if len(set(labels)) != len(labels):
            raise ValueError("--dist: the same coefficient set is given twice")
        frames = load_frames(args.data)
        group_by_scene(frames)
        model_path = args.model or shipped_model_path()
        models = SourceDetectors.load(model_path)
        t0 = time.perf_counter()
        study = run_distortion_study(frames, models, dists,
                                     cache_dir=args.cache or (args.out / "cache"),
                                     repeats=args.repeats,
                                     log=lambda s: print(s, file=sys.stderr, flush=True))
        summ = summarize_distortion_study(study, frames, n_boot=args.boot, seed=args.seed)
    except (ValueError, FileNotFoundError, UserError) as exc:
        return report_error(ap, exc)
    import cv2

    run = run_metadata(args.seed, data=str(args.data), model=str(model_path),
                       distortions={lab: d.tolist() for lab, d in zip(labels, dists)},
                       person_heights=list(STUDY_HEIGHTS), repeats=args.repeats,
                       remap_repeats=REMAP_REPEATS, n_boot=args.boot, n_frames=len(frames),
                       n_gt=int(summ["n_gt"].iloc[0]), opencv_threads=cv2.getNumThreads(),
                       operators=study["operators"],
                       max_remap_fraction=MAX_REMAP_FRACTION, verdict=study_verdict(summ),
                       seconds=round(time.perf_counter() - t0, 1))
    md = study_markdown(summ, run)
    with atomic_output_dir(args.out) as tmp:
        summ.to_csv(tmp / "distortion_study.csv", index=False, float_format="%.5f")
        (tmp / "distortion_study.md").write_text(md)
        (tmp / "run.json").write_text(json.dumps(run, indent=2))
    print(md)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
