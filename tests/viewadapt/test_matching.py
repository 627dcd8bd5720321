"""Matching detections to ground truth on each frame and accumulating the frames' matches
into a DET curve (viewadapt.matching, viewadapt.metrics): golden values worked out by hand
and plain-loop ports of the toolbox's bbGt evalRes/compOas and dbEval compRoc.
"""

import numpy as np
import pytest

from tests.tolerances import EXACT
from tests.viewadapt.toolbox_reference import APPROX, toolbox_lamr
from viewadapt.metrics import (
    FPPI_REFERENCE, FrameMatch, accumulate_frames, evaluate_frames, log_average_miss_rate,
    match_detections,
)

# ============================================================================ references


def _comp_oa(d, g, ig):
    """bbGt compOas for one pair (x, y, w, h)."""
    w = min(d[0] + d[2], g[0] + g[2]) - max(d[0], g[0])
    if w <= 0:
        return 0.0
    h = min(d[1] + d[3], g[1] + g[3]) - max(d[1], g[1])
    if h <= 0:
        return 0.0
    t = w * h
    u = d[2] * d[3] if ig else d[2] * d[3] + g[2] * g[3] - t
    return t / u


def _toolbox_eval_res(dt, gt, thr=0.5):
    """Plain-loop port of bbGt evalRes (mul=0).

    dt: list of (x, y, w, h, score); gt: list of (x, y, w, h, ignore).
    Returns (dt_labels, dt_gt) in input order, with dt_gt the matched gt index or -1.
    """
    nd, ng = len(dt), len(gt)
    dord = sorted(range(nd), key=lambda i: -dt[i][4])  # sort(...,'descend'), stable
    gord = sorted(range(ng), key=lambda j: gt[j][4])  # ignore last, stable
    gflag = [-1 if gt[j][4] else 0 for j in gord]
    labels, dgt = [0] * nd, [-1] * nd
    for d in dord:
        bst_oa, bstg, bstm = thr, -1, 0
        for gi, g in enumerate(gord):
            m = gflag[gi]
            if m == 1:
                continue
            if bstm != 0 and m == -1:
                break
            oa = _comp_oa(dt[d], gt[g], m == -1)
            if oa < bst_oa:
                continue
            bst_oa, bstg, bstm = oa, gi, (1 if m == 0 else -1)
        if bstm == -1:
            labels[d], dgt[d] = -1, gord[bstg]
        elif bstm == 1:
            gflag[bstg] = 1
            labels[d], dgt[d] = 1, gord[bstg]
    return labels, dgt


def _toolbox_comp_roc(per_image, n_pos):
    """dbEval compRoc (roc=1): one point per non-ignored detection, no tie grouping."""
    scores = [s for labels, scores in per_image for s, lab in zip(scores, labels) if lab != -1]
    labs = [lab for labels, scores in per_image for lab in labels if lab != -1]
    order = sorted(range(len(scores)), key=lambda i: -scores[i])
    tp = fp = 0
    xs, ys = [], []
    for i in order:
        tp += labs[i] == 1
        fp += labs[i] != 1
        xs.append(fp / len(per_image))
        ys.append(tp / n_pos)
    return xs, ys


def _random_scene(rng, n_dt, n_gt, p_ignore=0.3):
    """Integer boxes on a small canvas (overlaps, exact ties, duplicates are common)."""
    gt = np.hstack(
        [
            rng.integers(0, 30, (n_gt, 2)),
            rng.integers(1, 20, (n_gt, 2)),
            rng.random((n_gt, 1)) < p_ignore,
        ]
    ).astype(float)
    # Half of the detections jitter a gt, the rest are anywhere; a few have zero size.
    dt = np.hstack([rng.integers(0, 30, (n_dt, 2)), rng.integers(0, 20, (n_dt, 2))]).astype(float)
    if n_gt:
        src = rng.integers(0, n_gt, n_dt)
        jitter = rng.random(n_dt) < 0.5
        dt[jitter] = gt[src[jitter], :4] + rng.integers(-2, 3, (int(jitter.sum()), 4))
        dt[:, 2:] = np.maximum(dt[:, 2:], 0)
    scores = rng.integers(0, 6, n_dt) / 6.0  # tied scores on purpose
    return dt, scores, gt


# ============================================================================ summaries


