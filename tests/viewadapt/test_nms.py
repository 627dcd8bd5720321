"""Tests for viewadapt.nms: hand cases, a plain-loop port of bbNms 'maxg', the previous
numpy implementation as a reference for the compiled one, error paths."""

import numpy as np
import pytest

from viewadapt.boxes import safe_ratio
from viewadapt.nms import detections_from_scores, non_maximum_suppression


def _nms_maxg_loop(boxes, scores, overlap, ovr_dnm):
    """Plain-loop port of the toolbox's nmsMaxg (greedy=1), returning original indices.

    [~,ord]=sort(bbs(:,5),'descend') is stable in MATLAB; Python's sorted is stable too.
    """
    boxes = [list(map(float, b)) for b in boxes]
    order = sorted(range(len(boxes)), key=lambda i: -scores[i])
    kp = [True] * len(order)
    for a in range(len(order)):
        if not kp[a]:
            continue
        xi, yi, wi, hi = boxes[order[a]]
        for b in range(a + 1, len(order)):
            if not kp[b]:
                continue
            xj, yj, wj, hj = boxes[order[b]]
            iw = min(xi + wi, xj + wj) - max(xi, xj)
            if iw <= 0:
                continue
            ih = min(yi + hi, yj + hj) - max(yi, yj)
            if ih <= 0:
                continue
            o = iw * ih
            u = wi * hi + wj * hj - o if ovr_dnm == "union" else min(wi * hi, wj * hj)
            if o / u > overlap:
                kp[b] = False
    return [order[a] for a in range(len(order)) if kp[a]]


def _nms_previous(boxes, scores, thr, overlap):
    """The numpy implementation before the compiled loop (one vectorised step per kept box).

    Kept as the reference the compiled one must match decision for decision.
    """
    boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    scores = np.asarray(scores, dtype=np.float64)
    order = np.argsort(-scores, kind="stable")
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
        alive = rest[safe_ratio(inter, den) <= thr]
    return np.asarray(keep, dtype=np.intp)


def _detections_previous(boxes, scores, *, threshold=0.0, nms_threshold=0.5, overlap="union",
                         max_candidates=2000):
    """``detections_from_scores`` before the compiled loop: ``(detections, indices)``."""
    b = np.asarray(boxes, dtype=np.float64)
    s = np.asarray(scores, dtype=np.float64)
    keep = np.flatnonzero(s > threshold)
    if keep.size > max_candidates:
        keep = keep[np.argpartition(-s[keep], max_candidates - 1)[:max_candidates]]
    if keep.size == 0:
        sel = np.zeros(0, np.int64)
    else:
        sel = keep[_nms_previous(b[keep], s[keep], nms_threshold, overlap)]
    dets = np.c_[b[sel], s[sel]] if sel.size else np.zeros((0, 5))
    return dets, sel.astype(np.int64)


# ----------------------------------------------------------------------------- hand cases


def test_identical_boxes_keep_the_best_one():
    boxes = [[5, 5, 20, 40]] * 4
    keep = non_maximum_suppression(boxes, [0.1, 0.7, 0.3, 0.2])
    assert keep.tolist() == [1]


def test_disjoint_boxes_all_kept_in_score_order():
    boxes = [[0, 0, 10, 10], [20, 0, 10, 10], [0, 20, 10, 10], [10, 10, 5, 5]]  # touch only
    keep = non_maximum_suppression(boxes, [0.2, 0.9, 0.5, 0.7], iou_threshold=0.0)
    # Boxes sharing an edge have zero intersection: nothing is suppressed even at t = 0.
    assert keep.tolist() == [1, 3, 2, 0]


def test_empty_input_gives_empty_int_array():
    keep = non_maximum_suppression(np.zeros((0, 4)), np.zeros(0))
    assert keep.shape == (0,)
    assert keep.dtype == np.intp
    assert non_maximum_suppression([], []).dtype == np.intp


