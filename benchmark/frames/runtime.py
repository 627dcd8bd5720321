"""The paper's Table 1 for this implementation: frames per second per method.

    viewadapt bench runtime --data DIR --out DIR [--frames 3] [--warp-windows 1000]

Timing set-up (Wang et al. 2017, Sec. 5.5): 384x288 frames (the dataset's frames, resized
if needed) seen by a CAVIAR-like calibration -- 5 m high, 25 degrees down, 75-degree
horizontal field of view -- with persons of 1.65 and 1.85 m, which gives about 30,000
candidate windows (the paper: 31,603 on CAVIAR). The detectors are trained on the
dataset's elevation-0 crops. Single core: OpenCV and BLAS limited to one thread, one
process. All cores: one single-threaded process per core, each detecting frames, the
frames per second of all of them together (only for methods faster than ~1 s per frame).
The image-warping methods are timed on ``--warp-windows`` windows and extrapolated to all
candidate windows (they cost the same per window). Ratios against the baselines, measured
in the same run on the same machine, are the result; absolute fps depend on the machine.
The adapted detectors' stages (features, scoring, NMS) are also set against a
memory-bandwidth floor measured in the same run: a plain copy (``np.copyto`` into a
preallocated array) of as many bytes as the stage reads and writes at least once
(:func:`stage_bytes`). Not a test: nothing here asserts a time.

Measuring and judging are apart: :func:`measure_runtime` times the methods and returns
the measurements; :func:`runtime_ratios` and :func:`judge_runtime` derive the speed-ups and
the verdicts from measurements alone, against the targets of :data:`RUNTIME_TARGETS`;
:func:`run_runtime` composes the two.
"""

from __future__ import annotations

import os
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from viewadapt.detect import DEFAULT_FRAME_VIEW, DETECTOR_KINDS
from viewadapt.io import DEFAULT_CACHE_LIMIT_GB

__all__ = ["RuntimeTarget", "RUNTIME_TARGETS", "TIMING_SIZE", "timing_camera",
           "single_thread", "stage_bytes", "copy_floor_ms", "timing_frames", "time_one_core",
           "time_all_cores", "measure_runtime", "runtime_quantities", "runtime_ratios",
           "judge_runtime", "run_runtime", "format_table"]

#: frame size (width, height) every method is timed on
TIMING_SIZE = (384, 288)


@dataclass(frozen=True)
class RuntimeTarget:
    """A target of ``bench runtime``: a measured quantity, over a baseline's frames per
    second measured in the same run when there is a baseline, held against a bound.

    Attributes
    ----------
    quantity : str
        What is measured (a key of :func:`runtime_quantities`): a method's name for its
        frames per second on one core, or a named measurement (``"nms_ms"``,
        ``"hog_precompute_s"``, ...).
    baseline : str or None
        The method whose frames per second (one core) ``quantity`` is divided by: the
        target is a speed-up; None: ``quantity`` itself is judged.
    bound : float
        The least (or, with ``at_most``, the largest) value that meets the target.
    what : str
        The target in words, as the report and ``info["targets"]`` name it.
    at_most : bool
        True: met when the value is at most ``bound``; False: at least ``bound``.
    """

    quantity: str
    baseline: str | None
    bound: float
    what: str
    at_most: bool = False


#: the targets ``bench runtime`` judges, in the order the report lists them; speed-ups are
#: against baselines timed in the same run on the same machine
RUNTIME_TARGETS = (
    RuntimeTarget("hog_adapted", None, 30.0, "hog_adapted >= 30 fps (1 core)"),
    RuntimeTarget("hog_adapted", "hog_warp", 100.0, "hog_adapted >= 100x hog_warp"),
    RuntimeTarget("hog_adapted", "opencv", 10.0, "hog_adapted >= 10x opencv (4x)"),
    RuntimeTarget("acf_adapted", None, 15.0, "acf_adapted >= 15 fps (1 core)"),
    RuntimeTarget("hog_adapted", None, 100.0, "hog_adapted >= 100 fps (1 core)"),
    RuntimeTarget("acf_adapted", None, 60.0, "acf_adapted >= 60 fps (1 core)"),
    RuntimeTarget("nms_ms", None, 1.0, "NMS <= 1 ms (both detectors)", at_most=True),
    RuntimeTarget("hog_precompute_s", None, 30.0, "precompute <= 30 s (hog)", at_most=True),
    RuntimeTarget("hog_cache_hit_s", None, 1.0, "cache hit <= 1 s (hog)", at_most=True),
)