def test_match_greedy_by_score_not_by_overlap():
    # gt [0,0,10,20]. d0 (score .3) is a perfect fit (IoU 1); d1 (score .9) at x=2:
    # intersection 8*20 = 160, union 200+200-160 = 240, IoU 0.67 >= 0.5.
    # d1 scores higher, is visited first and takes the gt; d0 is then a false positive.
    m = match_detections([[0, 0, 10, 20], [2, 0, 10, 20]], [0.3, 0.9], [[0, 0, 10, 20]])
    np.testing.assert_array_equal(m.dt_labels, [0, 1])
    np.testing.assert_array_equal(m.dt_gt_index, [-1, 0])
    np.testing.assert_array_equal(m.gt_matched, [True])
    assert m.dt_labels.dtype == np.int8 and m.n_positives == 1


def test_match_picks_best_overlapping_gt():
    # det [0,0,10,10]; gt0 [3,0,10,10]: IoU 70/130 = 0.54; gt1 [1,0,10,10]: IoU 90/110 = 0.82.
    m = match_detections([[0, 0, 10, 10]], [1.0], [[3, 0, 10, 10], [1, 0, 10, 10]])
    np.testing.assert_array_equal(m.dt_gt_index, [1])
    np.testing.assert_array_equal(m.gt_matched, [False, True])


def test_match_iou_threshold_equality_and_setting():
    # det [0,0,10,10] vs gt [0,0,10,20]: intersection 100, union 200, IoU exactly 0.5 -> TP.
    assert match_detections([[0, 0, 10, 10]], [1.0], [[0, 0, 10, 20]]).dt_labels.tolist() == [1]
    m = match_detections([[0, 0, 10, 10]], [1.0], [[0, 0, 10, 20]], iou_threshold=0.6)
    assert m.dt_labels.tolist() == [0]


def test_match_ignore_regions():
    # gt0 regular [0,0,10,10]; gt1 ignore [0,0,100,100] (a crowd).
    # d0 [0,0,10,10] .9: IoU with gt0 = 1 -> TP (regular gts are preferred, even though its
    #   overlap with the ignore region, intersection / detection area, is also 1).
    # d1, d2 [50,50,10,10] .8 .7: inside the crowd, 100/100 = 1 -> both ignored (an ignore
    #   region absorbs any number of detections).
    # d3 [200,200,10,10] .6: no overlap -> FP.
    dt = [[0, 0, 10, 10], [50, 50, 10, 10], [50, 50, 10, 10], [200, 200, 10, 10]]
    m = match_detections(dt, [0.9, 0.8, 0.7, 0.6], [[0, 0, 10, 10], [0, 0, 100, 100]], [0, 1])
    np.testing.assert_array_equal(m.dt_labels, [1, -1, -1, 0])
    np.testing.assert_array_equal(m.dt_gt_index, [0, 1, 1, -1])
    np.testing.assert_array_equal(m.gt_matched, [True, True])
    assert m.n_positives == 1


def test_match_ignore_overlap_is_over_detection_area():
    # det [0,0,10,10], ignore gt [5,0,100,100]: intersection 5*10 = 50, det area 100 -> 0.5
    # (matches), while the IoU would be 50 / (100 + 10000 - 50) ~ 0.005.
    m = match_detections([[0, 0, 10, 10]], [1.0], [[5, 0, 100, 100]], [True])
    assert m.dt_labels.tolist() == [-1]
    m = match_detections([[0, 0, 10, 10]], [1.0], [[5, 0, 100, 100]], [False])
    assert m.dt_labels.tolist() == [0]


def test_match_taken_gt_falls_back_to_ignore():
    # The same person boxed twice, once as ignore. d0 takes the regular gt; d1 (duplicate)
    # finds it taken and lands on the ignore copy -> ignored, not a false positive.
    box = [0, 0, 10, 10]
    m = match_detections([box, box], [0.9, 0.8], [box, box], [False, True])
    np.testing.assert_array_equal(m.dt_labels, [1, -1])


def test_match_equal_overlaps_last_gt_wins():
    # Two identical regular gts, both IoU 1: the toolbox loop updates on oa >= best, so the
    # later gt is taken first.
    box = [0, 0, 10, 10]
    m = match_detections([box], [1.0], [box, box])
    np.testing.assert_array_equal(m.gt_matched, [False, True])


def test_match_first_qualifying_ignore_region_takes_the_detection():
    # det [0,0,10,10] lies fully inside both ignore regions (overlap 1 with each): the toolbox
    # loop stops at the first one listed. The label is -1 either way.
    m = match_detections([[0, 0, 10, 10]], [1.0], [[0, 0, 50, 50], [0, 0, 20, 20]], [1, 1])
    np.testing.assert_array_equal(m.dt_gt_index, [0])
    np.testing.assert_array_equal(m.gt_matched, [True, False])


