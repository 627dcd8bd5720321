"""Evaluating detections on frames: the Caltech protocol, its intervals and its DET figure.

Miss rate against false positives per image and the log-average miss rate over
``1e-2..1e0`` FPPI (Dollár et al. 2012, as Wang et al. 2017, Fig. 3), after standardising
every box to the pedestrian aspect 0.41 and ignoring ground truth that is too small, too
occluded or cut by the frame's border, that the ground truth itself marks ignored, or that
stands in an ignore region (:func:`in_regions`; detections standing there are dropped
before matching). Ignored ground truth absorbs the detections on it (Dollár's toolbox,
:func:`viewadapt.metrics.match_detections`). :func:`block_bootstrap` gives the summaries
95 % intervals over resamples of blocks of consecutive frames (consecutive frames of a
clip are not independent).

References
----------
.. [1] P. Dollár, C. Wojek, B. Schiele, P. Perona, "Pedestrian Detection: An Evaluation of
   the State of the Art", IEEE TPAMI 34(4), 2012.
.. [2] D. N. Politis and J. P. Romano, "A circular block-resampling procedure for
   stationary data", in *Exploring the Limits of Bootstrap*, Wiley, 1992.
"""

from __future__ import annotations

import numpy as np

from ..metrics import (
    accumulate_frames, evaluate_frames, log_average_miss_rate, match_detections, miss_rate_at,
)

__all__ = ["standardize_boxes", "ground_truth_rows", "evaluate_detections", "in_regions",
           "bottom_centres", "evaluation_rows", "ground_truth_counts", "block_length",
           "block_bootstrap", "matches_bootstrap", "evaluation_matches", "matches_summary",
           "evaluation_summary", "frame_matches", "block_resamples", "paired_block_bootstrap",
           "paired_matches_bootstrap", "paired_groups_bootstrap", "matches_lamr",
           "threshold_at_fppi", "matches_threshold_at_fppi", "frame_outcome", "summary_numbers", "BOOTSTRAP_BLOCK",
           "BOOTSTRAP_DRAWS"]

#: Frames per block of :func:`block_bootstrap`.
BOOTSTRAP_BLOCK = 10
#: Resamples of :func:`block_bootstrap`.
BOOTSTRAP_DRAWS = 1000


def standardize_boxes(boxes, aspect: float = 0.41) -> np.ndarray:
    """Boxes resized to ``width = aspect * height`` about their centre (Caltech ``dbEval``)."""
    b = np.asarray(boxes, float).reshape(-1, boxes.shape[-1] if np.ndim(boxes) == 2 else 4)
    out = b.copy()
    if len(b):
        cx = b[:, 0] + b[:, 2] / 2
        out[:, 2] = aspect * b[:, 3]
        out[:, 0] = cx - out[:, 2] / 2
    return out


def ground_truth_rows(boxes, occlusion, image_size, *, min_height: float = 24.0,
                      max_occlusion: float = 0.5) -> np.ndarray:
    """(G, 5) ``(x, y, w, h, ignore)`` of one frame's (G, 4) boxes: boxes too small, too
    occluded or cut by the border of the ``image_size`` (width, height) frame are ignored
    (Caltech protocol, Dollár et al. 2012); boxes standardised to the 0.41 aspect."""
    b = np.asarray(boxes, float).reshape(-1, 4)
    occ = np.asarray(occlusion, float).reshape(-1)
    gt = standardize_boxes(b) if len(b) else np.zeros((0, 4))
    w, h = image_size
    ign = np.zeros(len(gt), bool)
    if len(gt):
        ign |= b[:, 3] < min_height
        ign |= occ > max_occlusion
        ign |= (b[:, 0] < 1) | (b[:, 1] < 1) | (b[:, 0] + b[:, 2] > w - 1) | \
            (b[:, 1] + b[:, 3] > h - 1)
    return np.c_[gt, ign.astype(float)]


def bottom_centres(boxes) -> np.ndarray:
    """(N, 2) ``(x + w / 2, y + h)`` of (N, >=4) boxes ``(x, y, w, h, ...)``: where a
    person's box meets the ground."""
    b = np.asarray(boxes, float)
    b = b.reshape(-1, b.shape[-1]) if b.size else np.zeros((0, 4))
    return np.c_[b[:, 0] + b[:, 2] / 2, b[:, 1] + b[:, 3]]