#: the speed-ups of the report, (method, baseline) -> name; the paper's beside them
RATIOS = {("hog_adapted", "hog_warp"): "hog_adapted / hog_warp",
          ("hog_adapted", "opencv"): "hog_adapted / opencv (4x)",
          ("hog_adapted", "opencv_native"): "hog_adapted / opencv (native)",
          ("hog_adapted", "hog_pyramid"): "hog_adapted / hog_pyramid",
          ("acf_adapted", "acf_warp"): "acf_adapted / acf_warp",
          ("acf_adapted", "acf_pyramid"): "acf_adapted / acf_pyramid",
          ("acf_adapted", "acf_pyramid_fast"): "acf_adapted / acf_pyramid_fast"}
#: the faster of the two ACF pyramids: the baseline the ACF speed-up is claimed against
FASTER_ACF_PYRAMID = "acf_adapted / faster ACF pyramid"
PAPER_RATIOS = {"paper: hog_adapted / hog_warp": 11.8 / 0.0666,
                "paper: acf_adapted / acf_warp": 10.7 / 0.0419,
                "paper: hog_adapted / hog_pyramid": 11.8 / 0.439,
                "paper: acf_adapted / acf_pyramid": 10.7 / 3.54,
                "paper: acf_adapted / acf_pyramid_fast": 10.7 / 3.54,
                "paper: acf_adapted / faster ACF pyramid": 10.7 / 3.54}


def timing_camera(size=TIMING_SIZE):
    """The CAVIAR-like calibration used for timing (see the module docstring)."""
    from viewadapt.geometry import camera_from_pose

    w, h = size
    return camera_from_pose(focal=(w / 2) / np.tan(np.radians(37.5)),
                            principal_point=((w - 1) / 2, (h - 1) / 2), height=5.0,
                            tilt=np.radians(25), image_size=(w, h))


def single_thread():
    """OpenCV and BLAS limited to one thread: a context manager (threadpoolctl's)."""
    import cv2
    from threadpoolctl import threadpool_limits

    cv2.setNumThreads(1)
    return threadpool_limits(1)


def _best(fn, repeat):
    ts = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t)
    return float(np.median(ts)), float(np.min(ts))


def stage_bytes(op, image, features, scores, n_candidates, n_detections):
    """Bytes each stage of an adapted detector reads and writes at least once on one frame.

    Parameters
    ----------
    op : MultiResolutionOperator
        An adapted operator (HOG: linear templates; ACF: boosted trees).
    image : (M, N, 3) uint8 ndarray
        The frame.
    features : list of FrameFeatures
        ``op.frame_features(image)``.
    scores : (W,) float64 ndarray
        ``op.scores(features)``.
    n_candidates, n_detections : int
        Windows that reach non-maximum suppression, and the detections it keeps.

    Returns
    -------
    dict stage -> int
        ``features``: the frame read and the cell maps written (float32, every cell size,
        padding included); ``scoring``: those cell maps read, the adapted weights read once
        (HOG: the shared templates, float32; ACF: the trees' remapped feature rows, float32
        weights and int32 offsets) and the scores written; ``nms``: the scores read, the
        candidates' boxes and scores and the detections written (``(x, y, w, h, score)``
        float64 rows).
    """
    maps = sum(m.nbytes for f in features for m in f.maps.values())
    weights = 0
    for layer in op.layers:
        lop = layer.operator
        if hasattr(lop, "run_tables"):             # boosted trees: the rows of G they reach
            _, _, _, (_, _, offsets, w) = lop.run_tables()
            weights += offsets.nbytes + w.nbytes
        else:                                      # linear: the shared adapted templates
            weights += sum(g.template.nbytes for g in lop.groups)
    return {"features": int(image.nbytes + maps),
            "scoring": int(maps + weights + scores.nbytes),
            "nms": int(scores.nbytes + 40 * (n_candidates + n_detections))}


def copy_floor_ms(nbytes, repeat=25):
    """Median milliseconds of ``np.copyto`` of ``nbytes`` bytes into a preallocated array
    (both arrays touched first): the memory-bandwidth floor of a stage moving those bytes."""
    src = np.ones(max(1, int(nbytes)), np.uint8)
    dst = np.zeros_like(src)
    np.copyto(dst, src)
    return 1e3 * _best(lambda: np.copyto(dst, src), repeat)[0]


