"""The detector check of the calibration round trip: does a recovered camera detect as well
as the true one?

The adapted HOG detector (:class:`viewadapt.detect.FrameDetector`, persons
:data:`PERSON_HEIGHTS` m as ``bench frames``) runs on every frame with the true camera and
with the cameras ``viewadapt calibrate`` recovered
(:func:`benchmark.calibration_roundtrip.calibrate_draws`, focal length known and
estimated); each is evaluated against the same ground truth
(:func:`benchmark.frames.evaluate_method`), and the LAMR differences to the true camera get
a paired bootstrap interval over frames. The bar (issue 17): within :data:`LAMR_BAR`.

Used by ``python -m benchmark.calibration_roundtrip`` (:mod:`benchmark.calibration_roundtrip`),
which holds the calibration draws, the report and the command line.
"""

from __future__ import annotations

import time

import numpy as np
import pandas as pd

from viewadapt.detect import FrameDetector, ground_truth_rows, standardize_boxes
from viewadapt.metrics import accumulate_frames, log_average_miss_rate, match_detections

from .frames import evaluate_method

__all__ = ["LAMR_BAR", "PERSON_HEIGHTS", "FOCAL_MODES", "VARIANTS", "frame_matches",
           "matches_lamr", "paired_lamr_difference", "detector_check", "summarize_lamr",
           "detector_markdown", "fmt_number", "met_text"]

#: issue 17's bar of the detector check: the adapted HOG detector's LAMR with the recovered
#: camera within this of the true camera's
LAMR_BAR = 0.02
#: assumed person heights of the detector check, metres (``bench frames``' default)
PERSON_HEIGHTS = (1.65, 1.85)
#: focal modes of the calibration (:func:`benchmark.calibration_roundtrip.calibrate_draws`):
#: the true focal length given, or estimated
FOCAL_MODES = ("known", "estimated")
#: cameras of the detector check: the true one and the first draw's recovered ones
VARIANTS = ("true", "focal known", "focal estimated")


def _detect_frames(camera, models, group, cache_dir):
    """Adapted HOG detections on the frames of ``group`` with ``camera``; windows, times."""
    t0 = time.perf_counter()
    fd = FrameDetector(camera, models, person_heights=PERSON_HEIGHTS, cache_dir=cache_dir)
    fd.operator("hog")                                   # the offline step, timed apart
    t1 = time.perf_counter()
    dets = [fd.detect(f.image(), "hog") for f in group]
    return dets, len(fd.windows), t1 - t0, time.perf_counter() - t1


def frame_matches(detections, frames) -> list:
    """Per-frame matches of detections to ground truth, the first stage of
    :func:`benchmark.frames.evaluate_method` (the same ground-truth rows, ignore flags and
    box standardisation), so that resampled frames need only be accumulated.

    Parameters
    ----------
    detections : list of (D, 5) ndarray
        Per frame of ``frames``, ``(x, y, w, h, score)``.
    frames : list of FrameRecord

    Returns
    -------
    list of viewadapt.metrics.FrameMatch
    """
    out = []
    for d, f in zip(detections, frames, strict=True):
        gt = ground_truth_rows(f.gt, f.occlusion, f.camera.image_size)
        d = np.asarray(d, dtype=np.float64).reshape(-1, 5)
        out.append(match_detections(standardize_boxes(d[:, :4]), d[:, 4], gt[:, :4],
                                    gt[:, 4].astype(bool)))
    return out


def matches_lamr(matches) -> float:
    """The log-average miss rate of per-frame matches (accumulate, summarise)."""
    fppi, miss_rate, _ = accumulate_frames(matches)
    return float(log_average_miss_rate(fppi, miss_rate))


def paired_lamr_difference(dets, reference, frames, *, n_boot: int, rng) -> tuple:
    """``LAMR(dets) - LAMR(reference)`` on ``frames`` and its 95 % paired bootstrap
    interval over frames (the same resampled frames for both).

    Parameters
    ----------
    dets, reference : list of (D, 5) ndarray
        Per frame of ``frames``.
    frames : list of FrameRecord
    n_boot : int
        Bootstrap replicates (0: no interval, NaN bounds).
    rng : numpy.random.Generator

    Returns
    -------
    (difference, ci_low, ci_high) : floats
    """
    a, b = frame_matches(dets, frames), frame_matches(reference, frames)
    diff = matches_lamr(a) - matches_lamr(b)
    if n_boot <= 0:
        return float(diff), np.nan, np.nan
    boot = np.empty(n_boot)
    for k in range(n_boot):
        idx = rng.integers(len(frames), size=len(frames))
        boot[k] = matches_lamr([a[i] for i in idx]) - matches_lamr([b[i] for i in idx])
    return float(diff), float(np.quantile(boot, 0.025)), float(np.quantile(boot, 0.975))