def in_regions(points, polygons) -> np.ndarray:
    """(N,) bool: which of the (N, 2) points lie inside any of the polygons (each (M, 2)
    vertices, pixels), by the even-odd rule (a ray crossing count)."""
    p = np.asarray(points, float).reshape(-1, 2)
    inside = np.zeros(len(p), bool)
    px, py = p[:, 0:1], p[:, 1:2]
    for poly in polygons or ():
        v = np.asarray(poly, float).reshape(-1, 2)
        x0, y0 = v[:, 0], v[:, 1]
        x1, y1 = np.roll(x0, -1), np.roll(y0, -1)
        straddles = (y0 > py) != (y1 > py)
        with np.errstate(divide="ignore", invalid="ignore"):
            cross_x = x0 + (py - y0) * (x1 - x0) / (y1 - y0)
        inside |= (np.count_nonzero(straddles & (px < cross_x), axis=1) % 2) == 1
    return inside


def evaluation_rows(detections, ground_truth, *, regions=None, **kw):
    """The detections and ground truth of every frame as the matching reads them.

    Parameters
    ----------
    detections : list of (D, 5) ndarray
        Per frame, ``(x, y, w, h, score)``.
    ground_truth : list of tuples
        Per frame ``(boxes (G, 4), occlusion (G,), (width, height)[, ignore (G,)])``:
        ``ignore`` marks the boxes the ground truth itself ignores.
    regions : list of (M, 2) polygons, optional
        Ignore regions: detections whose bottom-centre lies in one are dropped, ground
        truth there ignored.
    **kw
        ``min_height``, ``max_occlusion`` of :func:`ground_truth_rows`.

    Returns
    -------
    dts : list of (D', 5) ndarray
        Standardised detections outside the regions.
    gts : list of (G, 5) ndarray
        Standardised ground truth, ``(x, y, w, h, ignore)``.
    """
    detections, ground_truth = list(detections), list(ground_truth)
    if len(detections) != len(ground_truth):
        raise ValueError(f"detections and ground truth have different lengths "
                         f"({len(detections)} != {len(ground_truth)} frames)")
    dts, gts = [], []
    for d, t in zip(detections, ground_truth):
        d = np.asarray(d, float).reshape(-1, 5)
        if regions and len(d):
            d = d[~in_regions(bottom_centres(d), regions)]
        dts.append(np.c_[standardize_boxes(d[:, :4]), d[:, 4]] if len(d) else np.zeros((0, 5)))
        boxes, occ, size = t[:3]
        g = ground_truth_rows(boxes, occ, size, **kw)
        if len(t) > 3 and len(g):
            g[:, 4] = np.maximum(g[:, 4], np.asarray(t[3], float).reshape(-1))
        if regions and len(g):
            feet = bottom_centres(np.asarray(boxes, float).reshape(-1, 4))
            g[in_regions(feet, regions), 4] = 1
        gts.append(g)
    return dts, gts


def evaluate_detections(detections, ground_truth, *, regions=None, **kw) -> dict:
    """Miss rate vs FPPI and LAMR of detections on frames
    (:func:`viewadapt.metrics.evaluate_frames`).

    Parameters
    ----------
    detections : list of (D, 5) ndarray
        Per frame, ``(x, y, w, h, score)``.
    ground_truth : list of tuples
        Per frame: ``(boxes, occlusion, (width, height))`` or with a fourth item, the
        boxes' ignore flags (see :func:`evaluation_rows`).
    regions : list of polygons, optional
        Ignore regions (:func:`evaluation_rows`).
    **kw
        ``min_height``, ``max_occlusion`` of :func:`ground_truth_rows`.

    Returns
    -------
    dict
        :func:`~viewadapt.metrics.evaluate_frames`'s ``fppi``, ``miss_rate``,
        ``thresholds``, ``lamr``, and ``n_gt`` (counted ground truth), ``n_gt_ignored``.
    """
    dts, gts = evaluation_rows(detections, ground_truth, regions=regions, **kw)
    ev = evaluate_frames(dts, gts)
    ev["n_gt"], ev["n_gt_ignored"] = ground_truth_counts(gts)
    return ev


def ground_truth_counts(gts) -> tuple[int, int]:
    """(counted, ignored) ground-truth boxes of :func:`evaluation_rows`' ``gts``."""
    ignored = int(sum(g[:, 4].sum() for g in gts))
    return int(sum(len(g) for g in gts)) - ignored, ignored


