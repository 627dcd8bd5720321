"""What a detector's errors on a real clip are: ``python -m benchmark.studies.footage_errors``.

Reads the detections ``viewadapt bench footage`` stored (``detections.json``) and the
clip's ground truth, and at each operating point (a false-positive rate per image, its
score threshold read from the DET curve) sorts the errors under the Caltech protocol
(:mod:`viewadapt.detect.evaluation`):

* misses -- the miss rate of persons with a neighbour (another annotated person whose box
  overlaps theirs by at least a fifth of its width and half its height: the people of a
  group, whom a window of one person also shows) against those alone, and by box height;
* false positives -- *localisation* errors (the best IoU with a ground-truth box between
  0.3 and 0.5: a person found, badly framed; counted apart when that person is missed, an
  error twice), *duplicates* (IoU at least 0.5 with a box another detection already
  matched) and *background* (the rest).

Writes ``errors.md``, ``errors.csv`` and ``error_map.jpg`` (per method, every counted
person's foot point on the clip's first frame, found or missed, and the false positives'
foot points, at the last operating point; at most 640 px wide) under ``--out``. (Runs
before 2026-12-05 stored scores rounded to three decimals, so a LAMR read back from them
can differ from the run's in the fourth.)
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from viewadapt.boxes import box_iou

__all__ = ["neighbours", "error_breakdown", "error_map", "main"]

#: Box-height bands of the miss rates, pixels.
HEIGHT_BANDS = (0, 60, 80, 100, 130, np.inf)


def neighbours(boxes) -> np.ndarray:
    """(G,) bool: boxes ``(x, y, w, h)`` overlapped by another box by at least a fifth of
    their width and half their height."""
    b = np.asarray(boxes, float).reshape(-1, 4)
    x0, x1, y0, y1 = b[:, 0], b[:, 0] + b[:, 2], b[:, 1], b[:, 1] + b[:, 3]
    ox = np.clip(np.minimum(x1[:, None], x1[None]) - np.maximum(x0[:, None], x0[None]), 0, None)
    oy = np.clip(np.minimum(y1[:, None], y1[None]) - np.maximum(y0[:, None], y0[None]), 0, None)
    near = (ox >= 0.2 * b[:, 2:3]) & (oy >= 0.5 * b[:, 3:4])
    np.fill_diagonal(near, False)
    return near.any(axis=1)


def _frame_errors(detections, truth, image_size, regions, fppi):
    """Per frame at the threshold of ``fppi``: (standardised detections kept, their labels,
    the ground-truth rows, found flags, neighbour flags) and the threshold."""
    from viewadapt.detect.evaluation import evaluation_rows, frame_matches, threshold_at_fppi

    gt = [(t.boxes, t.occlusion, image_size, t.ignore) for t in truth]
    dts, gts = evaluation_rows(detections, gt, regions=regions)
    thr = threshold_at_fppi(dts, gts, fppi)
    frames = []
    for d, g, t in zip(dts, gts, truth):
        d = d[d[:, 4] >= thr]
        m = frame_matches([d], [g])[0]
        nb = neighbours(t.boxes) if len(t.boxes) else np.zeros(0, bool)
        frames.append((d, np.asarray(m.dt_labels), g, np.asarray(m.gt_matched, bool), nb))
    return frames, thr


def error_breakdown(detections, truth, image_size, *, regions=None, fppi: float = 1.0) -> dict:
    """The errors of one method at ``fppi`` false positives per image.

    Parameters
    ----------
    detections : list of (D, 5) array_like
        Per frame ``(x, y, w, h, score)`` in the frame's pixels.
    truth : list of FrameBoxes
        Per frame, its ground truth.
    image_size : (width, height)
    regions : list of polygons, optional
        Ignore regions.
    fppi : float
        The operating point.

    Returns
    -------
    dict
        ``threshold``; ``counted`` and ``missed`` persons; ``with_neighbour`` and
        ``missed_with_neighbour``; ``height_bands`` ``[(low, high, counted, missed)]``;
        ``false_positives`` and of them ``localisation``, ``duplicates``, ``background``.
    """
    frames, thr = _frame_errors(detections, truth, image_size, regions, fppi)
    out = dict(threshold=thr, counted=0, missed=0, with_neighbour=0, missed_with_neighbour=0,
               false_positives=0, localisation=0, localisation_on_missed=0, duplicates=0,
               background=0)
    bands = np.zeros((len(HEIGHT_BANDS) - 1, 2), int)
    ratios = []
    for d, labels, g, found, nb in frames:
        counted = g[:, 4] == 0
        missed = counted & ~found
        out["counted"] += int(counted.sum())
        out["missed"] += int(missed.sum())
        out["with_neighbour"] += int((counted & nb).sum())
        out["missed_with_neighbour"] += int((missed & nb).sum())
        k = np.digitize(g[:, 3], HEIGHT_BANDS[1:-1])
        np.add.at(bands[:, 0], k[counted], 1)
        np.add.at(bands[:, 1], k[missed], 1)
        hit = labels == 1
        if hit.any():            # each hit against the counted box it overlaps most
            iou = box_iou(d[hit, :4], g[:, :4]) * counted[None, :]
            ratios += (d[hit, 3] / g[iou.argmax(axis=1), 3]).tolist()
        fp = labels == 0
        if fp.any():
            iou = box_iou(d[fp, :4], g[:, :4])
            best = iou.max(axis=1) if len(g) else np.zeros(fp.sum())
            loc = (best >= 0.3) & (best < 0.5)
            out["false_positives"] += int(fp.sum())
            out["duplicates"] += int((best >= 0.5).sum())
            out["localisation"] += int(loc.sum())
            if loc.any():        # the person it frames badly, missed: an error twice
                out["localisation_on_missed"] += int(missed[iou[loc].argmax(axis=1)].sum())
            out["background"] += int((best < 0.3).sum())
    r = np.log(ratios) if ratios else np.zeros(0)
    out["log_height_ratio_mean"] = float(r.mean()) if len(r) else float("nan")
    out["log_height_ratio_sd"] = float(r.std()) if len(r) else float("nan")
    out["height_bands"] = [(float(lo), float(hi), int(c), int(m)) for (lo, hi), (c, m)
                           in zip(zip(HEIGHT_BANDS[:-1], HEIGHT_BANDS[1:]), bands)]
    return out


def error_map(image, detections, truth, image_size, *, regions=None, fppi: float = 1.0,
              title: str = "") -> np.ndarray:
    """``image`` (an RGB frame of the clip) dimmed, with every counted person's foot point
    over all frames (green found, red missed at ``fppi``) and the false positives' foot
    points (cyan crosses): a (H, W, 3) uint8 image."""
    import cv2

    frames, _ = _frame_errors(detections, truth, image_size, regions, fppi)
    img = (np.asarray(image, np.uint8) // 2 + 60).astype(np.uint8)
    img = np.ascontiguousarray(img)
    for (d, labels, g, found, _), t in zip(frames, truth):
        for j, b in enumerate(np.asarray(t.boxes, float).reshape(-1, 4)):
            if g[j, 4] == 0:
                colour = (0, 200, 0) if found[j] else (230, 0, 0)
                cv2.circle(img, (int(b[0] + b[2] / 2), int(b[1] + b[3])), 3, colour, -1)
        for b in d[labels == 0]:
            cv2.drawMarker(img, (int(b[0] + b[2] / 2), int(b[1] + b[3])), (0, 230, 230),
                           cv2.MARKER_TILTED_CROSS, 7, 1)
    if title:
        cv2.putText(img, title, (10, 25), cv2.FONT_HERSHEY_SIMPLEX, 0.7, (255, 255, 255), 2)
    return img


def _rate(missed, counted) -> str:
    return f"{missed / counted:.3f} ({missed}/{counted})" if counted else "-"


def _lines(results, fppis) -> list[str]:
    out = ["| method | FPPI | threshold | miss rate | with a neighbour | alone | "
           "false positives | localisation (on a missed person) | duplicates | background | "
           "hits' log(h / h_gt): mean, sd |",
           "|---|---|---|---|---|---|---|---|---|---|---|"]
    for m, per in results.items():
        for f in fppis:
            r = per[f]
            alone = (r["missed"] - r["missed_with_neighbour"],
                     r["counted"] - r["with_neighbour"])
            out.append(f"| {m} | {f:g} | {r['threshold']:.3f} | "
                       f"{_rate(r['missed'], r['counted'])} | "
                       f"{_rate(r['missed_with_neighbour'], r['with_neighbour'])} | "
                       f"{_rate(*alone)} | {r['false_positives']} | {r['localisation']} "
                       f"({r['localisation_on_missed']}) | "
                       f"{r['duplicates']} | {r['background']} | "
                       f"{r['log_height_ratio_mean']:+.3f}, {r['log_height_ratio_sd']:.3f} |")
    bands = next(iter(next(iter(results.values())).values()))["height_bands"]
    out += ["", f"Miss rate by box height (px) at {fppis[-1]:g} FPPI:", "",
            "| method | " + " | ".join(f"{lo:g}-{hi:g}" for lo, hi, _, _ in bands) + " |",
            "|---|" + "---|" * len(bands)]
    for m, per in results.items():
        out.append(f"| {m} | " + " | ".join(_rate(mi, c) for _, _, c, mi
                                            in per[fppis[-1]]["height_bands"]) + " |")
    return out


def main(argv=None) -> int:
    import cv2
    import pandas as pd

    from benchmark.footage.run import add_clip_arguments, open_clip
    from viewadapt.io import FrameBoxes
    from viewadapt.io.files import atomic_output_dir, check_output_dir, run_metadata

    ap = argparse.ArgumentParser(prog="python -m benchmark.studies.footage_errors",
                                 description=__doc__.split("\n\n")[1])
    add_clip_arguments(ap)
    ap.add_argument("--detections", type=Path, required=True,
                    help="a bench footage output folder, or its detections.json")
    ap.add_argument("--methods", nargs="+", default=None,
                    help="methods to look at (default: every one in the file)")
    ap.add_argument("--fppi", type=float, nargs="+", default=[0.1, 1.0],
                    help="operating points, false positives per image (default 0.1 1)")
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args(argv)
    path = args.detections / "detections.json" if args.detections.is_dir() else args.detections
    try:
        stored = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        ap.error(f"cannot read detections from {path}: {exc}")
    methods = args.methods or list(stored)
    unknown = [m for m in methods if m not in stored]
    if unknown:
        ap.error(f"{path} has no detections of {', '.join(unknown)} "
                 f"(it has {', '.join(stored)})")
    if any(not np.isfinite(f) or f <= 0 for f in args.fppi):
        ap.error(f"--fppi must be positive, got {args.fppi}")
    check_output_dir(args.out)
    clip = open_clip(args.inputs, args.calibration, args.boxes, args.ignore)
    size = clip.camera.image_size
    keys = list(stored[methods[0]])                 # the run's frames, in its order
    video = clip.stream.paths is None               # a video's frames are keyed by index
    truth = [clip.truth.get(int(k) if video else k, FrameBoxes.empty()) for k in keys]
    results, maps = {}, []
    for m in methods:
        dets = [np.asarray(stored[m].get(k, []), float).reshape(-1, 5) for k in keys]
        results[m] = {f: error_breakdown(dets, truth, size, regions=clip.regions, fppi=f)
                      for f in args.fppi}
        first = next(iter(clip.stream))
        maps.append(error_map(first.image, dets, truth, size, regions=clip.regions,
                              fppi=args.fppi[-1], title=f"{m} @ {args.fppi[-1]:g} FPPI"))
    lines = _lines(results, args.fppi)
    rows = [dict(method=m, fppi=f, **{k: v for k, v in r.items() if k != "height_bands"})
            for m, per in results.items() for f, r in per.items()]
    with atomic_output_dir(args.out) as tmp:
        (tmp / "errors.md").write_text("\n".join(lines) + "\n")
        pd.DataFrame(rows).to_csv(tmp / "errors.csv", index=False, float_format="%.5f")
        grid = np.vstack(maps)
        if grid.shape[1] > 640:
            grid = cv2.resize(grid, None, fx=640 / grid.shape[1], fy=640 / grid.shape[1],
                              interpolation=cv2.INTER_AREA)
        cv2.imwrite(str(tmp / "error_map.jpg"), cv2.cvtColor(grid, cv2.COLOR_RGB2BGR),
                    [cv2.IMWRITE_JPEG_QUALITY, 85])
        (tmp / "run.json").write_text(json.dumps(run_metadata(
            0, inputs=[str(p) for p in args.inputs], detections=str(path), methods=methods,
            fppi=args.fppi), indent=2, default=str))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
