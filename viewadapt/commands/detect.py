"""The ``viewadapt detect`` command: adapted detection on one calibrated camera's frames."""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from viewadapt.camera.distortion import Undistortion
from viewadapt.detect.detector import FrameDetector
from viewadapt.detect.evaluation import evaluate_detections
from viewadapt.detect.kinds import DETECTOR_KINDS
from viewadapt.detect.layers import UPSAMPLE_BELOW
from viewadapt.detect.stream import DetectorSpec, detect_stream
from viewadapt.geometry import PERSON_HEIGHT_M
from viewadapt.io.boxes import read_boxes
from viewadapt.io.cache import DEFAULT_CACHE_LIMIT_GB, check_cache_limit
from viewadapt.io.calibration import read_calibration, read_distortion
from viewadapt.io.files import atomic_output_dir, atomic_write_text, check_output_dir, run_metadata
from viewadapt.io.models import SourceDetectors, shipped_model_path
from viewadapt.io.outputs import plot_det_figure
from viewadapt.io.outputs import ANNOTATE_CHOICES, DetectionWriter
from viewadapt.io.video import open_frames, prefetched
from viewadapt.objectmodel import OBJECT_MODELS
from viewadapt.remap import ANGLE_RULES

__all__ = ["LENS_CHOICES", "DEFAULT_LENS", "register", "cmd_detect", "check_frame_selection",
           "person_heights", "cache_limit", "add_cache_options", "lens_correction"]


#: How ``detect`` handles a calibration's lens distortion (``--lens``); ``auto`` maps the
#: windows through the lens with the plane object model and undistorts the frames with the
#: body model (whose windows cannot be mapped through a lens).
LENS_CHOICES = ("auto", "windows", "undistort")
DEFAULT_LENS = "auto"


_CORRECTION_NOTE = {None: "", "undistort": ", undistorted",
                    "windows": ", windows through the lens"}


def lens_correction(dist, lens: str, object_model: str):
    """How ``detect`` handles a calibration's lens: None (no ``dist``), "undistort" or
    "windows" (``lens`` one of :data:`LENS_CHOICES`)."""
    if dist is None:
        return None
    if lens == "auto":
        return "windows" if object_model == "plane" else "undistort"
    return lens


def person_heights(text):
    """argparse type: comma-separated person heights in metres."""
    try:
        vals = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"cannot read person heights {text!r} "
                                         "(metres, comma-separated)") from None
    if not vals or any(not np.isfinite(v) or v <= 0 for v in vals):
        raise argparse.ArgumentTypeError("person heights must be positive metres")
    return vals


def cache_limit(text):
    """argparse type: a cache size limit in GB (>= 0)."""
    try:
        return check_cache_limit(float(text))
    except ValueError:
        raise argparse.ArgumentTypeError(f"the cache limit must be >= 0 GB, got {text!r}") \
            from None


def add_cache_options(p):
    """``--cache`` and ``--cache-limit`` of the commands that build adapted operators."""
    p.add_argument("--cache", type=Path, default=None,
                   help="operator cache directory (default OUT/cache)")
    p.add_argument("--cache-limit", type=cache_limit, default=DEFAULT_CACHE_LIMIT_GB,
                   metavar="GB",
                   help="size limit of the cache directory: the least recently used "
                        f"operators are deleted first (default {DEFAULT_CACHE_LIMIT_GB:g}; "
                        "0 = no limit)")


def check_frame_selection(args) -> None:
    """One-line ``ValueError`` for ``--every``/``--max-frames`` below 1, ``--start`` below 0
    or ``--jobs`` 0 or below -1 (before anything is read or written)."""
    if args.every < 1:
        raise ValueError(f"--every must be at least 1, got {args.every}")
    if args.start < 0:
        raise ValueError(f"--start must be at least 0 (frames are numbered from 0), got "
                         f"{args.start}")
    if args.max_frames is not None and args.max_frames < 1:
        raise ValueError(f"--max-frames must be at least 1, got {args.max_frames}")
    if args.jobs == 0 or args.jobs < -1:
        raise ValueError(f"--jobs must be at least 1, or -1 for all cores, got {args.jobs}")


