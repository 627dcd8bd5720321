"""What the adapted OpenCV detector approximates, window by window, on a real clip.

``python -m benchmark.studies.opencv_adaptation INPUT --calibration C --boxes GT
[--ignore R] [--every N] --out DIR``

Image warping (Li et al. 2008) scores a candidate window by resampling the frame into the
canonical 64x128 window and computing OpenCV's HOG descriptor there: the blocks are
normalised on the *window's* cells. The adapted operator
(:func:`viewadapt.detect.build_adapted_opencv_operator`) normalises blocks of the *frame's*
cells (of the size chosen for the window, :func:`viewadapt.detect.choose_cell_sizes`) and
folds ``G`` into the weights; windows share templates snapped to the frame's cell grid
(``tolerance``). This study scores the same windows -- for each counted ground-truth person
the candidate window whose person box overlaps it most (IoU >= 0.5), and background windows
that overlap no person (IoU < 0.2 with every box) -- in five ways:

``warp``
    OpenCV's descriptor of the warped window (the reference);
``warp_cells``
    the warped window's descriptor from hard-binned 8-px cells (no Gaussian block window,
    no bilinear spatial interpolation): how much OpenCV's exact binning matters;
``renorm``
    the frame's raw 9-bin cell sums at the window's cell size remapped by ``G`` (Wang et
    al. 2017, eq. (5)), then blocks of the remapped cells L2-Hys normalised *in the window*
    -- normalisation after remapping, per window (not foldable into weights);
``fold_exact``
    the adapted operator with one exact template per window (``tolerance = 0``);
``fold``
    the adapted operator as ``detect`` builds it (shared templates, default tolerance).

It reports, per way, the correlation of its scores with ``warp``'s, the area under the ROC
curve of persons against background windows, and the persons' mean score. Writes
``opencv_adaptation.md`` and ``.json``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from benchmark.footage.run import open_clip
from viewadapt.detect import (
    CELLS_PER_SOURCE_CELL, FrameDetector, HOG_CELL, choose_cell_sizes,
    opencv_default_people_detector, person_boxes,
)
from viewadapt.detect.evaluation import in_regions
from viewadapt.detect.kinds import detector_kind
from viewadapt.detect.opencv_cells import opencv_gradients, opencv_window_features
from viewadapt.hog import cells_to_blocks, hog_descriptor, normalize_blocks_l2hys
from viewadapt.remap import CellGrid, feature_remap_matrix
from viewadapt.warp import warp_to_source_view

WAYS = ("warp", "warp_cells", "renorm", "fold_exact", "fold")


def _iou(a, b):
    """(N, M) IoU of (N, 4) and (M, 4) ``x, y, w, h`` boxes."""
    ax0, ay0, ax1, ay1 = a[:, 0], a[:, 1], a[:, 0] + a[:, 2], a[:, 1] + a[:, 3]
    bx0, by0, bx1, by1 = b[:, 0], b[:, 1], b[:, 0] + b[:, 2], b[:, 1] + b[:, 3]
    iw = np.clip(np.minimum(ax1[:, None], bx1) - np.maximum(ax0[:, None], bx0), 0, None)
    ih = np.clip(np.minimum(ay1[:, None], by1) - np.maximum(ay0[:, None], by0), 0, None)
    inter = iw * ih
    return inter / (a[:, 2:4].prod(1)[:, None] + b[:, 2:4].prod(1) - inter)


def _auc(pos, neg) -> float:
    """Area under the ROC curve of ``pos`` against ``neg`` (Mann-Whitney, ties halved)."""
    pos, neg = np.asarray(pos), np.asarray(neg)
    order = np.argsort(np.r_[pos, neg], kind="stable")
    ranks = np.empty(len(order))
    vals = np.r_[pos, neg][order]
    i = 0
    while i < len(vals):                     # average ranks over ties
        j = i
        while j + 1 < len(vals) and vals[j + 1] == vals[i]:
            j += 1
        ranks[order[i:j + 1]] = (i + j) / 2 + 1
        i = j + 1
    return float((ranks[:len(pos)].sum() - len(pos) * (len(pos) + 1) / 2) / (len(pos) * len(neg)))


def _cell_sums(mag, t, c) -> np.ndarray:
    """(M // c, N // c, 9) hard-binned cell sums of OpenCV's split orientations."""
    ny, nx = mag.shape[0] // c, mag.shape[1] // c
    m, tt = mag[:ny * c, :nx * c].astype(np.float64), t[:ny * c, :nx * c].astype(np.float64)
    b0 = np.floor(tt).astype(int) % 9
    f = tt - np.floor(tt)
    cell = (np.arange(ny * c)[:, None] // c) * nx + np.arange(nx * c)[None, :] // c
    out = np.bincount((cell * 9 + b0).ravel(), (m * (1 - f)).ravel(), ny * nx * 9)
    out += np.bincount((cell * 9 + (b0 + 1) % 9).ravel(), (m * f).ravel(), ny * nx * 9)
    return out.reshape(ny, nx, 9)


def renorm_scores(image, homographies, cells, W3780, b) -> np.ndarray:
    """``renorm``: raw 9-bin cells of each window's size remapped by ``G``, then OpenCV's
    L2-Hys on the remapped window's blocks, scored with the 3780 weights."""
    mag, t = opencv_gradients(image)
    maps = {c: _cell_sums(mag, t, c) for c in sorted(set(int(c) for c in cells))}
    out = np.empty(len(homographies))
    src = CellGrid.for_window(64, 128, HOG_CELL)
    for n, (H, c) in enumerate(zip(homographies, cells)):
        X = maps[int(c)]
        ny, nx = X.shape[:2]
        G = feature_remap_matrix(H, src, CellGrid(nx, ny, int(c)), n_bins=9, preserve="sum")
        x = (G @ X.astype(np.float64).ravel()).reshape(16, 8, 9)
        d = normalize_blocks_l2hys(cells_to_blocks(x)).ravel()
        out[n] = d @ W3780 + b
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("inputs", nargs="+")
    p.add_argument("--calibration", type=Path, required=True)
    p.add_argument("--boxes", type=Path, required=True)
    p.add_argument("--ignore", type=Path, default=None)
    p.add_argument("--every", type=int, default=5)
    p.add_argument("--negatives", type=int, default=100, help="background windows per frame")
    p.add_argument("--min-height", type=float, default=50.0)
    p.add_argument("--cells-per-source-cell", type=float, default=None,
                   help="frame cells per source cell of the fold and renorm ways (default the "
                        "detector's)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", type=Path, required=True)
    args = p.parse_args(argv)
    import cv2

    rng = np.random.default_rng(args.seed)
    clip = open_clip(args.inputs, args.calibration, args.boxes, args.ignore, every=args.every)
    lens = None if clip.correction is None else np.asarray(clip.dist).tolist()
    kind = detector_kind("opencv")
    Wc, b = opencv_default_people_detector()
    v = np.asarray(cv2.HOGDescriptor_getDefaultPeopleDetector(), np.float64).ravel()
    W3780 = v[:-1]
    cps = {} if args.cells_per_source_cell is None else {
        "cells_per_source_cell": args.cells_per_source_cell}
    base = FrameDetector(clip.camera, None, lens=lens, **cps)
    wins = base.windows
    folds = {"fold_exact": FrameDetector(clip.camera, None, lens=lens, tolerance=0.0, **cps),
             "fold": FrameDetector(clip.camera, None, lens=lens, **cps)}
    boxes = person_boxes(wins.homographies)
    scores = {w: [] for w in WAYS}
    label = []
    for frame in clip.stream:
        truth = clip.truth_of(frame)
        keep = ~truth.ignore & (truth.boxes[:, 3] >= args.min_height)
        if clip.regions:
            keep &= ~in_regions(np.c_[truth.boxes[:, 0] + truth.boxes[:, 2] / 2,
                                      truth.boxes[:, 1] + truth.boxes[:, 3]], clip.regions)
        gt = truth.boxes[keep]
        iou = _iou(boxes[:, :4], truth.boxes) if len(truth.boxes) else np.zeros((len(boxes), 0))
        pos = [int(np.argmax(iou[:, j])) for j in np.flatnonzero(keep)
               if iou[:, j].max() >= 0.5] if len(gt) else []
        free = np.flatnonzero(iou.max(1, initial=0) < 0.2)
        neg = rng.choice(free, size=min(args.negatives, len(free)), replace=False)
        idx = np.r_[pos, neg].astype(int)
        label += [1] * len(pos) + [0] * len(neg)
        img = frame.image
        Hs = wins.homographies[idx]
        warped = [warp_to_source_view(img, H) for H in Hs]
        scores["warp"] += [float((Wc * opencv_window_features(w)).sum() + b) for w in warped]
        scores["warp_cells"] += [float(hog_descriptor(w, method="cells", gamma=True) @ W3780
                                       + b) for w in warped]
        cells = choose_cell_sizes(wins.subset(idx).scale, HOG_CELL,
                                  cells_per_source_cell=cps.get("cells_per_source_cell",
                                                                CELLS_PER_SOURCE_CELL))
        scores["renorm"] += renorm_scores(img, Hs, cells, W3780, b).tolist()
        for way, det in folds.items():          # the operators of these windows alone
            det.windows = wins.subset(idx)
            det._ops.clear()
            op = det.operator(kind.name)
            for layer in op.layers:            # the fold alone, without the second stage
                layer.operator.stage = None
            scores[way] += op.scores(op.frame_features(img)).tolist()
    label = np.array(label, bool)
    rows = {}
    ref = np.array(scores["warp"])
    for w in WAYS:
        s = np.array(scores[w])
        rows[w] = dict(corr_with_warp=float(np.corrcoef(s, ref)[0, 1]),
                       auc=_auc(s[label], s[~label]), mean_person=float(s[label].mean()),
                       mean_background=float(s[~label].mean()))
    lines = [f"# What the adapted OpenCV detector approximates ({int(label.sum())} persons, "
             f"{int((~label).sum())} background windows, every {args.every}th frame)", "",
             "| way | r with warp | AUC persons vs background | mean person | mean background |",
             "|---|---|---|---|---|"]
    lines += [f"| {w} | {r['corr_with_warp']:.3f} | {r['auc']:.4f} | {r['mean_person']:.3f} | "
              f"{r['mean_background']:.3f} |" for w, r in rows.items()]
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "opencv_adaptation.md").write_text("\n".join(lines) + "\n")
    (args.out / "opencv_adaptation.json").write_text(json.dumps(
        dict(rows=rows, n_persons=int(label.sum()), n_background=int((~label).sum()),
             every=args.every), indent=1))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
