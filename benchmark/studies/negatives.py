"""Does the angle rule's ranking depend on what the source detector saw as negatives?

``python -m benchmark.studies.negatives --data DIR --out DIR [--folds N] [--quick]``

Viewpoint adaptation (Wang et al. 2017) scores a target-view window ``x`` with a source
detector through ``G = S (x) A``; the angle rule of ``A`` (``covariant``, the literal eq. (3)
``paper``, or ``none`` = S only) decides where target gradients land in the source model's
orientation bins. A source HOG/SVM trained on elevation-0 negatives learns which bins
backgrounds leave empty; ``G`` is applied to target backgrounds as well as to persons. This
study retrains the cross-validation's source HOG/SVM (:mod:`benchmark.crops.crossval`: the same
folds, seeds and configuration) on the same elevation-0 training persons and one of these
negative pools, all from the training scenes of the fold:

``elevation 0``
    the cross-validation's negatives (background windows at elevation 0);
``+ rotated``
    plus the same windows rotated in the image by +-30 and +-60 degrees about their centre
    (read from the whole background image): orientation-enriched negatives with no
    target-view data;
``+ shifted (control)``
    plus the same windows shifted by (+-8, +-8) px (read from the whole image): as many
    added negatives as ``+ rotated`` with the elevation-0 orientation statistics, the control
    for the pool's size;
``+ pi/4 backgrounds``
    plus the target elevation's background windows, read as they are (8-px cells), i.e.
    label-free target-view negatives that were never remapped;
``+ pi/4 through G``
    plus the target elevation's background windows through the rule's own ``G`` (4-px
    cells remapped onto the source cells): the negatives the adapted detector will meet,
    one model per rule.

Each model is tested, as the cross-validation, on the fold's target-view test persons and
background windows (scene- and person-disjoint) through ``G`` of each rule (plane object
model; and the covariant rule with the mean-body model, :mod:`viewadapt.objectmodel`), and
unadapted. Reported: the miss rate at 1e-2 false positives per window with a
95 % bootstrap interval over persons, the paired difference ``covariant - paper eq.3`` per
pool, and the change of that gap against the elevation-0 pool (the same resampled persons
for all four rows).

Outputs (``--out``): ``negatives_summary.csv``, ``negatives_gaps.csv``, ``negative_bin_shares.csv``,
``scores.parquet``,
``negatives.md``, ``negatives.png``, ``run.json``.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import pandas as pd

from viewadapt.adapt import remap_features
from viewadapt.io.files import atomic_output_dir, check_output_dir, run_metadata
from viewadapt.warp import translation

from benchmark.studies.contributions import CELL_SHAPE, bin_energy
from benchmark.crops.crossval import (
    ADAPT_VARIANTS, CrossvalConfig, fold_masks, task_seed, variant_remap, view_maps,
)
from benchmark.crops.detectors import detector_spec
from benchmark.data import load_dataset
from benchmark.recipes import PAPER_RECIPE
from benchmark.crops.features import (
    ROTATIONS_DEG, FeatureCache, background_windows, person_windows, rotated_windows,
)
from benchmark.crops.folds import make_folds
from benchmark.crops.summarize import operating_threshold, summarize
from benchmark.studies import report_error

__all__ = ["POOLS", "RULES", "SHIFTS_PX", "gap_changes", "run_negatives", "main"]

#: rule label -> the cross-validation's adapted method (object model: plane unless named)
RULES = {"covariant": "adapted", "paper eq.3": "adapted[paper eq.3]",
         "S only": "adapted[S only]", "covariant, body": "adapted[body]"}
POOLS = ("elevation 0", "+ rotated", "+ shifted (control)", "+ pi/4 backgrounds",
         "+ pi/4 through G")
#: the control's shifts (px): as many copies as rotations, half the background stride
SHIFTS_PX = ((-8, -8), (-8, 8), (8, -8), (8, 8))
DETECTOR = "hog"


def _per_person(pid, det):
    persons, inv = np.unique(pid, return_inverse=True)
    return persons, np.bincount(inv, weights=det.astype(float)), np.bincount(inv).astype(float)


def gap_changes(scores: pd.DataFrame, *, a: str, b: str, reference_pool: str,
                fppw: float = 1e-2, n_boot: int = 1000, rng) -> pd.DataFrame:
    """Per pool: ``gap = MR(rule a) - MR(rule b)`` and ``gap - gap(reference_pool)`` with a
    paired bootstrap over test persons (the same draw for every row of a replicate).

    ``scores`` has columns pool, rule, score, label, person_id (the same test windows in
    every (pool, rule)). Thresholds are set on each row's negatives, as in
    :func:`benchmark.crops.summarize.paired_differences`.
    """
    per, persons = {}, None
    for (pool, rule), g in scores.groupby(["pool", "rule"], sort=False):
        if rule not in (a, b):
            continue
        lab, sc = g["label"].to_numpy(), g["score"].to_numpy()
        thr = operating_threshold(sc[lab == 0], fppw)
        pp, hits, counts = _per_person(g.loc[lab == 1, "person_id"].to_numpy(),
                                       sc[lab == 1] >= thr)   # as the toolbox rule
        if persons is None:
            persons = pp
        elif not np.array_equal(persons, pp):
            raise ValueError("every pool and rule must be scored on the same test persons")
        per[(pool, rule)] = (hits, counts)
    if persons is None:
        raise ValueError(f"no rows of rules {a!r} and {b!r}")
    draw = rng.integers(len(persons), size=(n_boot, len(persons)))

    def mr(key, boot):
        h, c = per[key]
        return 1 - (h[draw].sum(1) / c[draw].sum(1) if boot else h.sum() / c.sum())

    pools = [p for p in dict.fromkeys(scores["pool"]) if (p, a) in per and (p, b) in per]
    if reference_pool not in pools:
        raise ValueError(f"reference pool {reference_pool!r} lacks rule {a!r} or {b!r}")
    ref = mr((reference_pool, a), False) - mr((reference_pool, b), False)
    ref_boot = mr((reference_pool, a), True) - mr((reference_pool, b), True)
    rows = []
    for p in pools:
        gap = mr((p, a), False) - mr((p, b), False)
        boot = mr((p, a), True) - mr((p, b), True)
        rows.append({"pool": p, "rule_a": a, "rule_b": b, "gap": gap,
                     "gap_ci_low": float(np.quantile(boot, 0.025)),
                     "gap_ci_high": float(np.quantile(boot, 0.975)),
                     "change": gap - ref,
                     "change_ci_low": float(np.quantile(boot - ref_boot, 0.025)),
                     "change_ci_high": float(np.quantile(boot - ref_boot, 0.975))})
    return pd.DataFrame(rows)


def _config(ds, seed=0, quick=False) -> CrossvalConfig:
    cfg = CrossvalConfig.for_dataset(ds, seed=seed, object_models=("plane", "body"),
                                     recipe=PAPER_RECIPE)
    if quick:
        cfg.initial_negatives = 2000
    return cfg


def run_negatives(ds, cfg: CrossvalConfig, cache: FeatureCache, *, n_folds: int = 9,
                  progress: bool = True) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Scores of every (pool, rule) on every fold's test windows, and the mean orientation
    histogram (energy share per bin, :func:`benchmark.studies.contributions.bin_energy`) of each
    set of added negatives over all scenes."""
    spec = detector_spec(DETECTOR)
    src, fine = spec.source_features, spec.target_features
    p = ds.persons
    folds = make_folds(p["person_id"], p["scene_id"], rng=np.random.default_rng(cfg.seed))
    if isinstance(n_folds, bool) or not isinstance(n_folds, (int, np.integer)) \
            or not 1 <= n_folds <= len(folds):
        raise ValueError(f"--folds must be an integer in 1..{len(folds)}, got {n_folds!r}")
    folds = folds[:n_folds]
    s, t = 0.0, float(cfg.target)
    es, et = ds.elevation_index(s), ds.elevation_index(t)
    pos_s, bg_s = person_windows(ds, es), background_windows(ds, es, stride=cfg.bg_stride)
    pos_t, bg_t = person_windows(ds, et), background_windows(ds, et, stride=cfg.bg_stride)
    X = {"pos_s": cache.get(pos_s, src), "bg_s": cache.get(bg_s, src),
         "pos_t": cache.get(pos_t, fine), "bg_t": cache.get(bg_t, fine),
         "pos_t8": cache.get(pos_t, src), "bg_t8": cache.get(bg_t, src)}
    rot = np.concatenate([cache.get(rotated_windows(bg_s, a), src) for a in ROTATIONS_DEG])
    rot_scene = np.tile(bg_s.meta["scene_id"].to_numpy(), len(ROTATIONS_DEG))
    shift = np.concatenate([cache.get(bg_s.warped(translation(dx, dy), f"shift{dx:+d}{dy:+d}",
                                                  crop_first=False), src)
                            for dx, dy in SHIFTS_PX])
    assert len(SHIFTS_PX) == len(ROTATIONS_DEG)          # the same scene labels
    maps = view_maps(s, t, cfg)
    G = {r: variant_remap(DETECTOR, maps[ADAPT_VARIANTS[m][2]], m, cfg)
         for r, m in RULES.items()}
    # pi/4 backgrounds through G, in source-cell layout (what fit reads)
    GX = {r: remap_features(g, X["bg_t"]) for r, g in G.items()}
    pool_sets = {"elevation 0": X["bg_s"], "+ rotated": rot, "+ shifted (control)": shift,
                 "+ pi/4 backgrounds": X["bg_t8"],
                 **{f"+ pi/4 through G ({r})": GX[r] for r in RULES}}
    shares = pd.DataFrame([{"negatives": k, "bin": b, "bin_centre_deg": (b + 0.5) * 20,
                            "energy_share": v}
                           for k, E in pool_sets.items()
                           for b, v in enumerate(bin_energy(E.reshape(len(E), *CELL_SHAPE)))])
    rows, t0 = [], time.perf_counter()
    for k, fold in enumerate(folds):
        tr_p, tr_s = fold_masks(pos_s.meta, fold, True), fold_masks(bg_s.meta, fold, True)
        tr_t = fold_masks(bg_t.meta, fold, True)
        te_p, te_n = fold_masks(pos_t.meta, fold, False), fold_masks(bg_t.meta, fold, False)
        rot_tr = np.isin(rot_scene, list(fold.train_scenes))
        seed = task_seed(cfg.seed, DETECTOR, s, fold)
        pools = {"elevation 0": (X["bg_s"][tr_s],),
                 "+ rotated": (X["bg_s"][tr_s], rot[rot_tr]),
                 "+ shifted (control)": (X["bg_s"][tr_s], shift[rot_tr]),
                 "+ pi/4 backgrounds": (X["bg_s"][tr_s], X["bg_t8"][tr_t])}
        pools.update({("+ pi/4 through G", r): (X["bg_s"][tr_s], GX[r][tr_t].astype(np.float32))
                      for r in RULES})
        pid = np.r_[pos_t.meta["person_id"].to_numpy()[te_p], np.full(int(te_n.sum()), "")]
        label = np.r_[np.ones(int(te_p.sum()), int), np.zeros(int(te_n.sum()), int)]
        Xt = np.vstack([X["pos_t"][te_p], X["bg_t"][te_n]])
        Xt8 = np.vstack([X["pos_t8"][te_p], X["bg_t8"][te_n]])
        for name, negs in pools.items():
            model = spec.fit(X["pos_s"][tr_p], np.vstack(negs), seed=seed, config=cfg)
            pool, only = (name, None) if isinstance(name, str) else name
            scored = {r: spec.score_adapted(model, Xt, g) for r, g in G.items()
                      if only in (None, r)}
            if only is None:
                scored["unadapted"] = spec.score(model, Xt8)
            for rule, sc in scored.items():
                rows.append(pd.DataFrame({"detector": DETECTOR, "source_elevation": s,
                                          "target_elevation": t, "pool": pool, "rule": rule,
                                          "method": f"{pool} | {rule}", "fold": fold.name,
                                          "score": sc, "label": label, "person_id": pid,
                                          "n_train_negatives": sum(len(n) for n in negs)}))
        if progress:
            print(f"fold {k + 1}/{len(folds)} {fold.name}: {len(pools)} models, "
                  f"{time.perf_counter() - t0:.0f} s", flush=True)
    return pd.concat(rows, ignore_index=True), shares


