"""The detector check of the calibration round trip: does a recovered camera detect as well
as the true one?

The adapted HOG detector (:class:`viewadapt.detect.FrameDetector`, persons
:data:`PERSON_HEIGHTS` m as ``bench frames``) runs on every frame with the true camera and
with the cameras ``viewadapt calibrate`` recovered
(:func:`benchmark.studies.calibration_roundtrip.calibrate_draws`, focal length known and
estimated); each is evaluated against the same ground truth
(:func:`benchmark.frames.methods.evaluate_method`), and the LAMR differences to the true camera get
a paired bootstrap interval over frames. The bar: within :data:`LAMR_BAR`.

Used by ``python -m benchmark.studies.calibration_roundtrip`` (:mod:`benchmark.studies.calibration_roundtrip`),
which holds the calibration draws, the report and the command line.
"""

from __future__ import annotations

import time

import numpy as np
import pandas as pd

from viewadapt.detect import FrameDetector

from benchmark.frames.methods import evaluate_method
from benchmark.frames.phases import grid_phases, phase_mean_difference

__all__ = ["LAMR_BAR", "PERSON_HEIGHTS", "FOCAL_MODES", "VARIANTS",
           "detector_check", "summarize_lamr",
           "detector_markdown", "fmt_number", "met_text"]

#: the bar of the detector check: the adapted HOG detector's LAMR with the recovered
#: camera within this of the true camera's
LAMR_BAR = 0.02
#: assumed person heights of the detector check, metres (``bench frames``' default)
PERSON_HEIGHTS = (1.65, 1.85)
#: focal modes of the calibration (:func:`benchmark.studies.calibration_roundtrip.calibrate_draws`):
#: the true focal length given, or estimated
FOCAL_MODES = ("known", "estimated")
#: cameras of the detector check: the true one and the first draw's recovered ones
VARIANTS = ("true", "focal known", "focal estimated")


def _detect_frames(camera, models, group, cache_dir, phase):
    """Adapted HOG detections on the frames of ``group`` with ``camera`` and its windows at
    grid phase ``phase``; windows, times (operators of the default grid only are cached)."""
    t0 = time.perf_counter()
    fd = FrameDetector(camera, models, person_heights=PERSON_HEIGHTS, grid_phase=phase,
                       cache_dir=None if any(phase) else cache_dir)
    fd.operator("hog")                                   # the offline step, timed apart
    t1 = time.perf_counter()
    dets = [fd.detect(f.image(), "hog") for f in group]
    return dets, len(fd.windows), t1 - t0, time.perf_counter() - t1


