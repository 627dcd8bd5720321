"""Negatives from rendered surveillance frames: ``python -m benchmark.studies.frame_negatives``.

The hypothesis under test: a source detector trained on renders fires on real footage's
facades, windows, bollards and vehicles because its negatives are 64x128 windows of
person-free backgrounds seen from the source view, not the clutter a surveillance camera
sees around people. The rendered frames of a dataset (``frames_coco.json``) are such
views. Each frame's candidate windows (:func:`viewadapt.detect.select_candidate_windows`,
the windows the adapted detector scores) whose person box overlaps no ground-truth person
(IoU below ``--max-iou``) and whose corners lie inside the frame are rectified to the
canonical 64x128 window through their own homography -- what image warping reads -- and a
seeded random ``--per-frame`` of them join the background windows as negatives; the
training is otherwise the one ``bench frames`` gives (:func:`train_source_detectors`,
same seed, recipe and frame-view copies).

``--misframed`` tests another hypothesis: that a detector trained on centred persons
scores windows that frame a person badly (shifted or of the wrong size, so that the
protocol counts them as false positives and, winning the non-maximum suppression, can
cost the person too) as highly as the window that frames the person. Instead of
person-free windows it draws, per person, up to ``--per-person`` candidate windows whose
IoU with that person lies in ``--iou`` and with no person above it
(:func:`misframed_windows`), rectified the same way.

``--hard-from MODEL`` tests a third, the toolbox's bootstrapping (Dalal & Triggs 2005;
Dollar et al. 2014 train ACF in rounds, each adding the negatives the detector of the round
before scores highest): instead of a random draw, the ``--per-frame`` person-free windows
of each frame that ``MODEL``'s adapted ``--hard-kind`` detector scores highest
(:func:`hard_negative_windows`), rectified the same way; the models are then trained
again from scratch with them.

Writes ``source_detectors.npz`` (the models, their training record naming the added set)
and ``frame_negatives.json`` (per frame: candidates, kept, drawn) into ``--out``; compare
the models with ``bench frames --model`` or on a real clip with
:mod:`benchmark.studies.footage_models`.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pandas as pd

from viewadapt.boxes import box_iou

__all__ = ["frame_negative_windows", "hard_negative_windows", "misframed_windows", "main"]


def _inside(cw, image_size) -> np.ndarray:
    """Which of the candidate windows ``cw`` have all four corners inside a frame of
    ``image_size`` (width, height)."""
    w, h = image_size
    corners = cw.window_corners()
    return ((corners[..., 0] >= 0) & (corners[..., 0] <= w - 1)
            & (corners[..., 1] >= 0) & (corners[..., 1] <= h - 1)).all(axis=1)


def _candidates_inside(frame):
    """A rendered frame's candidate windows (those the adapted detector scores), which of
    them lie inside the frame, and their person boxes."""
    from viewadapt.detect import select_candidate_windows

    cw = select_candidate_windows(frame.camera, frame.camera.image_size)
    return cw, _inside(cw, frame.camera.image_size), cw.person_boxes()


def _add_rectified(items, meta, frame, cw, boxes, j) -> None:
    """Append candidate window ``j`` of ``frame`` (its homography: the rectification) to a
    window set's ``items`` and ``meta`` rows."""
    items.append((Path(frame.path), np.asarray(cw.homographies[j], float)))
    meta.append((str(frame.path), "", frame.scene_id, int(frame.image_id),
                 float(boxes[j, 0]), float(boxes[j, 1])))


def frame_negative_windows(frames, *, per_frame: int, max_iou: float = 0.1,
                           min_height: float = 0.0, seed: int = 0):
    """A :class:`~benchmark.crops.features.WindowSet` of person-free candidate windows of
    rendered frames (:class:`~benchmark.frames.methods.FrameRecord` s), each rectified to
    the canonical window by its homography, at most ``per_frame`` per frame drawn at
    random (seeded by ``seed`` and the frame's index), and one row per frame of what was
    kept. ``min_height``: only windows whose person box is at least this tall (frame px),
    so that the rectified window is not mostly upsampled blur."""
    from benchmark.crops.features import WindowSet

    items, meta, report = [], [], []
    for i, f in enumerate(frames):
        cw, inside, boxes = _candidates_inside(f)
        free = inside & (boxes[:, 3] >= min_height)
        if len(f.gt):
            free &= box_iou(boxes, f.gt).max(axis=1) < max_iou
        idx = np.flatnonzero(free)
        rng = np.random.default_rng([int(seed), i])
        drawn = np.sort(rng.choice(idx, size=min(per_frame, len(idx)), replace=False))
        for j in drawn:
            _add_rectified(items, meta, f, cw, boxes, j)
        report.append({"frame": Path(f.path).name, "scene_id": f.scene_id,
                       "candidates": len(cw), "inside": int(inside.sum()),
                       "tall_enough": int((inside & (boxes[:, 3] >= min_height)).sum()),
                       "person_free": int(free.sum()), "drawn": int(len(drawn))})
    meta = pd.DataFrame(meta, columns=["path", "person_id", "scene_id", "instance", "x", "y"])
    key = f"frame_negatives|n{per_frame}|iou{max_iou:g}|h{min_height:g}|s{seed}"
    return WindowSet(key, items, meta.assign(label=0)), report


