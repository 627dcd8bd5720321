"""Robustness to a wrong elevation estimate (Wang et al. 2017, Fig. 6), and beyond.

A detector trained at the source elevation (0) is adapted to each *estimated* target
elevation on a grid over ``[0, pi/2)`` and tested on data of the *true* target elevation
(pi/4), fold by fold. Beyond the paper (its conclusion names it as future work): adaptation
under an uncertain elevation, with ``G`` averaged over a Gaussian prior around the estimate,
``G_bar(e) = sum_k w_k G(0 -> e_k)`` (Gauss-Hermite nodes, truncated to ``[0, pi/2)``).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from sklearn import config_context

from viewadapt.geometry import elevation_homography

from benchmark.crops.crossval import (
    ADAPT_VARIANTS, CrossvalConfig, fold_masks, prepare, task_seed, training_windows,
    variant_remap, view_maps,
)
from benchmark.crops.detectors import detector_spec, feature_key
from benchmark.crops.features import FeatureCache
from benchmark.crops.folds import make_folds
from benchmark.crops.summarize import operating_threshold
from benchmark.data import Dataset

__all__ = ["run_sweep", "averaged_remap", "sweep_summary", "SWEEP_VARIANTS"]

_MAX_ELEVATION = np.pi / 2 - 1e-3
#: the adapted variants swept side by side (angle rule x object model), in plot order
SWEEP_VARIANTS = ("adapted", "adapted[paper eq.3]", "adapted[S only]", "adapted[body]",
                  "adapted[body, paper eq.3]", "adapted[body, S only]")


def averaged_remap(det, source, estimate, sigma, cfg, n_nodes: int = 5):
    """``G`` averaged over ``N(estimate, sigma^2)`` truncated to ``[0, pi/2)``."""
    x, w = np.polynomial.hermite_e.hermegauss(n_nodes)
    w = w / w.sum()
    acc, tot = None, 0.0
    for xi, wi in zip(x, w):
        e = estimate + sigma * xi
        if not 0 <= e < _MAX_ELEVATION:
            continue
        G = variant_remap(det, elevation_homography(source, e, distance=cfg.distance,
                                                    framing=cfg.framing), "adapted", cfg)
        acc = G * wi if acc is None else acc + G * wi
        tot += wi
    if acc is None:
        e = min(max(estimate, 0), _MAX_ELEVATION)
        return variant_remap(det, elevation_homography(source, e, distance=cfg.distance,
                                                       framing=cfg.framing), "adapted", cfg)
    return acc / tot


def run_sweep(ds: Dataset, cfg: CrossvalConfig, cache: FeatureCache, *, detector="hog",
              source=0.0, step=np.pi / 72, sigma=0.1, variants=SWEEP_VARIANTS,
              progress=True, models=None, extra=None) -> pd.DataFrame:
    """Per fold, method and estimate: the test windows' scores.

    Every variant of ``variants`` (names of :data:`benchmark.crops.crossval.ADAPT_VARIANTS`: an
    angle rule and an object model; those whose model is not in ``cfg.object_models`` are
    left out) is adapted to each estimate and scored by the same fold models, so the
    curves differ only in the rule and model. The prior-averaged curve uses ``adapted``.
    ``models`` (optional): source models by ``(detector, source, fold name)`` from
    :func:`benchmark.crops.crossval.run_crossval` with the same seed and windows, used instead of
    training them again (the same models: the seeds derive from the same ids).
    ``extra`` (optional): a function of the estimate giving more ``{method name: G}`` to
    score beside the variants (e.g. a study's own remappings), on the same folds and models.

    Returns
    -------
    DataFrame with columns ``fold, method, estimate, label, score, person_id`` (the
    unadapted rows have ``estimate = NaN``); :func:`sweep_summary` pools the folds the way
    :func:`benchmark.crops.summarize.summarize` does, so the levels match the cross-validation.
    """
    from tqdm.auto import tqdm

    cfg = CrossvalConfig(**{**cfg.__dict__, "sources": (source,), "detectors": (detector,),
                            "ablations": False, "synthesised": False})
    rng = np.random.default_rng(cfg.seed)
    p = ds.persons
    folds = make_folds(p["person_id"], p["scene_id"], rng=rng)
    data = prepare(ds, cfg, cache)
    spec = detector_spec(detector)
    src_rep, fine_rep = feature_key(spec.source_features), feature_key(spec.target_features)
    es, et = data["index"][source], data["index"][cfg.target]
    estimates = np.arange(0.0, _MAX_ELEVATION, step)
    variants = [v for v in variants if ADAPT_VARIANTS[v][2] in cfg.object_models]
    if not variants:
        raise ValueError("no sweep variant left: --object-models excludes all of them")
    Gs = {}
    for e in tqdm(estimates, desc="sweep: remapping", disable=not progress):
        maps = view_maps(source, float(e), cfg)
        for v in variants:
            Gs[(v, e)] = variant_remap(detector, maps[ADAPT_VARIANTS[v][2]], v, cfg)
        for name, G in (extra(float(e)) if extra is not None else {}).items():
            Gs[(name, e)] = G
    if sigma > 0:
        for e in estimates:
            Gs[(f"adapted, prior σ={sigma:g}", e)] = averaged_remap(detector, source, e, sigma, cfg)
    F = data["feat"]
    seeds = [task_seed(cfg.seed, detector, source, f) for f in folds]
    meta_p, meta_n = data["meta"][("person", et)], data["meta"][("background", et)]
    fine = np.vstack([F[(fine_rep, "person", et, "")], F[(fine_rep, "background", et, "")]])
    plain = np.vstack([F[(src_rep, "person", et, "")], F[(src_rep, "background", et, "")]])
    n_pos_all = len(meta_p)
    labels_all = np.r_[np.ones(n_pos_all, np.int8), np.zeros(len(meta_n), np.int8)]
    pids_all = np.r_[meta_p["person_id"].to_numpy(), np.full(len(meta_n), "")]
    # per fold: the trained model and its test windows (rows of fine / plain)
    # the recipe's sets, stacked: each has its kind's rows (training_windows)
    n_sets = {k: sum(kk == k for kk, _ in cfg.recipe.training_suffixes())
              for k in ("person", "background")}
    meta_s = {k: data["meta"][(k, es)] for k in n_sets}
    X_all = training_windows(F, src_rep, es, "", {k: np.ones(len(m), bool)
                                                  for k, m in meta_s.items()}, cfg.recipe)
    train = [tuple(np.tile(fold_masks(meta_s[k], fold, True), n_sets[k]) for k in n_sets)
             + (int(seed),) for fold, seed in zip(folds, seeds)]
    data_args = (spec, X_all["person"], X_all["background"], cfg)
    fold_models = [(models or {}).get((detector, float(source), f.name)) for f in folds]
    todo = [k for k, m in enumerate(fold_models) if m is None]
    it = tqdm([train[k] for k in todo], desc="sweep: training", disable=not progress)
    if cfg.n_jobs == 1 or len(todo) < 2:
        fitted = [_fit_fold(*t, *data_args) for t in it]
    else:
        from joblib import Parallel, delayed

        fitted = Parallel(n_jobs=cfg.n_jobs)(delayed(_fit_fold)(*t, *data_args) for t in it)
    for k, m in zip(todo, fitted):
        fold_models[k] = m
    tests = [np.flatnonzero(np.r_[fold_masks(meta_p, fold, False),
                                  fold_masks(meta_n, fold, False)]) for fold in folds]
    used = np.unique(np.concatenate(tests))       # background windows serve three folds
    parts = []                                    # (fold, method, estimate, rows, scores)
    # the models' inputs are finite by construction: skip sklearn's check of every call
    with config_context(assume_finite=True):
        for fold, model, idx in zip(folds, fold_models, tests):
            parts.append((fold.name, "unadapted", np.nan, idx, spec.score(model, plain[idx])))
    Xu = fine[used]
    rows = [np.searchsorted(used, idx) for idx in tests]
    # each estimate's scores depend on its G alone, so workers may take them in any order
    # (joblib hands the windows to the workers once, memory-mapped)
    score_args = (spec, Xu, fold_models, rows)
    it = tqdm(list(Gs.values()), desc="sweep: estimates", disable=not progress)
    if cfg.n_jobs == 1:
        done = [_score_estimate(G, *score_args) for G in it]
    else:
        from joblib import Parallel, delayed

        done = Parallel(n_jobs=cfg.n_jobs)(delayed(_score_estimate)(G, *score_args) for G in it)
    for (method, e), scores in zip(Gs, done):
        for fold, idx, sc in zip(folds, tests, scores):
            parts.append((fold.name, method, float(e), idx, sc))
    sizes = [len(p[3]) for p in parts]
    idx = np.concatenate([p[3] for p in parts])
    return pd.DataFrame({"fold": np.repeat([p[0] for p in parts], sizes).astype(object),
                         "method": np.repeat([p[1] for p in parts], sizes).astype(object),
                         "estimate": np.repeat([p[2] for p in parts], sizes),
                         "label": labels_all[idx],
                         "score": np.concatenate([np.asarray(p[4], np.float32)
                                                  for p in parts]),
                         "person_id": pids_all[idx]})


def _fit_fold(pos_mask, neg_mask, seed, spec, X_pos, X_neg, cfg):
    """One fold's source model from its training windows (rows of ``X_pos``, ``X_neg``)."""
    return spec.fit(X_pos[pos_mask], X_neg[neg_mask], seed=seed, config=cfg)


def _score_estimate(G, spec, Xu, models, rows) -> list:
    """Each fold model's scores of its test windows (``rows`` of ``Xu``) through ``G``;
    every window is remapped once."""
    # the models' inputs are finite by construction: skip sklearn's check of every call
    with config_context(assume_finite=True):
        prepared = spec.adapted_inputs(Xu, G)
        return [spec.score_adapted_inputs(model, prepared[r], G)
                for model, r in zip(models, rows)]


def _rule_model(method: str) -> tuple[str, str]:
    """(angle rule, object model) of a sweep method name ("" for the unadapted rows)."""
    base = method.split(",")[0] if method.startswith("adapted, prior") else method
    if base in ADAPT_VARIANTS:
        rule, _, model = ADAPT_VARIANTS[base]
        return rule, model
    return "", ""


def sweep_summary(rows: pd.DataFrame, fppw: float = 1e-2) -> pd.DataFrame:
    """Miss rate at ``fppw`` per (method, estimate), scores pooled over folds (as in the
    cross-validation summary), plus the mean and std of the per-fold miss rates."""
    out = []
    for (method, est), d in rows.groupby(["method", "estimate"], dropna=False, sort=False):
        lab, sc = d["label"].to_numpy(), d["score"].to_numpy(np.float64)
        thr = operating_threshold(sc[lab == 0], fppw)
        fold_mr = []
        for _, f in d.groupby("fold"):
            fl, fs = f["label"].to_numpy(), f["score"].to_numpy(np.float64)
            fold_mr.append(1 - (fs[fl == 1] >= operating_threshold(fs[fl == 0], fppw)).mean())
        rule, model = _rule_model(method)
        out.append({"method": method, "rule": rule, "object_model": model, "estimate": est,
                    "n_pos": int((lab == 1).sum()),
                    "mr_at_fppw_0.01": 1 - (sc[lab == 1] >= thr).mean(),
                    "fold_mean": float(np.mean(fold_mr)), "fold_std": float(np.std(fold_mr))})
    return pd.DataFrame(out)
