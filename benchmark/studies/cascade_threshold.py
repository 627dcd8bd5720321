"""What an adapted detector's cascade drops: ``python -m benchmark.studies.cascade_threshold``.

The adapted OpenCV (and Daimler) detector -- and the HOG/SVM with its normalisation stage
(``--kind hog``: the source model of ``--model``) -- scores every
candidate window with the folded operator and rescores only those whose folded score
reaches the stage's threshold with their own block normalisation
(:class:`viewadapt.detect.RenormStage`); the rescoring is most of its per-frame cost. This study scores *every* window both ways on each frame of a
rendered frame set (``--data``: a ``frames_coco.json`` folder, e.g. ``viewadapt generate``'s
frames) and/or a clip (``--clip`` with ``--calibration``; its lens handled as ``bench
footage`` handles it) and reports, for each candidate threshold, how many windows per frame
would be rescored and what fraction of the windows whose final score reaches 0 (the SVM's
own boundary) or -1 (the lowest detection threshold, ``DEFAULT_THRESHOLD``) the cascade
would drop. No ground truth is read: it measures the approximation, not a detection rate.

Writes ``cascade.md``, ``cascade.csv`` and ``run.json`` under ``--out``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from benchmark.studies import report_error

__all__ = ["THRESHOLDS", "FINAL_LEVELS", "window_score_pairs", "cascade_table", "main"]

#: candidate thresholds of the folded score
THRESHOLDS = (-3.0, -2.5, -2.0, -1.75, -1.5, -1.25, -1.0)
#: final scores whose windows' loss is reported
FINAL_LEVELS = (0.0, -1.0)


def window_score_pairs(detector, image, kind: str = "opencv") -> tuple[np.ndarray, np.ndarray]:
    """``(folded, final)`` scores of every candidate window of ``detector`` (a
    :class:`viewadapt.detect.FrameDetector`) on one frame: the folded operator's, and the
    normalisation stage's of every window (whatever its folded score)."""
    from viewadapt.detect import check_frame
    from viewadapt.detect.layers import upsampled_band

    op = detector.operator(kind)
    img = check_frame(image, detector.size)
    folded, final = [], []
    for layer in op.layers:
        o = layer.operator
        if o.stage is None:
            raise ValueError(f"the {kind} operator has no normalisation stage")
        feats = o.frame_features(upsampled_band(img, layer.factor, layer.rows))
        folded.append(o.fold_scores(feats))
        final.append(o.stage.scores(np.arange(o.n_windows), feats.raw))
    return np.concatenate(folded), np.concatenate(final)


def cascade_table(pairs, thresholds=THRESHOLDS, levels=FINAL_LEVELS) -> list[dict]:
    """One row per threshold from per-frame ``(folded, final)`` pairs: windows rescored per
    frame (mean) and, per final level, the windows at or above it and the fraction of them
    whose folded score is below the threshold."""
    rows = []
    n_frames = len(pairs)
    folded = np.concatenate([p[0] for p in pairs])
    final = np.concatenate([p[1] for p in pairs])
    for t in thresholds:
        row = dict(threshold=float(t), rescored_per_frame=float((folded >= t).sum() / n_frames))
        for s in levels:
            above = final >= s
            n = int(above.sum())
            row[f"n_final_ge_{s:g}"] = n
            row[f"dropped_final_ge_{s:g}"] = float((folded[above] < t).mean()) if n else np.nan
        rows.append(row)
    return rows


def _frame_sources(args):
    """``(name, camera, dist, images)`` groups: a rendered set's frames by camera (all
    named ``renders``), a clip."""
    out = []
    if args.data is not None:
        from benchmark.frames.methods import load_frames

        by_cam = {}
        for f in load_frames(args.data)[::args.every]:
            key = json.dumps(f.camera.to_dict(), sort_keys=True)
            by_cam.setdefault(key, (f.camera, f.dist, []))[2].append(f)
        for cam, dist, records in by_cam.values():   # one table over all its cameras
            out.append(("renders", cam, dist, records))
    if args.clip is not None:
        from viewadapt.io import open_frames
        from viewadapt.io.calibration import read_calibration_file

        if args.calibration is None:
            raise ValueError("--clip needs --calibration")
        cal = read_calibration_file(args.calibration)     # the lens: windows through it
        out.append(("clip", cal.camera, cal.dist, open_frames([args.clip], every=args.every)))
    if not out:
        raise ValueError("give --data and/or --clip")
    for name, cam, dist, src in out:        # FrameRecord.image() / a FrameStream's frames
        yield name, cam, dist, (f.image() if isinstance(src, list) else f.image for f in src)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmark.studies.cascade_threshold",
                                description=__doc__.split("\n\n")[1])
    p.add_argument("--data", type=Path, help="a rendered frame set (frames_coco.json)")
    p.add_argument("--clip", type=Path, help="a folder of a clip's frames")
    p.add_argument("--calibration", type=Path, help="the clip's calibration")
    p.add_argument("--kind", default="opencv", choices=["opencv", "daimler", "hog"])
    p.add_argument("--model", type=Path, default=None,
                   help="source detectors for --kind hog (default: the shipped models)")
    p.add_argument("--every", type=int, default=1, help="every N-th frame")
    p.add_argument("--cache", type=Path, default=None, help="operator cache folder")
    p.add_argument("--out", type=Path, required=True)
    args = p.parse_args(argv)
    from viewadapt.detect import FrameDetector
    from viewadapt.io import SourceDetectors, shipped_model_path

    try:
        if args.every < 1:
            raise ValueError("--every must be at least 1")
        models = None
        if args.kind == "hog":          # the registry's HOG carries its stage
            models = SourceDetectors.load(args.model or shipped_model_path())
        pairs = {}
        for name, cam, dist, images in _frame_sources(args):
            det = FrameDetector(cam, models, cache_dir=args.cache, lens=dist)
            pairs.setdefault(name, []).extend(window_score_pairs(det, img, args.kind)
                                              for img in images)
        if any(not v for v in pairs.values()):
            raise ValueError("no frames selected")
        tables = {name: cascade_table(v) for name, v in pairs.items()}
        counts = {name: len(v) for name, v in pairs.items()}
    except (ValueError, OSError) as exc:
        return report_error(p, exc)
    lines = [f"# Cascade of the adapted {args.kind} detector: every window scored both ways",
             ""]
    levels = [f"{s:g}" for s in FINAL_LEVELS]
    for name, rows in tables.items():
        lines += [f"## {name} ({counts[name]} frames)", "",
                  "| folded threshold | windows rescored per frame | "
                  + " | ".join(f"dropped of final >= {s} (n)" for s in levels) + " |",
                  "|---|---|" + "---|" * len(levels)]
        for r in rows:
            cells = [f"{100 * r[f'dropped_final_ge_{s}']:.2f} % ({r[f'n_final_ge_{s}']})"
                     for s in levels]
            lines.append(f"| {r['threshold']:g} | {r['rescored_per_frame']:.0f} | "
                         + " | ".join(cells) + " |")
        lines.append("")
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "cascade.md").write_text("\n".join(lines))
    import pandas as pd

    pd.DataFrame([dict(source=n, **r) for n, rows in tables.items() for r in rows]).to_csv(
        args.out / "cascade.csv", index=False)
    (args.out / "run.json").write_text(json.dumps(dict(
        data=None if args.data is None else str(args.data),
        clip=None if args.clip is None else str(args.clip),
        calibration=None if args.calibration is None else str(args.calibration),
        kind=args.kind, model=None if args.kind != "hog" else str(args.model or "shipped"),
        every=args.every, frames=counts), indent=2))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
