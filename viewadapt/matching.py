"""Matching the detections of one image to its ground truth (the first stage of
:mod:`viewadapt.metrics`).

Detections are matched greedily by decreasing score, each to the unmatched ground truth of
highest overlap above the threshold, with ignore regions matched last and on the
detection's own area, as in Dollár's toolbox (``bbGt`` ``evalRes``).

References
----------
.. [1] P. Dollár, C. Wojek, B. Schiele, P. Perona, "Pedestrian Detection: An Evaluation of
   the State of the Art", IEEE TPAMI 34(4), 2012.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .boxes import box_intersections, check_boxes, check_scores, safe_ratio

__all__ = ["FrameMatch", "match_detections"]


@dataclass(frozen=True)
class FrameMatch:
    """Result of matching the detections of one image to its ground truth.

    Arrays are in the order of the inputs of :func:`match_detections`.

    Attributes
    ----------
    dt_scores : (D,) ndarray of float64
        Detection scores.
    dt_labels : (D,) ndarray of int8
        1 true positive, 0 false positive, -1 ignored (matched to an ignore region).
    dt_gt_index : (D,) ndarray of intp
        Index of the ground truth each detection was matched to, -1 for false positives.
    gt_matched : (G,) ndarray of bool
        For a non-ignored ground truth, whether a detection matched it (False = miss).
        For an ignore ground truth, whether at least one detection fell on it.
    gt_ignore : (G,) ndarray of bool
        The ignore flags given to :func:`match_detections`.
    """

    dt_scores: np.ndarray
    dt_labels: np.ndarray
    dt_gt_index: np.ndarray
    gt_matched: np.ndarray
    gt_ignore: np.ndarray

    @property
    def n_positives(self) -> int:
        """Number of non-ignored ground truths (the denominator of the miss rate)."""
        return int(np.count_nonzero(~self.gt_ignore))


def _check_ignore(gt_ignore, n: int) -> np.ndarray:
    if gt_ignore is None:
        return np.zeros(n, dtype=bool)
    ig = np.asarray(gt_ignore)
    if ig.ndim != 1 or ig.shape[0] != n:
        raise ValueError(
            f"gt_ignore must have shape ({n},) to match gt_boxes, got shape {ig.shape}"
        )
    if ig.dtype != bool:
        if ig.dtype == object or not np.issubdtype(ig.dtype, np.number):
            raise ValueError(f"gt_ignore must be bool or 0/1, got dtype {ig.dtype}")
        if not np.all(np.isin(ig, [0, 1])):
            raise ValueError("gt_ignore must be bool or 0/1")
    return ig.astype(bool)


def _check_threshold(value, name: str) -> float:
    """``value`` as a float in (0, 1], else TypeError / ValueError."""
    try:
        thr = float(value)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a number, got {value!r}") from None
    if not 0.0 < thr <= 1.0:
        raise ValueError(f"{name} must lie in (0, 1], got {value!r}")
    return thr


def match_detections(dt_boxes, dt_scores, gt_boxes, gt_ignore=None, iou_threshold=0.5):
    """Match the detections of one image to its ground truth (toolbox ``evalRes`` rule).

    Parameters
    ----------
    dt_boxes : (D, 4) array_like
        Detections as ``(x, y, w, h)``.
    dt_scores : (D,) array_like
        Detection scores, higher = more confident.
    gt_boxes : (G, 4) array_like
        Ground truths as ``(x, y, w, h)``.
    gt_ignore : (G,) array_like of bool, optional
        True for "ignore" regions (crowds, too small, too occluded...). Default: none.
    iou_threshold : float, default=0.5
        Minimum overlap for a match, in ``(0, 1]``.

    Returns
    -------
    FrameMatch
        Per-detection labels (1 TP, 0 FP, -1 ignored) and per-ground-truth matched flags.

    Raises
    ------
    ValueError
        On wrong shapes, negative box sizes, NaN scores or mismatched lengths.

    Notes
    -----
    Detections are visited by descending score (stable for ties). Each takes, among the
    non-ignored ground truths not yet matched, the one with the largest IoU, if that IoU is
    at least ``iou_threshold``; it is then a true positive. Otherwise it may fall on an
    ignore region, with the overlap measured over the *detection* area,

    .. math::

        o_{\\text{ignore}}(d, g) = \\frac{|d \\cap g|}{|d|}
        \\quad\\text{instead of}\\quad
        o(d, g) = \\frac{|d \\cap g|}{|d \\cup g|},

    (the detection matches some sub-window of the region); if that overlap reaches the
    threshold the detection is ignored (neither TP nor FP). An ignore region can absorb any
    number of detections. Anything else is a false positive. Among regular ground truths
    with equal overlaps the one listed last wins (the toolbox's loop replaces its best match
    when ``oa >= bstOa``); among ignore regions the first one listed that reaches the
    threshold takes the detection (the loop stops there). Only ``dt_gt_index`` and
    ``gt_matched`` depend on these tie rules, never the labels.

    Unlike ``dbEval`` we do not filter boxes by height or resize them to a fixed aspect
    ratio: set ``gt_ignore`` and filter detections before calling.

    References
    ----------
    .. [1] P. Dollár, C. Wojek, B. Schiele, P. Perona, "Pedestrian Detection: An Evaluation
           of the State of the Art", IEEE TPAMI 34(4), 2012.
    .. [2] P. Dollár, "Piotr's Computer Vision Matlab Toolbox", ``bbGt.m`` (``evalRes``,
           ``compOas``).
    """
    dt = check_boxes(dt_boxes, "dt_boxes")
    scores = check_scores(dt_scores, dt.shape[0], name="dt_scores", other="dt_boxes")
    gt = check_boxes(gt_boxes, "gt_boxes")
    ignore = _check_ignore(gt_ignore, gt.shape[0])
    thr = _check_threshold(iou_threshold, "iou_threshold")

    n_dt, n_gt = dt.shape[0], gt.shape[0]
    labels = np.zeros(n_dt, dtype=np.int8)
    gt_index = np.full(n_dt, -1, dtype=np.intp)
    matched = np.zeros(n_gt, dtype=bool)
    if n_dt and n_gt:
        # bbGt compOas: IoU for regular gts, intersection over detection area for ignore gts.
        inter = box_intersections(dt, gt)
        dt_area = dt[:, 2] * dt[:, 3]
        gt_area = gt[:, 2] * gt[:, 3]
        den = np.where(ignore[None, :], dt_area[:, None], dt_area[:, None] + gt_area - inter)
        oa = safe_ratio(inter, den)
        regular = np.flatnonzero(~ignore)
        ignored = np.flatnonzero(ignore)
        oa_reg = oa[:, regular]
        oa_ign = oa[:, ignored]
        taken = np.zeros(regular.size, dtype=bool)
        for d in np.argsort(-scores, kind="stable"):
            if regular.size:
                cand = np.where(taken, -1.0, oa_reg[d])
                # argmax over reversed columns: the last gt among equal overlaps, as the
                # toolbox updates its best match on oa >= bstOa.
                k = regular.size - 1 - int(np.argmax(cand[::-1]))
                if cand[k] >= thr:
                    taken[k] = True
                    labels[d] = 1
                    gt_index[d] = regular[k]
                    continue
            # No regular match: the first ignore region reaching the threshold absorbs the
            # detection (the toolbox loop breaks as soon as bstm ~= 0 on an ignore gt).
            hits = np.flatnonzero(oa_ign[d] >= thr)
            if hits.size:
                labels[d] = -1
                gt_index[d] = ignored[hits[0]]
        matched[regular[taken]] = True
        hit = gt_index[labels == -1]
        matched[hit] = True
    return FrameMatch(
        dt_scores=scores,
        dt_labels=labels,
        dt_gt_index=gt_index,
        gt_matched=matched,
        gt_ignore=ignore,
    )