def hard_negative_windows(frames, models, *, kind: str = "acf", per_frame: int,
                          max_iou: float = 0.1, min_height: float = 0.0):
    """A :class:`~benchmark.crops.features.WindowSet` of the person-free candidate windows
    of rendered frames that the adapted detector ``kind`` of ``models``
    (:class:`~viewadapt.io.SourceDetectors`) scores highest: per frame, of the windows
    inside the frame whose person box overlaps every person below ``max_iou``, the
    ``per_frame`` of highest score (ties: the earlier window), each rectified to the
    canonical window by its homography; and one row per frame of what was kept (with the
    lowest score kept). ``min_height``: only windows whose person box is at least this tall
    (frame px), as in :func:`frame_negative_windows`. Frames seen by the same camera (a
    scene's frames) share one detector and its operator."""
    import json

    from benchmark.crops.features import WindowSet
    from viewadapt.detect import FrameDetector

    items, meta, report = [], [], []
    detectors = {}
    for f in frames:
        key = json.dumps(f.camera.to_dict(), sort_keys=True)
        if key not in detectors:
            det = FrameDetector(f.camera, models)
            cw = det.windows
            boxes = cw.person_boxes()
            detectors[key] = (det.operator(kind), cw, boxes,
                              _inside(cw, f.camera.image_size) & (boxes[:, 3] >= min_height))
        op, cw, boxes, eligible = detectors[key]
        scores = np.asarray(op.scores(op.frame_features(f.image())), float)
        free = eligible.copy()
        if len(f.gt):
            free &= box_iou(boxes, f.gt).max(axis=1) < max_iou
        idx = np.flatnonzero(free)
        top = idx[np.argsort(-scores[idx], kind="stable")[:per_frame]]
        for j in np.sort(top):
            _add_rectified(items, meta, f, cw, boxes, j)
        report.append({"frame": Path(f.path).name, "scene_id": f.scene_id,
                       "candidates": len(cw), "person_free": int(free.sum()),
                       "drawn": int(len(top)),
                       "lowest_score": float(scores[top].min()) if len(top) else None})
    meta = pd.DataFrame(meta, columns=["path", "person_id", "scene_id", "instance", "x", "y"])
    key = (f"hard_negatives|{kind}|{models.fingerprint()}|n{per_frame}|iou{max_iou:g}"
           f"|h{min_height:g}")
    return WindowSet(key, items, meta.assign(label=0)), report


def misframed_windows(frames, *, iou=(0.15, 0.4), per_person: int = 40,
                      min_height: float = 40.0, seed: int = 0):
    """A :class:`~benchmark.crops.features.WindowSet` of candidate windows of rendered
    frames that frame a person badly -- IoU with that person in ``iou`` (low, high) and
    with no person above ``high`` -- each rectified to the canonical window by its
    homography: at most ``per_person`` per person drawn at random (seeded by ``seed`` and
    the frame's index), only windows inside the frame whose person box is at least
    ``min_height`` px tall. Returns ``(window set, per-frame report)``."""
    from benchmark.crops.features import WindowSet

    lo, hi = (float(v) for v in iou)
    if not 0 <= lo < hi < 0.5:
        raise ValueError(f"iou must be (low, high) with 0 <= low < high < 0.5, got {iou!r}")
    items, meta, report = [], [], []
    for i, f in enumerate(frames):
        if not len(f.gt):
            continue
        cw, inside, boxes = _candidates_inside(f)
        overlap = box_iou(boxes, f.gt)
        best = overlap.max(axis=1)
        rng = np.random.default_rng([int(seed), i])
        n = 0
        for g in range(len(f.gt)):
            ok = inside & (boxes[:, 3] >= min_height) & (overlap[:, g] >= lo) \
                & (overlap[:, g] <= hi) & (best <= hi)
            idx = np.flatnonzero(ok)
            for j in np.sort(rng.choice(idx, size=min(per_person, len(idx)), replace=False)):
                _add_rectified(items, meta, f, cw, boxes, j)
                n += 1
        report.append({"frame": Path(f.path).name, "scene_id": f.scene_id,
                       "persons": len(f.gt), "drawn": n})
    meta = pd.DataFrame(meta, columns=["path", "person_id", "scene_id", "instance", "x", "y"])
    key = f"misframed|{lo}-{hi}|n{per_person}|h{min_height}|s{seed}"
    return WindowSet(key, items, meta.assign(label=0)), report


