"""Speed of ``viewadapt detect`` on a video against the bare adapted detector.

    python -m benchmark.studies.footage_speed --data DIR [--frames 150] [--model M] [--out DIR]

The bar: on a 384x288 clip, ``viewadapt detect`` with the shipped HOG model runs
within 10 % of the adapted detector's own frame rate (``bench runtime``'s adapted fps),
decoding and undistortion included. Both are timed here, in one process with OpenCV and
BLAS limited to one thread, on the same frames and the same operator; the command reads
(and undistorts) the next frames in a second thread while it detects, so its CPU time per
frame is reported beside the frame rates:

``detect (video)``
    the ``viewadapt detect`` command on an mp4 of the frames (decoding, detection with
    ground positions, ``detections.csv``, COCO, ``det.txt``; no annotated video), the
    operator read from the cache; its own frames per second (``metadata.json``, which
    leaves out loading the operator);
``detect (video, dist)``
    the same with lens distortion in the calibration (the clip distorted by
    :func:`viewadapt.camera.distort_image`), so every frame is undistorted first;
``detect (video, dist, lens windows)``
    the same distorted clip with ``--lens windows``: the candidate windows mapped through
    the lens once, the frames read as they are (no undistortion); compared with the bare
    detector on the undistorted frames (the pinhole detector's fps);
``detector``, per clip
    :meth:`FrameDetector.detect <viewadapt.detect.FrameDetector.detect>` at the score
    threshold 0 the command uses by default (``bench runtime``'s operating point) on the
    very images the command's detector sees -- the clip decoded, and undistorted, into
    memory beforehand -- timed before a command's first run and after each of its
    ``--repeats`` runs. Each run's fps is divided by the mean fps of the two detector
    timings around it, and the median of these paired ratios, with a distribution-free
    95 % interval (:func:`median_interval`), is the result, so that a drift of the
    machine's speed between runs cancels. The detector's own cost depends on the images
    (non-maximum suppression on what passes the threshold, more on a compressed clip
    than on the PNGs), so each command is compared
    with the detector on its own input: the ratio is what decoding, undistortion and
    writing the outputs cost.

The frames are the dataset's, resized to 384x288 and seen by ``bench runtime``'s timing
camera (:func:`benchmark.frames.runtime.timing_camera`). Ratios against the bare detector,
measured in the same run, are the result; nothing here asserts a time.
"""

from __future__ import annotations

import argparse
import json
import math
import tempfile
import time
from pathlib import Path

import numpy as np

from benchmark.studies import report_error

#: a moderate barrel lens for the distorted clip (k1, k2, p1, p2, k3)
DISTORTION = (-0.25, 0.08, 0.0, 0.0, 0.0)
SIZE = (384, 288)

__all__ = ["DISTORTION", "SIZE", "clip_frames", "write_clip", "write_calibration",
           "median_interval", "run_footage_benchmark", "format_table", "write_study", "main"]


def clip_frames(data, n_frames: int) -> list:
    """``n_frames`` RGB frames of 384x288: the dataset's frames resized, repeated in order."""
    import cv2

    from benchmark.frames.methods import load_frames

    base = []
    for f in load_frames(data):
        img = f.image()
        if (img.shape[1], img.shape[0]) != SIZE:
            img = cv2.resize(img, SIZE, interpolation=cv2.INTER_AREA)
        base.append(img)
    return [base[i % len(base)] for i in range(n_frames)]


def write_clip(path, frames, fps: float = 25.0) -> Path:
    """An mp4 (mp4v) of RGB ``frames`` of :data:`SIZE` at ``path``."""
    import cv2

    vw = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), fps, SIZE)
    if not vw.isOpened():
        raise RuntimeError("OpenCV cannot write mp4v video here")
    for img in frames:
        vw.write(np.ascontiguousarray(img[:, :, ::-1]))
    vw.release()
    return Path(path)


def write_calibration(path, camera, dist=None) -> Path:
    """A calibration JSON (``image_size``, ``K``, ``R``, ``t`` [, ``dist``]) at ``path``."""
    doc = {"image_size": list(camera.image_size), "K": camera.K.tolist(),
           "R": camera.R.tolist(), "t": camera.t.tolist()}
    if dist is not None:
        doc["dist"] = list(dist)
    Path(path).write_text(json.dumps(doc))
    return Path(path)


def median_interval(values, level: float = 0.95) -> tuple[float, float, float]:
    """Distribution-free interval for the median of ``values``: order statistics.

    The interval ``[x_(k), x_(n+1-k)]`` of the sorted values with the largest ``k`` whose
    coverage ``1 - 2 P(Binomial(n, 1/2) < k)`` is at least ``level`` (the sign test's
    interval, e.g. Conover, *Practical Nonparametric Statistics*, 3rd ed., Sec. 3.2). With
    too few values for ``level`` (fewer than 6 at 0.95) it is the whole range, and its
    coverage, returned, is below ``level``.

    Returns
    -------
    (low, high, coverage)
    """
    x = np.sort(np.asarray(values, dtype=float))
    n = len(x)
    if n == 0:
        raise ValueError("no values")

    def coverage(k):                # of [x_(k), x_(n+1-k)]: 1 - 2 P(B < k)
        return 1 - 2 * sum(math.comb(n, i) for i in range(k)) / 2.0 ** n

    k = 1
    while k < (n + 1) // 2 and coverage(k + 1) >= level:
        k += 1
    cover = coverage(k)
    return float(x[k - 1]), float(x[n - k]), float(cover)


