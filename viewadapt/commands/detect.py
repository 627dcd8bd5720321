"""The ``viewadapt detect`` command: adapted detection on one calibrated camera's frames."""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from viewadapt.boxes import mapped_boxes
from viewadapt.camera.distortion import Undistortion, distort_points
from viewadapt.detect.detector import (DEFAULT_BOX_VOTING, DEFAULT_THRESHOLD, FrameDetector,
                                      check_box_voting)
from viewadapt.detect.evaluation import (
    BOOTSTRAP_BLOCK, BOOTSTRAP_DRAWS, evaluation_matches, frame_outcome, matches_summary,
    matches_threshold_at_fppi,
)
from viewadapt.detect.kinds import DETECTOR_KINDS, PRETRAINED_KINDS, PRETRAINED_UPSAMPLE_BELOW
from viewadapt.detect.layers import UPSAMPLE_BELOW, check_upsample_below
from viewadapt.detect.stream import DetectorSpec, detect_stream, pretrained_kinds
from viewadapt.detect.windows import GROUND_STRIDE_M, MIN_PERSON_HEIGHT_PX, check_ground_stride
from viewadapt.geometry import PERSON_HEIGHT_M
from viewadapt.io.boxes import FrameBoxes, read_boxes, read_ignore_regions
from viewadapt.io.cache import DEFAULT_CACHE_LIMIT_GB, check_cache_limit
from viewadapt.io.calibration import read_calibration_file
from viewadapt.io.files import atomic_output_dir, atomic_write_text, check_output_dir, run_metadata
from viewadapt.io.models import SourceDetectors, shipped_model_path
from viewadapt.io.outputs import (
    ANNOTATE_CHOICES, AnnotationWriter, DetectionWriter, draw_detections, plot_det_figure,
)
from viewadapt.io.video import open_frames, prefetched
from viewadapt.objectmodel import OBJECT_MODELS
from viewadapt.remap import ANGLE_RULES

__all__ = ["LENS_CHOICES", "DEFAULT_LENS", "register", "cmd_detect", "check_frame_selection",
           "person_heights", "ground_stride", "add_ground_stride_option", "box_voting",
           "add_box_voting_option", "cache_limit", "add_cache_options", "lens_correction",
           "boxes_in_input_pixels"]


#: How ``detect`` handles a calibration's lens distortion (``--lens``); ``auto`` maps the
#: windows through the lens with the plane object model and undistorts the frames with the
#: body model (the measured default; ``windows`` maps the body's windows through the lens).
LENS_CHOICES = ("auto", "windows", "undistort")
DEFAULT_LENS = "auto"


_CORRECTION_NOTE = {None: "", "undistort": ", undistorted",
                    "windows": ", windows through the lens"}


def lens_correction(dist, lens: str):
    """How ``detect`` handles a calibration's lens: None (no ``dist``), "undistort" or
    "windows" (``lens`` one of :data:`LENS_CHOICES`; ``auto``: the windows through the lens,
    for every object model)."""
    if dist is None:
        return None
    return "windows" if lens == "auto" else lens


def boxes_in_input_pixels(boxes, K, dist) -> np.ndarray:
    """Detections ``(x, y, w, h, score)`` (D, 5) found on the undistorted frame -> the same
    detections in the distorted input's pixels (:func:`viewadapt.boxes.mapped_boxes`
    through :func:`~viewadapt.camera.distortion.distort_points`)."""
    return mapped_boxes(boxes, lambda p: distort_points(p, K, dist))


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


def ground_stride(text):
    """argparse type: the candidate windows' ground stride, metres: one number, or
    ``FORWARD,LATERAL``."""
    try:
        return check_ground_stride([float(v) for v in text.split(",")])
    except ValueError:
        raise argparse.ArgumentTypeError(f"cannot read the ground stride {text!r} (positive "
                                         "metres: one, or forward,lateral)") from None