def main(argv=None) -> int:
    from benchmark.data import load_dataset
    from benchmark.frames.methods import load_frames, train_source_detectors
    from benchmark.recipes import DEFAULT_RECIPE
    from viewadapt.io.files import atomic_output_dir, check_output_dir

    ap = argparse.ArgumentParser(prog="python -m benchmark.studies.frame_negatives",
                                 description=__doc__.split("\n\n")[1])
    ap.add_argument("--data", type=Path, required=True, help="a generated dataset with frames")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--per-frame", type=int, default=1000,
                    help="negatives drawn per frame (default 1000)")
    ap.add_argument("--max-iou", type=float, default=0.1,
                    help="a window is person-free below this IoU with every person (0.1)")
    ap.add_argument("--min-height", type=float, default=None,
                    help="only windows whose person is at least this tall, frame px "
                         "(default 0; 40 with --misframed)")
    ap.add_argument("--misframed", action="store_true",
                    help="instead, windows that frame a person badly: IoU with a person "
                         "within --iou (misframed_windows)")
    ap.add_argument("--iou", type=float, nargs=2, default=(0.15, 0.4), metavar=("LOW", "HIGH"),
                    help="with --misframed: the IoU band (default 0.15 0.4)")
    ap.add_argument("--per-person", type=int, default=40,
                    help="with --misframed: windows drawn per person (default 40)")
    ap.add_argument("--hard-from", type=Path, metavar="MODEL",
                    help="instead, each frame's --per-frame person-free windows that this "
                         "source-detector file's adapted --hard-kind detector scores highest")
    ap.add_argument("--hard-kind", choices=("hog", "acf"), default="acf",
                    help="with --hard-from: the detector that scores them (default acf)")
    ap.add_argument("--recipe", default=DEFAULT_RECIPE)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--quick", action="store_true", help="smaller detectors (tests)")
    args = ap.parse_args(argv)
    if args.per_frame < 1 or args.per_person < 1:
        ap.error(f"--per-frame and --per-person must be at least 1, got {args.per_frame} "
                 f"and {args.per_person}")
    if args.misframed and args.hard_from:
        ap.error("--misframed and --hard-from are two different tests: give one")
    check_output_dir(args.out)
    ds = load_dataset(args.data)
    frames = load_frames(args.data)
    if args.hard_from:
        from viewadapt.io import SourceDetectors

        min_height = 0.0 if args.min_height is None else args.min_height
        negs, report = hard_negative_windows(frames, SourceDetectors.load(args.hard_from),
                                             kind=args.hard_kind, per_frame=args.per_frame,
                                             max_iou=args.max_iou, min_height=min_height)
        settings = {"hard_from": str(args.hard_from), "hard_kind": args.hard_kind,
                    "per_frame": args.per_frame, "max_iou": args.max_iou}
    elif args.misframed:
        min_height = 40.0 if args.min_height is None else args.min_height
        try:
            negs, report = misframed_windows(frames, iou=args.iou, per_person=args.per_person,
                                             min_height=min_height, seed=args.seed)
        except ValueError as exc:
            ap.error(str(exc))
        settings = {"misframed": True, "iou": list(args.iou), "per_person": args.per_person}
    else:
        min_height = 0.0 if args.min_height is None else args.min_height
        negs, report = frame_negative_windows(frames, per_frame=args.per_frame,
                                              max_iou=args.max_iou, min_height=min_height,
                                              seed=args.seed)
        settings = {"per_frame": args.per_frame, "max_iou": args.max_iou}
    print(f"{len(negs)} negatives from {len(frames)} rendered frames")
    models = train_source_detectors(ds, seed=args.seed, quick=args.quick,
                                    recipe=args.recipe, extra_negatives=[negs])
    with atomic_output_dir(args.out) as tmp:
        models.save(tmp / "source_detectors.npz")
        (tmp / "frame_negatives.json").write_text(json.dumps(
            {**settings, "min_height": min_height, "seed": args.seed,
             "recipe": args.recipe, "negatives": len(negs), "frames": report}, indent=1))
    print(f"wrote {args.out}/source_detectors.npz, frame_negatives.json")
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
