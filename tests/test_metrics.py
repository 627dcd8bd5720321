"""Tests for viewadapt.metrics.

Each stage is checked three ways: golden values worked out by hand (in the comments),
properties, and a plain-loop port of Dollár's toolbox (bbGt evalRes/compOas, dbEval
compRoc) that the fast numpy code must reproduce.
"""

import math

import numpy as np
import pytest
from sklearn.metrics import roc_curve

from tests.tolerances import EXACT
from viewadapt.metrics import (
    FPPI_REFERENCE,
    FrameMatch,
    accumulate_frames,
    det_curve_windows,
    evaluate_frames,
    log_average_miss_rate,
    match_detections,
    miss_rate_at,
    miss_rate_at_fppw,
)

#: pytest.approx spelling of EXACT (float64 arithmetic on counts; no iterative algorithm).
APPROX = dict(rel=EXACT["rtol"], abs=EXACT["atol"])

# ============================================================================ references


def _toolbox_lamr(xs, ys, ref):
    """Plain-loop port of dbEval: xs = fppi, ys = recall, curve by decreasing score.

    xs1=[-inf; xs]; ys1=[0; ys];
    for i=1:m, j=find(xs1<=ref(i)); ref(i)=ys1(j(end)); end
    miss=exp(mean(log(max(1e-10,1-ref))));
    """
    xs1 = [-math.inf] + list(xs)
    ys1 = [0.0] + list(ys)
    logs = []
    for r in ref:
        j = [i for i, x in enumerate(xs1) if x <= r]
        logs.append(math.log(max(1e-10, 1.0 - ys1[j[-1]])))
    return math.exp(sum(logs) / len(logs))


def _citypersons_lamr(fppi, miss, ref):
    """CityPersons-style port: ``searchsorted(...) - 1`` with no sentinel (buggy)."""
    inds = np.searchsorted(fppi, ref, side="right") - 1
    q = np.asarray(miss)[inds]  # index -1 silently reads the *final* miss rate
    return float(np.exp(np.mean(np.log(np.maximum(1e-10, q)))))


def _brambox_lamr(fppi, miss, ref):
    """brambox-style port: miss rate 0 past the end of the curve, no floor (buggy)."""
    vals = []
    for r in ref:
        j = [i for i, x in enumerate(fppi) if x <= r]
        if r > fppi[-1]:
            vals.append(0.0)
        else:
            vals.append(miss[j[-1]] if j else 1.0)
    with np.errstate(divide="ignore"):
        return float(np.exp(np.mean(np.log(vals))))


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


def test_default_reference_is_the_exact_caltech_grid():
    # 10.^(-2:.25:0): nine points, 0.01, 0.1 and 1 exactly (scalar pow is correctly rounded).
    assert FPPI_REFERENCE.shape == (9,)
    assert FPPI_REFERENCE[0] == 0.01 and FPPI_REFERENCE[4] == 0.1 and FPPI_REFERENCE[8] == 1.0
    np.testing.assert_allclose(FPPI_REFERENCE, np.logspace(-2, 0, 9), **EXACT)
    assert not FPPI_REFERENCE.flags.writeable


def test_lamr_single_point_golden():
    # One point at fppi = 0.1 (e.g. 10 FP over 100 images), miss 0.25.
    # References 0.01, 0.018, 0.032, 0.056 (< 0.1): no point -> miss 1.
    # References 0.1 (exactly, included), 0.18, 0.32, 0.56, 1: miss 0.25.
    # LAMR = exp((4 log 1 + 5 log 0.25) / 9) = 0.25 ** (5 / 9).
    fppi, miss = np.array([10 / 100]), np.array([0.25])
    assert log_average_miss_rate(fppi, miss) == pytest.approx(0.25 ** (5 / 9), **APPROX)
    assert log_average_miss_rate(fppi, miss) == pytest.approx(
        _toolbox_lamr(fppi, 1 - miss, FPPI_REFERENCE), **APPROX
    )


