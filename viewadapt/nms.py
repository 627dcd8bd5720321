"""Greedy non-maximum suppression of detection boxes (Dollár's toolbox ``bbNms`` 'maxg').

Boxes are ``(x, y, w, h)`` in continuous pixel coordinates, as in Piotr Dollár's toolbox: the
box covers ``[x, x + w) x [y, y + h)`` and its area is ``w * h`` (no "+1" pixel convention).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from .boxes import check_boxes, check_scores

__all__ = ["non_maximum_suppression", "detections_from_scores", "voted_boxes"]

_OVERLAPS = ("union", "min")


def non_maximum_suppression(boxes, scores, iou_threshold=0.5, *, overlap="union"):
    """Greedy non-maximum suppression; return the indices of the kept boxes.

    Boxes are visited by descending score. A box that is still kept suppresses every
    lower-scoring box whose overlap with it is strictly greater than ``iou_threshold``;
    a suppressed box suppresses nothing (Dollár's 'maxg' greedy rule).

    Parameters
    ----------
    boxes : (N, 4) array_like
        Boxes as rows ``(x, y, w, h)`` with ``w, h >= 0``.
    scores : (N,) array_like
        Detection scores, higher = more confident. Must be finite.
    iou_threshold : float, default=0.5
        Overlap above which the lower-scoring box is suppressed, in ``[0, 1]``. With
        ``overlap="min"`` this is a threshold on the intersection over the smaller area,
        not on the IoU.
    overlap : {"union", "min"}, default="union"
        Denominator of the overlap:

        - ``"union"``: intersection over union (``bbNms`` default, ``ovrDnm='union'``);
        - ``"min"``: intersection over the smaller of the two areas (``ovrDnm='min'``, used
          by the ACF detector, which pairs it with a threshold of 0.65).

    Returns
    -------
    keep : (K,) ndarray of intp
        Indices into ``boxes`` of the kept boxes, sorted by descending score. Ties in score
        keep the input order (a stable sort, like MATLAB's ``sort(..., 'descend')``).

    Raises
    ------
    ValueError
        On a wrong box shape, negative box sizes, NaN scores, mismatched lengths, an
        ``iou_threshold`` outside ``[0, 1]`` or an unknown ``overlap``.

    Notes
    -----
    For boxes :math:`a` (kept, higher score) and :math:`b`, :math:`b` is suppressed when

    .. math::

        \\frac{|a \\cap b|}{|a \\cup b|} > t \\quad (\\text{union}), \\qquad
        \\frac{|a \\cap b|}{\\min(|a|, |b|)} > t \\quad (\\text{min}).

    The comparison is strict, as in ``bbNms``: two boxes whose overlap equals the threshold
    both survive. Boxes of zero area overlap nothing and are never suppressed (the toolbox
    skips pairs with a non-positive intersection width or height).

    The loop is compiled (numba) and runs over kept boxes only; each step compares the kept
    box with the boxes still alive and drops the ones it suppresses, which gives the same
    result as the toolbox's double loop in (kept) x (alive) steps rather than :math:`N^2`.
    numba is imported on the first call, not with :mod:`viewadapt`.

    References
    ----------
    .. [1] P. Dollár, "Piotr's Computer Vision Matlab Toolbox", ``bbNms.m`` (``nmsMaxg``).
    .. [2] P. Dollár, R. Appel, S. Belongie, P. Perona, "Fast Feature Pyramids for Object
           Detection", IEEE TPAMI 36(8), 2014.

    Examples
    --------
    >>> non_maximum_suppression([[0, 0, 10, 10], [1, 0, 10, 10], [50, 50, 5, 5]],
    ...                         [0.9, 0.8, 0.7]).tolist()
    [0, 2]
    """
    boxes = check_boxes(boxes)
    scores = check_scores(scores, boxes.shape[0])
    if overlap not in _OVERLAPS:
        raise ValueError(f"overlap must be one of {_OVERLAPS}, got {overlap!r}")
    try:
        thr = float(iou_threshold)
    except (TypeError, ValueError):
        raise TypeError(f"iou_threshold must be a number, got {iou_threshold!r}") from None
    if not 0.0 <= thr <= 1.0:
        raise ValueError(f"iou_threshold must lie in [0, 1], got {iou_threshold!r}")

    order = np.argsort(-scores, kind="stable")
    keep = _maxg_kernel()(np.ascontiguousarray(boxes[order]), thr, overlap == "min")
    return order[keep].astype(np.intp, copy=False)


def _greedy_maxg(boxes, threshold, over_min):  # pragma: no cover - compiled by _maxg_kernel
    """Positions of the rows of ``boxes`` (already in visiting order) that greedy NMS keeps.

    The boxes still alive are kept compacted at the front of coordinate arrays: each kept box
    is compared with them in one contiguous pass that also drops the ones it suppresses, so
    the work is (kept boxes) x (boxes alive), as in the toolbox's double loop. The arithmetic
    is that of :func:`viewadapt.boxes.box_intersections` and :func:`viewadapt.boxes.safe_ratio`
    operation for operation (no fastmath), so the decisions are the same bit for bit.
    """
    n = boxes.shape[0]
    x1 = np.empty(n)
    y1 = np.empty(n)
    x2 = np.empty(n)
    y2 = np.empty(n)
    area = np.empty(n)
    pos = np.empty(n, np.intp)
    for k in range(n):
        x1[k] = boxes[k, 0]
        y1[k] = boxes[k, 1]
        x2[k] = boxes[k, 0] + boxes[k, 2]
        y2[k] = boxes[k, 1] + boxes[k, 3]
        area[k] = boxes[k, 2] * boxes[k, 3]
        pos[k] = k
    keep = np.empty(n, np.intp)
    n_keep = 0
    head = 0
    alive = n
    while head < alive:
        i = head
        keep[n_keep] = pos[i]
        n_keep += 1
        ax1, ay1, ax2, ay2, aa = x1[i], y1[i], x2[i], y2[i], area[i]
        w = i + 1
        for j in range(i + 1, alive):
            iw = min(ax2, x2[j]) - max(ax1, x1[j])
            ih = min(ay2, y2[j]) - max(ay1, y1[j])
            inter = max(iw, 0.0) * max(ih, 0.0)
            if over_min:
                den = min(aa, area[j])
            else:
                den = aa + area[j] - inter
            ovr = inter / den if den > 0 else 0.0
            # bbNms: "if(o>overlap), kp(j)=0; end" -- strict comparison; the box stays
            # alive when o <= overlap (written so, a NaN overlap drops it as numpy did)
            if ovr <= threshold:
                x1[w] = x1[j]
                y1[w] = y1[j]
                x2[w] = x2[j]
                y2[w] = y2[j]
                area[w] = area[j]
                pos[w] = pos[j]
                w += 1
        head = i + 1
        alive = w
    return keep[:n_keep]


@functools.cache
def _maxg_kernel():
    """:func:`_greedy_maxg` compiled (numba loads on the first suppression, not on import;
    the machine code is cached on disk like :mod:`viewadapt._kernels`)."""
    from numba import njit

    return njit(cache=True, nogil=True, boundscheck=False)(_greedy_maxg)


def detections_from_scores(boxes, scores, *, threshold: float = 0.0,
                           nms_threshold: float = 0.5, overlap: str = "union",
                           max_candidates: int = 2000, return_index: bool = False,
                           vote: float = 0.0):
    """Threshold, keep the best ``max_candidates``, non-maximum suppression.

    Parameters
    ----------
    boxes : (N, 4) array_like
        ``(x, y, w, h)``.
    scores : (N,) array_like
    return_index : bool
        Also return which of the ``N`` boxes each detection is.
    vote : float
        Box voting's temperature (:func:`voted_boxes`): each kept box replaced by the
        weighted mean of the candidates overlapping it; 0 (default): the kept boxes as
        they are.

    Returns
    -------
    (D, 5) ndarray of ``(x, y, w, h, score)``, decreasing score; with ``return_index``,
    ``(detections, (D,) int64 indices into boxes)``.
    """
    b = np.asarray(boxes, dtype=np.float64)
    s = np.asarray(scores, dtype=np.float64)
    keep = np.flatnonzero(s > threshold)
    if keep.size > max_candidates:
        keep = keep[np.argpartition(-s[keep], max_candidates - 1)[:max_candidates]]
    if keep.size == 0:
        sel = np.zeros(0, np.int64)
    else:
        sel = keep[non_maximum_suppression(b[keep], s[keep], nms_threshold, overlap=overlap)]
    dets = np.c_[b[sel], s[sel]] if sel.size else np.zeros((0, 5))
    if vote and sel.size:
        dets[:, :4] = voted_boxes(b, s, sel, keep, tau=vote, overlap_threshold=nms_threshold,
                                  overlap=overlap)
    return (dets, sel.astype(np.int64)) if return_index else dets


def voted_boxes(boxes, scores, kept, candidates, *, tau: float,
                overlap_threshold: float = 0.5, overlap: str = "union") -> np.ndarray:
    """Box voting: each kept box as the weighted mean of the candidates overlapping it.

    Each kept box ``i`` becomes the mean of the candidate boxes ``j`` (itself included)
    whose overlap with it exceeds ``overlap_threshold`` (the suppression's own test,
    :func:`non_maximum_suppression`), weighted by ``exp((s_j - s_i) / tau)``: neighbours
    scoring nearly as high pull the box towards them, much weaker ones hardly count, and
    a candidate scoring higher (one another detection suppressed) pulls it more than its
    own box does. Scores are left as they are. A box the detector's strongest window
    frames off-centre is so moved towards the person its neighbours frame (Gidaris and
    Komodakis 2015, Sec. 4, weight each overlapping box by its score; here by a
    temperature on the score difference, since SVM scores are not probabilities).

    Parameters
    ----------
    boxes : (N, 4) array_like
        ``(x, y, w, h)``.
    scores : (N,) array_like
    kept, candidates : (D,), (C,) int array_like
        Indices into ``boxes`` of the boxes kept by suppression and of the candidates they
        vote with (the thresholded boxes suppression ran on; ``kept`` among them).
    tau : float
        Temperature, in score units (> 0).
    overlap_threshold : float
    overlap : {"union", "min"}

    Returns
    -------
    (D, 4) ndarray, the voted boxes of ``kept``.

    References
    ----------
    S. Gidaris and N. Komodakis, "Object detection via a multi-region & semantic
    segmentation-aware CNN model", ICCV 2015.
    """
    tau = float(tau)
    if not (np.isfinite(tau) and tau > 0):
        raise ValueError(f"the box voting temperature must be a number > 0, got {tau!r}")
    if overlap not in _OVERLAPS:
        raise ValueError(f"overlap must be one of {_OVERLAPS}, got {overlap!r}")
    b = np.ascontiguousarray(boxes, np.float64).reshape(-1, 4)
    s = np.ascontiguousarray(scores, np.float64).ravel()
    kept = np.ascontiguousarray(kept, np.int64).ravel()
    cand = np.asarray(candidates, np.int64).ravel()
    cand = np.ascontiguousarray(cand[np.argsort(b[cand, 0], kind="stable")])  # by left edge
    out = np.empty((len(kept), 4))
    _vote_kernel()(b, s, kept, cand, float(overlap_threshold), overlap == "min", 1.0 / tau,
                   out)
    return out


def _voted_boxes(b, s, kept, cand, threshold, over_min, inv_tau, out):  # pragma: no cover
    """:func:`voted_boxes`' loop (compiled by :func:`_vote_kernel`): ``cand`` sorted by
    left edge, so each kept box reads only the candidates whose left edge lies within the
    widest candidate's width of its own; the overlap as :func:`_greedy_maxg` computes it.
    The weights ``exp(s_j / tau - top)``, ``top`` the largest ``s_j / tau`` voting, are
    ``exp((s_j - s_i) / tau)`` normalised (the same mean, without overflow)."""
    nc = cand.shape[0]
    left = np.empty(nc)
    votes = np.zeros(nc, np.bool_)
    wmax = 0.0
    for k in range(nc):
        left[k] = b[cand[k], 0]
        wmax = max(wmax, b[cand[k], 2])
    for r in range(kept.shape[0]):
        i = kept[r]
        ax1, ay1 = b[i, 0], b[i, 1]
        ax2, ay2 = ax1 + b[i, 2], ay1 + b[i, 3]
        aa = b[i, 2] * b[i, 3]
        lo = np.searchsorted(left, ax1 - wmax, side="left")
        hi = np.searchsorted(left, ax2, side="right")
        top = s[i] * inv_tau               # the kept box always votes for itself
        own = False
        for k in range(lo, hi):
            j = cand[k]
            iw = min(ax2, b[j, 0] + b[j, 2]) - max(ax1, b[j, 0])
            ih = min(ay2, b[j, 1] + b[j, 3]) - max(ay1, b[j, 1])
            inter = max(iw, 0.0) * max(ih, 0.0)
            area = b[j, 2] * b[j, 3]
            den = min(aa, area) if over_min else aa + area - inter
            ovr = inter / den if den > 0 else 0.0
            votes[k] = j == i or ovr > threshold
            own = own or j == i
            if votes[k]:
                top = max(top, s[j] * inv_tau)
        tw = x = y = w = h = 0.0
        if not own:
            tw = math.exp(s[i] * inv_tau - top)
            x, y, w, h = tw * ax1, tw * ay1, tw * b[i, 2], tw * b[i, 3]
        for k in range(lo, hi):
            if votes[k]:
                j = cand[k]
                wt = math.exp(s[j] * inv_tau - top)
                tw += wt
                x += wt * b[j, 0]
                y += wt * b[j, 1]
                w += wt * b[j, 2]
                h += wt * b[j, 3]
        out[r, 0], out[r, 1], out[r, 2], out[r, 3] = x / tw, y / tw, w / tw, h / tw


@functools.cache
def _vote_kernel():
    """:func:`_voted_boxes` compiled (numba loads on first use, as :func:`_maxg_kernel`)."""
    from numba import njit

    return njit(cache=True, nogil=True, boundscheck=False)(_voted_boxes)