def run_footage_benchmark(data, *, n_frames: int = 150, model=None, heights=(1.65, 1.85),
                          workdir=None, repeats: int = 9) -> dict:
    """Time the bare detector and the ``viewadapt detect`` command on the same clip.

    Each command runs ``repeats`` times, each run between two timings of the bare detector
    on the images that command's detector sees (``repeats + 1`` of them, alternating). A
    run's ratio is its fps over the mean fps of the two detector timings around it, so
    that a machine whose speed drifts affects both sides of a ratio alike; a row reports
    the median of its ratios with :func:`median_interval`'s 95 % interval, and, for
    comparison with the earlier estimator, the fastest command run over the fastest
    detector timing.

    Returns a dict with ``rows`` (method, frames, median seconds and fps, the ratios) and
    the set-up (windows, model, operator build seconds).
    """
    if repeats < 1:
        raise ValueError(f"repeats must be at least 1, got {repeats}")
    from viewadapt.cli import main as viewadapt_main
    from viewadapt.camera import Undistortion, distort_image
    from viewadapt.detect import FrameDetector
    from viewadapt.io import SourceDetectors, open_frames, shipped_model_path

    from benchmark.frames.runtime import single_thread, timing_camera

    model = Path(model) if model else shipped_model_path()
    work = Path(workdir) if workdir else Path(tempfile.mkdtemp(prefix="viewadapt-footage-"))
    cache = work / "cache"
    frames = clip_frames(data, n_frames)
    cam = timing_camera(SIZE)
    rows = []
    with single_thread():
        # threshold 0: the command's default, and bench runtime's operating point
        det = FrameDetector(cam, SourceDetectors.load(model), person_heights=heights,
                            cache_dir=cache, thresholds={"hog": 0.0})
        t = time.perf_counter()
        det.operator("hog")
        build = time.perf_counter() - t
        det.detect(frames[0], "hog")                      # warm-up

        def bare(images):
            t, c = time.perf_counter(), time.process_time()
            for img in images:
                det.detect(img, "hog")
            return time.perf_counter() - t, time.process_time() - c

        plain = write_clip(work / "clip.mp4", frames)
        bent = write_clip(work / "clip_dist.mp4",
                           [distort_image(img, cam.K, DISTORTION) for img in frames])
        # (row, clip, dist, --lens); the lens-windows row reads the distorted clip as it is
        # and is compared with the bare detector on its undistorted frames (the pinhole
        # detector's speed)
        runs = [("detect (video)", plain, None, "undistort"),
                ("detect (video, dist)", bent, DISTORTION, "undistort"),
                ("detect (video, dist, lens windows)", bent, DISTORTION, "windows")]
        for name, clip, dist, lens in runs:
            if lens == "undistort":
                undistort = Undistortion(cam.K, dist, SIZE) if dist is not None else None
                seen = [f.image if undistort is None else undistort(f.image)
                        for f in open_frames(clip)]
                detector_name = name.replace("detect", "detector on the decoded clip")
            cal = write_calibration(work / f"{clip.stem}.json", cam, dist)
            timings = [bare(seen)]
            metas = []
            for r in range(repeats):
                out = work / (f"out_{clip.stem}_{lens}" + (f"_{r}" if r else ""))
                rc = viewadapt_main(["detect", "--calibration", str(cal), "--model",
                                     str(model), "--cache", str(cache), "--annotate", "none",
                                     "--quiet", "--threshold", "0", "--lens", lens,
                                     "--heights", ",".join(f"{h:g}" for h in heights),
                                     "--out", str(out), str(clip)])
                if rc != 0:
                    raise RuntimeError(f"viewadapt detect failed on {clip} (exit {rc})")
                metas.append(json.loads((out / "metadata.json").read_text()))
                timings.append(bare(seen))
            bare_fps = np.array([len(seen) / s for s, _ in timings])
            cmd_fps = np.array([m["frames_per_second"] for m in metas])
            ratios = cmd_fps / ((bare_fps[:-1] + bare_fps[1:]) / 2)
            low, high, cover = median_interval(ratios)
            if lens == "undistort":
                rows.append(dict(
                    method=detector_name, frames=len(seen),
                    seconds=float(np.median([s for s, _ in timings])),
                    fps=float(np.median(bare_fps)), ratio_to_detector=1.0,
                    ratio_low=1.0, ratio_high=1.0, ratio_fastest=1.0,
                    cpu_ms_per_frame=float(np.median([1e3 * c / len(seen)
                                                      for _, c in timings]))))
            rows.append(dict(
                method=name, frames=metas[0]["frames"],
                seconds=float(np.median([m["seconds"] for m in metas])),
                fps=float(np.median(cmd_fps)), ratio_to_detector=float(np.median(ratios)),
                ratio_low=low, ratio_high=high, ratio_coverage=cover,
                ratio_fastest=float(cmd_fps.max() / bare_fps.max()),
                ratios=[round(float(x), 4) for x in ratios],
                cpu_ms_per_frame=float(np.median([1e3 * m["cpu_seconds"] / m["frames"]
                                                  for m in metas]))))
    return {"rows": rows, "windows": len(det.windows), "model": str(model),
            "operator_build_s": round(build, 2), "frame_size": list(SIZE),
            "distortion": list(DISTORTION), "repeats": repeats}