def _plot(summary: pd.DataFrame, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rules = ["unadapted", *RULES]
    fig, ax = plt.subplots(figsize=(7.5, 3.6))
    width = 0.8 / len(rules)
    for j, rule in enumerate(rules):
        d = summary[summary["rule"] == rule].set_index("pool").reindex(list(POOLS))
        x = np.arange(len(POOLS)) + (j - (len(rules) - 1) / 2) * width
        y = d["mr_at_fppw_0.01"].to_numpy()
        err = np.vstack([y - d["ci_low"].to_numpy(), d["ci_high"].to_numpy() - y])
        ax.bar(x, y, width, yerr=err, capsize=2, label=rule)
    ax.set_xticks(np.arange(len(POOLS)), [p.replace(" (", "\n(").replace("+ pi/4 ", "+ pi/4\n")
                                          for p in POOLS], fontsize=8)
    ax.set_ylabel("miss rate at 1e-2 FPPW")
    ax.set_title("HOG/SVM 0 -> pi/4 by training negatives (95 % CI over persons)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


def _markdown(summary, gaps, run, shares) -> str:
    lines = ["# Training negatives and the angle rule (HOG/SVM, 0 -> pi/4)", "",
             f"{run['n_folds']} folds; {run['n_test_persons']} test crops; miss rate at "
             "1e-2 FPPW with 95 % bootstrap intervals over persons.", "",
             "| pool | rule | miss rate | 95 % CI | training negatives (mean per fold) |",
             "|---|---|---|---|---|"]
    for _, r in summary.iterrows():
        lines.append(f"| {r['pool']} | {r['rule']} | {r['mr_at_fppw_0.01']:.3f} | "
                     f"{r['ci_low']:.3f}-{r['ci_high']:.3f} | {r['n_train_negatives']:.0f} |")
    lines += ["", "Gap covariant - paper eq.3 per pool, and its change against the "
              "elevation-0 pool (paired bootstrap over persons):", "",
              "| pool | gap | 95 % CI | change | 95 % CI |", "|---|---|---|---|---|"]
    for _, r in gaps.iterrows():
        lines.append(f"| {r['pool']} | {r['gap']:+.3f} | {r['gap_ci_low']:+.3f}…"
                     f"{r['gap_ci_high']:+.3f} | {r['change']:+.3f} | "
                     f"{r['change_ci_low']:+.3f}…{r['change_ci_high']:+.3f} |")
    lines += ["", "Orientation energy share per bin of the negatives (mean per-window histogram "
              "of 8-px cells; bin centres in degrees of the unsigned gradient angle):", "",
              "| negatives | " + " | ".join(f"{c:.0f}°" for c in
                                           sorted(set(shares["bin_centre_deg"]))) + " |",
              "|---|" + "---|" * shares["bin"].nunique()]
    for k, d in shares.groupby("negatives", sort=False):
        lines.append(f"| {k} | " + " | ".join(f"{v:.3f}" for v in d["energy_share"]) + " |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmark.studies.negatives",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, required=True, help="dataset directory")
    ap.add_argument("--out", type=Path, required=True, help="output directory")
    ap.add_argument("--folds", type=int, default=9, help="use the first N of the 9 folds")
    ap.add_argument("--quick", action="store_true", help="fewer initial negatives (tests)")
    ap.add_argument("--cache", type=Path, default=None,
                    help="feature cache directory (default OUT/cache)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--jobs", type=int, default=1, help="feature worker processes")
    ap.add_argument("--overwrite", action="store_true",
                    help="write into a non-empty --out that viewadapt did not write")
    args = ap.parse_args(argv)
    try:
        check_output_dir(args.out, overwrite=args.overwrite)
        ds = load_dataset(args.data)
        cfg = _config(ds, args.seed, args.quick)
        cache = FeatureCache(ds, args.cache or (args.out / "cache"), n_jobs=args.jobs)
        t0 = time.perf_counter()
        scores, shares = run_negatives(ds, cfg, cache, n_folds=args.folds)
    except (ValueError, FileNotFoundError) as exc:
        return report_error(ap, exc)
    summ = summarize(scores, n_boot=1000, rng=np.random.default_rng(args.seed))
    first = scores.groupby("method", sort=False)[["pool", "rule"]].first()
    summ = summ.join(first, on="method")
    # one count per (method, fold): the mean over folds of each fold's training negatives
    n_neg = scores.groupby(["method", "fold"])["n_train_negatives"].first() \
        .groupby(level="method").mean()
    summ["n_train_negatives"] = summ["method"].map(n_neg)
    summ = summ[["pool", "rule", "mr_at_fppw_0.01", "ci_low", "ci_high", "lamr", "n_pos",
                 "n_neg", "n_train_negatives"]]
    # the "+ pi/4 through G" rows of each rule come from that rule's own model
    gaps = gap_changes(scores, a="covariant", b="paper eq.3", reference_pool="elevation 0",
                       rng=np.random.default_rng(args.seed))
    run = run_metadata(args.seed, data=str(args.data), n_folds=args.folds,
                       n_test_persons=int(summ["n_pos"].iloc[0]), quick=args.quick,
                       rotations_deg=list(ROTATIONS_DEG),
                       seconds=round(time.perf_counter() - t0, 1))
    with atomic_output_dir(args.out) as tmp:
        summ.to_csv(tmp / "negatives_summary.csv", index=False, float_format="%.5f")
        gaps.to_csv(tmp / "negatives_gaps.csv", index=False, float_format="%.5f")
        shares.to_csv(tmp / "negative_bin_shares.csv", index=False, float_format="%.5f")
        scores.to_parquet(tmp / "scores.parquet", index=False)
        (tmp / "negatives.md").write_text(_markdown(summ, gaps, run, shares))
        (tmp / "run.json").write_text(json.dumps(run, indent=2))
        _plot(summ, tmp / "negatives.png")
    print(_markdown(summ, gaps, run, shares))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