def test_union_overlap_golden():
    # [0,0,10,10] vs [5,0,10,10]: intersection 5*10 = 50, union 100+100-50 = 150, IoU 1/3.
    boxes = [[0, 0, 10, 10], [5, 0, 10, 10]]
    assert non_maximum_suppression(boxes, [1.0, 0.5], 0.5).tolist() == [0, 1]
    assert non_maximum_suppression(boxes, [1.0, 0.5], 0.33).tolist() == [0]
    assert non_maximum_suppression(boxes, [1.0, 0.5], 0.34).tolist() == [0, 1]


def test_overlap_equal_to_threshold_is_kept():
    # [0,0,10,10] vs [0,0,10,5]: intersection 50, union 100 -> IoU exactly 0.5; the toolbox
    # suppresses only when o > overlap.
    boxes = [[0, 0, 10, 10], [0, 0, 10, 5]]
    assert non_maximum_suppression(boxes, [0.9, 0.8], 0.5).tolist() == [0, 1]
    # Over the smaller area the overlap is 50 / 50 = 1.
    assert non_maximum_suppression(boxes, [0.9, 0.8], 0.5, overlap="min").tolist() == [0]


def test_min_overlap_suppresses_nested_box():
    # [2,2,4,4] inside [0,0,10,10]: intersection 16, IoU 16/100 = 0.16, over min 16/16 = 1.
    boxes = [[0, 0, 10, 10], [2, 2, 4, 4]]
    assert non_maximum_suppression(boxes, [0.9, 0.8], 0.5).tolist() == [0, 1]
    assert non_maximum_suppression(boxes, [0.9, 0.8], 0.65, overlap="min").tolist() == [0]
    # The nested box scoring higher suppresses the big one too (the min is symmetric).
    assert non_maximum_suppression(boxes, [0.1, 0.8], 0.65, overlap="min").tolist() == [1]


def test_suppressed_box_suppresses_nothing():
    # A=[0,0,10,10], B=[4,0,10,10], C=[8,0,10,10]; scores A > B > C.
    # IoU(A,B) = 60/140 = 0.43 > 0.4 -> B out. IoU(B,C) = 0.43 would remove C, but B is
    # already out; IoU(A,C) = 20/180 = 0.11 -> C stays (greedy 'maxg').
    boxes = [[0, 0, 10, 10], [4, 0, 10, 10], [8, 0, 10, 10]]
    assert non_maximum_suppression(boxes, [0.9, 0.8, 0.7], 0.4).tolist() == [0, 2]


def test_tied_scores_keep_input_order():
    boxes = [[0, 0, 10, 10], [0, 0, 10, 10], [50, 0, 10, 10]]
    assert non_maximum_suppression(boxes, [0.5, 0.5, 0.5]).tolist() == [0, 2]


def test_zero_area_boxes_are_never_suppressed():
    boxes = [[0, 0, 10, 10], [3, 3, 0, 0], [3, 3, 0, 5]]
    for overlap in ("union", "min"):
        keep = non_maximum_suppression(boxes, [0.9, 0.8, 0.7], 0.0, overlap=overlap)
        assert keep.tolist() == [0, 1, 2]


# ----------------------------------------------------------------------------- properties


def _random_boxes(rng, n):
    # Integer coordinates on a small canvas: many overlaps, exact ties and duplicates.
    xy = rng.integers(0, 40, size=(n, 2))
    wh = rng.integers(0, 25, size=(n, 2))
    boxes = np.hstack([xy, wh]).astype(np.float64)
    scores = rng.integers(0, 8, size=n) / 8.0  # tied scores on purpose
    return boxes, scores