def _worker(cache_dir, cache_limit_gb, model_path, heights, method, frames, seconds):
    """Detect frames in a loop for ``seconds``; return the number done and the time."""
    single_thread()
    from benchmark.frames.methods import FrameMethods
    from viewadapt.io import SourceDetectors

    models = SourceDetectors.load(model_path)
    det = FrameMethods(timing_camera(), models, person_heights=heights, cache_dir=cache_dir,
                       cache_limit_gb=cache_limit_gb, thresholds={"hog": 0.0, "acf": 0.0})
    for kind in DETECTOR_KINDS:
        if method.startswith(kind + "_adapted"):
            det.adapted.operator(kind)
    det.detect(method, frames[0])                  # warm-up
    n, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        det.detect(method, frames[n % len(frames)])
        n += 1
    return n, time.perf_counter() - t0


def _pyramid_pixels(size, upsample, step, per_level=lambda w, h: w * h):
    from benchmark.frames.methods import pyramid_scales

    w, h = size
    return int(sum(per_level(round(w * s), round(h * s))
                   for s in pyramid_scales(size, upsample, step)))


def timing_frames(data, n_frames=3, size=TIMING_SIZE):
    """The first ``n_frames`` frames of the dataset (at least one), resized to ``size``
    (``cv2.INTER_AREA``) where they are another size: a list of uint8 images."""
    import cv2

    from benchmark.frames.methods import load_frames

    frames = []
    for f in load_frames(data)[:max(1, n_frames)]:
        img = f.image()
        if (img.shape[1], img.shape[0]) != size:
            img = cv2.resize(img, size, interpolation=cv2.INTER_AREA)
        frames.append(img)
    return frames


def _time_operators(det, models, cam, cache):
    """Each adapted operator's precompute, cache save and cache hit: a dict of seconds,
    template counts and cell sizes per detector kind."""
    info = {}
    for kind in DETECTOR_KINDS:
        t = time.perf_counter()
        op = det.adapted.operator(kind)
        info[f"{kind}_precompute_s"] = round(time.perf_counter() - t, 2)
        parts = dict(camera=cam.to_dict(), kind=kind, model=models.fingerprint(),
                     **det.adapted.params)
        cache.save(parts, op)
        t = time.perf_counter()
        cache.load(parts)
        info[f"{kind}_cache_hit_s"] = round(time.perf_counter() - t, 2)
        info[f"{kind}_templates"] = op.n_templates
        info[f"{kind}_cell_sizes"] = op.cell_sizes
    return info


def _adapted_row(det, kind, frames, repeat):
    """The adapted detector ``kind`` timed stage by stage, each stage beside its
    memory-bandwidth floor, and end to end: its row of the table."""
    from viewadapt.nms import detections_from_scores

    op, thr = det.adapted.operator(kind), det.thr[kind]
    feats = [op.frame_features(f) for f in frames]
    tf = _best(lambda: op.frame_features(frames[0]), repeat)[0]
    ts = _best(lambda: op.scores(feats[0]), repeat)[0]
    s = op.scores(feats[0])
    boxes = op.boxes()

    def nms():
        return detections_from_scores(boxes, s, threshold=thr, overlap=op.nms_overlap,
                                      nms_threshold=op.nms_threshold)

    tn = _best(nms, max(repeat, 25))[0]
    tt = _best(lambda: [det.detect(f"{kind}_adapted", f) for f in frames], 2)[0] / len(frames)
    nbytes = stage_bytes(op, frames[0], feats[0], s,  # NMS sees <= 2000 candidates
                         min(int((s > thr).sum()), 2000), len(nms()))
    stages = [dict(stage=name, ms=1e3 * t, bytes=nbytes[name],
                   floor_ms=copy_floor_ms(nbytes[name], max(repeat, 25)))
              for name, t in (("features", tf), ("scoring", ts), ("nms", tn))]
    return dict(method=f"{kind}_adapted", seconds_per_frame=tt, windows=len(det.windows),
                feature_pixels=op.feature_pixels(), how="measured", stages=stages,
                detail=f"features {1e3 * tf:.1f} ms, scoring {1e3 * ts:.1f} ms, "
                f"NMS {1e3 * tn:.2f} ms")


