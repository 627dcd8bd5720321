"""Tests for viewadapt.metrics.

Each stage is checked three ways: golden values worked out by hand (in the comments),
properties, and a plain-loop port of Dollár's toolbox (bbGt evalRes/compOas, dbEval
compRoc) that the fast numpy code must reproduce.
"""

import numpy as np
import pytest
from sklearn.metrics import roc_curve

from tests.tolerances import EXACT
from tests.viewadapt.toolbox_reference import APPROX, toolbox_lamr
from viewadapt.metrics import (
    FPPI_REFERENCE,
    det_curve_windows,
    log_average_miss_rate,
    miss_rate_at,
    miss_rate_at_fppw,
)


# ============================================================================ references


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
        toolbox_lamr(fppi, 1 - miss, FPPI_REFERENCE), **APPROX
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
    assert ours == pytest.approx(toolbox_lamr(fppi, 1 - miss, FPPI_REFERENCE), **APPROX)
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
    assert ours == pytest.approx(toolbox_lamr(fppi, 1 - miss, FPPI_REFERENCE), **APPROX)
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
        ref = toolbox_lamr(fppi, 1 - miss, FPPI_REFERENCE)
        assert ours == pytest.approx(ref, **APPROX)


def test_lamr_on_fppw_scale_matches_plain_loop():
    rng = np.random.default_rng(99)
    ref = np.array([10.0 ** (k / 4) for k in range(-24, -7)])  # 1e-6 .. 1e-2 FPPW
    fppw = np.sort(rng.integers(0, 2000, 50)) / 100_000
    miss = np.sort(rng.random(50))[::-1]
    assert log_average_miss_rate(fppw, miss, ref=ref) == pytest.approx(
        toolbox_lamr(fppw, 1 - miss, ref), **APPROX
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
