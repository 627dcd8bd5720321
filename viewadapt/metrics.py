"""Detection metrics: DET curves, miss rates and the log-average miss rate.

Evaluation runs in stages, like pycocotools' ``COCOeval`` (``evaluateImg`` -> ``accumulate``
-> ``summarize``):

1. **match** -- :func:`match_detections` labels the detections of one image as true
   positive, false positive or ignored, with the rule of Dollár's toolbox (``bbGt``
   ``evalRes``);
2. **accumulate** -- :func:`accumulate_frames` turns the labels of a whole data set into a
   DET curve ``(fppi, miss_rate, thresholds)``;
3. **summarize** -- :func:`log_average_miss_rate` and :func:`miss_rate_at` read numbers off a
   curve (``dbEval``).

:func:`evaluate_frames` runs the three stages. Window-level evaluation (cropped windows
classified as person / background, Dalal & Triggs' FPPW protocol) uses
:func:`det_curve_windows` and :func:`miss_rate_at_fppw`.

Curve convention
----------------
Every curve is ordered by **decreasing threshold**: point ``i`` counts the detections (or
windows) with ``score >= thresholds[i]``, so the false-positive rate is non-decreasing and the
miss rate non-increasing along the arrays. Tied scores form a single point. This is the
reverse of :func:`sklearn.metrics.det_curve`'s order. No point is added for "nothing
detected"; the summaries supply it (miss rate 1 at any rate below the first point).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from .boxes import check_scores
from .matching import FrameMatch, match_detections

__all__ = [
    "FPPI_REFERENCE",
    "FrameMatch",
    "det_curve_windows",
    "miss_rate_at_fppw",
    "match_detections",
    "accumulate_frames",
    "miss_rate_at",
    "log_average_miss_rate",
    "evaluate_frames",
]

#: The nine reference rates of the Caltech log-average miss rate, ``10 ** (-2:.25:0)``,
#: (9,) float64. Built with scalar ``pow`` so that 0.01, 0.1 and 1 are the exact doubles
#: MATLAB produces: numpy's vectorised ``10.0 ** np.arange(-2, 0.25, 0.25)`` may return
#: ``0.09999999999999999`` for 0.1 (it does on AVX-512 builds), which would drop an operating
#: point at exactly 0.1 FPPI (e.g. 10 false positives over 100 images).
FPPI_REFERENCE = np.array([10.0 ** (k / 4) for k in range(-8, 1)], dtype=np.float64)
FPPI_REFERENCE.setflags(write=False)

#: Floor on the miss rate before taking logs (``dbEval``: ``max(1e-10, 1-ref)``).
_MISS_FLOOR = 1e-10


# --------------------------------------------------------------------------- helpers


def _check_curve(fp_rate, miss_rate, fp_name: str):
    """Validate a DET curve ordered by decreasing threshold; return float64 copies."""
    fp = np.asarray(fp_rate, dtype=np.float64)
    miss = np.asarray(miss_rate, dtype=np.float64)
    if fp.ndim != 1 or miss.ndim != 1:
        raise ValueError(
            f"{fp_name} and miss_rate must be one-dimensional, got shapes {fp.shape} and "
            f"{miss.shape}"
        )
    if fp.shape != miss.shape:
        raise ValueError(
            f"{fp_name} and miss_rate have different lengths ({fp.shape[0]} != {miss.shape[0]})"
        )
    if not (np.all(np.isfinite(fp)) and np.all(np.isfinite(miss))):
        raise ValueError(f"{fp_name} or miss_rate contains NaN or infinite values")
    if np.any(fp < 0):
        raise ValueError(f"{fp_name} must be >= 0")
    if np.any((miss < 0) | (miss > 1)):
        raise ValueError("miss_rate must lie in [0, 1]")
    if np.any(np.diff(fp) < 0):
        raise ValueError(
            f"{fp_name} must be non-decreasing: pass curve points ordered by decreasing "
            "threshold (reverse the arrays returned by sklearn.metrics.det_curve)"
        )
    return fp, miss


def _check_reference(reference, name: str) -> np.ndarray:
    ref = np.asarray(reference, dtype=np.float64)
    if ref.ndim > 1:
        raise ValueError(f"{name} must be a scalar or one-dimensional, got shape {ref.shape}")
    if ref.size == 0:
        raise ValueError(f"{name} is empty")
    if np.isnan(ref).any():
        raise ValueError(f"{name} contains NaN values")
    return ref


def _cumulative_counts(scores: np.ndarray, positive: np.ndarray):
    """Cumulative TP and FP counts at each distinct score, scores descending.

    Returns ``(tp, fp, thresholds)``, each (T,), where ``tp[i]`` / ``fp[i]`` count the
    positive / negative items with ``score >= thresholds[i]``.
    """
    if scores.size == 0:
        empty = np.zeros(0, dtype=np.float64)
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64), empty
    order = np.argsort(-scores, kind="stable")
    s = scores[order]
    p = positive[order]
    tp = np.cumsum(p, dtype=np.int64)
    fp = np.cumsum(~p, dtype=np.int64)
    # Last item of every run of equal scores: all items with score >= that score.
    last = np.flatnonzero(np.append(s[1:] != s[:-1], True))
    return tp[last], fp[last], s[last]


# --------------------------------------------------------------------------- windows


def det_curve_windows(y_true, scores):
    """DET curve of a window classifier: false positives per window against miss rate.

    Parameters
    ----------
    y_true : (N,) array_like of {0, 1} or bool
        1 for a person window, 0 for a background window.
    scores : (N,) array_like
        Classifier scores, higher = person (e.g. ``decision_function``). Must be finite.

    Returns
    -------
    fppw : (T,) ndarray of float64
        False positives per window: fraction of negative windows with
        ``score >= thresholds[i]``. Non-decreasing.
    miss_rate : (T,) ndarray of float64
        Fraction of positive windows with ``score < thresholds[i]`` (the false negative rate).
        Non-increasing.
    thresholds : (T,) ndarray of float64
        The distinct scores, decreasing. ``T <= N``.

    Raises
    ------
    ValueError
        If the lengths differ, ``scores`` has NaN values, ``y_true`` is not binary, or there
        are no positive or no negative windows (the message says which).

    See Also
    --------
    sklearn.metrics.det_curve : same quantities (``fpr``, ``fnr``) in the reverse order,
        with points past full recall / zero false positives trimmed.
    miss_rate_at_fppw, log_average_miss_rate

    Notes
    -----
    With :math:`P` positive and :math:`N` negative windows and threshold :math:`t`,

    .. math::

        \\mathrm{FPPW}(t) = \\frac{|\\{j : y_j = 0,\\ s_j \\ge t\\}|}{N}, \\qquad
        \\mathrm{MR}(t) = \\frac{|\\{j : y_j = 1,\\ s_j < t\\}|}{P}.

    Every distinct score is kept (no intermediate point is dropped).

    References
    ----------
    .. [1] N. Dalal, B. Triggs, "Histograms of Oriented Gradients for Human Detection",
           CVPR 2005 (DET curves in FPPW).
    """
    y, s = _check_binary_problem(y_true, scores)
    pos = y == 1
    n_pos = int(pos.sum())
    n_neg = y.size - n_pos
    tp, fp, thresholds = _cumulative_counts(s, pos)
    fppw = fp / n_neg
    miss_rate = (n_pos - tp) / n_pos
    return fppw, miss_rate, thresholds


def _check_binary_problem(y_true, scores):
    y = np.asarray(y_true)
    if y.ndim != 1:
        raise ValueError(f"y_true must be one-dimensional, got shape {y.shape}")
    if y.dtype == object or not (np.issubdtype(y.dtype, np.number) or y.dtype == bool):
        raise ValueError(f"y_true must be binary (0/1 or bool), got dtype {y.dtype}")
    s = check_scores(scores, y.shape[0], name="scores", other="y_true")
    values = np.unique(y)
    if not np.all(np.isin(values, [0, 1])):
        raise ValueError(
            f"y_true must be binary (0/1 or bool), got values {values[:5].tolist()}; "
            "convert e.g. {-1, +1} labels with y_true == 1"
        )
    y = y.astype(np.int8)
    n_pos = int(y.sum())
    if n_pos == 0:
        raise ValueError("y_true has no positive windows: the miss rate is undefined")
    if n_pos == y.size:
        raise ValueError("y_true has no negative windows: the false positive rate is undefined")
    return y, s


def miss_rate_at_fppw(y_true, scores, fppw=1e-2):
    """Miss rate of a window classifier at a given false-positive-per-window rate.

    Parameters
    ----------
    y_true : (N,) array_like of {0, 1} or bool
        1 for a person window, 0 for a background window.
    scores : (N,) array_like
        Classifier scores, higher = person.
    fppw : float or (R,) array_like, default=1e-2
        Reference false-positive rate(s).

    Returns
    -------
    miss_rate : float or (R,) ndarray
        Miss rate at the operating point with the largest FPPW not exceeding ``fppw`` (among
        points with equal FPPW, the lowest threshold, i.e. the lowest miss rate). If no
        operating point qualifies -- every threshold gives more false positives than
        allowed -- the miss rate is 1.0 (the classifier must reject everything).

    Raises
    ------
    ValueError
        As :func:`det_curve_windows`.

    Notes
    -----
    The rule is the toolbox's (``dbEval``), applied to FPPW: no interpolation between
    operating points, so the value is achievable by some threshold.
    """
    fp, miss, _ = det_curve_windows(y_true, scores)
    return miss_rate_at(fp, miss, fppw)


# --------------------------------------------------------------------------- frames


def accumulate_frames(matches: Sequence[FrameMatch]):
    """DET curve over a set of images: false positives per image against miss rate.

    Parameters
    ----------
    matches : sequence of FrameMatch, length I
        One :func:`match_detections` result per image, images without detections or
        ground truth included (they count in the number of images).

    Returns
    -------
    fppi : (T,) ndarray of float64
        False positives per image, ``FP(t) / I``, non-decreasing.
    miss_rate : (T,) ndarray of float64
        ``1 - TP(t) / P`` with ``P`` the number of non-ignored ground truths,
        non-increasing.
    thresholds : (T,) ndarray of float64
        The distinct scores of the non-ignored detections, decreasing. Empty if no
        detection is left.

    Raises
    ------
    ValueError
        If ``matches`` is empty, holds something else than ``FrameMatch``, or there are no
        non-ignored ground truths (no positives).

    Notes
    -----
    As ``dbEval``'s ``compRoc``: ignored detections are dropped and the rest pooled over
    all images. The toolbox keeps one point per detection, so that with tied scores its
    curve depends on the order of the tied detections; here tied scores form one point (all
    detections with ``score >= t``), which is order-independent and identical to the
    toolbox whenever scores are distinct.
    """
    matches = list(matches)
    if not matches:
        raise ValueError("matches is empty: need at least one image")
    for i, m in enumerate(matches):
        if not isinstance(m, FrameMatch):
            raise ValueError(
                f"matches[{i}] is a {type(m).__name__}, expected a FrameMatch from "
                "match_detections"
            )
    n_images = len(matches)
    n_pos = sum(m.n_positives for m in matches)
    if n_pos == 0:
        raise ValueError(
            "no non-ignored ground truth in any image (no positives): the miss rate is "
            "undefined"
        )
    labels = np.concatenate([m.dt_labels for m in matches])
    scores = np.concatenate([m.dt_scores for m in matches])
    keep = labels != -1
    tp, fp, thresholds = _cumulative_counts(scores[keep], labels[keep] == 1)
    fppi = fp / n_images
    miss_rate = (n_pos - tp) / n_pos
    return fppi, miss_rate, thresholds


# --------------------------------------------------------------------------- summaries


def miss_rate_at(fp_rate, miss_rate, reference):
    """Miss rate of a DET curve at reference false-positive rate(s), without interpolation.

    Parameters
    ----------
    fp_rate : (T,) array_like
        FPPI or FPPW of the curve points, non-decreasing (decreasing threshold).
    miss_rate : (T,) array_like
        Miss rate of the curve points, in ``[0, 1]``.
    reference : float or (R,) array_like
        Reference false-positive rate(s).

    Returns
    -------
    float or (R,) ndarray of float64
        For each reference ``r``: the miss rate of the *last* curve point with
        ``fp_rate <= r`` -- the largest rate not exceeding ``r``, and among equal rates the
        lowest miss rate. 1.0 if no point qualifies (the curve starts above ``r``; at that
        rate the detector must report nothing).

    Raises
    ------
    ValueError
        If the arrays differ in length, are not finite, ``fp_rate`` decreases, or
        ``miss_rate`` leaves ``[0, 1]``.

    Notes
    -----
    This is ``dbEval``'s ``compRoc``: with ``xs1 = [-inf; xs]`` and ``ys1 = [0; ys]`` (recall),
    ``j = find(xs1 <= r); m = ys1(j(end))``; we return ``1 - m``.
    """
    fp, miss = _check_curve(fp_rate, miss_rate, "fp_rate")
    ref = _check_reference(reference, "reference")
    # Number of points with fp <= r; the point before that count is the last one.
    k = np.searchsorted(fp, ref, side="right")
    padded = np.concatenate(([1.0], miss))  # sentinel: before the curve nothing is detected
    out = padded[k]
    return float(out) if out.ndim == 0 else out


def log_average_miss_rate(fppi, miss_rate, ref=None):
    """Log-average miss rate of a DET curve (Dollár et al.'s Caltech summary).

    Parameters
    ----------
    fppi : (T,) array_like
        False positives per image of the curve points, non-decreasing (decreasing
        threshold). A false-positive-per-window curve works the same way; pass ``ref``
        on the FPPW scale then, e.g. ``10 ** np.arange(-6, -1.75, 0.25)``.
    miss_rate : (T,) array_like
        Miss rate of the curve points, in ``[0, 1]``.
    ref : (R,) array_like, optional
        Reference false-positive rates. Default :data:`FPPI_REFERENCE`, the nine rates
        evenly spaced in log space from :math:`10^{-2}` to :math:`10^{0}` FPPI.

    Returns
    -------
    lamr : float
        In ``[1e-10, 1]``; lower is better.

    Raises
    ------
    ValueError
        As :func:`miss_rate_at`, or if ``ref`` is empty or contains NaN.

    Notes
    -----
    Exactly ``dbEval``'s rule: the miss rate at each reference :math:`r_i` is read with
    :func:`miss_rate_at` (last curve point with rate :math:`\\le r_i`, 1 if none), floored
    at :math:`10^{-10}`, and averaged in log space,

    .. math::

        \\mathrm{LAMR} = \\exp\\Big(\\frac{1}{R}\\sum_{i=1}^{R}
        \\log \\max\\big(10^{-10},\\ \\mathrm{MR}(r_i)\\big)\\Big).

    A curve that stops before the last reference (few false positives even at the lowest
    threshold) holds its last miss rate up to that reference; a curve that starts above a
    reference counts a miss rate of 1 there. Two public ports get these cases wrong:
    CityPersons' ``searchsorted(...) - 1`` reads index -1, the *final* miss rate, when the
    curve starts above :math:`10^{-2}`, and brambox returns 0 past the end of the curve.
    An empty curve (no detections) gives 1.

    References
    ----------
    .. [1] P. Dollár, C. Wojek, B. Schiele, P. Perona, "Pedestrian Detection: An Evaluation
           of the State of the Art", IEEE TPAMI 34(4), 2012.
    .. [2] P. Dollár, "Caltech Pedestrian Detection Benchmark" code, ``dbEval.m``.
    """
    ref = FPPI_REFERENCE if ref is None else _check_reference(ref, "ref")
    if ref.ndim == 0:
        ref = ref.reshape(1)
    miss = np.atleast_1d(miss_rate_at(fppi, miss_rate, ref))
    # dbEval: miss = exp(mean(log(max(1e-10, 1-ref))))
    return float(math.exp(np.mean(np.log(np.maximum(_MISS_FLOOR, miss)))))


# --------------------------------------------------------------------------- all stages


def _split_detections(arr, i: int):
    a = np.asarray(arr, dtype=np.float64)
    if a.size == 0:
        return np.zeros((0, 4)), np.zeros(0)
    if a.ndim != 2 or a.shape[1] != 5:
        raise ValueError(
            f"detections[{i}] must have shape (D, 5) with rows (x, y, w, h, score), "
            f"got {a.shape}"
        )
    return a[:, :4], a[:, 4]


def _split_ground_truth(arr, i: int):
    a = np.asarray(arr, dtype=np.float64)
    if a.size == 0:
        return np.zeros((0, 4)), np.zeros(0, dtype=bool)
    if a.ndim != 2 or a.shape[1] not in (4, 5):
        raise ValueError(
            f"ground_truths[{i}] must have shape (G, 4) or (G, 5) with rows "
            f"(x, y, w, h[, ignore]), got {a.shape}"
        )
    if a.shape[1] == 4:
        return a, np.zeros(a.shape[0], dtype=bool)
    return a[:, :4], a[:, 4]


def evaluate_frames(detections, ground_truths, *, iou_threshold=0.5, ref=None):
    """Match, accumulate and summarize detections over a set of images.

    Parameters
    ----------
    detections : sequence of (D_i, 5) array_like, length I
        Per image, rows ``(x, y, w, h, score)`` (the toolbox's ``dt`` format). An image
        without detections may be given as ``[]``.
    ground_truths : sequence of (G_i, 4) or (G_i, 5) array_like, length I
        Per image, rows ``(x, y, w, h)`` or ``(x, y, w, h, ignore)`` with ``ignore`` 0/1
        (the toolbox's ``gt`` format).
    iou_threshold : float, default=0.5
        Minimum overlap for a match, see :func:`match_detections`.
    ref : (R,) array_like, optional
        Reference FPPI for the log-average miss rate, default :data:`FPPI_REFERENCE`.

    Returns
    -------
    dict
        ``"fppi"``, ``"miss_rate"``, ``"thresholds"``: (T,) arrays from
        :func:`accumulate_frames`; ``"lamr"``: float from :func:`log_average_miss_rate`.

    Raises
    ------
    ValueError
        If the two sequences differ in length, or on any error of the three stages.
    """
    detections = list(detections)
    ground_truths = list(ground_truths)
    if len(detections) != len(ground_truths):
        raise ValueError(
            f"detections and ground_truths have different lengths "
            f"({len(detections)} != {len(ground_truths)} images)"
        )
    matches = []
    for i, (dt, gt) in enumerate(zip(detections, ground_truths)):
        dt_boxes, dt_scores = _split_detections(dt, i)
        gt_boxes, gt_ignore = _split_ground_truth(gt, i)
        matches.append(
            match_detections(dt_boxes, dt_scores, gt_boxes, gt_ignore, iou_threshold)
        )
    fppi, miss, thresholds = accumulate_frames(matches)
    return {
        "fppi": fppi,
        "miss_rate": miss,
        "thresholds": thresholds,
        "lamr": log_average_miss_rate(fppi, miss, ref),
    }