def _warp_rows(det, models, frame, warp_windows):
    """The image-warping methods timed on ``warp_windows`` windows spread over the
    candidates and extrapolated to all of them: their rows of the table."""
    from benchmark.frames.methods import warp_scores

    n_win = len(det.windows)
    k = min(warp_windows, n_win)
    idx = np.linspace(0, n_win - 1, k).astype(int)
    rows = []
    for kind in DETECTOR_KINDS:
        t = _best(lambda: warp_scores(frame, det.windows.homographies[idx], models, kind),
                  1)[1]
        rows.append(dict(method=f"{kind}_warp", seconds_per_frame=t / k * n_win,
                         windows=n_win, feature_pixels=n_win * 64 * 128,
                         how=f"extrapolated from {k} windows",
                         detail=f"{1e3 * t / k:.3f} ms per window"))
    return rows


def _pyramid_rows(models, frame, size, repeat):
    """The sliding-window baselines (HOG and ACF pyramids, OpenCV's detectMultiScale)
    timed on one frame: their rows of the table."""
    from benchmark.frames.methods import (
        ACF_PYRAMID_LAMBDAS, acf_pyramid_detect, acf_pyramid_fast_detect, hog_pyramid_detect,
        opencv_detect,
    )

    def row(method, t, pixels, detail):
        return dict(method=method, seconds_per_frame=t, windows=None, feature_pixels=pixels,
                    how="measured", detail=detail)

    lam = ", ".join(f"{x:g}" for x in ACF_PYRAMID_LAMBDAS)
    rows = [row("hog_pyramid",
                _best(lambda: hog_pyramid_detect(frame, models, threshold=0.0), 1)[1],
                _pyramid_pixels(size, 4, 1.05), "4x upsampled, scale step 1.05"),
            row("acf_pyramid",
                _best(lambda: acf_pyramid_detect(frame, models, threshold=0.0), 1)[1],
                _pyramid_pixels(size, 4, 2 ** 0.25),
                "4x upsampled, 4 scales per octave, channels at every level"),
            # Dollár et al. 2014 fast feature pyramid: channels at 1 level per octave (real),
            # the others power-law approximated -- what the paper's 3.54 fps (the toolbox) timed
            row("acf_pyramid_fast",
                _best(lambda: acf_pyramid_fast_detect(frame, models, threshold=0.0), 1)[1],
                _pyramid_pixels(size, 4, 2.0),
                "4x upsampled, 4 scales per octave, channels at 1 per octave, "
                f"approximated between (lambda LUV/mag/orient {lam})")]
    for up, name in ((4, "opencv"), (1, "opencv_native")):
        t = _best(lambda: opencv_detect(frame, upsample=up, hit_threshold=0.0),
                  2 if up == 4 else repeat)[0]
        rows.append(row(name, t, _pyramid_pixels(size, up, 1.05),
                        f"detectMultiScale, {up}x, stride 8, scale 1.05"))
    return rows


def time_one_core(frames, models, cache_dir, *, heights=(1.65, 1.85),
                  cache_limit_gb=DEFAULT_CACHE_LIMIT_GB, warp_windows=1000, size=TIMING_SIZE):
    """Every method timed on one core (call it under :func:`single_thread`).

    Parameters
    ----------
    frames : list of (288, 384, 3) uint8 ndarray
        The frames (:func:`timing_frames`), ``size`` large.
    models : SourceDetectors
        The trained source detectors.
    cache_dir : path
        Where the operators are saved and loaded again (the cache-hit time).
    heights : tuple of float
        Person heights (m) the candidate windows are selected for.
    cache_limit_gb : float
        The operator cache's size limit.
    warp_windows : int
        Windows the image-warping methods are timed on.
    size : (int, int)
        Frame size (width, height) of the timing camera.

    Returns
    -------
    rows : list of dict
        Per method: ``method``, ``seconds_per_frame``, ``windows``, ``feature_pixels``,
        ``how``, ``detail``; the adapted detectors also ``stages`` (``stage``, ``ms``,
        ``bytes``, ``floor_ms``). The adapted detectors first, then the baselines.
    info : dict
        The set-up: window selection, candidate windows, each operator's precompute and
        cache-hit seconds, templates and cell sizes, HOG's scored positions and weights per
        window, the scoring forms' milliseconds.
    """
    from benchmark.frames.methods import FrameMethods
    from benchmark.frames.scoring_forms import scoring_forms_ms
    from viewadapt.io import OperatorCache

    cam = timing_camera(size)
    t = time.perf_counter()
    # thresholds at the operating point (score 0): NMS sees what a deployment keeps
    det = FrameMethods(cam, models, person_heights=heights, cache_dir=None,
                       thresholds={"hog": 0.0, "acf": 0.0})
    info = {"window_selection_s": round(time.perf_counter() - t, 2),
            "candidate_windows": len(det.windows)}
    info.update(_time_operators(det, models, cam, OperatorCache(cache_dir, cache_limit_gb)))
    hog, acf = det.adapted.operator("hog"), det.adapted.operator("acf")
    pw = hog.position_weights()
    info["hog_scored_positions"] = int(pw.size)
    info["hog_weights_per_window"] = float(pw.mean())
    repeat = max(3, 2 * len(frames))
    # the operators' scoring loops against other forms of the same operator
    info["hog_scoring_forms_ms"], info["acf_scoring_forms_ms"] = scoring_forms_ms(
        hog, acf, frames[0], repeat)
    rows = [_adapted_row(det, kind, frames, repeat) for kind in ("hog", "acf")]
    rows += _warp_rows(det, models, frames[0], warp_windows)
    rows += _pyramid_rows(models, frames[0], size, repeat)
    return rows, info