def add_ground_stride_option(p) -> None:
    """``--ground-stride``, shared by ``detect`` and ``bench footage``."""
    p.add_argument("--ground-stride", type=ground_stride, default=None, metavar="M[,M]",
                   help="the candidate windows' ground grid, metres between ground positions: "
                        f"one stride, or forward,lateral (default {GROUND_STRIDE_M:.4f} both "
                        "ways, the paper's). A lateral stride of half (e.g. 0.1458,0.0729) "
                        "doubles the windows across the view, for more time per frame "
                        "(docs/real_footage.md has the measurement)")


def box_voting(text):
    """argparse type: box voting's temperature (a finite number >= 0)."""
    try:
        return check_box_voting(float(text))
    except ValueError:
        raise argparse.ArgumentTypeError(f"cannot read the box voting temperature {text!r} "
                                         "(a finite number >= 0, 0 for none)") from None


def add_box_voting_option(p) -> None:
    """``--box-voting``, shared by ``detect``, ``bench footage`` and ``bench frames``."""
    p.add_argument("--box-voting", type=box_voting, default=DEFAULT_BOX_VOTING, metavar="TAU",
                   help="after non-maximum suppression, each box becomes the mean of the "
                        "candidate boxes overlapping it, weighted by exp(score difference / "
                        f"TAU); scores are kept (default {DEFAULT_BOX_VOTING:g}). Centres "
                        "boxes that the strongest window frames off a person "
                        "(docs/real_footage.md has the measurement). 0: none, each box the "
                        "kept window's")


def upsample_below(text):
    """argparse type: the person scale below which windows read the frame upsampled
    (a finite number >= 0)."""
    try:
        return check_upsample_below(text, "the upsampling threshold")
    except ValueError:
        raise argparse.ArgumentTypeError(f"cannot read the upsampling threshold {text!r} (a "
                                         "finite number >= 0, 0 for never)") from None


def add_upsample_below_option(p) -> None:
    """``--upsample-below``, shared by ``detect``, ``bench frames`` and ``bench footage``."""
    p.add_argument("--upsample-below", type=upsample_below, default=None, metavar="S",
                   help="windows of persons smaller than 96 x S px read the frame "
                        "upsampled 2x; 0 = never (default: each detector's own, "
                        f"{UPSAMPLE_BELOW:g} for hog and acf, i.e. {96 * UPSAMPLE_BELOW:.0f} px; "
                        f"{PRETRAINED_UPSAMPLE_BELOW:g} for opencv and daimler, trained on "
                        "their windows alone)")


def min_height(text):
    """argparse type: a person height in pixels (>= 0)."""
    try:
        v = float(text)
    except ValueError:
        v = float("nan")
    if not (0 <= v < 1e4):
        raise argparse.ArgumentTypeError(f"the minimum person height must be >= 0 px, got "
                                         f"{text!r}")
    return v


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


def _calibration_import(imported) -> dict | None:
    """How an imported calibration (Tsai XML, OpenCV FileStorage) was read, or None."""
    if imported is None:
        return None
    out = {"format": {"tsai": "PETS 2009 / Tsai XML",
                      "opencv": "OpenCV FileStorage"}[imported.format]}
    if imported.fit_error_px is not None:
        out["lens_fit_max_error_px"] = round(imported.fit_error_px, 4)
        out["lens_fit"] = ("Tsai's radial lens (distorted -> undistorted) fitted by OpenCV's "
                           "k1, k2, k3 over a 30 x 20 grid of image points")
    return out


#: what each pretrained detector's model is (metadata.json's ``model``)
_PRETRAINED_MODELS = {"opencv": "OpenCV's HOGDescriptor_getDefaultPeopleDetector (INRIA Person, "
                                "Dalal & Triggs 2005)",
                      "daimler": "OpenCV's HOGDescriptor_getDaimlerPeopleDetector (48x96, "
                                 "Daimler pedestrian data, Enzweiler & Gavrila 2009)"}