def test_lamr_curve_starting_above_first_reference_golden():
    # fppi = [0.05, 0.5, 2], miss = [0.6, 0.4, 0.2].
    # r = 0.01, 0.018, 0.032 -> before the curve, miss 1
    # r = 0.056, 0.1, 0.18, 0.32 -> point 0, miss 0.6
    # r = 0.56, 1 -> point 1, miss 0.4 (point 2 at fppi 2 is never read)
    # LAMR = 0.6 ** (4/9) * 0.4 ** (2/9)
    fppi, miss = np.array([0.05, 0.5, 2.0]), np.array([0.6, 0.4, 0.2])
    expected = 0.6 ** (4 / 9) * 0.4 ** (2 / 9)
    ours = log_average_miss_rate(fppi, miss)
    assert ours == pytest.approx(expected, **APPROX)
    assert ours == pytest.approx(_toolbox_lamr(fppi, 1 - miss, FPPI_REFERENCE), **APPROX)
    # CityPersons' searchsorted-1 reads the final miss rate 0.2 at the first three refs.
    buggy = _citypersons_lamr(fppi, miss, FPPI_REFERENCE)
    assert buggy == pytest.approx(0.2 ** (3 / 9) * 0.6 ** (4 / 9) * 0.4 ** (2 / 9), **APPROX)
    assert ours > buggy * 1.5


def test_lamr_curve_stopping_before_one_golden():
    # fppi = [0.005, 0.02, 0.3], miss = [0.5, 0.3, 0.1]; the curve ends at 0.3 FPPI.
    # r = 0.01, 0.018 -> point 0 (0.5); r = 0.032, 0.056, 0.1, 0.18 -> point 1 (0.3);
    # r = 0.32, 0.56, 1 -> point 2 held (0.1).
    # LAMR = 0.5 ** (2/9) * 0.3 ** (4/9) * 0.1 ** (3/9)
    fppi, miss = np.array([0.005, 0.02, 0.3]), np.array([0.5, 0.3, 0.1])
    expected = 0.5 ** (2 / 9) * 0.3 ** (4 / 9) * 0.1 ** (3 / 9)
    ours = log_average_miss_rate(fppi, miss)
    assert ours == pytest.approx(expected, **APPROX)
    assert ours == pytest.approx(_toolbox_lamr(fppi, 1 - miss, FPPI_REFERENCE), **APPROX)
    assert _brambox_lamr(fppi, miss, FPPI_REFERENCE) == 0.0  # the brambox failure mode


def test_lamr_ties_in_fppi_take_the_last_point():
    # fppi = [0.01, 0.01, 0.5], miss = [0.7, 0.6, 0.2]: at equal fppi the last point (lowest
    # miss) counts. r = 0.01 .. 0.32 (7 refs) -> 0.6; r = 0.56, 1 -> 0.2.
    fppi, miss = np.array([0.01, 0.01, 0.5]), np.array([0.7, 0.6, 0.2])
    expected = 0.6 ** (7 / 9) * 0.2 ** (2 / 9)
    assert log_average_miss_rate(fppi, miss) == pytest.approx(expected, **APPROX)


def test_lamr_perfect_detector_hits_the_floor():
    # Every positive found before any false positive: miss 0 at all refs -> clamp 1e-10.
    lamr = log_average_miss_rate([0.0, 0.0, 3.0], [0.5, 0.0, 0.0])
    assert lamr == pytest.approx(1e-10, rel=1e-12)


def test_lamr_empty_curve_is_one():
    # No detection at all: the sentinel gives miss 1 everywhere (dbEval: ref=ref*0).
    assert log_average_miss_rate([], []) == 1.0


def test_lamr_is_between_floor_and_one_and_monotone_in_miss():
    rng = np.random.default_rng(5)
    fppi = np.sort(rng.random(20) * 3)
    miss = np.sort(rng.random(20))[::-1]
    lamr = log_average_miss_rate(fppi, miss)
    assert 1e-10 <= lamr <= 1
    # Lowering the miss rate of every point can only lower the LAMR.
    assert log_average_miss_rate(fppi, miss * 0.5) < lamr
    # Missing 100% at every point (nothing found) is 1.
    assert log_average_miss_rate(fppi, np.ones(20)) == pytest.approx(1.0, **APPROX)