def _frame_size_error(frame, stream, cam) -> str:
    h, w = frame.image.shape[:2]
    where = (f"frame {frame.index} of {stream.name}" if stream.kind == "video"
             else f"frame {frame.source}")
    return (f"{where} is {w}x{h} px, the calibration is for {cam.image_size[0]}x"
            f"{cam.image_size[1]}")


def _metadata(args, det, stream, writer, dist, correction, annotate, *, operator_seconds,
              seconds, cpu_seconds) -> dict:
    """metadata.json of a detect run: what ran on what, and how fast (``correction``:
    :func:`lens_correction`'s)."""
    return run_metadata(
        args.seed, detector=f"{args.detector}_adapted", rule=args.rule,
        object_model=args.object_model, threshold=args.threshold,
        person_heights=list(det.params["person_heights"]), windows=len(det.windows),
        input=stream.describe(), frames=writer.n_frames, detections=writer.n_detections,
        annotate=annotate, jobs=args.jobs, model=str(args.model),
        model_training=det.models.training,
        undistortion=None if correction != "undistort" else {
            "dist": dist.tolist(),
            "method": "every frame remapped (cv2.remap, bilinear) with maps precomputed once "
                      "by cv2.initUndistortRectifyMap, new camera matrix = K: boxes and "
                      "annotations are in the undistorted frame's pixels"},
        lens_windows=None if correction != "windows" else {
            "dist": dist.tolist(),
            "method": "each candidate window's homography refitted to where the lens puts "
                      "its pixels (viewadapt.detect.windows_through_lens); the frames are "
                      "read as they are: boxes and annotations are in their pixels"},
        ground_position="the ground point (world X, Y, metres) of the detection's candidate "
                        "window",
        operator_seconds=round(operator_seconds, 2),
        operator_from_cache=det.cache_hit.get(args.detector), seconds=round(seconds, 2),
        frames_per_second=round(writer.n_frames / max(seconds, 1e-9), 2),
        cpu_seconds=round(cpu_seconds, 3),
        cpu_seconds_note="CPU time of this process over the frames, all its threads (the "
                         "frames are read in a second thread); --jobs workers' not included",
        camera=det.camera.to_dict())


