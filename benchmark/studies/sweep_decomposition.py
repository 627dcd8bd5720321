"""Which part of ``G`` fails when the elevation is overestimated:
``python -m benchmark.studies.sweep_decomposition --data DS --out OUT``.

``G = S (x) A`` (Wang et al. 2017, eq. (5)): the spatial resampling ``S`` of the cells and,
per source cell, the orientation map ``A_k``; through a homography (the person plane) both
come from the same estimated elevation. Here they come from two: ``G(e_s, e_a) = D_A(e_a)
(S(e_s) (x) I)``, with ``D_A`` the block-diagonal of the ``A_k`` (so ``G(e, e)`` is the
adapted detector's own ``G``, checked). The robustness sweep (:func:`benchmark.crops.sweep.
run_sweep`, HOG, source 0, the crops of the true target elevation) then scores, per
estimate ``e``, each rule's ``G(e, e)`` beside ``G(e, truth)`` (the orientations right, the
geometry estimated) and ``G(truth, e)`` (the geometry right, the orientations estimated):
whichever of the two follows the rule's own curve when ``e`` passes the truth is where its
loss lies.

Writes the sweep's ``sweep_scores.parquet``, ``sweep_summary.csv``, a table
(``decomposition.md``, with the crossing and the interpolated crossing of every curve,
:func:`benchmark.crops.report.sweep_table`, and each rule's orientation-map cost at the
truth with a paired interval over test persons, :func:`orientation_cost`) and
``decomposition.png``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from viewadapt.adapt import hog_remap_matrix
from viewadapt.geometry import (
    WINDOW_HEIGHT, WINDOW_WIDTH, elevation_homography, homography_jacobian,
)
from viewadapt.remap import CellGrid, assemble_remap_matrix, orientation_remap_matrix

from benchmark.studies import report_error

__all__ = ["angle_blocks", "split_remap", "orientation_cost", "decomposition_lines", "main"]

#: the HOG crops' source cells and bins (:func:`viewadapt.adapt.hog_remap_matrix`' defaults)
_CELL, _BINS = 8, 9


def angle_blocks(H_st, rule: str, keep=None) -> sp.csr_matrix:
    """``D_A``: per source cell, the orientation map ``A_k`` of ``rule`` from the Jacobian of
    ``H_st`` (source window -> target window pixels) at the cell's centre, block-diagonal
    over the source cells -- the factor of ``G`` that :func:`viewadapt.remap.feature_remap_matrix`
    multiplies into ``S``. ``keep`` (optional, a boolean per source cell in row-major order):
    the cells that get their map; the others get the identity."""
    grid = CellGrid.for_window(WINDOW_WIDTH, WINDOW_HEIGHT, _CELL)
    A = orientation_remap_matrix(homography_jacobian(H_st, grid.centers()), _BINS, rule)
    if keep is not None:
        keep = np.asarray(keep, bool)
        if keep.shape != (grid.n_cells,):
            raise ValueError(f"keep must hold one flag per source cell ({grid.n_cells}), "
                             f"got shape {keep.shape}")
        A[~keep] = np.eye(_BINS)
    return assemble_remap_matrix(sp.identity(grid.n_cells, format="csr"), A, n_bins=_BINS)


def split_remap(H_spatial, H_angles, rule: str, target_cell_size: int,
                keep=None) -> sp.csr_matrix:
    """``G`` with ``S`` from ``H_spatial`` and the ``A_k`` of ``rule`` from ``H_angles``
    (only in the source cells ``keep`` flags, when given: :func:`angle_blocks`)."""
    S = hog_remap_matrix(H_spatial, target_cell_size=target_cell_size, rule="none")
    if rule == "none":
        return S
    return (angle_blocks(H_angles, rule, keep) @ S).tocsr()


def _methods(e, truth, cfg):
    """Per estimate: each rule's ``G(e, truth)`` and ``G(truth, e)`` (the plane)."""
    def H(x):
        return elevation_homography(0.0, x, distance=cfg.distance, framing=cfg.framing)

    He, Ht = H(e), H(truth)
    out = {}
    for rule, name in (("covariant", "covariant"), ("paper", "eq. (3)")):
        out[f"{name}: S estimated, A true"] = split_remap(He, Ht, rule, cfg.target_cell_size)
        out[f"{name}: S true, A estimated"] = split_remap(Ht, He, rule, cfg.target_cell_size)
    return out


