"""Intervals for a robustness sweep: ``python -m benchmark.studies.sweep_intervals RUN``.

``viewadapt bench sweep`` (Wang et al. 2017, Fig. 6) reports, per angle rule, the best
elevation estimate and the largest estimate still better than the unadapted detector (the
crossing), on all test persons. This study reads the run's ``sweep_scores.parquet`` and
resamples the test *persons* (the positives of one person share its renders): per draw,
each (method, estimate)'s miss rate at 10^-2 FPPW -- the threshold fixed by its own
negatives on all folds, as the sweep and ``bench crossval``'s paired differences fix it --
and then :func:`benchmark.crops.report.sweep_table` on those miss rates, so that the best
estimate, its miss rate, the miss rate at the true elevation and the crossing each get a
95 % percentile interval, with the same draw for every method.

Writes ``sweep_intervals.csv`` and ``sweep_intervals.md`` into RUN (or ``--out``).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pandas as pd

from viewadapt.io.bounded import read_json_object

from benchmark.crops.report import is_paper_target, paper_sweep_table, sweep_table, sweep_target
from benchmark.crops.summarize import PAPER_SWEEP_UNADAPTED, operating_threshold
from benchmark.studies import report_error

__all__ = ["person_hits", "person_weights", "bootstrap_miss_rates", "sweep_intervals", "main"]

#: the sweep_table columns an interval is given for
_COLUMNS = ("best_estimate", "best_mr", "mr_at_true", "crossing", "band_above_truth",
            "crossing_interp", "band_interp", "band_paper_level")


def person_hits(scores: pd.DataFrame, fppw: float = 1e-2):
    """Per (method, estimate): the test persons' detected and counted positives at the
    miss rate's threshold (``operating_threshold`` of that row's negatives, all folds).

    Returns
    -------
    keys : list of (method, estimate, rule, object_model)
    persons : (P,) array of person ids
    hits, counts : (K, P) float arrays
    """
    pos = scores["label"].to_numpy() == 1
    persons = np.unique(scores.loc[pos, "person_id"].to_numpy())
    keys, hits, counts = [], [], []
    for (method, est), d in scores.groupby(["method", "estimate"], dropna=False, sort=False):
        lab, sc = d["label"].to_numpy(), d["score"].to_numpy(np.float64)
        thr = operating_threshold(sc[lab == 0], fppw)
        idx = np.searchsorted(persons, d.loc[lab == 1, "person_id"].to_numpy())
        det = (sc[lab == 1] >= thr).astype(float)
        keys.append((method, est))
        hits.append(np.bincount(idx, weights=det, minlength=len(persons)))
        counts.append(np.bincount(idx, minlength=len(persons)).astype(float))
    return keys, persons, np.array(hits), np.array(counts)


def person_weights(n_persons: int, n_boot: int, rng) -> np.ndarray:
    """``(n_boot, n_persons)`` float weights of a bootstrap over persons: per draw, how many
    copies of each person it holds (``n_persons`` persons drawn with replacement from
    ``rng``, a ``numpy.random.Generator``)."""
    draws = rng.integers(n_persons, size=(n_boot, n_persons))
    return np.stack([np.bincount(d, minlength=n_persons) for d in draws]).astype(float)


def bootstrap_miss_rates(hits, counts, n_boot: int, rng) -> np.ndarray:
    """``(1 + n_boot, K)`` miss rates of the ``K`` rows of :func:`person_hits`' ``hits`` and
    ``counts``: row 0 on every person once, then one row per draw of :func:`person_weights`
    -- the same draw for every column, so differences between columns are paired."""
    n = hits.shape[1]
    W = np.vstack([np.ones(n), person_weights(n, n_boot, rng)])
    return 1 - (W @ hits.T) / np.maximum(W @ counts.T, 1e-12)


def _summary(keys, mr, rules) -> pd.DataFrame:
    return pd.DataFrame([{"method": m, "estimate": e, "rule": rules[m][0],
                          "object_model": rules[m][1], "mr_at_fppw_0.01": v}
                         for (m, e), v in zip(keys, mr)])


def sweep_intervals(scores: pd.DataFrame, *, true_elevation: float = np.pi / 4,
                    n_boot: int = 1000, seed: int = 0, fppw: float = 1e-2) -> pd.DataFrame:
    """:func:`~benchmark.crops.report.sweep_table` on all test persons, with 95 % intervals
    (``<column>_low``, ``<column>_high``) from a bootstrap over test persons.

    ``scores``: a sweep's scores (``method``, ``estimate``, ``label``, ``score``,
    ``person_id``; the ``unadapted`` rows with no estimate), optionally ``rule`` and
    ``object_model`` per method. A draw in which a method never beats the unadapted
    detector has no crossing; ``crossing_defined`` is the share of draws that have one.
    """
    if n_boot < 1:
        raise ValueError(f"n_boot must be at least 1, got {n_boot}")
    need = {"method", "estimate", "label", "score", "person_id"}
    if not need <= set(scores.columns):
        raise ValueError(f"sweep scores lack the columns {sorted(need - set(scores.columns))}")
    if "unadapted" not in set(scores["method"]):
        raise ValueError("sweep scores have no unadapted rows to compare against")
    rules = {}
    for m, g in scores.groupby("method", sort=False):
        rules[m] = (g["rule"].iloc[0] if "rule" in g else "",
                    g["object_model"].iloc[0] if "object_model" in g else "")
    keys, persons, hits, counts = person_hits(scores, fppw)
    full = sweep_table(_summary(keys, 1 - hits.sum(1) / counts.sum(1), rules), true_elevation)
    boot = []
    for w in person_weights(len(persons), n_boot, np.random.default_rng(seed)):
        mr = 1 - (hits @ w) / np.maximum(counts @ w, 1e-12)
        boot.append(sweep_table(_summary(keys, mr, rules), true_elevation))
    boot = pd.concat(boot, ignore_index=True)
    out = full.copy()
    for col in _COLUMNS:
        by = boot.groupby("method", sort=False)[col]
        out[f"{col}_low"] = out["method"].map(by.quantile(0.025))
        out[f"{col}_high"] = out["method"].map(by.quantile(0.975))
    out["crossing_defined"] = out["method"].map(
        boot.groupby("method", sort=False)["crossing"].apply(lambda s: s.notna().mean()))
    out["n_persons"], out["n_boot"] = len(persons), n_boot
    return out


def _lines(tab: pd.DataFrame, run: Path, true_elevation: float) -> list[str]:
    def iv(r, col, nd=2):
        return f"{r[col]:.{nd}f} ({r[col + '_low']:.{nd}f}–{r[col + '_high']:.{nd}f})"

    paper = is_paper_target(true_elevation)
    lines = [f"# Sweep intervals: {run}", "",
             f"{int(tab['n_persons'].iloc[0])} test persons, {int(tab['n_boot'].iloc[0])} "
             "resamples of them (95 % percentile intervals); unadapted miss rate "
             f"{tab['unadapted'].iloc[0]:.3f}. Crossing: the largest estimate still better "
             "than unadapted; interpolated: where the curve reaches unadapted between it and "
             f"the next estimate; the true elevation {true_elevation:.3f} rad."
             + (" The last column: where the curve reaches the paper's unadapted miss rate "
                f"({PAPER_SWEEP_UNADAPTED:.3f}) instead, above the truth. The paper's own "
                "Fig. 6 data by the same rules (no interval: its scores are not published) "
                "is the last row." if paper else
                " (The paper swept only a true pi/4: no row of its data.)"), "",
             "| method | best estimate (rad) | best MR | MR at truth | crossing (rad) | "
             "above truth (rad) | interpolated (rad) | above truth (rad) | "
             "draws with a crossing |"
             + (" at the paper's unadapted, above truth (rad) |" if paper else ""),
             "|---|---|---|---|---|---|---|---|---|" + ("---|" if paper else "")]
    for _, r in tab.iterrows():
        lines.append(f"| {r['method']} | {iv(r, 'best_estimate')} | {iv(r, 'best_mr', 3)} | "
                     f"{iv(r, 'mr_at_true', 3)} | {iv(r, 'crossing')} | "
                     f"{iv(r, 'band_above_truth')} | {iv(r, 'crossing_interp')} | "
                     f"{iv(r, 'band_interp')} | {r['crossing_defined']:.2f} |"
                     + (f" {iv(r, 'band_paper_level')} |" if paper else ""))
    if not paper:
        return lines
    p = paper_sweep_table().iloc[0]
    lines.append(f"| {p['method']} | {p['best_estimate']:.2f} | {p['best_mr']:.3f} | "
                 f"{p['mr_at_true']:.3f} | {p['crossing']:.2f} | {p['band_above_truth']:.2f} | "
                 f"{p['crossing_interp']:.2f} | {p['band_interp']:.2f} | – | "
                 f"{p['band_paper_level']:.2f} |")
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmark.studies.sweep_intervals",
                                 description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("run", type=Path, help="a `viewadapt bench sweep` output directory")
    ap.add_argument("--out", type=Path, default=None, help="where to write (default RUN)")
    ap.add_argument("--target", type=float, default=None,
                    help="the true target elevation, rad (default: the one RUN/run.json "
                         "records; pi/4 for runs that record none)")
    ap.add_argument("--boot", type=int, default=1000, help="resamples (default 1000)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    try:
        path = args.run / "sweep_scores.parquet"
        if not path.is_file():
            raise ValueError(f"{args.run} holds no sweep_scores.parquet (not a bench sweep run)")
        target = args.target
        if target is None:
            run = args.run / "run.json"
            target = sweep_target(read_json_object(run, "run.json") if run.is_file() else {})
        tab = sweep_intervals(pd.read_parquet(path), true_elevation=target,
                              n_boot=args.boot, seed=args.seed)
    except ValueError as exc:
        return report_error(ap, exc)
    out = args.out or args.run
    out.mkdir(parents=True, exist_ok=True)
    tab.to_csv(out / "sweep_intervals.csv", index=False, float_format="%.4f")
    lines = _lines(tab, args.run, target)
    (out / "sweep_intervals.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