@pytest.mark.parametrize("seed", range(10))
def test_lamr_matches_plain_loop_on_random_curves(seed):
    rng = np.random.default_rng(seed)
    for _ in range(20):
        n = int(rng.integers(1, 40))
        n_img = int(rng.integers(5, 400))
        n_pos = int(rng.integers(1, 60))
        fppi = np.sort(rng.integers(0, 300, n)) / n_img  # ties in fppi are common
        miss = (n_pos - np.sort(rng.integers(0, n_pos + 1, n))) / n_pos
        ours = log_average_miss_rate(fppi, miss)
        ref = _toolbox_lamr(fppi, 1 - miss, FPPI_REFERENCE)
        assert ours == pytest.approx(ref, **APPROX)


def test_lamr_on_fppw_scale_matches_plain_loop():
    rng = np.random.default_rng(99)
    ref = np.array([10.0 ** (k / 4) for k in range(-24, -7)])  # 1e-6 .. 1e-2 FPPW
    fppw = np.sort(rng.integers(0, 2000, 50)) / 100_000
    miss = np.sort(rng.random(50))[::-1]
    assert log_average_miss_rate(fppw, miss, ref=ref) == pytest.approx(
        _toolbox_lamr(fppw, 1 - miss, ref), **APPROX
    )


def test_miss_rate_at_golden():
    fppi, miss = [0.05, 0.5, 0.5, 2.0], [0.6, 0.4, 0.3, 0.2]
    assert miss_rate_at(fppi, miss, 0.01) == 1.0  # before the curve
    assert miss_rate_at(fppi, miss, 0.05) == 0.6  # equality included
    assert miss_rate_at(fppi, miss, 0.7) == 0.3  # last of the tied points at 0.5
    assert miss_rate_at(fppi, miss, 100.0) == 0.2  # past the end: hold the last point
    out = miss_rate_at(fppi, miss, [0.01, 0.1, 1.0])
    assert isinstance(out, np.ndarray)
    np.testing.assert_array_equal(out, [1.0, 0.6, 0.3])
    assert isinstance(miss_rate_at(fppi, miss, 0.1), float)


@pytest.mark.parametrize(
    "fppi, miss, match",
    [
        ([0.5, 0.1], [0.2, 0.4], "non-decreasing.*det_curve"),  # sklearn's order
        ([0.1, 0.5], [0.2], r"different lengths \(2 != 1\)"),
        ([0.1, np.nan], [0.4, 0.2], "NaN or infinite"),
        ([0.1, 0.5], [0.4, 1.5], r"miss_rate must lie in \[0, 1\]"),
        ([-0.1, 0.5], [0.4, 0.2], ">= 0"),
    ],
)
def test_curve_errors(fppi, miss, match):
    with pytest.raises(ValueError, match=match):
        log_average_miss_rate(fppi, miss)
    with pytest.raises(ValueError, match=match):
        miss_rate_at(fppi, miss, 0.1)


def test_reference_errors():
    with pytest.raises(ValueError, match="ref is empty"):
        log_average_miss_rate([0.1], [0.5], ref=[])
    with pytest.raises(ValueError, match="reference contains NaN"):
        miss_rate_at([0.1], [0.5], np.nan)


# ============================================================================ windows