def cmd_detect(args) -> int:
    """Detect persons in frames of one calibrated camera (a video, a folder, a glob
    pattern or image files)."""
    from itertools import chain

    from tqdm.auto import tqdm

    check_output_dir(args.out, overwrite=args.overwrite)
    check_frame_selection(args)
    cam = read_calibration(args.calibration)
    dist = read_distortion(args.calibration)
    correction = lens_correction(dist, args.lens, args.object_model)
    undistort = Undistortion(cam.K, dist, cam.image_size) \
        if correction == "undistort" else None
    stream = open_frames(args.inputs, start=args.start, every=args.every,
                         max_frames=args.max_frames)
    if args.model is None:
        args.model = shipped_model_path()
    models = SourceDetectors.load(args.model)
    boxes = None
    if args.boxes:
        if stream.paths is None:
            raise ValueError("--boxes needs image frames (ground truth is matched by file "
                             "name); a video's frames have none")
        boxes = read_boxes(args.boxes, stream.paths)
    frames = iter(stream)
    first = next(frames, None)
    if first is None:
        raise ValueError(f"video {stream.name} has no frames" + (
            f" from --start {args.start} (it has {stream.n_total})"
            if args.start and stream.n_total else ""))
    if (first.image.shape[1], first.image.shape[0]) != tuple(cam.image_size):
        raise ValueError(_frame_size_error(first, stream, cam))

    def prepared(frames):
        for f in frames:
            if (f.image.shape[1], f.image.shape[0]) != tuple(cam.image_size):
                raise ValueError(_frame_size_error(f, stream, cam))
            yield f if undistort is None else f._replace(image=undistort(f.image))

    annotate = args.annotate
    if annotate == "auto":
        annotate = "video" if stream.kind == "video" else "frames"
    options = dict(person_heights=args.heights, cache_dir=args.cache or (args.out / "cache"),
                   cache_limit_gb=args.cache_limit,
                   upsample_below=UPSAMPLE_BELOW if args.upsample_below is None
                   else args.upsample_below,
                   thresholds={args.detector: args.threshold}, rule=args.rule,
                   object_model=args.object_model)
    if correction == "windows":
        options["lens"] = dist.tolist()
    spec = DetectorSpec.create(cam, args.model, args.detector, **options)
    det = FrameDetector(cam, models, **options)
    t0 = time.perf_counter()
    det.operator(args.detector)         # built (or read from the cache) before any output
    t_operator = time.perf_counter() - t0
    dets, names = [], []
    t0, c0 = time.perf_counter(), time.process_time()
    with atomic_output_dir(args.out) as tmp:
        with DetectionWriter(tmp, annotate=annotate, fps=stream.fps,
                             image_size=cam.image_size) as writer, \
                tqdm(total=stream.n_frames, desc="detect", unit="frame", dynamic_ncols=True,
                     disable=args.quiet) as bar:
            # the next frames are read (and undistorted) in a second thread meanwhile
            for frame, found in detect_stream(prefetched(prepared(chain([first], frames))),
                                              spec, jobs=args.jobs, detector=det):
                writer.write(frame, found)
                if boxes is not None:
                    dets.append(found.boxes)
                    names.append(frame.source)
                bar.update(1)
        seconds, cpu_seconds = time.perf_counter() - t0, time.process_time() - c0
        evaluation = None
        if boxes is not None:
            truth = [(*boxes[n], cam.image_size) for n in names]
            ev = evaluate_detections(dets, truth)
            evaluation = {"lamr": ev["lamr"], "n_gt": int(sum(len(t[0]) for t in truth)),
                          "fppi": ev["fppi"].tolist(), "miss_rate": ev["miss_rate"].tolist()}
            atomic_write_text(tmp / "evaluation.json", json.dumps(evaluation))
            plot_det_figure({f"{args.detector}_adapted": ev}, tmp / "det",
                            title=f"{len(names)} frames, {evaluation['n_gt']} persons")
        atomic_write_text(tmp / "metadata.json", json.dumps(_metadata(
            args, det, stream, writer, dist, correction, annotate, operator_seconds=t_operator,
            seconds=seconds, cpu_seconds=cpu_seconds), indent=2))
    wrote = ["detections.csv", "detections_coco.json", "det.txt"] + {
        "video": ["annotated.mp4"], "frames": ["annotated/"], "none": []}[annotate]
    print(f"{writer.n_detections} detections in {writer.n_frames} frames "
          f"({len(det.windows)} candidate windows, {writer.n_frames / max(seconds, 1e-9):.1f} "
          f"frames/s{_CORRECTION_NOTE[correction]}); wrote "
          f"{args.out}/{', '.join(wrote)}")
    if evaluation is not None:
        print(f"against {evaluation['n_gt']} boxes of {args.boxes}: log-average miss rate "
              f"{evaluation['lamr']:.3f} over 1e-2..1e0 FPPI (evaluation.json, det.png)")
    return 0


