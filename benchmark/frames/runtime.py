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
from pathlib import Path

import numpy as np

from viewadapt.detect import DEFAULT_FRAME_VIEW, DETECTOR_KINDS, PRETRAINED_KINDS
from viewadapt.io import DEFAULT_CACHE_LIMIT_GB

from benchmark.frames.runtime_report import (
    RUNTIME_TARGETS, RuntimeTarget, format_table, judge_runtime, runtime_quantities,
    runtime_ratios,
)
from benchmark.recipes import DEFAULT_RECIPE

# the judging and the report live in benchmark.frames.runtime_report; named here too, the
# one module a caller of `bench runtime` needs
__all__ = ["RuntimeTarget", "RUNTIME_TARGETS", "TIMING_SIZE", "timing_camera",
           "single_thread", "stage_bytes", "copy_floor_ms", "timing_frames", "time_one_core",
           "time_all_cores", "measure_runtime", "runtime_quantities", "runtime_ratios",
           "judge_runtime", "run_runtime", "format_table"]

#: frame size (width, height) every method is timed on (the paper's; ``--size`` for another)
TIMING_SIZE = (384, 288)
#: the adapted detectors timed: ours and OpenCV's INRIA-trained one
TIMED_KINDS = tuple(DETECTOR_KINDS) + tuple(sorted(PRETRAINED_KINDS))
#: thresholds at the operating point (score 0): NMS sees what a deployment keeps
_THRESHOLDS = {k: 0.0 for k in TIMED_KINDS}


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


def _worker(cache_dir, cache_limit_gb, model_path, heights, method, frames, seconds, size):
    """Detect frames in a loop for ``seconds``; return the number done and the time."""
    single_thread()
    from benchmark.frames.methods import FrameMethods
    from viewadapt.io import SourceDetectors

    models = SourceDetectors.load(model_path)
    det = FrameMethods(timing_camera(size), models, person_heights=heights, cache_dir=cache_dir,
                       cache_limit_gb=cache_limit_gb, thresholds=_THRESHOLDS)
    for kind in TIMED_KINDS:
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
    for kind in TIMED_KINDS:
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
                                      nms_threshold=op.nms_threshold,
                                      vote=det.adapted.box_voting)

    tn = _best(nms, max(repeat, 25))[0]
    # end to end: the median of ``repeat`` passes over the frames (two passes, the median
    # being their mean, moved by one slow pass on a shared machine)
    tt = _best(lambda: [det.detect(f"{kind}_adapted", f) for f in frames],
               repeat)[0] / len(frames)
    nbytes = stage_bytes(op, frames[0], feats[0], s,  # NMS sees <= 2000 candidates
                         min(int((s > thr).sum()), 2000), len(nms()))
    stages = [dict(stage=name, ms=1e3 * t, bytes=nbytes[name],
                   floor_ms=copy_floor_ms(nbytes[name], max(repeat, 25)))
              for name, t in (("features", tf), ("scoring", ts), ("nms", tn))]
    return dict(method=f"{kind}_adapted", seconds_per_frame=tt, windows=len(det.windows),
                feature_pixels=op.feature_pixels(),
                how=f"measured (median of {repeat} passes over {len(frames)} frames)",
                stages=stages,
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
    for kind in TIMED_KINDS:
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
    for up, name in ((4, "opencv"), (2, "opencv_2x"), (1, "opencv_native")):
        t = _best(lambda: opencv_detect(frame, upsample=up, hit_threshold=0.0),
                  2 if up > 1 else repeat)[0]
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
    det = FrameMethods(cam, models, person_heights=heights, cache_dir=None,
                       thresholds=_THRESHOLDS)
    info = {"window_selection_s": round(time.perf_counter() - t, 2),
            "candidate_windows": len(det.windows), "size": list(size)}
    info.update(_time_operators(det, models, cam, OperatorCache(cache_dir, cache_limit_gb)))
    hog, acf = det.adapted.operator("hog"), det.adapted.operator("acf")
    pw = hog.position_weights()
    info["hog_scored_positions"] = int(pw.size)
    info["hog_weights_per_window"] = float(pw.mean())
    repeat = max(3, 2 * len(frames))
    # the operators' scoring loops against other forms of the same operator
    info["hog_scoring_forms_ms"], info["acf_scoring_forms_ms"] = scoring_forms_ms(
        hog, acf, frames[0], repeat)
    rows = [_adapted_row(det, kind, frames, repeat) for kind in TIMED_KINDS]
    rows += _warp_rows(det, models, frames[0], warp_windows)
    rows += _pyramid_rows(models, frames[0], size, repeat)
    return rows, info


def time_all_cores(rows, frames, model_path, *, jobs=-1, heights=(1.65, 1.85),
                   cache_dir=None, cache_limit_gb=DEFAULT_CACHE_LIMIT_GB, seconds=4.0,
                   size=TIMING_SIZE):
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
                                 frames, seconds, size) for _ in range(n_jobs))
            r["fps_all_cores"] = sum(n for n, _ in res) / max(t for _, t in res)
        r["paper_fps"] = PAPER_FPS.get(r["method"])
    return n_jobs


def measure_runtime(data, *, n_frames=3, warp_windows=1000, heights=(1.65, 1.85), jobs=-1,
                    seed=0, quick=True, cache_dir=None, throughput_seconds=4.0,
                    frame_view=DEFAULT_FRAME_VIEW, cache_limit_gb=DEFAULT_CACHE_LIMIT_GB,
                    recipe=DEFAULT_RECIPE, size=TIMING_SIZE, models=None):
    """Train the detectors on ``data`` (or take ``models``, a loaded
    :class:`viewadapt.io.SourceDetectors`) and time every method on its frames, ``size``
    (width, height) large; judge nothing. The adapted HOG's normalisation stage rescores
    the windows its fold scores a person, so its time depends on the model and the frames.

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

    frames = timing_frames(data, n_frames, size)
    if models is None:
        models = train_source_detectors(load_dataset(data), seed=seed, quick=quick,
                                        frame_view=frame_view, recipe=recipe)
    with tempfile.TemporaryDirectory(prefix="viewadapt-runtime-") as tmp:
        cache_dir = Path(cache_dir) if cache_dir else Path(tmp) / "cache"
        model_path = Path(tmp) / "models.npz"
        models.save(model_path)
        with single_thread():
            rows, setup = time_one_core(frames, models, cache_dir, heights=heights,
                                        cache_limit_gb=cache_limit_gb,
                                        warp_windows=warp_windows, size=size)
        load = os.getloadavg()[0] if hasattr(os, "getloadavg") else None
        cores = time_all_cores(rows, frames, model_path, jobs=jobs, heights=heights,
                               cache_dir=cache_dir, cache_limit_gb=cache_limit_gb,
                               seconds=throughput_seconds, size=size)
    return rows, {"training": models.training, **setup, "cores": cores, "load_average": load}


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