def time_all_cores(rows, frames, model_path, *, jobs=-1, heights=(1.65, 1.85),
                   cache_dir=None, cache_limit_gb=DEFAULT_CACHE_LIMIT_GB, seconds=4.0):
    """Frames per second on one core and on all cores, added to each row in place.

    Every row gets ``fps_1core`` (from its ``seconds_per_frame``), ``fps_all_cores`` (one
    single-threaded process per core, each detecting ``frames`` in a loop for ``seconds``
    with the models saved at ``model_path``, the frames of all of them together; None for
    methods slower than 1 s per frame or with one process) and ``paper_fps`` (the paper's,
    or None). Returns the number of processes.
    """
    from joblib import Parallel, delayed

    from benchmark.frames.methods import PAPER_FPS

    n_jobs = os.cpu_count() if jobs in (None, -1, 0) else int(jobs)
    for r in rows:
        r["fps_1core"] = 1.0 / r["seconds_per_frame"]
        r["fps_all_cores"] = None
        if r["seconds_per_frame"] < 1.0 and n_jobs > 1:
            res = Parallel(n_jobs=n_jobs)(
                delayed(_worker)(cache_dir, cache_limit_gb, model_path, heights, r["method"],
                                 frames, seconds) for _ in range(n_jobs))
            r["fps_all_cores"] = sum(n for n, _ in res) / max(t for _, t in res)
        r["paper_fps"] = PAPER_FPS.get(r["method"])
    return n_jobs


def measure_runtime(data, *, n_frames=3, warp_windows=1000, heights=(1.65, 1.85), jobs=-1,
                    seed=0, quick=True, cache_dir=None, throughput_seconds=4.0,
                    frame_view=DEFAULT_FRAME_VIEW, cache_limit_gb=DEFAULT_CACHE_LIMIT_GB):
    """Train the detectors on ``data`` and time every method on its frames; judge nothing.

    The models (and the operator cache, unless ``cache_dir`` is given) live in a temporary
    folder for the run, removed when it ends, whether it succeeds or raises.

    Returns
    -------
    rows : list of dict
        Per method, :func:`time_one_core`'s row with :func:`time_all_cores`'s columns.
    info : dict
        ``training`` (how the detectors were trained), :func:`time_one_core`'s set-up,
        ``cores`` (processes of the all-cores column) and ``load_average`` (the 1-minute
        load average after the one-core timing, None where the system has none).
    """
    from benchmark.data import load_dataset
    from benchmark.frames.methods import train_source_detectors

    frames = timing_frames(data, n_frames)
    models = train_source_detectors(load_dataset(data), seed=seed, quick=quick,
                                    frame_view=frame_view)
    with tempfile.TemporaryDirectory(prefix="viewadapt-runtime-") as tmp:
        cache_dir = Path(cache_dir) if cache_dir else Path(tmp) / "cache"
        model_path = Path(tmp) / "models.npz"
        models.save(model_path)
        with single_thread():
            rows, setup = time_one_core(frames, models, cache_dir, heights=heights,
                                        cache_limit_gb=cache_limit_gb,
                                        warp_windows=warp_windows)
        load = os.getloadavg()[0] if hasattr(os, "getloadavg") else None
        cores = time_all_cores(rows, frames, model_path, jobs=jobs, heights=heights,
                               cache_dir=cache_dir, cache_limit_gb=cache_limit_gb,
                               seconds=throughput_seconds)
    return rows, {"training": models.training, **setup, "cores": cores, "load_average": load}