def detector_check(groups: dict, recovered: dict, models, *, n_detector_draws: int = 1,
                   cache_dir=None, n_boot: int = 500, seed: int = 0, progress: bool = True):
    """The adapted HOG detector on every frame with the true and the recovered cameras.

    Parameters
    ----------
    groups : dict
        ``camera name -> list of FrameRecord``
        (:func:`benchmark.calibration_roundtrip.group_cameras`).
    recovered : dict
        ``camera name -> list over draws of {focal mode: GroundCalibration or None}``
        (:func:`benchmark.calibration_roundtrip.calibrate_draws`); the first
        ``n_detector_draws`` draws are scored (a failed calibration leaves its draw and
        mode unscored).
    models : SourceDetectors
    n_detector_draws : int
    cache_dir : path or None
        Operator cache of the true cameras (the recovered ones are built each run and not
        cached: each is used once).
    n_boot : int
        Replicates of the paired bootstrap over frames (:func:`paired_lamr_difference`).
    seed : int
        Seeds the bootstrap.

    Returns
    -------
    overall : pandas.DataFrame
        One row per camera variant over all frames: ``variant`` (:data:`VARIANTS`),
        ``draw`` (-1 for the true cameras), ``lamr``, ``n_detections``,
        ``lamr_minus_true`` with its 95 % paired bootstrap interval ``diff_ci_low,
        diff_ci_high`` and ``within_bar`` (``|lamr_minus_true| <= LAMR_BAR``); LAMR NaN
        where a camera's calibration failed.
    per_camera : pandas.DataFrame
        One row per (camera, variant, draw): ``n_frames, n_gt, n_windows, n_detections,
        lamr, build_seconds, detect_seconds``.
    """
    frames_all = [f for g in groups.values() for f in g]
    keys = [("true", -1)] + [(f"focal {m}", k) for k in range(n_detector_draws)
                             for m in FOCAL_MODES]
    dets = {key: [] for key in keys}
    failed, rows = set(), []
    for name, group in groups.items():
        for variant, k in keys:
            if variant == "true":
                cam, cache = group[0].camera, cache_dir
            else:
                r = recovered[name][k][variant.split()[1]]
                cam, cache = (None if r is None else r.camera), None
            row = {"camera": name, "variant": variant, "draw": k, "n_frames": len(group),
                   "n_gt": int(sum(len(f.gt) for f in group))}
            if cam is None:
                failed.add((variant, k))
                rows.append(row | {"lamr": np.nan})
                continue
            d, n_windows, build, detect = _detect_frames(cam, models, group, cache)
            dets[(variant, k)] += d
            rows.append(row | {"n_windows": n_windows,
                               "n_detections": int(sum(len(x) for x in d)),
                               "lamr": float(evaluate_method(d, group)["lamr"]),
                               "build_seconds": build, "detect_seconds": detect})
            if progress:
                print(f"  {name} [{variant}{'' if k < 0 else f', draw {k}'}]: {n_windows} "
                      f"windows, operator {build:.0f} s, {len(group)} frames {detect:.1f} s",
                      flush=True)
    rng = np.random.default_rng([seed, 17])
    out = []
    for variant, k in keys:
        if (variant, k) in failed:
            out.append({"variant": variant, "draw": k, "lamr": np.nan, "n_detections": 0,
                        "lamr_minus_true": np.nan, "diff_ci_low": np.nan,
                        "diff_ci_high": np.nan, "within_bar": False})
            continue
        d = dets[(variant, k)]
        row = {"variant": variant, "draw": k,
               "lamr": float(evaluate_method(d, frames_all)["lamr"]),
               "n_detections": int(sum(len(x) for x in d))}
        if variant == "true":
            row |= {"lamr_minus_true": 0.0, "diff_ci_low": 0.0, "diff_ci_high": 0.0,
                    "within_bar": True}
        else:
            diff, lo, hi = paired_lamr_difference(d, dets[("true", -1)], frames_all,
                                                  n_boot=n_boot, rng=rng)
            row |= {"lamr_minus_true": diff, "diff_ci_low": lo, "diff_ci_high": hi,
                    "within_bar": bool(abs(diff) <= LAMR_BAR)}
        out.append(row)
    cols = ["camera", "variant", "draw", "n_frames", "n_gt", "n_windows", "n_detections",
            "lamr", "build_seconds", "detect_seconds"]
    return pd.DataFrame(out), pd.DataFrame(rows).reindex(columns=cols)