def orientation_cost(scores, truth: float, *, n_boot: int = 1000, seed: int = 0,
                     fppw: float = 1e-2) -> list[dict]:
    """What each rule's orientation maps cost with the geometry right: per curve named
    ``"<rule>: S true, A estimated"``, the miss rate (at ``fppw``, thresholds fixed by each
    row's own negatives) at the estimate nearest ``truth`` minus at the estimate nearest 0
    (where ``A`` is the identity), with a 95 % percentile interval from a paired bootstrap
    over test persons (the same draw for both estimates,
    :func:`benchmark.studies.sweep_intervals.person_hits`).

    Returns one dict per such curve: ``rule``, ``mr_identity``, ``mr_truth``, ``cost``,
    ``low``, ``high``.
    """
    from benchmark.studies.sweep_intervals import bootstrap_miss_rates, person_hits

    out = []
    rng = np.random.default_rng(seed)
    for method in [m for m in scores["method"].unique() if m.endswith(": S true, A estimated")]:
        rows = scores[scores["method"] == method]
        est = np.sort(rows["estimate"].unique())
        ends = (est[np.argmin(abs(est))], est[np.argmin(abs(est - truth))])
        keys, persons, hits, counts = person_hits(rows[rows["estimate"].isin(ends)], fppw)
        i0, it = ([k[1] for k in keys].index(e) for e in ends)
        mr = bootstrap_miss_rates(hits, counts, n_boot, rng)             # (1 + n_boot, K)
        diff = mr[:, it] - mr[:, i0]
        out.append({"rule": method.split(":")[0], "mr_identity": float(mr[0, i0]),
                    "mr_truth": float(mr[0, it]), "cost": float(diff[0]),
                    "low": float(np.percentile(diff[1:], 2.5)),
                    "high": float(np.percentile(diff[1:], 97.5))})
    return out


def decomposition_lines(rows, summary, truth: float, *, title: str, intro: str,
                        seed: int = 0) -> list[str]:
    """The Markdown lines of ``decomposition.md``: ``title``, ``intro`` (one sentence, to which
    the unadapted miss rate is appended), every curve of ``summary``
    (:func:`benchmark.crops.sweep.sweep_summary` of ``rows``) with its best estimate and its
    crossings (:func:`benchmark.crops.report.sweep_table`), and the orientation-map cost of
    each ``"<name>: S true, A estimated"`` curve of ``rows`` (:func:`orientation_cost`)."""
    from benchmark.crops.report import sweep_table

    tab = sweep_table(summary, truth)
    lines = [f"# {title}", "", f"{intro}; unadapted {tab['unadapted'].iloc[0]:.3f}.", "",
             "| curve | best estimate | best MR | MR at truth | crossing | above truth | "
             "interpolated | above truth |", "|---|---|---|---|---|---|---|---|"]
    for _, r in tab.iterrows():
        lines.append(f"| {r['method']} | {r['best_estimate']:.2f} | {r['best_mr']:.3f} | "
                     f"{r['mr_at_true']:.3f} | {r['crossing']:.2f} | "
                     f"{r['band_above_truth']:+.2f} | {r['crossing_interp']:.2f} | "
                     f"{r['band_interp']:+.2f} |")
    lines += ["", "The orientation maps' cost with the geometry right (`S` true): miss rate with "
              "`A` of the true elevation minus with `A` the identity (e = 0), paired bootstrap "
              "over test persons (95 %):", "",
              "| rule | A identity | A true | cost |", "|---|---|---|---|"]
    for c in orientation_cost(rows, truth, seed=seed):
        lines.append(f"| {c['rule']} | {c['mr_identity']:.3f} | {c['mr_truth']:.3f} | "
                     f"{c['cost']:+.3f} ({c['low']:+.3f}…{c['high']:+.3f}) |")
    return lines