def register(sub, common) -> None:
    """Add ``detect`` to the ``viewadapt`` parser ``sub`` (``common``: the shared options)."""
    p = sub.add_parser(
        "detect", parents=[common], help="detect persons in a calibrated camera's video or "
                                         "frames",
        description="Viewpoint-adapted detection over world-space windows of one calibrated "
                    "camera. The calibration file is YAML or JSON with image_size and either "
                    "K, R, t (OpenCV convention, world Z up, ground Z = 0) or focal, height "
                    "(m), tilt (degrees below horizontal) [, principal_point, roll], and "
                    "optionally dist (OpenCV lens distortion coefficients, see --lens). "
                    "Frames are streamed from a video, a folder, a glob "
                    "pattern or image files. Writes detections.csv (frame, source, box, "
                    "score, ground position in metres), detections_coco.json (COCO "
                    "results), det.txt (MOTChallenge) and annotated.mp4 or annotated/*.png; "
                    "--jobs splits the frames over processes with the same results.")
    p.add_argument("inputs", nargs="+", metavar="INPUT",
                   help="a video file (mp4, avi: anything OpenCV reads), a folder of images, "
                        "a quoted glob pattern ('frames/*.png'), or image files (PNG, JPEG, "
                        "...); a folder's or pattern's images are read in natural order "
                        "(frame_2 before frame_10), files in the order given")
    p.add_argument("--start", type=int, default=0, metavar="K",
                   help="index of the first frame read, counting from 0 (default 0)")
    p.add_argument("--every", type=int, default=1, metavar="N",
                   help="read every N-th frame from --start on (default 1)")
    p.add_argument("--max-frames", type=int, default=None, metavar="M",
                   help="read at most M frames (default: all)")
    p.add_argument("--annotate", choices=["auto", *ANNOTATE_CHOICES], default="auto",
                   help="write the frames with their boxes: video (annotated.mp4), frames "
                        "(annotated/*.png) or none (default auto: video for a video input, "
                        "frames for images)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--calibration", type=Path, required=True, help="calibration YAML/JSON")
    p.add_argument("--model", type=Path, default=None,
                   help="source detectors: models/source_detectors.npz written by `viewadapt "
                        "bench frames` (default: the models shipped with viewadapt, trained "
                        "on the paper preset's elevation-0 crops)")
    p.add_argument("--detector", choices=list(DETECTOR_KINDS), default="hog",
                   help="the adapted detector (default hog: HOG/SVM; acf: boosted trees on ACF)")
    p.add_argument("--rule", choices=list(ANGLE_RULES), default="covariant",
                   help="angle rule of A: covariant (default, J^-T), paper (the literal eq. 3) "
                        "or none (S only)")
    p.add_argument("--object-model", choices=list(OBJECT_MODELS), default="plane",
                   help="how a person's pixels move between the views: plane (default, the "
                        "paper's person plane) or body (a mean body shape shipped with the "
                        "package; slower to build, cached)")
    p.add_argument("--lens", choices=LENS_CHOICES, default=DEFAULT_LENS,
                   help="with dist in the calibration: windows (map the candidate windows "
                        "through the lens once and read the frames as they are; boxes in "
                        "their pixels), undistort (remap every frame first; boxes in the "
                        "undistorted frame's pixels) or auto: windows, undistort with "
                        "--object-model body (default auto; docs/findings.md, lens "
                        "distortion, has the measurement)")
    p.add_argument("--threshold", type=float, default=0.0, help="score threshold (default 0)")
    p.add_argument("--heights", type=person_heights, default=(PERSON_HEIGHT_M,),
                   help="assumed person heights, metres, comma-separated (default 1.75)")
    add_cache_options(p)
    p.add_argument("--upsample-below", type=float, default=None,
                   help="windows of persons smaller than 96 x this many px read the frame "
                        f"upsampled 2x (default {UPSAMPLE_BELOW:g}, i.e. "
                        f"{96 * UPSAMPLE_BELOW:.0f} px; 0 = never)")
    p.add_argument("--boxes", type=Path, default=None,
                   help="optional ground truth to evaluate against: CSV with frame,x,y,w,h"
                        "[,occlusion] or COCO JSON; writes evaluation.json and det.png "
                        "(miss rate vs FPPI, log-average miss rate)")
    p.set_defaults(func=cmd_detect)