def test_det_curve_windows_golden():
    # scores 0.9 .. 0.4, labels 1 1 0 1 0 0: P = 3, N = 3.
    # t:    0.9  0.8  0.7  0.6  0.5  0.4
    # TP:   1    2    2    3    3    3     -> miss 2/3 1/3 1/3 0 0 0
    # FP:   0    0    1    1    2    3     -> fppw 0 0 1/3 1/3 2/3 1
    y = [1, 1, 0, 1, 0, 0]
    s = [0.9, 0.8, 0.7, 0.6, 0.5, 0.4]
    fppw, miss, thr = det_curve_windows(y, s)
    np.testing.assert_allclose(fppw, [0, 0, 1 / 3, 1 / 3, 2 / 3, 1], **EXACT)
    np.testing.assert_allclose(miss, [2 / 3, 1 / 3, 1 / 3, 0, 0, 0], **EXACT)
    np.testing.assert_array_equal(thr, s)
    # miss_rate_at_fppw: 0.5 -> last point with fppw <= 0.5 is t=0.6 (miss 0);
    # 1e-2 -> last point with fppw 0 is t=0.8 (miss 1/3).
    assert miss_rate_at_fppw(y, s, 0.5) == 0.0
    assert miss_rate_at_fppw(y, s) == pytest.approx(1 / 3, **APPROX)


def test_det_curve_windows_ties_form_one_point():
    # A positive and a negative tie at 0.5: one point with both counted.
    fppw, miss, thr = det_curve_windows([1, 0, 1, 0], [0.9, 0.5, 0.5, 0.1])
    np.testing.assert_array_equal(thr, [0.9, 0.5, 0.1])
    np.testing.assert_allclose(fppw, [0, 0.5, 1], **EXACT)
    np.testing.assert_allclose(miss, [0.5, 0, 0], **EXACT)


def test_miss_rate_at_fppw_no_qualifying_point_is_one():
    # The top score is a negative: even the strictest threshold gives fppw = 1 > 0.5.
    assert miss_rate_at_fppw([0, 1], [0.9, 0.1], 0.5) == 1.0
    np.testing.assert_array_equal(miss_rate_at_fppw([0, 1], [0.9, 0.1], [0.5, 1.0]), [1.0, 0.0])


@pytest.mark.parametrize("seed", range(5))
def test_det_curve_windows_matches_sklearn_roc_curve(seed):
    rng = np.random.default_rng(seed)
    y = rng.random(300) < 0.3
    y[:2] = [True, False]
    scores = rng.integers(0, 40, 300) / 7.0  # ties
    fppw, miss, thr = det_curve_windows(y, scores)
    fpr, tpr, sk_thr = roc_curve(y, scores, drop_intermediate=False)
    # roc_curve prepends the (0, 0, inf) "nothing detected" point; ours does not.
    np.testing.assert_array_equal(thr, sk_thr[1:])
    np.testing.assert_allclose(fppw, fpr[1:], **EXACT)
    np.testing.assert_allclose(miss, 1 - tpr[1:], **EXACT)
    assert np.all(np.diff(fppw) >= 0) and np.all(np.diff(miss) <= 0)


def test_det_curve_windows_accepts_bool_and_is_order_invariant():
    rng = np.random.default_rng(1)
    y = rng.random(50) < 0.5
    s = rng.random(50)
    perm = rng.permutation(50)
    a = det_curve_windows(y, s)
    b = det_curve_windows(y[perm].astype(int), s[perm])
    for u, v in zip(a, b):
        np.testing.assert_array_equal(u, v)


@pytest.mark.parametrize(
    "y, s, match",
    [
        ([0, 1, 2], [0.1, 0.2, 0.3], "binary"),
        ([-1, 1], [0.1, 0.2], "binary"),
        ([0, 0, 0], [0.1, 0.2, 0.3], "no positive windows"),
        ([1, 1], [0.1, 0.2], "no negative windows"),
        ([0, 1], [0.1, np.nan], "scores contains NaN"),
        ([0, 1, 1], [0.1, 0.2], r"different lengths \(2 != 3\)"),
        ([], [], "no positive windows"),
    ],
)
def test_window_errors(y, s, match):
    with pytest.raises(ValueError, match=match):
        det_curve_windows(y, s)
    with pytest.raises(ValueError, match=match):
        miss_rate_at_fppw(y, s)


# ============================================================================ matching


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
        _toolbox_lamr(xs, ys, FPPI_REFERENCE), **APPROX
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
