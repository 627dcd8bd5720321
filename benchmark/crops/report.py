"""Figures and the Markdown report of a benchmark results directory."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from viewadapt.io.bounded import read_json_object
from viewadapt.metrics import det_curve_windows

from benchmark.crops.summarize import PAPER_MISS_RATES, PAPER_SWEEP, PAPER_SWEEP_UNADAPTED

__all__ = ["plot_det", "plot_sweep", "sweep_table", "paper_sweep_table", "PAPER_SWEEP_METHOD",
           "PAPER_SWEEP_TARGET", "is_paper_target", "sweep_target",
           "plot_score_shift", "write_report",
           "elevation_label", "closing_summary"]

_STYLE = {"unadapted": "-", "oracle": "-", "image warping": "--", "adapted": ":",
          "synthesised": "-.", "adapted[S only]": (0, (1, 1)),
          "adapted[paper eq.3]": (0, (3, 1, 1, 1)), "adapted[single A]": (0, (5, 2)),
          "adapted[body]": (0, (6, 1, 1, 1, 1, 1)), "image warping[body]": (0, (8, 2)),
          "exact geometry": (0, (1, 2))}
_COLOURS = ["#c0392b", "#8e44ad", "#2471a3", "#117a65", "#b9770e"]


def elevation_label(e) -> str:
    for frac, name in ((0, "0"), (1 / 8, "π/8"), (1 / 4, "π/4"), (3 / 8, "3π/8")):
        if abs(e - frac * np.pi) < 1e-6:
            return name
    return f"{e:.3f}"


def _radians(e) -> str:
    """An elevation in words: ``π/4 (0.785 rad)``, or ``0.600 rad`` off the named ones."""
    label = elevation_label(e)
    return f"{label} ({e:.3f} rad)" if label != f"{e:.3f}" else f"{e:.3f} rad"


def _mpl():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def plot_det(scores: pd.DataFrame, summary: pd.DataFrame, detector: str,
             methods=("unadapted", "image warping", "adapted", "synthesised", "oracle")):
    """Miss rate vs fppw pooled over folds, one colour per source elevation (Fig. 5)."""
    plt = _mpl()
    d = scores[scores["detector"] == detector]
    fig, ax = plt.subplots(figsize=(6.4, 5))
    sources = sorted(d["source_elevation"].unique())
    for ci, s in enumerate(sources):
        for m in methods:
            g = d[(d["source_elevation"] == s) & (d["method"] == m)]
            if g.empty or g["label"].nunique() < 2:
                continue
            fp, miss, _ = det_curve_windows(g["label"].to_numpy(), g["score"].to_numpy())
            row = summary[(summary["detector"] == detector) & (summary["source_elevation"] == s)
                          & (summary["method"] == m)]
            mr = float(row["mr_at_fppw_0.01"].iloc[0]) if len(row) else np.nan
            t = float(g["target_elevation"].iloc[0])
            ax.step(np.maximum(fp, 1e-4), miss, where="post", ls=_STYLE.get(m, "-"),
                    color=_COLOURS[ci % len(_COLOURS)], lw=1.6 if m != "oracle" else 2.4,
                    label=f"{elevation_label(s)}→{elevation_label(t)} {m} ({mr:.2f})")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(1e-3, 1)
    ax.set_ylim(0.01, 1)
    ax.axvline(1e-2, color="0.6", lw=0.8)
    ax.set_xlabel("false positives per window")
    ax.set_ylabel("miss rate")
    ax.set_title(f"{detector}: DET pooled over folds (legend: miss rate at 10⁻² fppw)", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=6.5, loc="lower left")
    fig.tight_layout()
    return fig


_RULE_COLOUR = {"covariant": "k", "paper": "#2471a3", "none": "#117a65"}
_MODEL_STYLE = {"plane": "-", "body": "--"}


def plot_sweep(summary: pd.DataFrame, *, true_elevation=np.pi / 4, title=""):
    """Miss rate at 1e-2 fppw against the estimated target elevation (Fig. 6): one curve per
    angle rule (colour) and object model (line style), the prior-averaged curve dotted, and
    -- for the paper's true elevation, pi/4 -- the paper's own curve and unadapted level in
    grey (``PAPER_SWEEP``)."""
    plt = _mpl()
    fig, ax = plt.subplots(figsize=(7.2, 4.4))
    un = summary[summary["method"] == "unadapted"]["mr_at_fppw_0.01"]
    for m, g in summary[summary["method"] != "unadapted"].groupby("method", sort=False):
        g = g.sort_values("estimate")
        rule = g["rule"].iloc[0] if "rule" in g else "covariant"
        model = g["object_model"].iloc[0] if "object_model" in g else "plane"
        prior = "prior" in m
        ax.plot(g["estimate"], g["mr_at_fppw_0.01"], ":" if prior else
                _MODEL_STYLE.get(model, "-."), marker="o", ms=2.5, lw=1.1 if prior else 1.6,
                color=_RULE_COLOUR.get(rule, "#b9770e"), alpha=0.6 if prior else 1.0, label=m)
    if len(un):
        ax.axhline(float(un.iloc[0]), color="#c0392b", ls="-", lw=1.0,
                   label=f"unadapted ({float(un.iloc[0]):.2f})")
    if is_paper_target(true_elevation):
        pe, pm = np.array(PAPER_SWEEP).T
        ax.plot(pe, pm, color="0.6", lw=0.9, label="paper, Fig. 6 (their data)")
        ax.axhline(PAPER_SWEEP_UNADAPTED, color="0.6", ls="--", lw=0.8,
                   label=f"paper's unadapted ({PAPER_SWEEP_UNADAPTED:.2f})")
    ax.axvline(true_elevation, color="0.4", ls=":", lw=1.2, label="true target elevation")
    ax.set_xlabel("estimated target elevation (rad)")
    ax.set_ylabel("miss rate @ fppw = 10⁻²")
    ax.set_xlim(0, 1.6)
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=6.5, ncol=2)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def _reach(e, mr, k: int, level: float):
    """Where the curve ``mr`` over the estimates ``e`` leaves the run of estimates below
    ``level`` that holds its best one (index ``k``): the last grid estimate of that run and
    the point where the curve reaches ``level`` between it and the next estimate (linear;
    the last one itself at the grid's end); (nan, nan) when even the best is not below."""
    if not mr[k] < level:
        return np.nan, np.nan
    hi = k
    while hi + 1 < len(e) and mr[hi + 1] < level:
        hi += 1
    if hi + 1 == len(e):
        return float(e[hi]), float(e[hi])
    return float(e[hi]), float(e[hi] + (level - mr[hi]) / (mr[hi + 1] - mr[hi])
                               * (e[hi + 1] - e[hi]))


def sweep_table(summary: pd.DataFrame, true_elevation: float = np.pi / 4) -> pd.DataFrame:
    """Per swept method: the best estimate and its miss rate, the miss rate at the true
    elevation, the largest grid estimate (above the best) still better than unadapted -- the
    crossing -- and how far above the truth that lies; and the crossing read off the curve
    between that estimate and the next one by linear interpolation (``crossing_interp``,
    ``band_interp``: where the curve reaches the unadapted miss rate, not a grid point; the
    crossing itself when no estimate after it is worse). ``band_paper_level``: the same
    reading against a fixed level instead, the paper's unadapted miss rate
    (``PAPER_SWEEP_UNADAPTED``), above the truth -- how far past it an estimate may go before
    the curve is as bad as the paper's unadapted detector, which compares sweeps whose
    unadapted detectors differ (for the paper's own curve it is its interpolated crossing).
    :func:`paper_sweep_table` gives the paper's Fig. 6 by the same rules."""
    un = summary.loc[summary["method"] == "unadapted", "mr_at_fppw_0.01"]
    u = float(un.iloc[0]) if len(un) else np.nan
    rows = []
    for m, g in summary[summary["method"] != "unadapted"].groupby("method", sort=False):
        g = g.sort_values("estimate")
        e, mr = g["estimate"].to_numpy(), g["mr_at_fppw_0.01"].to_numpy()
        k = int(np.argmin(mr))
        at_true = float(mr[int(np.argmin(np.abs(e - true_elevation)))])
        cross, interp = _reach(e, mr, k, u)
        level = _reach(e, mr, k, PAPER_SWEEP_UNADAPTED)[1]
        rows.append({"method": m, "rule": g["rule"].iloc[0] if "rule" in g else "",
                     "object_model": g["object_model"].iloc[0] if "object_model" in g else "",
                     "best_estimate": float(e[k]), "best_mr": float(mr[k]),
                     "mr_at_true": at_true, "crossing": cross,
                     "band_above_truth": cross - true_elevation, "crossing_interp": interp,
                     "band_interp": interp - true_elevation,
                     "band_paper_level": level - true_elevation, "unadapted": u})
    return pd.DataFrame(rows)


PAPER_SWEEP_METHOD = "paper (Wang et al. 2017, Fig. 6)"
#: the true target elevation of the paper's Fig. 6 (its sweep tests at pi/4 only)
PAPER_SWEEP_TARGET = np.pi / 4


def is_paper_target(true_elevation) -> bool:
    """Whether a sweep's true elevation is the paper's Fig. 6's (pi/4), so that the paper's
    curve belongs beside it."""
    return bool(abs(float(true_elevation) - PAPER_SWEEP_TARGET) < 1e-6)


def sweep_target(run: dict) -> float:
    """The true target elevation a ``bench sweep`` run recorded (``run["sweep"]["target"]``);
    pi/4, the default, for runs written before it was recorded."""
    sweep = run.get("sweep") if isinstance(run, dict) else None
    target = sweep.get("target") if isinstance(sweep, dict) else None
    if target is None:
        return float(PAPER_SWEEP_TARGET)
    if isinstance(target, bool) or not isinstance(target, (int, float)) \
            or not 0 <= target < np.pi / 2:
        raise ValueError(f"run.json: the sweep's target elevation is {target!r}, not an "
                         "elevation in [0, pi/2) radians")
    return float(target)


def paper_sweep_table() -> pd.DataFrame:
    """:func:`sweep_table` of the paper's own Fig. 6 data (``PAPER_SWEEP``: HOG/SVM, 0 ->
    pi/4, their renders), one row named :data:`PAPER_SWEEP_METHOD`, so that a sweep and the
    paper are read by the same rules."""
    e, mr = np.array(PAPER_SWEEP).T
    summary = pd.DataFrame({"method": [PAPER_SWEEP_METHOD] * len(e) + ["unadapted"],
                            "estimate": np.r_[e, np.nan], "rule": "paper",
                            "object_model": "plane",
                            "mr_at_fppw_0.01": np.r_[mr, PAPER_SWEEP_UNADAPTED]})
    return sweep_table(summary)


def plot_score_shift(scores: pd.DataFrame, detector="hog", source=0.0):
    """Violin plot of the test persons' scores and of the top 1 % of background scores for
    each of ``unadapted``, ``image warping``, ``adapted`` and ``synthesised`` (those present),
    one detector and source elevation: does a method that lifts the persons' scores lift the
    background's too? Measured shifts: ``docs/findings.md`` (angle rules and the body model)."""
    plt = _mpl()
    d = scores[(scores["detector"] == detector) & (np.isclose(scores["source_elevation"], source))]
    methods = [m for m in ("unadapted", "image warping", "adapted", "synthesised")
               if m in set(d["method"])]
    fig, ax = plt.subplots(figsize=(6.4, 3.4))
    for k, m in enumerate(methods):
        g = d[d["method"] == m]
        pos = g.loc[g["label"] == 1, "score"].to_numpy()
        neg = np.sort(g.loc[g["label"] == 0, "score"].to_numpy())[::-1]
        top = neg[: max(1, len(neg) // 100)]
        parts = ax.violinplot([pos, top], positions=[k * 3, k * 3 + 1], showmedians=True)
        for body, col in zip(parts["bodies"], ("#117a65", "#c0392b")):
            body.set_facecolor(col)
    ax.set_xticks([k * 3 + 0.5 for k in range(len(methods))])
    ax.set_xticklabels([f"{m}\n(green: persons, red: top 1% negatives)" if k == 0 else m
                        for k, m in enumerate(methods)], fontsize=7)
    ax.set_ylabel("score")
    ax.set_title(f"{detector}, {elevation_label(source)}→π/4: where the scores move", fontsize=9)
    fig.tight_layout()
    return fig


def _paper(detector, source, method):
    """The paper's HOG/SVM miss rate for this row, if it reports one."""
    if detector != "hog":
        return None
    for (ps, pm), v in PAPER_MISS_RATES.items():
        if abs(ps - source) < 1e-6 and pm == method:
            return v
    return None


def _fmt(v, nd=3):
    return "–" if v is None or (isinstance(v, float) and not np.isfinite(v)) else f"{v:.{nd}f}"


#: the warning line ``report.md`` opens with for results of an incomplete dataset
INCOMPLETE_NOTE = "> **Warning: computed on an incomplete dataset (--allow-incomplete):** "


def write_report(out: Path) -> Path:
    """Write ``report.md`` for a results directory (crossval and/or sweep outputs)."""
    out = Path(out)
    run = read_json_object(out / "run.json", "run.json") if (out / "run.json").is_file() else {}
    lines = ["# viewadapt benchmark report", ""]
    sweep = run.get("sweep")
    notes = [n for n in (run.get("incomplete_dataset"),
                         sweep.get("incomplete_dataset") if isinstance(sweep, dict) else None)
             if n]
    if notes:                 # results of a dataset run with --allow-incomplete
        lines += [INCOMPLETE_NOTE + n for n in dict.fromkeys(notes)] + [""]
    if run:
        lines += [f"Dataset: `{run.get('data')}` (fingerprint `{run.get('fingerprint')}`, "
                  f"renderer `{run.get('renderer')}`, framing `{run.get('framing')}`), "
                  f"seed {run.get('seed')}.", ""]
        recipe = run.get("recipe") if isinstance(run.get("recipe"), dict) else \
            {"name": "elevation0", "summary": "recorded by no field: results written before "
                                              "recipes existed"}
        lines += [f"Source training: recipe `{recipe.get('name')}` ({recipe.get('summary')}), "
                  "the same for every method that trains.", ""]
    if (out / "summary.csv").is_file():
        s = pd.read_csv(out / "summary.csv")
        targets = ", ".join(elevation_label(t) for t in sorted(set(s["target_elevation"])))
        lines += [f"## Miss rate at 10⁻² fppw, target {targets}", "",
                  "Pooled over the nine person/scene-disjoint folds; 95% interval from a "
                  "bootstrap over test persons; mean ± std over folds; LAMR over 10⁻³–10⁰ fppw. "
                  "Paper: Wang et al. 2017, Fig. 5 (HOG/SVM on their SketchUp data).", "",
                  "| detector | source→target | method | ours | 95% CI | fold mean ± std | LAMR | paper | positives |",
                  "|---|---|---|---|---|---|---|---|---|"]
        for _, r in s.iterrows():
            paper = _paper(r["detector"], r["source_elevation"], r["method"])
            lines.append(
                f"| {r['detector']} | {elevation_label(r['source_elevation'])}→"
                f"{elevation_label(r['target_elevation'])} | {r['method']} | "
                f"{_fmt(r['mr_at_fppw_0.01'])} | {_fmt(r['ci_low'], 2)}–{_fmt(r['ci_high'], 2)} | "
                f"{_fmt(r['mr_at_fppw_0.01_mean'], 2)} ± {_fmt(r['mr_at_fppw_0.01_std'], 2)} | "
                f"{_fmt(r['lamr'])} | {_fmt(paper)} | {int(r['n_pos'])} |")
        lines.append("")
    if (out / "paired_differences.csv").is_file():
        p = pd.read_csv(out / "paired_differences.csv")
        lines += ["## Paired differences (miss rate a − b, same test windows)", "",
                  "| detector | source | a | b | a − b | 95% CI | P(a better) |",
                  "|---|---|---|---|---|---|---|"]
        for _, r in p.iterrows():
            lines.append(f"| {r['detector']} | {elevation_label(r['source_elevation'])} | "
                         f"{r['method_a']} | {r['method_b']} | {r['diff']:+.3f} | "
                         f"{r['ci_low']:+.3f}…{r['ci_high']:+.3f} | {r['p_a_better']:.2f} |")
        lines.append("")
    for f in sorted(out.glob("det_*.png")):
        lines += [f"![{f.stem}]({f.name})", ""]
    if (out / "score_shift.png").is_file():
        lines += ["![score shift](score_shift.png)", ""]
    if (out / "sweep_summary.csv").is_file():
        sw = pd.read_csv(out / "sweep_summary.csv")
        target = sweep_target(run)
        paper = is_paper_target(target)
        tab = sweep_table(sw, target)
        lines += ["## Robustness to the elevation estimate (Fig. 6)", "",
                  "Per angle rule and object model on the same folds and fold models: the best "
                  f"estimate, the miss rate there and at the true {_radians(target)}, the "
                  "largest estimate still better than unadapted "
                  "(crossing), the crossing interpolated between that estimate and the next, "
                  "and their distances above the truth."
                  + (" The last column reads the curve against the paper's unadapted miss "
                     f"rate ({PAPER_SWEEP_UNADAPTED:.3f}) instead of this run's: how far above "
                     "the truth an estimate may go before adapting is as bad as the paper's "
                     "unadapted detector, comparable between sweeps whose unadapted detectors "
                     "differ. The last row is the paper's own Fig. 6 data (HOG/SVM, their "
                     "renders) read by the same rules." if paper else
                     " The paper swept only a true π/4: no row of its data."), ""]
        if len(tab):
            lines += [f"Unadapted: {tab['unadapted'].iloc[0]:.3f}"
                      + (f" (paper: {PAPER_SWEEP_UNADAPTED:.3f})." if paper else "."), "",
                      "| method | rule | model | best estimate | best MR | MR at truth | "
                      "crossing | above truth | interpolated | above truth |"
                      + (" at the paper's unadapted, above truth |" if paper else ""),
                      "|---|---|---|---|---|---|---|---|---|---|" + ("---|" if paper else "")]
            rows = [tab, paper_sweep_table()] if paper else [tab]
            for _, r in pd.concat(rows, ignore_index=True).iterrows():
                lines.append(f"| {r['method']} | {r['rule']} | {r['object_model']} | "
                             f"{r['best_estimate']:.2f} | {r['best_mr']:.3f} | "
                             f"{r['mr_at_true']:.3f} | {_fmt(r['crossing'], 2)} | "
                             f"{_fmt(r['band_above_truth'], 2)} | "
                             f"{_fmt(r['crossing_interp'], 2)} | {_fmt(r['band_interp'], 2)} |"
                             + (f" {_fmt(r['band_paper_level'], 2)} |" if paper else ""))
            lines.append("")
        lines += ["![sweep](sweep.png)", ""]
    if (out / "remap_illustration.png").is_file():
        lines += ["## Remapping illustration (Fig. 4)", "", "![remap](remap_illustration.png)", ""]
    path = out / "report.md"
    tmp = path.with_suffix(".md.tmp")
    tmp.write_text("\n".join(lines))
    tmp.replace(path)
    return path


#: the rows the closing summary lists, in this order (the oracle is the ``s == t`` row)
_SUMMARY_METHODS = ("unadapted", "adapted", "image warping", "synthesised")


def closing_summary(out: Path, *, source: float = 0.0) -> list:
    """A few console lines on a cross-validation results directory, read from its
    ``summary.csv`` and ``paired_differences.csv`` (nothing is recomputed): per detector, the
    miss rates at 10⁻² fppw of the main methods ``source`` → target and of the oracle, and
    ``adapted − unadapted`` with its paired 95% interval, said in words."""
    out = Path(out)
    s = pd.read_csv(out / "summary.csv")
    p = pd.read_csv(out / "paired_differences.csv")
    same = lambda col, v: np.isclose(col.astype(float), v)  # noqa: E731
    lines, unresolved = [], []
    for det in dict.fromkeys(s["detector"]):
        d = s[(s["detector"] == det)]
        rows = d[same(d["source_elevation"], source) & (d["method"] != "oracle")]
        if rows.empty:
            continue
        t = float(rows["target_elevation"].iloc[0])
        mr = {m: float(r["mr_at_fppw_0.01"]) for m in _SUMMARY_METHODS
              for _, r in rows[rows["method"] == m].iterrows()}
        orc = d[(d["method"] == "oracle") & same(d["target_elevation"], t)]
        if len(orc):
            mr["oracle"] = float(orc["mr_at_fppw_0.01"].iloc[0])
        pair = f"{elevation_label(source)}→{elevation_label(t)}"
        lines.append(f"{det} {pair}, miss rate at 10⁻² fppw ({int(rows['n_pos'].iloc[0])} test "
                     "positives): " + ", ".join(f"{m} {v:.3f}" for m, v in mr.items()))
        if "oracle" in mr and len(mr) > 1:
            best = min(mr, key=mr.get)
            lines.append("  oracle (trained on the target view) is best" if best == "oracle"
                         else f"  oracle is NOT best: {best} is lower")
        q = p[(p["detector"] == det) & same(p["source_elevation"], source)
              & (p["method_a"] == "adapted") & (p["method_b"] == "unadapted")]
        if len(q):
            r = q.iloc[0]
            lo, hi = float(r["ci_low"]), float(r["ci_high"])
            verdict = ("adapted is better than unadapted" if hi < 0 else
                       "adapted is WORSE than unadapted" if lo > 0 else
                       "it includes 0, so this run cannot tell adapted from unadapted")
            lines.append(f"  adapted − unadapted {float(r['diff']):+.3f}, paired 95% interval "
                         f"[{lo:+.3f}, {hi:+.3f}]: {verdict}")
            if lo <= 0 <= hi:
                unresolved.append(det)
    if unresolved:
        lines.append(f"not shown at this size for {', '.join(unresolved)}: this run shows no "
                     "difference either way; more test persons and scenes (e.g. the paper-scale "
                     "dataset) give narrower intervals")
    return lines