def test_match_empty_inputs():
    m = match_detections([], [], [])
    assert m.dt_labels.shape == (0,) and m.gt_matched.shape == (0,)
    m = match_detections([[0, 0, 1, 1]], [0.5], np.zeros((0, 4)))
    assert m.dt_labels.tolist() == [0]
    m = match_detections([], [], [[0, 0, 1, 1]], [True])
    assert m.gt_matched.tolist() == [False] and m.n_positives == 0


@pytest.mark.parametrize("seed", range(8))
def test_match_matches_toolbox_loop_on_random_scenes(seed):
    rng = np.random.default_rng(100 + seed)
    for _ in range(25):
        n_dt, n_gt = int(rng.integers(0, 15)), int(rng.integers(0, 8))
        dt, scores, gt = _random_scene(rng, n_dt, n_gt)
        thr = float(rng.choice([0.3, 0.5, 0.7]))
        m = match_detections(dt, scores, gt[:, :4], gt[:, 4].astype(bool), iou_threshold=thr)
        rows = [list(b) + [s] for b, s in zip(dt, scores)]
        labels, dgt = _toolbox_eval_res(rows, gt.tolist(), thr)
        assert m.dt_labels.tolist() == labels
        assert m.dt_gt_index.tolist() == dgt


@pytest.mark.parametrize(
    "args, match",
    [
        (([[0, 0, -1, 1]], [1.0], [[0, 0, 1, 1]]), "dt_boxes has negative box sizes"),
        (([[0, 0, 1, 1]], [1.0], [[0, 0, 1, -2]]), "gt_boxes has negative box sizes"),
        (([[0, 0, 1, 1]], [np.nan], [[0, 0, 1, 1]]), "dt_scores contains NaN"),
        (([[0, 0, 1, 1]], [1.0, 0.5], [[0, 0, 1, 1]]), "different lengths"),
        (
            ([[0, 0, 1, 1]], [1.0], [[0, 0, 1, 1]], [True, False]),
            r"gt_ignore must have shape \(1,\)",
        ),
        (([[0, 0, 1, 1]], [1.0], [[0, 0, 1, 1]], [2]), "gt_ignore must be bool or 0/1"),
        (([[0, 0, 1, 1]], [1.0], [[0, 0, 1, 1]], None, 0.0), r"iou_threshold must lie in \(0, 1\]"),
        (([[0, 0, 1]], [1.0], [[0, 0, 1, 1]]), r"dt_boxes must have shape \(N, 4\)"),
    ],
)
def test_match_errors(args, match):
    with pytest.raises(ValueError, match=match):
        match_detections(*args)


# ============================================================================ accumulate


def _golden_frames():
    # Image A: gt regular [0,0,10,10]; dets .9 on it (TP), .5 far away (FP).
    # Image B: gts regular [0,0,10,10], ignore [50,50,40,40], regular [500,500,10,10] (missed);
    #   dets .8 inside the ignore region (ignored), .7 on the first gt (TP), .6 far (FP).
    dets = [
        [[0, 0, 10, 10, 0.9], [300, 0, 5, 5, 0.5]],
        [[60, 60, 10, 10, 0.8], [0, 0, 10, 10, 0.7], [300, 300, 5, 5, 0.6]],
    ]
    gts = [
        [[0, 0, 10, 10, 0]],
        [[0, 0, 10, 10, 0], [50, 50, 40, 40, 1], [500, 500, 10, 10, 0]],
    ]
    return dets, gts


def test_accumulate_frames_golden():
    # Non-ignored detections by score: .9 TP, .7 TP, .6 FP, .5 FP; P = 3, I = 2.
    # TP 1 2 2 2 -> miss 2/3 1/3 1/3 1/3;  FP 0 0 1 2 -> fppi 0 0 0.5 1.
    # LAMR: every reference >= 0 reads a point with miss 1/3 -> 1/3.
    dets, gts = _golden_frames()
    matches = [
        match_detections(d[:, :4], d[:, 4], g[:, :4], g[:, 4])
        for d, g in zip(map(np.array, dets), map(np.array, gts))
    ]
    fppi, miss, thr = accumulate_frames(matches)
    np.testing.assert_allclose(fppi, [0, 0, 0.5, 1], **EXACT)
    np.testing.assert_allclose(miss, [2 / 3, 1 / 3, 1 / 3, 1 / 3], **EXACT)
    np.testing.assert_array_equal(thr, [0.9, 0.7, 0.6, 0.5])
    assert log_average_miss_rate(fppi, miss) == pytest.approx(1 / 3, **APPROX)
    # An extra empty image counts in the number of images: fppi 0 0 1/3 2/3.
    fppi3, miss3, _ = accumulate_frames(matches + [match_detections([], [], [])])
    np.testing.assert_allclose(fppi3, [0, 0, 1 / 3, 2 / 3], **EXACT)
    np.testing.assert_array_equal(miss3, miss)

    result = evaluate_frames(dets, gts)
    assert set(result) == {"fppi", "miss_rate", "thresholds", "lamr"}
    np.testing.assert_array_equal(result["fppi"], fppi)
    np.testing.assert_array_equal(result["miss_rate"], miss)
    np.testing.assert_array_equal(result["thresholds"], thr)
    assert result["lamr"] == pytest.approx(1 / 3, **APPROX)


