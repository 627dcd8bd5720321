"""Summaries of window-level scores: miss rate at a fppw, LAMR, bootstrap intervals.

Stages (as pycocotools): the cross-validation produced per-window scores (match);
:func:`operating_threshold` / :func:`miss_rate_pooled` accumulate them; :func:`summarize`
and :func:`paired_differences` summarise, with intervals from a bootstrap over test
*persons* (the unit that varies between datasets; negatives are kept fixed, so the
operating threshold at a fppw does not move and the bootstrap is exact and fast).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from viewadapt.metrics import det_curve_windows, log_average_miss_rate, miss_rate_at_fppw

__all__ = ["FPPW_REFERENCE", "operating_threshold", "summarize", "paired_differences",
           "group_keys", "PAPER_MISS_RATES", "PAPER_SWEEP", "PAPER_SWEEP_UNADAPTED"]

#: LAMR over the paper's plotted fppw range (Fig. 5: 1e-3 .. 1), 13 log-spaced points
FPPW_REFERENCE = np.array([10.0 ** (k / 4) for k in range(-12, 1)])
group_keys = ["detector", "source_elevation", "target_elevation", "method"]

#: Wang et al. 2017, Fig. 5 / Fig. 6 data (20170113b_sketchupResults.tex,
#: 20160308_sketchupRobustness.tex): miss rate at 1e-2 fppw, HOG/SVM, target pi/4
PAPER_MISS_RATES = {
    (0.0, "unadapted"): 0.787, (0.0, "image warping"): 0.624, (0.0, "adapted"): 0.645,
    (np.pi / 8, "unadapted"): 0.502, (np.pi / 8, "image warping"): 0.473,
    (np.pi / 8, "adapted"): 0.348, (np.pi / 4, "oracle"): 0.317,
}

#: Wang et al. 2017, Fig. 6 (20160308_sketchupRobustness.tex): a HOG/SVM trained at
#: elevation 0, adapted to each estimate ``k pi / 72`` (k = 1..35) and tested at pi/4 --
#: the miss rate at 1e-2 fppw per estimate, in order, and the unadapted detector's
PAPER_SWEEP = tuple(zip(np.arange(1, 36) * np.pi / 72, (
    0.7863, 0.7739, 0.7676, 0.7623, 0.7514, 0.7416, 0.7384, 0.7298, 0.7073, 0.6992, 0.6968,
    0.6932, 0.6795, 0.6717, 0.6624, 0.6643, 0.6677, 0.6723, 0.6765, 0.6995, 0.7190, 0.7440,
    0.7652, 0.7865, 0.8072, 0.8327, 0.8550, 0.8942, 0.9224, 0.9485, 0.9725, 0.9911, 0.9962,
    0.9994, 0.9984)))
PAPER_SWEEP_UNADAPTED = 0.7964


def operating_threshold(neg_scores, fppw: float) -> float:
    """Score threshold of the DET point used for the miss rate at ``fppw``.

    The toolbox rule: the last curve point (lowest threshold) whose false-positive rate does
    not exceed ``fppw``. With ``k = floor(fppw N_neg)`` allowed false positives, that is the
    lowest score ``s`` with ``#{neg >= s} <= k``; positives with score ``>= s`` are
    detected. Returns ``+inf`` when no point qualifies (miss rate 1).
    """
    neg = np.sort(np.asarray(neg_scores, np.float64))[::-1]
    k = int(np.floor(fppw * len(neg) + 1e-9))
    if k >= len(neg):
        return -np.inf
    # thresholds just above the (k+1)-th highest negative keep at most k negatives
    return np.nextafter(neg[k], np.inf)


def _detected(pos, thr):
    return np.asarray(pos) >= thr


def summarize(scores: pd.DataFrame, *, fppw: float = 1e-2, n_boot: int = 1000,
              rng: np.random.Generator) -> pd.DataFrame:
    """One row per (detector, source, target, method).

    Columns: ``mr_at_fppw_0.01`` (pooled over folds), ``mr_at_fppw_0.01_mean`` and
    ``mr_at_fppw_0.01_std`` (over folds), ``ci_low``/``ci_high`` (95% bootstrap over test
    persons, pooled), ``lamr`` (pooled, fppw 1e-3..1), ``n_pos``, ``n_neg``, ``n_folds``.
    """
    col = f"mr_at_fppw_{fppw:g}"
    rows = []
    for key, d in scores.groupby(group_keys, sort=False):
        lab, sc = d["label"].to_numpy(), d["score"].to_numpy()
        pos, neg = sc[lab == 1], sc[lab == 0]
        if len(pos) == 0 or len(neg) == 0:
            continue
        thr = operating_threshold(neg, fppw)
        det = _detected(pos, thr)
        mr = 1.0 - det.mean()
        fold_mr = [miss_rate_at_fppw(f["label"].to_numpy(), f["score"].to_numpy(), fppw)
                   for _, f in d.groupby("fold") if f["label"].nunique() == 2]
        persons = d.loc[lab == 1, "person_id"].to_numpy()
        uniq, inv = np.unique(persons, return_inverse=True)
        hits = np.bincount(inv, weights=det.astype(float), minlength=len(uniq))
        cnt = np.bincount(inv, minlength=len(uniq)).astype(float)
        draw = rng.integers(len(uniq), size=(n_boot, len(uniq)))
        boot = 1.0 - hits[draw].sum(1) / cnt[draw].sum(1)
        fp, miss, _ = det_curve_windows(lab, sc)
        rows.append(dict(zip(group_keys, key)) | {
            col: mr, f"{col}_mean": float(np.mean(fold_mr)) if fold_mr else np.nan,
            f"{col}_std": float(np.std(fold_mr, ddof=1)) if len(fold_mr) > 1 else np.nan,
            "ci_low": float(np.percentile(boot, 2.5)), "ci_high": float(np.percentile(boot, 97.5)),
            "lamr": log_average_miss_rate(fp, miss, ref=FPPW_REFERENCE),
            "n_pos": int(len(pos)), "n_neg": int(len(neg)), "n_persons": int(len(uniq)),
            "n_folds": int(d["fold"].nunique())})
    return pd.DataFrame(rows)


DEFAULT_PAIRS = (("adapted", "unadapted"), ("image warping", "unadapted"),
                 ("adapted", "image warping"), ("synthesised", "unadapted"),
                 ("synthesised", "adapted"), ("adapted[S only]", "adapted"),
                 ("adapted[paper eq.3]", "adapted"), ("adapted[single A]", "adapted"),
                 ("adapted[body]", "adapted"), ("adapted[body]", "adapted[paper eq.3]"),
                 ("adapted[body]", "synthesised"), ("adapted[body]", "unadapted"),
                 ("adapted[body, paper eq.3]", "adapted[body]"),
                 ("image warping[body]", "image warping"),
                 ("exact geometry", "adapted"), ("exact geometry", "adapted[body]"),
                 ("exact geometry[paper eq.3]", "exact geometry"))


def paired_differences(scores: pd.DataFrame, *, pairs=DEFAULT_PAIRS, fppw: float = 1e-2,
                       n_boot: int = 1000, rng: np.random.Generator) -> pd.DataFrame:
    """Pooled miss-rate differences ``a - b`` on the same test windows, with a paired
    bootstrap over test persons (the same resampled persons for both methods).

    Columns: detector, source/target elevation, ``method_a``, ``method_b``, ``diff``,
    ``ci_low``, ``ci_high``, ``p_a_better`` (bootstrap fraction with ``a < b``).
    """
    rows = []
    keys = ["detector", "source_elevation", "target_elevation"]
    for key, d in scores.groupby(keys, sort=False):
        by = {m: g for m, g in d.groupby("method")}
        for a, b in pairs:
            if a not in by or b not in by:
                continue
            stats = []
            for m in (a, b):
                g = by[m]
                lab, sc = g["label"].to_numpy(), g["score"].to_numpy()
                thr = operating_threshold(sc[lab == 0], fppw)
                det = _detected(sc[lab == 1], thr).astype(float)
                stats.append((g.loc[lab == 1, "person_id"].to_numpy(), det))
            persons = np.unique(np.r_[stats[0][0], stats[1][0]])
            per = []
            for pid, det in stats:
                inv = np.searchsorted(persons, pid)
                per.append((np.bincount(inv, weights=det, minlength=len(persons)),
                            np.bincount(inv, minlength=len(persons)).astype(float)))
            draw = rng.integers(len(persons), size=(n_boot, len(persons)))
            mr = [1 - h.sum() / c.sum() for h, c in per]
            boot = [1 - h[draw].sum(1) / c[draw].sum(1) for h, c in per]
            diff = boot[0] - boot[1]
            rows.append(dict(zip(keys, key)) | {
                "method_a": a, "method_b": b, "diff": mr[0] - mr[1],
                "ci_low": float(np.percentile(diff, 2.5)),
                "ci_high": float(np.percentile(diff, 97.5)),
                "p_a_better": float((diff < 0).mean())})
    return pd.DataFrame(rows)