def summarize_lamr(overall: pd.DataFrame) -> pd.DataFrame:
    """Per focal mode: the first draw's LAMR difference to the true cameras (the bar) and
    its spread over the detector draws.

    Returns
    -------
    pandas.DataFrame
        Columns ``focal, n_draws, first_diff, first_ci_low, first_ci_high,
        first_within_bar, median_diff, mean_diff, min_diff, max_diff, fraction_within``
        (a failed calibration counts as outside the bar).
    """
    rows = []
    for mode in FOCAL_MODES:
        g = overall[overall["variant"] == f"focal {mode}"].sort_values("draw")
        if not len(g):
            continue
        d = g["lamr_minus_true"].to_numpy(float)
        ok = d[np.isfinite(d)]
        f = g.iloc[0]
        rows.append({"focal": mode, "n_draws": len(g), "first_diff": f["lamr_minus_true"],
                     "first_ci_low": f["diff_ci_low"], "first_ci_high": f["diff_ci_high"],
                     "first_within_bar": bool(f["within_bar"]),
                     "median_diff": float(np.median(ok)) if len(ok) else np.nan,
                     "mean_diff": float(np.mean(ok)) if len(ok) else np.nan,
                     "min_diff": float(np.min(ok)) if len(ok) else np.nan,
                     "max_diff": float(np.max(ok)) if len(ok) else np.nan,
                     "fraction_within": float(g["within_bar"].mean())})
    return pd.DataFrame(rows)


def fmt_number(x, spec=".3f") -> str:
    """``x`` formatted by ``spec`` for the report, ``n/a`` where it is None or not finite."""
    return "n/a" if x is None or not np.isfinite(x) else format(x, spec)


def met_text(ok: bool) -> str:
    """A bar's verdict for the report: ``**met**`` or ``**not met**``."""
    return "**met**" if ok else "**not met**"


def detector_markdown(overall: pd.DataFrame, per_camera: pd.DataFrame, *, model: str,
                      n_frames: int, n_boot: int, n_detector_draws: int) -> list:
    """The report's detector check section: markdown lines (:func:`detector_check`'s
    results; ``model`` as the report names it, ``n_boot`` its bootstrap replicates)."""
    lamr = summarize_lamr(overall)
    true = overall[overall["variant"] == "true"].iloc[0]
    first = overall[overall["draw"] == 0].set_index("variant")
    lines = ["", "## Detector check (adapted HOG)", "",
             f"Persons {', '.join(f'{h:g}' for h in PERSON_HEIGHTS)} m; model: {model}. "
             f"LAMR over all {n_frames} frames against the same ground truth; the interval "
             f"is a 95 % paired bootstrap over frames ({n_boot} replicates). The bar: the "
             f"first draw's recovered cameras within {LAMR_BAR:g} LAMR of the true ones.", "",
             "| cameras used | LAMR | minus true | 95 % CI | detections | within "
             f"{LAMR_BAR:g} |", "|---|---|---|---|---|---|",
             f"| true | {fmt_number(true['lamr'], '.4f')} | — | — | {true['n_detections']} "
             "| — |"]
    for v in VARIANTS[1:]:
        if v not in first.index:
            continue
        r = first.loc[v]
        lines.append(f"| recovered (draw 0), {v} | {fmt_number(r['lamr'], '.4f')} | "
                     f"{fmt_number(r['lamr_minus_true'], '+.4f')} | "
                     f"{fmt_number(r['diff_ci_low'], '+.3f')}…"
                     f"{fmt_number(r['diff_ci_high'], '+.3f')} "
                     f"| {r['n_detections']} | {met_text(r['within_bar'])} |")
    if n_detector_draws > 1:
        lines += ["", f"Over the first {n_detector_draws} draws' recovered cameras "
                  "(LAMR minus the true cameras'):", "",
                  "| focal | draws | median | mean | min | max | draws within "
                  f"{LAMR_BAR:g} |", "|---|---|---|---|---|---|---|"]
        for _, r in lamr.iterrows():
            lines.append(f"| {r['focal']} | {r['n_draws']} | "
                         f"{fmt_number(r['median_diff'], '+.4f')} | "
                         f"{fmt_number(r['mean_diff'], '+.4f')} | "
                         f"{fmt_number(r['min_diff'], '+.4f')} | "
                         f"{fmt_number(r['max_diff'], '+.4f')} | "
                         f"{100 * r['fraction_within']:.0f} % |")
    lines += ["", "Per camera (the true cameras and the first draw's; all draws in "
              "`calibration_detector.csv`):", "",
              "| camera | cameras used | frames | persons | windows | detections | LAMR |",
              "|---|---|---|---|---|---|---|"]
    for _, r in per_camera[per_camera["draw"] <= 0].iterrows():
        nw = "n/a" if pd.isna(r["n_windows"]) else f"{int(r['n_windows'])}"
        nd = "n/a" if pd.isna(r["n_detections"]) else f"{int(r['n_detections'])}"
        lines.append(f"| {r['camera']} | {r['variant']} | {r['n_frames']} | {r['n_gt']} | "
                     f"{nw} | {nd} | {fmt_number(r['lamr'], '.4f')} |")
    return lines