def _metadata(args, det, stream, writer, dist, correction, annotate, *, imported,
              operator_seconds, seconds, cpu_seconds) -> dict:
    """metadata.json of a detect run: what ran on what, and how fast (``correction``:
    :func:`lens_correction`'s)."""
    return run_metadata(
        args.seed, detector=f"{args.detector}_adapted", rule=args.rule,
        object_model=args.object_model, threshold=args.threshold,
        stage=any(getattr(L.operator, "stage", None) is not None
                  for L in det.operator(args.detector).layers),
        person_heights=list(det.params["person_heights"]), min_person_height=args.min_height,
        ground_stride=list(check_ground_stride(det.params.get("ground_stride",
                                                               GROUND_STRIDE_M))),
        windows=len(det.windows), box_voting=det.box_voting,
        upsample_below=det.upsample_below(args.detector),
        input=stream.describe(), frames=writer.n_frames, detections=writer.n_detections,
        annotate=annotate, annotate_threshold=args.annotate_threshold,
        annotate_fppi=args.annotate_fppi, jobs=args.jobs,
        model=_PRETRAINED_MODELS[args.detector]
        if args.detector in PRETRAINED_KINDS and args.model is None else str(args.model),
        model_training=None if args.detector in PRETRAINED_KINDS else det.models.training,
        calibration=str(args.calibration),
        calibration_import=_calibration_import(imported),
        undistortion=None if correction != "undistort" else {
            "dist": dist.tolist(),
            "method": "every frame remapped (cv2.remap, bilinear) with maps precomputed once "
                      "by cv2.initUndistortRectifyMap, new camera matrix = K; each box found "
                      "there mapped back through the lens (its corners and edge midpoints, "
                      "their bounding box): boxes and annotations are in the input frames' "
                      "pixels"},
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


def _annotate_again(args, folder, annotate, dets, truth, annotation, cam) -> None:
    """The second pass of ``--annotate-fppi``: the input read again and each frame drawn
    with its detections (in the input's pixels) at the operating point."""
    stream = open_frames(args.inputs, start=args.start, every=args.every,
                         max_frames=args.max_frames)
    with AnnotationWriter(folder, annotate, fps=stream.fps or 25.0,
                          image_size=cam.image_size) as out:
        for frame, d, t in zip(stream, dets, truth):
            out.write(frame, draw_detections(frame.image, d, **annotation(d, t)))


def cmd_detect(args) -> int:
    """Detect persons in frames of one calibrated camera (a video, a folder, a glob
    pattern or image files)."""
    from itertools import chain

    from tqdm.auto import tqdm

    check_output_dir(args.out, overwrite=args.overwrite)
    check_frame_selection(args)
    if args.threshold is None:
        args.threshold = DEFAULT_THRESHOLD if args.boxes else 0.0
    calibration = read_calibration_file(args.calibration)
    cam, dist = calibration.camera, calibration.dist
    correction = lens_correction(dist, args.lens)
    undistort = Undistortion(cam.K, dist, cam.image_size) \
        if correction == "undistort" else None
    stream = open_frames(args.inputs, start=args.start, every=args.every,
                         max_frames=args.max_frames)
    kinds = {}
    if args.detector in PRETRAINED_KINDS:         # its weights come with it, or in --model
        models = None
        kinds = pretrained_kinds(args.detector, args.model)
    else:
        if args.model is None:
            args.model = shipped_model_path()
        models = SourceDetectors.load(args.model)
    boxes = regions = None
    if args.ignore is not None and args.boxes is None:
        raise ValueError("--ignore needs --boxes (ignore regions are part of the evaluation)")
    if args.bootstrap_block < 1:
        raise ValueError(f"--bootstrap-block must be at least 1 frame, got "
                         f"{args.bootstrap_block}")
    if args.boxes:
        # images: by file name or the number a name ends in; a video: by frame index
        boxes = read_boxes(args.boxes, stream.paths,
                           n_frames=stream.n_total if stream.paths is None else None)
    if args.ignore is not None:
        regions = read_ignore_regions(args.ignore)
    frames = iter(stream)
    first = next(frames, None)
    if first is None:
        raise ValueError(f"video {stream.name} has no frames" + (
            f" from --start {args.start} (it has {stream.n_total})"
            if args.start and stream.n_total else ""))
    if (first.image.shape[1], first.image.shape[0]) != tuple(cam.image_size):
        raise ValueError(_frame_size_error(first, stream, cam))

    originals = {}          # frame index -> the input's image, while its undistorted copy is out

    def prepared(frames):
        for f in frames:
            if (f.image.shape[1], f.image.shape[0]) != tuple(cam.image_size):
                raise ValueError(_frame_size_error(f, stream, cam))
            if undistort is None:
                yield f
            else:
                originals[f.index] = f.image
                yield f._replace(image=undistort(f.image))

    annotate = args.annotate
    if annotate == "auto":
        annotate = "video" if stream.kind == "video" else "frames"
    if args.annotate_fppi is not None and (args.boxes is None or annotate == "none"):
        raise ValueError("--annotate-fppi reads the operating point off the evaluated clip: "
                         "it needs --boxes and annotated output")
    # with --annotate-fppi the frames are annotated in a second pass, after the evaluation
    later = args.annotate_fppi is not None

    def annotation(boxes, t):
        """draw_detections' keywords at the operating point (hits and misses with --boxes)."""
        out = dict(threshold=args.annotate_threshold, scores=True)
        if t is not None:
            labels, status = frame_outcome(boxes, (t.boxes, t.occlusion, cam.image_size,
                                                   t.ignore),
                                           threshold=out["threshold"], regions=regions)
            out.update(labels=labels, truth=t.boxes, status=status)
        return out
    options = dict(person_heights=args.heights, min_person_height=args.min_height,
                   **({} if args.ground_stride is None
                      else {"ground_stride": list(args.ground_stride)}),
                   box_voting=args.box_voting,
                   cache_dir=args.cache or (args.out / "cache"),
                   cache_limit_gb=args.cache_limit,
                   upsample_below=args.upsample_below,
                   thresholds={args.detector: args.threshold}, rule=args.rule,
                   object_model=args.object_model, stage=args.stage == "on")
    if correction == "windows":
        options["lens"] = dist.tolist()
    spec = DetectorSpec.create(cam, args.model or "", args.detector, **options)
    det = FrameDetector(cam, models, kinds=kinds, **options)
    t0 = time.perf_counter()
    det.operator(args.detector)         # built (or read from the cache) before any output
    t_operator = time.perf_counter() - t0
    dets, truth = [], []
    t0, c0 = time.perf_counter(), time.process_time()
    with atomic_output_dir(args.out) as tmp:
        with DetectionWriter(tmp, annotate="none" if later else annotate, fps=stream.fps,
                             image_size=cam.image_size) as writer, \
                tqdm(total=stream.n_frames, desc="detect", unit="frame", dynamic_ncols=True,
                     disable=args.quiet) as bar:
            # the next frames are read (and undistorted) in a second thread meanwhile
            for frame, found in detect_stream(prefetched(prepared(chain([first], frames))),
                                              spec, jobs=args.jobs, detector=det):
                if undistort is not None:       # back to the input's frame and pixels
                    frame = frame._replace(image=originals.pop(frame.index))
                    found = found._replace(boxes=boxes_in_input_pixels(found.boxes, cam.K,
                                                                       dist))
                t = None
                if boxes is not None:
                    key = frame.source if stream.paths is not None else frame.index
                    t = boxes.get(key, FrameBoxes.empty())
                    dets.append(found.boxes)
                    truth.append(t)
                writer.write(frame, found, annotation=None if annotate == "none" or later
                             else annotation(found.boxes, t))
                bar.update(1)
        seconds, cpu_seconds = time.perf_counter() - t0, time.process_time() - c0
        evaluation = None
        if boxes is not None:
            matches, gts = evaluation_matches(dets, truth, cam.image_size, regions=regions)
            evaluation, curve = matches_summary(matches, gts, block=args.bootstrap_block,
                                                seed=args.seed)
            evaluation = {"boxes": str(args.boxes), "ignore_regions":
                          None if args.ignore is None else str(args.ignore)} | evaluation
            if later:                   # the same matches: each frame matched once
                args.annotate_threshold = matches_threshold_at_fppi(matches, args.annotate_fppi)
                evaluation["annotate_threshold"] = args.annotate_threshold
                _annotate_again(args, tmp, annotate, dets, truth, annotation, cam)
            atomic_write_text(tmp / "evaluation.json", json.dumps(evaluation))
            plot_det_figure({f"{args.detector}_adapted": curve}, tmp / "det",
                            title=f"{len(truth)} frames, {evaluation['n_gt']} persons counted "
                                  f"({evaluation['n_gt_ignored']} ignored)")
        atomic_write_text(tmp / "metadata.json", json.dumps(_metadata(
            args, det, stream, writer, dist, correction, annotate,
            imported=calibration.imported, operator_seconds=t_operator,
            seconds=seconds, cpu_seconds=cpu_seconds), indent=2))
    wrote = ["detections.csv", "detections_coco.json", "det.txt"] + {
        "video": ["annotated.mp4"], "frames": ["annotated/"], "none": []}[annotate]
    print(f"{writer.n_detections} detections in {writer.n_frames} frames "
          f"({len(det.windows)} candidate windows, {writer.n_frames / max(seconds, 1e-9):.1f} "
          f"frames/s{_CORRECTION_NOTE[correction]}); wrote "
          f"{args.out}/{', '.join(wrote)}")
    if evaluation is not None:
        lo, hi = evaluation["lamr_ci95"]
        interval = f" (95% {lo:.3f}..{hi:.3f})" if lo is not None else ""
        print(f"against {evaluation['n_gt']} counted boxes of {args.boxes} "
              f"({evaluation['n_gt_ignored']} ignored): log-average miss rate "
              f"{evaluation['lamr']:.3f}{interval} over 1e-2..1e0 FPPI (evaluation.json, "
              "det.png)")
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
                    "optionally dist (OpenCV lens distortion coefficients, see --lens); or a "
                    "PETS 2009 / Tsai XML, or an OpenCV FileStorage file (camera_matrix, "
                    "distortion_coefficients, image_width, image_height, rvec/tvec or R/t). "
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
    p.add_argument("--calibration", type=Path, required=True,
                   help="calibration: the project's YAML/JSON, a PETS 2009 / Tsai XML or an "
                        "OpenCV FileStorage YAML/XML")
    p.add_argument("--model", type=Path, default=None,
                   help="source detectors: models/source_detectors.npz written by `viewadapt "
                        "bench frames` (default: the models shipped with viewadapt, trained "
                        "on renders alone: two renders of the paper preset's elevation-0 "
                        "crops through camera effects, recipe averaged, the two models "
                        "averaged); with --detector opencv a "
                        "64x128 HOG/SVM saved by cv2.HOGDescriptor.save (YAML or XML; "
                        "default OpenCV's INRIA-trained people detector), with --detector "
                        "daimler a 48x96 one without gamma correction")
    p.add_argument("--detector", choices=list(DETECTOR_KINDS | PRETRAINED_KINDS), default="hog",
                   help="the adapted detector (default hog: HOG/SVM; acf: boosted trees on ACF; "
                        "both trained on renders, --model; opencv: OpenCV's INRIA-trained "
                        "HOG/SVM people detector, adapted the same way; daimler: OpenCV's "
                        "48x96 Daimler-trained one)")
    p.add_argument("--rule", choices=list(ANGLE_RULES), default="covariant",
                   help="angle rule of A: covariant (default, J^-T), paper (the literal eq. 3) "
                        "or none (S only)")
    p.add_argument("--object-model", choices=list(OBJECT_MODELS), default="plane",
                   help="how a person's pixels move between the views: plane (default, the "
                        "paper's person plane) or body (a mean body shape shipped with the "
                        "package; slower to build, cached)")
    p.add_argument("--stage", choices=("on", "off"), default="on",
                   help="hog (either object model), opencv and daimler (the plane): on "
                        "(default) rescores the windows the adapted operator calls a person "
                        "with their own block normalisation "
                        "(the others keep their score); off: the adapted operator alone "
                        "(faster where many windows look like persons; docs/real_footage.md "
                        "has the measurement)")
    p.add_argument("--lens", choices=LENS_CHOICES, default=DEFAULT_LENS,
                   help="with dist in the calibration: windows (map the candidate windows "
                        "through the lens once and read the frames as they are), undistort "
                        "(remap every frame first, and the boxes found back through the "
                        "lens) or auto (default): windows, for either object model; the "
                        "boxes are in the input's pixels in every mode (docs/findings.md, "
                        "lens distortion, has the measurements)")
    p.add_argument("--threshold", type=float, default=None,
                   help="score threshold of the detections kept (default 0; with --boxes "
                        f"{DEFAULT_THRESHOLD:g}, low enough that the DET curve reaches 1 false "
                        "positive per image)")
    p.add_argument("--annotate-threshold", type=float, default=0.0, metavar="SCORE",
                   help="the operating point of the annotated frames: boxes scoring at least "
                        "this, each with its score (default 0, the classifier's own decision "
                        "boundary); with --boxes hits are green, false positives red, boxes "
                        "in ignored places grey, and the ground truth white when found, "
                        "orange when missed")
    p.add_argument("--annotate-fppi", type=float, default=None, metavar="FPPI",
                   help="with --boxes: annotate at the threshold where the evaluated clip "
                        "has this many false positives per image (e.g. 0.1; recorded in "
                        "evaluation.json) instead of --annotate-threshold; the input is "
                        "read a second time")
    p.add_argument("--heights", type=person_heights, default=(PERSON_HEIGHT_M,),
                   help="assumed person heights, metres, comma-separated (default 1.75); "
                        "each adds a window size at every ground position, so a band such "
                        "as 1.65,1.75,1.85 also tolerates a calibration whose tilt is a "
                        "little off, for more windows and false positives")
    add_ground_stride_option(p)
    add_box_voting_option(p)
    p.add_argument("--min-height", type=min_height, default=MIN_PERSON_HEIGHT_PX, metavar="PX",
                   help="persons shorter than this in the frame get no candidate window "
                        f"(default {MIN_PERSON_HEIGHT_PX:g} px; 0 = down to the horizon)")
    add_cache_options(p)
    add_upsample_below_option(p)
    p.add_argument("--boxes", type=Path, default=None,
                   help="optional ground truth to evaluate against: CSV with frame,x,y,w,h"
                        "[,occlusion,ignore], COCO JSON, MOTChallenge gt.txt or CAVIAR XML, in "
                        "the input's pixels (frames by file name or by number: the image "
                        "whose name ends in it, or a video's frame); writes evaluation.json "
                        "and det.png (miss rate vs FPPI, log-average miss rate with 95%% "
                        "intervals)")
    p.add_argument("--ignore", type=Path, default=None, metavar="REGIONS",
                   help='with --boxes: JSON {"polygons": [[[x, y], ...], ...]} of image '
                        "regions left out: detections whose bottom-centre lies in one are "
                        "dropped, ground truth there is ignored")
    p.add_argument("--bootstrap-block", type=int, default=BOOTSTRAP_BLOCK, metavar="N",
                   help="with --boxes: the intervals resample blocks of N consecutive frames "
                        f"({BOOTSTRAP_DRAWS} draws, seeded by --seed; default "
                        f"{BOOTSTRAP_BLOCK})")
    p.set_defaults(func=cmd_detect)
