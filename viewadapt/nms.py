"""Greedy non-maximum suppression of detection boxes (Dollár's toolbox ``bbNms`` 'maxg').

Boxes are ``(x, y, w, h)`` in continuous pixel coordinates, as in Piotr Dollár's toolbox: the
box covers ``[x, x + w) x [y, y + h)`` and its area is ``w * h`` (no "+1" pixel convention).
"""

from __future__ import annotations

import numpy as np

from .boxes import check_boxes, check_scores, safe_ratio

__all__ = ["non_maximum_suppression", "detections_from_scores"]

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

    The loop runs over kept boxes only; each step computes the overlaps with all remaining
    boxes at once, which gives the same result as the toolbox's double loop.

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
    # coordinates in visiting order, gathered once; each step compares the kept box with
    # the boxes still alive (the same arithmetic as box_intersections / safe_ratio)
    x1, y1 = boxes[order, 0], boxes[order, 1]
    x2, y2 = x1 + boxes[order, 2], y1 + boxes[order, 3]
    areas = boxes[order, 2] * boxes[order, 3]
    alive = np.arange(order.size)
    keep = []
    while alive.size:
        i = alive[0]
        keep.append(order[i])
        rest = alive[1:]
        iw = np.minimum(x2[i], x2[rest]) - np.maximum(x1[i], x1[rest])
        ih = np.minimum(y2[i], y2[rest]) - np.maximum(y1[i], y1[rest])
        inter = np.clip(iw, 0.0, None) * np.clip(ih, 0.0, None)
        if overlap == "union":
            den = areas[i] + areas[rest] - inter
        else:
            den = np.minimum(areas[i], areas[rest])
        ovr = safe_ratio(inter, den)
        # bbNms: "if(o>overlap), kp(j)=0; end" -- strict comparison.
        alive = rest[ovr <= thr]
    return np.asarray(keep, dtype=np.intp)


def detections_from_scores(boxes, scores, *, threshold: float = 0.0,
                           nms_threshold: float = 0.5, overlap: str = "union",
                           max_candidates: int = 2000, return_index: bool = False):
    """Threshold, keep the best ``max_candidates``, non-maximum suppression.

    Parameters
    ----------
    boxes : (N, 4) array_like
        ``(x, y, w, h)``.
    scores : (N,) array_like
    return_index : bool
        Also return which of the ``N`` boxes each detection is.

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
    return (dets, sel.astype(np.int64)) if return_index else dets
