"""The ``viewadapt detect`` command: adapted detection on one calibrated camera's frames."""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from ..files import atomic_output_dir, check_output_dir, run_metadata
from ..geometry import PERSON_HEIGHT_M
from ..objectmodel import OBJECT_MODELS
from ..remap import ANGLE_RULES
from .cache import DEFAULT_CACHE_LIMIT_GB, check_cache_limit
from .calibration import read_boxes, read_calibration, read_frame
from .detector import FrameDetector
from .evaluation import evaluate_detections, plot_det_figure
from .kinds import DETECTOR_KINDS
from .layers import UPSAMPLE_BELOW
from .models import SourceDetectors

__all__ = ["register", "cmd_detect", "person_heights", "cache_limit", "add_cache_options"]


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


def cmd_detect(args) -> int:
    """Detect persons in frames of one calibrated camera."""
    import cv2

    check_output_dir(args.out, overwrite=args.overwrite)
    cam = read_calibration(args.calibration)
    models = SourceDetectors.load(args.model)
    paths = [Path(p) for p in args.frames]
    for p in paths:
        if not p.is_file():
            raise FileNotFoundError(f"frame {p} does not exist")
    boxes = read_boxes(args.boxes, paths) if args.boxes else None
    dets = []
    det = FrameDetector(cam, models, person_heights=args.heights,
                        cache_dir=args.cache or (args.out / "cache"),
                        cache_limit_gb=args.cache_limit,
                        upsample_below=UPSAMPLE_BELOW if args.upsample_below is None
                        else args.upsample_below,
                        thresholds={args.detector: args.threshold}, rule=args.rule,
                        object_model=args.object_model)
    method = f"{args.detector}_adapted"
    rows, coco_img, coco_ann = [], [], []
    t0 = time.perf_counter()
    with atomic_output_dir(args.out) as tmp:
        (tmp / "annotated").mkdir()
        for i, p in enumerate(paths):
            img = read_frame(p)
            if (img.shape[1], img.shape[0]) != tuple(cam.image_size):
                raise ValueError(f"frame {p} is {img.shape[1]}x{img.shape[0]} px, the "
                                 f"calibration is for {cam.image_size[0]}x{cam.image_size[1]}")
            d = det.detect(img, args.detector)
            dets.append(d)
            coco_img.append({"id": i + 1, "file_name": str(p), "width": img.shape[1],
                             "height": img.shape[0]})
            vis = img[:, :, ::-1].copy()
            for x, y, w, h, s in d:
                rows.append({"frame": str(p), "x": x, "y": y, "w": w, "h": h, "score": s})
                coco_ann.append({"id": len(coco_ann) + 1, "image_id": i + 1, "category_id": 1,
                                 "bbox": [float(x), float(y), float(w), float(h)],
                                 "score": float(s)})
                cv2.rectangle(vis, (int(round(x)), int(round(y))),
                              (int(round(x + w)), int(round(y + h))), (0, 255, 0), 1)
            cv2.imwrite(str(tmp / "annotated" / f"{i:05d}_{p.stem}.png"), vis)
        import pandas as pd

        pd.DataFrame(rows, columns=["frame", "x", "y", "w", "h", "score"]).to_csv(
            tmp / "detections.csv", index=False)
        (tmp / "detections_coco.json").write_text(json.dumps(
            {"images": coco_img, "annotations": coco_ann,
             "categories": [{"id": 1, "name": "person"}]}))
        evaluation = None
        if boxes is not None:
            truth = [(*boxes[p.name], cam.image_size) for p in paths]
            ev = evaluate_detections(dets, truth)
            evaluation = {"lamr": ev["lamr"], "n_gt": int(sum(len(t[0]) for t in truth)),
                          "fppi": ev["fppi"].tolist(), "miss_rate": ev["miss_rate"].tolist()}
            (tmp / "evaluation.json").write_text(json.dumps(evaluation))
            plot_det_figure({method: ev}, tmp / "det",
                            title=f"{len(paths)} frames, {evaluation['n_gt']} persons")
        (tmp / "metadata.json").write_text(json.dumps(run_metadata(
            args.seed, detector=method, rule=args.rule, object_model=args.object_model,
            windows=len(det.windows),
            frames=len(paths),
            seconds=round(time.perf_counter() - t0, 2), camera=cam.to_dict()), indent=2))
    print(f"{len(rows)} detections in {len(paths)} frames ({len(det.windows)} candidate "
          f"windows); wrote {args.out}/detections.csv, detections_coco.json, annotated/")
    if evaluation is not None:
        print(f"against {evaluation['n_gt']} boxes of {args.boxes}: log-average miss rate "
              f"{evaluation['lamr']:.3f} over 1e-2..1e0 FPPI (evaluation.json, det.png)")
    return 0


def register(sub, common) -> None:
    """Add ``detect`` to the ``viewadapt`` parser ``sub`` (``common``: the shared options)."""
    p = sub.add_parser(
        "detect", parents=[common], help="detect persons in calibrated frames",
        description="Viewpoint-adapted detection over world-space windows of one calibrated "
                    "camera. The calibration file is YAML or JSON with image_size and either "
                    "K, R, t (OpenCV convention, world Z up, ground Z = 0) or focal, height "
                    "(m), tilt (degrees below horizontal) [, principal_point, roll]. Writes "
                    "detections.csv, detections_coco.json and annotated/*.png.")
    p.add_argument("frames", nargs="+", type=Path, help="frame images (PNG, JPEG)")
    p.add_argument("--calibration", type=Path, required=True, help="calibration YAML/JSON")
    p.add_argument("--model", type=Path, required=True,
                   help="source detectors (models/source_detectors.npz written by "
                        "`viewadapt bench frames`)")
    p.add_argument("--detector", choices=list(DETECTOR_KINDS), default="hog",
                   help="the adapted detector (default hog: HOG/SVM; acf: boosted trees on ACF)")
    p.add_argument("--rule", choices=list(ANGLE_RULES), default="covariant",
                   help="angle rule of A: covariant (default, J^-T), paper (the literal eq. 3) "
                        "or none (S only)")
    p.add_argument("--object-model", choices=list(OBJECT_MODELS), default="plane",
                   help="how a person's pixels move between the views: plane (default, the "
                        "paper's person plane) or body (a mean body shape shipped with the "
                        "package; slower to build, cached)")
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