def _plot(summary, truth, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 4), sharey=True)
    u = float(summary.loc[summary["method"] == "unadapted", "mr_at_fppw_0.01"].iloc[0])
    for ax, (name, own) in zip(axes, (("covariant", "adapted"),
                                      ("eq. (3)", "adapted[paper eq.3]"))):
        for m, style, label in ((own, "k-", f"{name}: G(e, e), the adapted detector"),
                                (f"{name}: S estimated, A true", "C0--", "S(e), A(truth)"),
                                (f"{name}: S true, A estimated", "C1--", "S(truth), A(e)"),
                                ("adapted[S only]", "C2:", "S(e) only")):
            g = summary[summary["method"] == m].sort_values("estimate")
            ax.plot(g["estimate"], g["mr_at_fppw_0.01"], style, marker="o", ms=2, label=label)
        ax.axhline(u, color="#c0392b", lw=1, label=f"unadapted ({u:.2f})")
        ax.axvline(truth, color="0.4", ls=":", lw=1)
        ax.set_title(f"{name} rule, person plane", fontsize=9)
        ax.set_xlabel("estimated target elevation e (rad)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    axes[0].set_ylabel("miss rate @ fppw = 10⁻²")
    fig.tight_layout()
    fig.savefig(path, dpi=150)
    plt.close(fig)


def main(argv=None) -> int:
    from benchmark.crops.crossval import CrossvalConfig
    from benchmark.crops.features import FeatureCache
    from benchmark.crops.sweep import run_sweep, sweep_summary
    from benchmark.data import load_dataset
    from benchmark.recipes import add_recipe_argument
    from viewadapt.io.files import atomic_output_dir, check_output_dir

    ap = argparse.ArgumentParser(prog="python -m benchmark.studies.sweep_decomposition",
                                 description=__doc__.split("\n\n")[1],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", type=Path, required=True, help="dataset directory")
    ap.add_argument("--out", type=Path, required=True, help="output directory")
    ap.add_argument("--cache", type=Path, default=None,
                    help="feature cache directory (default OUT/cache)")
    ap.add_argument("--step", type=float, default=np.pi / 72,
                    help="grid step of the estimates, rad (default pi/72, the paper's)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--jobs", type=int, default=1)
    add_recipe_argument(ap, what="the source HOG/SVM")
    args = ap.parse_args(argv)
    try:
        if not 0 < args.step <= np.pi / 36 + 1e-12:
            raise ValueError("--step must lie in (0, pi/36] radians")
        check_output_dir(args.out)
        ds = load_dataset(args.data)
        cfg = CrossvalConfig.for_dataset(ds, seed=args.seed, n_jobs=args.jobs,
                                         object_models=("plane",), recipe=args.recipe)
    except ValueError as exc:
        return report_error(ap, exc)
    truth = cfg.target
    cache = FeatureCache(ds, args.cache or (args.out / "cache"), n_jobs=args.jobs)
    rows = run_sweep(ds, cfg, cache, detector="hog", step=args.step, sigma=0.0,
                     variants=("adapted", "adapted[paper eq.3]", "adapted[S only]"),
                     extra=lambda e: _methods(e, truth, cfg))
    summary = sweep_summary(rows)
    lines = decomposition_lines(
        rows, summary, truth, title="Which part of G fails under a wrong elevation estimate",
        intro=f"Data `{args.data}`, recipe `{cfg.recipe.name}`, HOG 0 → {truth:.3f} rad, the "
              f"person plane", seed=args.seed)
    with atomic_output_dir(args.out) as tmp:
        rows.to_parquet(tmp / "sweep_scores.parquet", index=False)
        summary.to_csv(tmp / "sweep_summary.csv", index=False)
        (tmp / "decomposition.md").write_text("\n".join(lines) + "\n")
        _plot(summary, truth, tmp / "decomposition.png")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