def test_accumulate_frames_ties_form_one_point():
    # Two images, one detection each at score 0.5: one TP, one FP -> a single point
    # (fppi 0.5, miss 0), whatever the order of the images.
    a = match_detections([[0, 0, 10, 10]], [0.5], [[0, 0, 10, 10]])
    b = match_detections([[50, 0, 10, 10]], [0.5], [])
    for ms in ([a, b], [b, a]):
        fppi, miss, thr = accumulate_frames(ms)
        np.testing.assert_array_equal(thr, [0.5])
        np.testing.assert_allclose(fppi, [0.5], **EXACT)
        np.testing.assert_allclose(miss, [0.0], **EXACT)


def test_accumulate_frames_all_detections_ignored_gives_empty_curve():
    m = match_detections([[0, 0, 5, 5]], [0.5], [[0, 0, 10, 10], [0, 0, 50, 50]], [0, 1])
    fppi, miss, thr = accumulate_frames([m])
    assert fppi.shape == miss.shape == thr.shape == (0,)
    assert log_average_miss_rate(fppi, miss) == 1.0


@pytest.mark.parametrize("seed", range(6))
def test_accumulate_matches_toolbox_comp_roc(seed):
    rng = np.random.default_rng(200 + seed)
    n_img = int(rng.integers(1, 30))
    per_image, matches, n_pos = [], [], 0
    for _ in range(n_img):
        dt, _, gt = _random_scene(rng, int(rng.integers(0, 10)), int(rng.integers(1, 6)))
        scores = rng.random(len(dt))  # distinct scores: the toolbox curve has no tie ambiguity
        rows = [list(b) + [s] for b, s in zip(dt, scores)]
        labels, _ = _toolbox_eval_res(rows, gt.tolist())
        per_image.append((labels, list(scores)))
        n_pos += int(np.sum(gt[:, 4] == 0))
        matches.append(match_detections(dt, scores, gt[:, :4], gt[:, 4]))
    if n_pos == 0:
        pytest.skip("random scene without positives")  # pragma: no cover
    xs, ys = _toolbox_comp_roc(per_image, n_pos)
    fppi, miss, _ = accumulate_frames(matches)
    np.testing.assert_allclose(fppi, xs, **EXACT)
    np.testing.assert_allclose(miss, 1 - np.array(ys), **EXACT)
    assert log_average_miss_rate(fppi, miss) == pytest.approx(
        toolbox_lamr(xs, ys, FPPI_REFERENCE), **APPROX
    )


def test_accumulate_errors():
    with pytest.raises(ValueError, match="matches is empty"):
        accumulate_frames([])
    with pytest.raises(ValueError, match="expected a FrameMatch"):
        accumulate_frames([(np.zeros(0), np.zeros(0))])
    only_ignored = match_detections([[0, 0, 1, 1]], [1.0], [[0, 0, 1, 1]], [True])
    with pytest.raises(ValueError, match="no positives"):
        accumulate_frames([only_ignored])
    assert isinstance(only_ignored, FrameMatch)


@pytest.mark.parametrize(
    "dets, gts, match",
    [
        ([[]], [[], []], r"different lengths \(1 != 2 images\)"),
        ([[[0, 0, 1, 1]]], [[[0, 0, 1, 1]]], r"detections\[0\] must have shape \(D, 5\)"),
        ([[]], [[[0, 0, 1]]], r"ground_truths\[0\] must have shape"),
        ([[[0, 0, 1, 1, np.nan]]], [[[0, 0, 1, 1]]], "dt_scores contains NaN"),
        ([[]], [[[0, 0, 1, 1, 1]]], "no positives"),
    ],
)
def test_evaluate_frames_errors(dets, gts, match):
    with pytest.raises(ValueError, match=match):
        evaluate_frames(dets, gts)