def runtime_quantities(rows, info) -> dict:
    """The quantities targets are judged on, taken from measurements alone.

    Each method's frames per second on one core (keyed by the method's name; rows without
    ``fps_1core`` are left out), ``nms_ms`` (the slowest NMS stage among the rows with
    ``stages``, milliseconds; absent without any) and every number in ``info`` whose key
    ends in ``_s`` (seconds: ``hog_precompute_s``, ``hog_cache_hit_s``, ...).
    """
    q = {r["method"]: r["fps_1core"] for r in rows if r.get("fps_1core") is not None}
    nms = [st["ms"] for r in rows for st in r.get("stages") or () if st["stage"] == "nms"]
    if nms:
        q["nms_ms"] = max(nms)
    q.update({k: v for k, v in info.items()
              if k.endswith("_s") and isinstance(v, (int, float)) and not isinstance(v, bool)})
    return q


def runtime_ratios(rows) -> dict:
    """The report's speed-ups from the rows' frames per second (one core), the paper's
    beside them (``"paper: "`` and the same name).

    One entry per pair of :data:`RATIOS` both measured, then ``"acf_adapted / faster ACF
    pyramid"`` (against the faster of ``acf_pyramid`` and ``acf_pyramid_fast``) where all
    three are, then the paper's ratios.
    """
    fps = runtime_quantities(rows, {})
    out = {name: fps[m] / fps[b] for (m, b), name in RATIOS.items() if m in fps and b in fps}
    if {"acf_adapted", "acf_pyramid", "acf_pyramid_fast"} <= fps.keys():
        out[FASTER_ACF_PYRAMID] = fps["acf_adapted"] / max(fps["acf_pyramid"],
                                                           fps["acf_pyramid_fast"])
    return {**out, **PAPER_RATIOS}


def judge_runtime(rows, info, targets=RUNTIME_TARGETS) -> list:
    """Each target held against the measurements (:func:`runtime_quantities` of ``rows``
    and ``info``); measures nothing.

    Returns
    -------
    list of dict
        Per target, in order: ``target`` (its ``what``), ``value`` (the quantity, or the
        quantity over the baseline's frames per second; None when not judged), ``bound``,
        ``met`` (bool; None when not judged) and ``missing`` (the quantity or baseline not
        measured, or not positive for a baseline; None when judged).
    """
    q = runtime_quantities(rows, info)
    out = []
    for t in targets:
        value, missing = q.get(t.quantity), None
        if value is None:
            missing = t.quantity
        elif t.baseline is not None:
            base = q.get(t.baseline)
            value, missing = (value / base, None) if base else (None, t.baseline)
        met = None if value is None else bool(value <= t.bound if t.at_most
                                              else value >= t.bound)
        out.append(dict(target=t.what, value=value, bound=t.bound, met=met, missing=missing))
    return out


def run_runtime(data, **options):
    """Time every method and judge the measurements; return (rows, info).

    ``options`` are :func:`measure_runtime`'s; so are ``rows`` and ``info``, to which this
    adds ``ratios`` (:func:`runtime_ratios`), ``faster_acf_pyramid`` (the ACF pyramid of
    more frames per second), ``paper_windows`` (the paper's candidate windows) and
    ``targets`` (each target of :data:`RUNTIME_TARGETS` -> met, :func:`judge_runtime`).
    """
    from benchmark.frames.methods import PAPER_WINDOWS

    rows, info = measure_runtime(data, **options)
    fps = runtime_quantities(rows, {})
    info["ratios"] = runtime_ratios(rows)
    info["faster_acf_pyramid"] = max(("acf_pyramid", "acf_pyramid_fast"), key=fps.get)
    info["paper_windows"] = PAPER_WINDOWS
    info["targets"] = {v["target"]: v["met"] for v in judge_runtime(rows, info)}
    return rows, info