@pytest.mark.parametrize("overlap", ["union", "min"])
@pytest.mark.parametrize("threshold", [0.0, 0.3, 0.5, 0.65, 1.0])
def test_matches_plain_loop_on_random_boxes(overlap, threshold):
    rng = np.random.default_rng(20170 + int(threshold * 100) + (overlap == "min"))
    for _ in range(30):
        n = int(rng.integers(0, 40))
        boxes, scores = _random_boxes(rng, n)
        fast = non_maximum_suppression(boxes, scores, threshold, overlap=overlap)
        slow = _nms_maxg_loop(boxes, scores, threshold, overlap)
        assert fast.tolist() == slow
        assert fast.dtype == np.intp
        np.testing.assert_array_equal(fast, _nms_previous(boxes, scores, threshold, overlap))


def _window_like_boxes(rng, n):
    # Non-integer boxes on a frame, sizes from a few window heights, many near-duplicates and
    # rounded scores: overlaps close to every threshold, ties in score.
    h = rng.choice([40.0, 48.5, 57.25, 96.0], size=n)
    w = np.round(h * rng.uniform(0.35, 0.45, size=n), 2)
    xy = np.round(rng.uniform(0, 160, size=(n, 2)), 1)
    boxes = np.c_[xy, w, h]
    boxes[n // 2:] = boxes[: n - n // 2]               # exact duplicates with other scores
    scores = np.round(rng.normal(size=n), 1)
    return boxes, scores


@pytest.mark.parametrize("overlap", ["union", "min"])
@pytest.mark.parametrize("threshold", [0.0, 0.2, 0.5, 0.65, 0.9, 1.0])
def test_matches_previous_implementation_on_many_window_boxes(overlap, threshold):
    rng = np.random.default_rng(1805 + int(threshold * 100) + 7 * (overlap == "min"))
    for n in (0, 1, 2, 257, 1500):
        boxes, scores = _window_like_boxes(rng, n)
        fast = non_maximum_suppression(boxes, scores, threshold, overlap=overlap)
        np.testing.assert_array_equal(fast, _nms_previous(boxes, scores, threshold, overlap))


@pytest.mark.parametrize("overlap, nms_threshold", [("union", 0.5), ("min", 0.65),
                                                     ("union", 0.0), ("min", 1.0)])
@pytest.mark.parametrize("max_candidates", [1, 50, 2000])
def test_detections_from_scores_match_previous_implementation(overlap, nms_threshold,
                                                              max_candidates):
    """Same detections, order and indices, also when ``max_candidates`` cuts through ties."""
    rng = np.random.default_rng(18 + max_candidates + 3 * (overlap == "min"))
    boxes, scores = _window_like_boxes(rng, 3000)
    for threshold in (-1.0, 0.0, 0.95, 10.0):
        kw = dict(threshold=threshold, nms_threshold=nms_threshold, overlap=overlap,
                  max_candidates=max_candidates)
        dets, idx = detections_from_scores(boxes, scores, return_index=True, **kw)
        dets_ref, idx_ref = _detections_previous(boxes, scores, **kw)
        np.testing.assert_array_equal(dets, dets_ref)
        np.testing.assert_array_equal(idx, idx_ref)
        assert idx.dtype == np.int64 and dets.shape == (len(idx), 5)


def test_zero_and_one_candidates():
    for overlap in ("union", "min"):
        one = non_maximum_suppression([[3.0, 4.0, 10.0, 20.0]], [-2.0], 0.0, overlap=overlap)
        assert one.tolist() == [0] and one.dtype == np.intp
        assert non_maximum_suppression(np.zeros((0, 4)), [], overlap=overlap).tolist() == []
    boxes = np.array([[0.0, 0.0, 10.0, 20.0], [1.0, 0.0, 10.0, 20.0]])
    dets, idx = detections_from_scores(boxes, [0.2, 0.7], threshold=0.5, return_index=True)
    assert idx.tolist() == [1] and dets.tolist() == [[1.0, 0.0, 10.0, 20.0, 0.7]]
    dets, idx = detections_from_scores(boxes, [0.2, 0.7], threshold=0.9, return_index=True)
    assert dets.shape == (0, 5) and idx.shape == (0,) and idx.dtype == np.int64
    dets, idx = detections_from_scores(np.zeros((0, 4)), np.zeros(0), return_index=True)
    assert dets.shape == (0, 5) and idx.shape == (0,)


def test_kept_boxes_do_not_overlap_above_threshold_and_cover_the_rest():
    rng = np.random.default_rng(7)
    boxes, _ = _random_boxes(rng, 60)
    scores = rng.permutation(60).astype(float)  # distinct scores
    t = 0.4
    keep = non_maximum_suppression(boxes, scores, t)
    assert np.all(np.diff(scores[keep]) < 0)  # sorted by descending score

    def iou(a, b):
        iw = max(0.0, min(a[0] + a[2], b[0] + b[2]) - max(a[0], b[0]))
        ih = max(0.0, min(a[1] + a[3], b[1] + b[3]) - max(a[1], b[1]))
        u = a[2] * a[3] + b[2] * b[3] - iw * ih
        return iw * ih / u if u > 0 else 0.0

    kept = set(keep.tolist())
    for i in kept:
        for j in kept:
            if i < j:
                assert iou(boxes[i], boxes[j]) <= t
    # Every removed box is suppressed by a kept box with a higher score.
    for j in set(range(60)) - kept:
        assert any(scores[i] > scores[j] and iou(boxes[i], boxes[j]) > t for i in kept)


def test_permuting_inputs_permutes_indices():
    rng = np.random.default_rng(3)
    boxes, _ = _random_boxes(rng, 30)
    scores = rng.random(30)
    perm = rng.permutation(30)
    keep = non_maximum_suppression(boxes, scores)
    keep_p = non_maximum_suppression(boxes[perm], scores[perm])
    assert perm[keep_p].tolist() == keep.tolist()


def test_threshold_one_keeps_everything():
    rng = np.random.default_rng(11)
    boxes, scores = _random_boxes(rng, 25)
    assert sorted(non_maximum_suppression(boxes, scores, 1.0).tolist()) == list(range(25))


# ----------------------------------------------------------------------------- errors


@pytest.mark.parametrize(
    "boxes, scores, kwargs, match",
    [
        ([[0, 0, 1]], [1.0], {}, r"shape \(N, 4\)"),
        ([[0, 0, -1, 2]], [1.0], {}, "negative box sizes"),
        ([[0, 0, 1, np.nan]], [1.0], {}, "NaN or infinite"),
        ([[0, 0, 1, 1]], [np.nan], {}, "scores contains NaN"),
        ([[0, 0, 1, 1]], [1.0, 2.0], {}, r"different lengths \(2 != 1\)"),
        ([[0, 0, 1, 1]], [1.0], {"iou_threshold": 1.5}, r"iou_threshold must lie in \[0, 1\]"),
        ([[0, 0, 1, 1]], [1.0], {"overlap": "iou"}, "overlap must be one of"),
    ],
)
def test_errors(boxes, scores, kwargs, match):
    with pytest.raises(ValueError, match=match):
        non_maximum_suppression(boxes, scores, **kwargs)


def test_detections_from_scores_names_the_kept_boxes():
    rng = np.random.default_rng(3)
    boxes = np.c_[rng.uniform(0, 200, (300, 2)), np.full((300, 1), 20.0), np.full((300, 1), 48.0)]
    boxes[150:] = boxes[:150]                       # every box twice: equal boxes, other scores
    scores = rng.normal(size=300)
    dets, idx = detections_from_scores(boxes, scores, threshold=0.0, return_index=True)
    assert np.array_equal(dets, detections_from_scores(boxes, scores, threshold=0.0))
    assert idx.dtype == np.int64 and len(idx) == len(dets) > 0
    np.testing.assert_array_equal(dets[:, :4], boxes[idx])
    np.testing.assert_array_equal(dets[:, 4], scores[idx])
    none, idx = detections_from_scores(boxes, scores, threshold=10.0, return_index=True)
    assert none.shape == (0, 5) and idx.shape == (0,)


# --- box voting -------------------------------------------------------------------------

def test_box_voting_is_the_weighted_mean_of_the_overlapping_candidates():
    """A kept box moves to the mean of itself and the candidates overlapping it, each
    weighted by exp((s_j - s_kept) / tau); a far box and the scores do not move."""
    from viewadapt.nms import detections_from_scores

    boxes = np.array([[0, 0, 10, 20], [2, 0, 10, 20], [1, 0, 10, 20], [50, 0, 10, 20.]])
    scores = np.array([2.0, 1.5, 1.7, 1.0])
    tau = 0.5
    dets, kept = detections_from_scores(boxes, scores, threshold=0.0, vote=tau,
                                        return_index=True)
    assert kept.tolist() == [0, 3]
    w = np.exp((scores[:3] - 2.0) / tau)
    np.testing.assert_allclose(dets[0, :4], w @ boxes[:3] / w.sum())
    np.testing.assert_array_equal(dets[1, :4], boxes[3])
    np.testing.assert_array_equal(dets[:, 4], [2.0, 1.0])


def test_box_voting_off_cold_and_below_the_threshold():
    """vote 0 is plain suppression; scores never move; a very small temperature takes each
    kept box to the best-scoring candidate overlapping it (itself, unless a candidate
    another detection suppressed scores higher); candidates below the threshold never
    vote."""
    from viewadapt.nms import detections_from_scores

    rng = np.random.default_rng(3)
    boxes = np.c_[rng.uniform(0, 100, (300, 2)), rng.uniform(10, 40, (300, 2))]
    scores = rng.normal(size=300)
    plain, kept = detections_from_scores(boxes, scores, threshold=-0.5, return_index=True)
    np.testing.assert_array_equal(detections_from_scores(boxes, scores, threshold=-0.5,
                                                         vote=0.0), plain)
    voted = detections_from_scores(boxes, scores, threshold=-0.5, vote=1.0)
    assert not np.allclose(voted[:, :4], plain[:, :4])
    np.testing.assert_array_equal(voted[:, 4], plain[:, 4])
    cold = detections_from_scores(boxes, scores, threshold=-0.5, vote=1e-9)
    cand = np.flatnonzero(scores > -0.5)
    for row, i in zip(cold, kept):
        x0 = np.maximum(boxes[cand, 0], boxes[i, 0])
        x1 = np.minimum(boxes[cand, 0] + boxes[cand, 2], boxes[i, 0] + boxes[i, 2])
        y0 = np.maximum(boxes[cand, 1], boxes[i, 1])
        y1 = np.minimum(boxes[cand, 1] + boxes[cand, 3], boxes[i, 1] + boxes[i, 3])
        inter = np.clip(x1 - x0, 0, None) * np.clip(y1 - y0, 0, None)
        iou = inter / (boxes[cand, 2] * boxes[cand, 3] + boxes[i, 2] * boxes[i, 3] - inter)
        near = cand[iou > 0.5]
        np.testing.assert_allclose(row[:4], boxes[near[np.argmax(scores[near])]], atol=1e-6)
    # a strong box just below the threshold does not vote
    b = np.array([[0, 0, 10, 20], [3, 0, 10, 20.]])
    d = detections_from_scores(b, np.array([1.0, 0.9]), threshold=0.95, vote=1.0)
    np.testing.assert_array_equal(d[0, :4], b[0])


@pytest.mark.parametrize("tau", [0.0, -1.0, float("nan"), float("inf")])
def test_box_voting_refuses_a_bad_temperature(tau):
    from viewadapt.nms import voted_boxes

    with pytest.raises(ValueError, match="temperature must be a number > 0"):
        voted_boxes(np.zeros((1, 4)), np.zeros(1), [0], [0], tau=tau)