def format_table(result) -> str:
    lines = [f"`viewadapt detect` on a {result['frame_size'][0]}x{result['frame_size'][1]} "
             f"clip, OpenCV limited to one thread, {result['windows']} candidate windows, model "
             f"`{result['model']}` (operator built in {result['operator_build_s']} s, not "
             f"timed below); {result['repeats']} runs of each command, each between two "
             "timings of the bare detector on the images it sees.", "",
             "| method | frames | s (median) | fps (median) | / detector: median of the "
             "paired ratios [95 % interval] | fastest / fastest | CPU ms / frame |",
             "|---|---|---|---|---|---|---|"]
    for r in result["rows"]:
        paired = (f"{r['ratio_to_detector']:.3f} [{r['ratio_low']:.3f}, "
                  f"{r['ratio_high']:.3f}]") if "ratios" in r else "1"
        lines.append(f"| {r['method']} | {r['frames']} | {r['seconds']:.2f} | "
                     f"{r['fps']:.1f} | {paired} | {r['ratio_fastest']:.3f} | "
                     f"{r['cpu_ms_per_frame']:.2f} |")
    runs = [r for r in result["rows"] if "ratios" in r]
    worst = min(runs, key=lambda r: r["ratio_to_detector"])
    cover = min(r["ratio_coverage"] for r in runs)
    lines += ["", f"Bar: the command within 10 % of the detector's fps, on the "
              f"median paired ratio: {'met' if worst['ratio_to_detector'] >= 0.9 else 'NOT met'}"
              f" (lowest median {worst['ratio_to_detector']:.3f}, {worst['method']}); every "
              f"interval above 0.9: {'yes' if min(r['ratio_low'] for r in runs) >= 0.9 else 'no'}"
              f" (intervals' coverage at least {100 * cover:.1f} %).", "",
              "The command reads and undistorts the next frames in a second thread while it "
              "detects (`viewadapt.io.prefetched`); its CPU time per frame counts both "
              "threads over its frame loop (`cpu_seconds` of its metadata.json: reading, "
              "undistorting, detecting, writing), the detector's its detection loop."]
    return "\n".join(lines) + "\n"


def write_study(out, stem: str, table: str, data, result: dict) -> None:
    """Print a footage study's ``table`` and, with ``out``, write it atomically as
    ``out/STEM.md`` beside ``out/STEM.json`` (the run's metadata and ``result``)."""
    from viewadapt.io.files import atomic_output_dir, run_metadata

    print(table)
    if out is not None:
        with atomic_output_dir(out) as tmp:
            (tmp / f"{stem}.md").write_text(table)
            (tmp / f"{stem}.json").write_text(json.dumps(
                run_metadata(0, data=str(data), **result), indent=2))


def main(argv=None) -> int:
    from viewadapt.io.files import check_output_dir

    ap = argparse.ArgumentParser(prog="python -m benchmark.studies.footage_speed",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, required=True, help="dataset directory with frames")
    ap.add_argument("--frames", type=int, default=150, help="frames in the clip (default 150)")
    ap.add_argument("--repeats", type=int, default=9,
                    help="runs of each command, each between two timings of the bare "
                         "detector; the median of their paired ratios is the result "
                         "(default 9)")
    ap.add_argument("--model", type=Path, default=None,
                    help="source detectors (default: the shipped models)")
    ap.add_argument("--out", type=Path, default=None,
                    help="write footage.md and footage.json here (default: print only)")
    ap.add_argument("--overwrite", action="store_true")
    args = ap.parse_args(argv)
    try:
        if args.frames < 2:
            raise ValueError(f"--frames must be at least 2, got {args.frames}")
        if args.repeats < 1:
            raise ValueError(f"--repeats must be at least 1, got {args.repeats}")
        if args.out is not None:
            check_output_dir(args.out, overwrite=args.overwrite)
        result = run_footage_benchmark(args.data, n_frames=args.frames, model=args.model,
                                       repeats=args.repeats)
    except (ValueError, FileNotFoundError) as exc:
        return report_error(ap, exc)
    write_study(args.out, "footage", format_table(result), args.data, result)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