def summary_numbers(fppi, miss_rate) -> dict:
    """``lamr`` and the miss rates at 0.1 and 1 FPPI of a DET curve (``dbEval``'s rule,
    :func:`~viewadapt.metrics.miss_rate_at`)."""
    return {"lamr": log_average_miss_rate(fppi, miss_rate),
            "miss_rate_at_0.1_fppi": miss_rate_at(fppi, miss_rate, 0.1),
            "miss_rate_at_1_fppi": miss_rate_at(fppi, miss_rate, 1.0)}


def block_length(block: int, n_frames: int) -> int:
    """The block length :func:`block_bootstrap` uses on ``n_frames`` frames: ``block``, at
    most half the frames (at least 1)."""
    return max(1, min(int(block), n_frames // 2))


def block_bootstrap(dts, gts, *, block: int = BOOTSTRAP_BLOCK, draws: int = BOOTSTRAP_DRAWS,
                    seed: int = 0, level: float = 0.95) -> dict:
    """Percentile intervals of :func:`summary_numbers` from a circular block bootstrap
    over consecutive frames (Politis & Romano 1992).

    Each resample joins ``ceil(n / L)`` runs of ``L`` consecutive frames that start at
    uniformly drawn frames (wrapping around the end), cut to the ``n`` frames, and
    evaluates them as one set (each frame matched once, its matches reused); ``L`` is
    ``block``, or half the frames when there are fewer than two blocks' worth (a single
    block of all frames would resample nothing). A resample without counted ground truth
    is left out.

    Parameters
    ----------
    dts, gts : lists
        :func:`evaluation_rows`' output, frames in their order in the clip.
    block : int
        Frames per block (at least 1; at most ``n // 2`` is used, and at least 1).
    draws : int
        Resamples.
    seed : int
        Seed of ``numpy.random.default_rng``: the same inputs give the same intervals.
    level : float
        Coverage of the intervals.

    Returns
    -------
    dict
        Per summary name ``[low, high]``; ``"draws_used"``: resamples with ground truth;
        ``"block_frames"``: the block length used.
    """
    return matches_bootstrap(frame_matches(dts, gts), block=block, draws=draws, seed=seed,
                             level=level)


def matches_bootstrap(matches, *, block: int = BOOTSTRAP_BLOCK, draws: int = BOOTSTRAP_DRAWS,
                      seed: int = 0, level: float = 0.95) -> dict:
    """:func:`block_bootstrap` of per-frame matches (:func:`frame_matches`), frames in their
    order in the clip."""
    idx, length = block_resamples(len(matches), block=block, draws=draws, seed=seed)
    values = {k: [] for k in ("lamr", "miss_rate_at_0.1_fppi", "miss_rate_at_1_fppi")}
    for sel in idx:
        chosen = [matches[i] for i in sel]
        if not any(m.n_positives for m in chosen):
            continue
        fppi, miss, _ = accumulate_frames(chosen)
        for k, v in summary_numbers(fppi, miss).items():
            values[k].append(v)
    tail = 100 * (1 - level) / 2
    out = {k: ([float(np.percentile(v, tail)), float(np.percentile(v, 100 - tail))]
               if v else [None, None]) for k, v in values.items()}
    out["draws_used"] = len(values["lamr"])
    out["block_frames"] = length
    return out


def evaluation_matches(detections, truth, image_size, *, regions=None) -> tuple[list, list]:
    """``(matches, gts)``: per frame, the matches (:func:`frame_matches`) of detections in
    the input's pixels against ``truth`` (per frame, an object with ``boxes``,
    ``occlusion`` and ``ignore``: :class:`viewadapt.io.boxes.FrameBoxes`), and
    :func:`evaluation_rows`' ground truth."""
    gt = [(t.boxes, t.occlusion, image_size, t.ignore) for t in truth]
    dts, gts = evaluation_rows(detections, gt, regions=regions)
    return frame_matches(dts, gts), gts


def matches_summary(matches, gts, *, block: int = BOOTSTRAP_BLOCK,
                    seed: int = 0) -> tuple[dict, dict]:
    """``evaluation.json`` of :func:`evaluation_matches`' output, and the DET curve.

    Raises
    ------
    ValueError
        No counted ground truth in the frames.
    """
    n_gt, n_ignored = ground_truth_counts(gts)
    if n_gt == 0:
        raise ValueError(f"no ground-truth box is counted in the {len(gts)} frames detected "
                         f"({n_ignored} ignored): nothing to evaluate")
    fppi, miss, _ = accumulate_frames(matches)
    numbers = summary_numbers(fppi, miss)
    ci = matches_bootstrap(matches, block=block, draws=BOOTSTRAP_DRAWS, seed=seed)
    out = {}
    for k, v in numbers.items():
        out[k] = v
        out[f"{k}_ci95"] = ci[k]
    out |= {
        "n_gt": n_gt, "n_gt_ignored": n_ignored, "n_frames": len(gts),
        "fppi": fppi.tolist(), "miss_rate": miss.tolist(),
        "bootstrap": {"method": "circular block bootstrap over consecutive frames (Politis "
                                "& Romano 1992), 2.5 and 97.5 percentiles",
                      "block_frames": ci["block_frames"], "draws": BOOTSTRAP_DRAWS,
                      "draws_used": ci["draws_used"], "seed": seed},
        "protocol": "Caltech (Dollar et al. 2012): IoU >= 0.5 on boxes standardised to "
                    "width 0.41 height; ground truth under 24 px tall, over half occluded, "
                    "cut by the frame's border, ignored by its file or with its "
                    "bottom-centre in an ignore region is ignored and absorbs detections; "
                    "detections with the bottom-centre in an ignore region are dropped"}
    return out, {"fppi": fppi, "miss_rate": miss, "lamr": numbers["lamr"]}


def evaluation_summary(detections, truth, image_size, *, regions=None,
                       block: int = BOOTSTRAP_BLOCK, seed: int = 0) -> tuple[dict, dict]:
    """``evaluation.json`` of detections on frames, and the curve for the DET figure.

    Parameters
    ----------
    detections : list of (D, 5) ndarray
        Per frame, in the input's pixels.
    truth : list of FrameBoxes
        Per frame, its ground truth.
    image_size : (width, height)
    regions : list of polygons, optional
        Ignore regions.
    block, seed
        Of the block bootstrap (:func:`block_bootstrap`).

    Raises
    ------
    ValueError
        No counted ground truth in the frames.
    """
    return matches_summary(*evaluation_matches(detections, truth, image_size, regions=regions),
                           block=block, seed=seed)


def frame_matches(dts, gts) -> list:
    """Per-frame matches (:func:`viewadapt.metrics.match_detections`) of
    :func:`evaluation_rows`' output, so that resampled frames need only be accumulated."""
    return [match_detections(d[:, :4], d[:, 4], g[:, :4], g[:, 4].astype(bool))
            for d, g in zip(dts, gts)]


def block_resamples(n: int, *, block: int = BOOTSTRAP_BLOCK, draws: int = BOOTSTRAP_DRAWS,
                    seed: int = 0) -> tuple[np.ndarray, int]:
    """The frames of each circular block-bootstrap resample of ``n`` consecutive frames
    (:func:`block_bootstrap`): ``(draws, n)`` frame indices and the block length used."""
    if block < 1:
        raise ValueError(f"the bootstrap block must be at least 1 frame, got {block}")
    if draws < 1:
        raise ValueError(f"the bootstrap needs at least 1 draw, got {draws}")
    if n == 0:
        raise ValueError("no frames to resample")
    length = block_length(block, n)
    rng = np.random.default_rng(seed)
    starts = rng.integers(n, size=(int(draws), -(-n // length)))
    return ((starts[:, :, None] + np.arange(length)) % n).reshape(int(draws), -1)[:, :n], length


def paired_block_bootstrap(dts, reference, gts, *, block: int = BOOTSTRAP_BLOCK,
                           draws: int = BOOTSTRAP_DRAWS, seed: int = 0,
                           level: float = 0.95) -> dict:
    """``LAMR(dts) - LAMR(reference)`` on the same frames, with the percentile interval of
    a paired circular block bootstrap: both methods resampled on the same frames
    (:func:`block_resamples`), so the interval is that of the difference, not of two
    independent rates.

    Parameters
    ----------
    dts, reference : lists
        :func:`evaluation_rows`' detections of two methods on the frames of ``gts``.
    gts : list
        Their ground truth (:func:`evaluation_rows`).

    Returns
    -------
    dict
        ``difference``, ``ci`` ``[low, high]``, ``draws_used``, ``block_frames``.
    """
    if len(dts) != len(gts) or len(reference) != len(gts):
        raise ValueError(f"both methods need detections on the {len(gts)} frames, got "
                         f"{len(dts)} and {len(reference)}")
    return paired_matches_bootstrap(frame_matches(dts, gts), frame_matches(reference, gts),
                                    block=block, draws=draws, seed=seed, level=level)


def matches_lamr(matches) -> float:
    """The log-average miss rate (:func:`summary_numbers`) of per-frame matches
    (:func:`frame_matches`)."""
    fppi, miss, _ = accumulate_frames(matches)
    return summary_numbers(fppi, miss)["lamr"]


def paired_matches_bootstrap(a, b, *, block: int = BOOTSTRAP_BLOCK,
                             draws: int = BOOTSTRAP_DRAWS, seed: int = 0,
                             level: float = 0.95) -> dict:
    """:func:`paired_block_bootstrap` of two methods' per-frame matches
    (:func:`frame_matches`; each method matched once however many pairs it is in)."""
    return paired_groups_bootstrap([a], [b], block=block, draws=draws, seed=seed,
                                   level=level)


def paired_groups_bootstrap(a, b, *, block: int = BOOTSTRAP_BLOCK,
                            draws: int = BOOTSTRAP_DRAWS, seed: int = 0,
                            level: float = 0.95) -> dict:
    """Mean LAMR of the methods ``a`` minus that of the methods ``b`` (each a list of
    per-frame matches, :func:`frame_matches`, e.g. one detector per training seed), with
    the percentile interval of a paired circular block bootstrap: every method of both
    lists on the same resampled frames. Whatever varies between the methods of a list
    (their training) is held fixed: the interval is over frames only."""
    def mean_lamr(group, sel=None):
        return float(np.mean([matches_lamr(ms if sel is None else [ms[i] for i in sel])
                              for ms in group]))

    idx, length = block_resamples(len(a[0]), block=block, draws=draws, seed=seed)
    diffs = [mean_lamr(a, sel) - mean_lamr(b, sel) for sel in idx
             if any(a[0][i].n_positives for i in sel)]
    tail = 100 * (1 - level) / 2
    return {"difference": mean_lamr(a) - mean_lamr(b),
            "ci": ([float(np.percentile(diffs, tail)), float(np.percentile(diffs, 100 - tail))]
                   if diffs else [None, None]),
            "draws_used": len(diffs), "block_frames": length}


def threshold_at_fppi(dts, gts, fppi: float) -> float:
    """The lowest score threshold at which the frames have at most ``fppi`` false
    positives per image (:func:`evaluation_rows`' output; the DET curve's operating point);
    ``inf`` when even the best detection is a false positive beyond it."""
    return matches_threshold_at_fppi(frame_matches(dts, gts), fppi)


def matches_threshold_at_fppi(matches, fppi: float) -> float:
    """:func:`threshold_at_fppi` of per-frame matches (:func:`frame_matches`)."""
    if not np.isfinite(fppi) or fppi < 0:
        raise ValueError(f"the operating point must be >= 0 false positives per image, got "
                         f"{fppi!r}")
    curve, _, thresholds = accumulate_frames(matches)
    ok = np.flatnonzero(curve <= fppi)
    return float(thresholds[ok[-1]]) if len(ok) else float("inf")


def frame_outcome(boxes, truth, *, threshold: float, regions=None) -> tuple:
    """What the protocol makes of one frame's detections at a score threshold.

    Parameters
    ----------
    boxes : (D, 5) array_like
        ``(x, y, w, h, score)``.
    truth : tuple
        ``(boxes (G, 4), occlusion (G,), (width, height)[, ignore (G,)])`` as
        :func:`evaluation_rows` reads it.
    threshold : float
    regions : list of polygons, optional

    Returns
    -------
    labels : (D,) int8 ndarray
        1 a hit, 0 a false positive, -1 ignored (in an ignore region or on ignored ground
        truth), -2 below the threshold.
    status : (G,) int8 ndarray
        1 found, 0 missed, -1 ignored.
    """
    d = np.asarray(boxes, float).reshape(-1, 5)
    labels = np.full(len(d), -2, np.int8)
    shown = np.flatnonzero(d[:, 4] >= threshold)
    if regions and len(shown):
        inside = in_regions(bottom_centres(d[shown]), regions)
        labels[shown[inside]] = -1
        shown = shown[~inside]
    # the region's detections are out already, so the rows are those of ``shown``
    dts, gts = evaluation_rows([d[shown]], [truth], regions=regions)
    g = gts[0]
    m = match_detections(dts[0][:, :4], dts[0][:, 4], g[:, :4], g[:, 4].astype(bool))
    labels[shown] = m.dt_labels
    status = np.where(g[:, 4].astype(bool), -1, m.gt_matched.astype(np.int8)).astype(np.int8)
    return labels, status