def format_table(rows, info) -> str:
    """Markdown: ratios first (the headline), then Table 1 with the paper beside ours."""
    out = ["# Runtime (Table 1 of Wang et al. 2017, this implementation)", "",
           f"{info['candidate_windows']} candidate windows on a 384x288 frame (paper: "
           f"{info['paper_windows']} on CAVIAR); HOG: {info['hog_scored_positions']} "
           f"distinct scored positions, {info['hog_weights_per_window']:.0f} adapted weights "
           f"each, {info['hog_templates']} shared templates, cell sizes "
           f"{', '.join(f'{c:g}' for c in info['hog_cell_sizes'])} frame px (under 2 px: "
           "cells of the 2x-upsampled frame).", "", "## Speed-ups measured in the same run", "",
           "| ratio | ours | paper |", "|---|---|---|"]
    r = info["ratios"]
    for k in ("hog_adapted / hog_warp", "acf_adapted / acf_warp", "hog_adapted / hog_pyramid",
              "acf_adapted / acf_pyramid", "acf_adapted / acf_pyramid_fast"):
        out.append(f"| {k} | {r[k]:.0f}x | {r['paper: ' + k]:.0f}x |")
    k = "acf_adapted / faster ACF pyramid"
    out.append(f"| **{k}** ({info['faster_acf_pyramid']}: the baseline the ACF speed-up is "
               f"claimed against; the paper's 3.54 fps is the toolbox's fast pyramid) | "
               f"{r[k]:.0f}x | {r['paper: ' + k]:.0f}x |")
    for k in ("hog_adapted / opencv (4x)", "hog_adapted / opencv (native)"):
        out.append(f"| {k} | {r[k]:.1f}x | - |")
    out += ["", "## Frames per second", "",
            "| method | fps, 1 core | fps, all cores | paper fps (1 i7 core) | windows | "
            "feature pixels | how |", "|---|---|---|---|---|---|---|"]
    for row in rows:
        allc = f"{row['fps_all_cores']:.2f}" if row["fps_all_cores"] else "-"
        paper = f"{row['paper_fps']}" if row["paper_fps"] else "-"
        win = f"{row['windows']}" if row["windows"] else "-"
        out.append(f"| {row['method']} | {row['fps_1core']:.3g} | {allc} | {paper} | {win} | "
                   f"{row['feature_pixels']:.3g} | {row['how']}; {row['detail']} |")
    out += ["", "## Stages against a memory-bandwidth floor (one core, one frame)", "",
            "Floor: a plain copy (np.copyto, preallocated) of as many bytes as the stage "
            "reads and writes at least once, timed in this run -- features: the frame in, the "
            "cell maps out; scoring: the cell maps and the adapted weights in, the scores out; "
            "NMS: the scores in, candidates and detections. Fraction = floor / stage (1 = at "
            "the floor).", "",
            "| method | stage | ms | MB read + written | floor ms | fraction of floor |",
            "|---|---|---|---|---|---|"]
    for row in rows:
        for st in row.get("stages", ()):
            out.append(f"| {row['method']} | {st['stage']} | {st['ms']:.2f} | "
                       f"{st['bytes'] / 1e6:.3g} | {st['floor_ms']:.3f} | "
                       f"{st['floor_ms'] / st['ms']:.3f} |")
    out += ["", "## Scoring, forms of the same operator (one core, same scores)", "",
            "| detector | form | ms per frame |", "|---|---|---|"]
    for kind in DETECTOR_KINDS:
        for k, v in info.get(f"{kind}_scoring_forms_ms", {}).items():
            out.append(f"| {kind.upper()} | {k} | {v} |")
    out += ["", f"Precompute (one camera, one model): HOG {info['hog_precompute_s']} s, ACF "
            f"{info['acf_precompute_s']} s; cache hit HOG {info['hog_cache_hit_s']} s, ACF "
            f"{info['acf_cache_hit_s']} s; window selection {info['window_selection_s']} s.",
            (f"All cores = {info['cores']} processes, each detecting on its own frames"
             if info["cores"] > 1 else "All cores not measured (--jobs 1)")
            + "; load average at the end "
            + ("n/a" if info["load_average"] is None else f"{info['load_average']:.2f}") + ".",
            "Detectors trained with " + ", ".join(
                f"{k}={v}" for k, v in info.get("training", {}).items()) + ".",
            "", "## Targets", ""]
    for t in RUNTIME_TARGETS:
        met = info["targets"].get(t.what)
        out.append(f"- {t.what}: "
                   + ("not judged (not measured)" if met is None else "met" if met else "NOT met"))
    return "\n".join(out) + "\n"