def detector_check(groups: dict, recovered: dict, models, *, n_detector_draws: int = 1,
                   phases: int = 1, cache_dir=None, n_boot: int = 500, seed: int = 0,
                   n_jobs: int = 1, progress: bool = True):
    """The adapted HOG detector on every frame with the true and the recovered cameras,
    each with its candidate windows at ``phases x phases`` ground-grid phases.

    Where the windows' grid falls on the ground is arbitrary, and a frame LAMR moves with
    it; a camera's LAMR here is the mean over the grid phases (:func:`grid_phases`), so that
    the comparison of two cameras measures the calibration, not where each camera's grid
    happens to fall.

    Parameters
    ----------
    groups : dict
        ``camera name -> list of FrameRecord``
        (:func:`benchmark.studies.calibration_roundtrip.group_cameras`).
    recovered : dict
        ``camera name -> list over draws of {focal mode: GroundCalibration or None}``
        (:func:`benchmark.studies.calibration_roundtrip.calibrate_draws`); the first
        ``n_detector_draws`` draws are scored (a failed calibration leaves its draw and
        mode unscored).
    models : SourceDetectors
    n_detector_draws : int
    phases : int
        Grid phases per ground axis (1: the default grid only).
    cache_dir : path or None
        Operator cache of the true cameras' default grid (the others are built each run
        and not cached: each is used once).
    n_boot : int
        Replicates of the paired bootstrap over frames (:func:`phase_mean_difference`).
    seed : int
        Seeds the bootstrap.
    n_jobs : int
        Processes for the (camera, variant, phase) runs (joblib).

    Returns
    -------
    overall : pandas.DataFrame
        One row per camera variant over all frames: ``variant`` (:data:`VARIANTS`),
        ``draw`` (-1 for the true cameras), ``lamr`` (mean over the grid phases),
        ``lamr_sd, lamr_min, lamr_max`` (over the phases), ``lamr_grid0`` (the default
        grid's), ``n_phases``, ``n_detections`` (the default grid's), ``lamr_minus_true``
        with its 95 % paired bootstrap interval ``diff_ci_low, diff_ci_high`` and
        ``within_bar`` (``|lamr_minus_true| <= LAMR_BAR``); LAMR NaN where a camera's
        calibration failed.
    per_camera : pandas.DataFrame
        One row per (camera, variant, draw, grid phase): ``phase_forward, phase_left,
        n_frames, n_gt, n_windows, n_detections, lamr, build_seconds, detect_seconds``.
    """
    from joblib import Parallel, delayed

    frames_all = [f for g in groups.values() for f in g]
    grid = grid_phases(phases)
    keys = [("true", -1)] + [(f"focal {m}", k) for k in range(n_detector_draws)
                             for m in FOCAL_MODES]
    failed, rows, tasks = set(), [], []
    for name, group in groups.items():
        for variant, k in keys:
            if variant == "true":
                cam = group[0].camera
            else:
                r = recovered[name][k][variant.split()[1]]
                cam = None if r is None else r.camera
            row = {"camera": name, "variant": variant, "draw": k, "n_frames": len(group),
                   "n_gt": int(sum(len(f.gt) for f in group))}
            # one row per phase, in this order; a run fills its row when it is done
            for a, b in grid:
                rows.append(row | {"phase_forward": a, "phase_left": b, "lamr": np.nan})
                if cam is not None:
                    tasks.append((len(rows) - 1, cam, group,
                                  cache_dir if variant == "true" else None, (a, b)))
            if cam is None:
                failed.add((variant, k))
    dets = {(v, k, p): [] for v, k in keys for p in grid}
    run = Parallel(n_jobs=n_jobs, return_as="generator")(
        delayed(_detect_frames)(cam, models, group, cache, p)
        for _, cam, group, cache, p in tasks)
    for (i, _, group, _, p), (d, n_windows, build, detect) in zip(tasks, run):
        row = rows[i]
        dets[(row["variant"], row["draw"], p)] += d
        row |= {"n_windows": n_windows, "n_detections": int(sum(len(x) for x in d)),
                "lamr": float(evaluate_method(d, group)["lamr"]),
                "build_seconds": build, "detect_seconds": detect}
        if progress:
            k = row["draw"]
            print(f"  {row['camera']} [{row['variant']}{'' if k < 0 else f', draw {k}'}, grid "
                  f"phase {p[0]:g},{p[1]:g}]: {n_windows} windows, operator {build:.0f} s, "
                  f"{len(group)} frames {detect:.1f} s", flush=True)
    rng = np.random.default_rng([seed, 17])
    true = [dets[("true", -1, p)] for p in grid]
    out = []
    for variant, k in keys:
        if (variant, k) in failed:
            out.append({"variant": variant, "draw": k, "lamr": np.nan, "n_phases": len(grid),
                        "n_detections": 0, "lamr_minus_true": np.nan, "diff_ci_low": np.nan,
                        "diff_ci_high": np.nan, "within_bar": False})
            continue
        d = [dets[(variant, k, p)] for p in grid]
        per_phase = np.array([evaluate_method(x, frames_all)["lamr"] for x in d])
        row = {"variant": variant, "draw": k, "lamr": float(per_phase.mean()),
               "lamr_sd": float(per_phase.std(ddof=1)) if len(grid) > 1 else 0.0,
               "lamr_min": float(per_phase.min()), "lamr_max": float(per_phase.max()),
               "lamr_grid0": float(per_phase[0]), "n_phases": len(grid),
               "n_detections": int(sum(len(x) for x in d[0]))}
        if variant == "true":
            row |= {"lamr_minus_true": 0.0, "diff_ci_low": 0.0, "diff_ci_high": 0.0,
                    "within_bar": True}
        else:
            diff, lo, hi = phase_mean_difference(d, true, frames_all, n_boot=n_boot, rng=rng)
            row |= {"lamr_minus_true": diff, "diff_ci_low": lo, "diff_ci_high": hi,
                    "within_bar": bool(abs(diff) <= LAMR_BAR)}
        out.append(row)
    cols = ["camera", "variant", "draw", "phase_forward", "phase_left", "n_frames", "n_gt",
            "n_windows", "n_detections", "lamr", "build_seconds", "detect_seconds"]
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
    n_phases = int(true["n_phases"])
    side = int(round(np.sqrt(n_phases)))
    if n_phases > 1:
        grid_text = (f"Each camera's candidate windows are scored at {side} x {side} phases of "
                     "their ground grid (offsets of 0, "
                     + ", ".join(f"{i}/{side}" for i in range(1, side))
                     + " of a stride along each ground axis); a LAMR is the mean over "
                     "the phases, and the interval resamples the frames for every phase of "
                     "both cameras. The true cameras' LAMR alone moves between "
                     f"{fmt_number(true['lamr_min'])} and {fmt_number(true['lamr_max'])} "
                     f"(sd {fmt_number(true['lamr_sd'])}) with where their grid falls.")
    else:
        grid_text = "One grid phase (the default grid)."
    lines = ["", "## Detector check (adapted HOG)", "",
             f"Persons {', '.join(f'{h:g}' for h in PERSON_HEIGHTS)} m; model: {model}. "
             f"LAMR over all {n_frames} frames against the same ground truth; the interval "
             f"is a 95 % paired bootstrap over frames ({n_boot} replicates). {grid_text} "
             f"The bar: the first draw's recovered cameras within {LAMR_BAR:g} LAMR of the "
             "true ones.", "",
             "| cameras used | LAMR | sd over phases | min…max | default grid | minus true | "
             f"95 % CI | detections (default grid) | within {LAMR_BAR:g} |",
             "|---|---|---|---|---|---|---|---|---|"]

    def cells(r):
        return (f"{fmt_number(r['lamr'], '.4f')} | {fmt_number(r.get('lamr_sd'), '.4f')} | "
                f"{fmt_number(r.get('lamr_min'))}…{fmt_number(r.get('lamr_max'))} | "
                f"{fmt_number(r.get('lamr_grid0'), '.4f')}")

    lines.append(f"| true | {cells(true)} | — | — | {true['n_detections']} | — |")
    for v in VARIANTS[1:]:
        if v not in first.index:
            continue
        r = first.loc[v]
        lines.append(f"| recovered (draw 0), {v} | {cells(r)} | "
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
    lines += ["", "Per camera (the true cameras and the first draw's, means over the grid "
              "phases; every phase and draw in `calibration_detector.csv`):", "",
              "| camera | cameras used | frames | persons | windows | detections | LAMR |",
              "|---|---|---|---|---|---|---|"]
    sel = per_camera[per_camera["draw"] <= 0]
    for (name, variant), g in sel.groupby(["camera", "variant"], sort=False):
        nw, nd = g["n_windows"].mean(), g["n_detections"].mean()
        nw = "n/a" if pd.isna(nw) else f"{nw:.0f}"
        nd = "n/a" if pd.isna(nd) else f"{nd:.0f}"
        lines.append(f"| {name} | {variant} | {g['n_frames'].iloc[0]} | {g['n_gt'].iloc[0]} | "
                     f"{nw} | {nd} | {fmt_number(g['lamr'].mean(), '.4f')} |")
    return lines
