"""Figure of docs/training.md point 67: the seed-1 effects render at three crop-camera
distances. Left, each method's miss rate at 1e-2 FPPW at the true pi/4 (95 % over test
persons); right, each sweep rule's interpolated crossing above the truth (95 % over test
persons), with the issue's +0.31 bar.

    python distance_plot.py distance.png      (run in this folder)
"""
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

HERE = Path(__file__).resolve().parent
TEN = HERE.parent / "sweep_crossing" / "render_s1_default" / "sweep_intervals.csv"
TEN_CV = HERE.parents[1] / "issue32_bars_2c66908" / "crossval_s1" / "summary.csv"
RUNS = {5: (HERE / "d5" / "crossval" / "summary.csv", HERE / "d5" / "sweep_intervals.csv"),
        10: (TEN_CV, TEN),
        15: (HERE / "d15" / "crossval" / "summary.csv", HERE / "d15" / "sweep_intervals.csv")}
METHODS = ["unadapted", "adapted", "adapted[S only]", "adapted[paper eq.3]", "adapted[body]",
           "adapted[body, S only]", "adapted[body, paper eq.3]", "image warping",
           "synthesised"]
SWEEP = METHODS[1:7]
COLOUR = {m: f"C{k}" for k, m in enumerate(METHODS)}


def crossval_row(d, m):
    """(value, low, high) of method ``m``'s miss rate at the truth at distance ``d``."""
    s = pd.read_csv(RUNS[d][0])
    r = s[(s["method"] == m) & (s["target_elevation"] > 0.7)
          & (s["source_elevation"] == 0)].iloc[0]
    return r["mr_at_fppw_0.01"], r["ci_low"], r["ci_high"]


def sweep_row(d, m):
    """(value, low, high) of method ``m``'s interpolated crossing above the truth."""
    s = pd.read_csv(RUNS[d][1])
    r = s[s["method"] == m].iloc[0]
    return r["band_interp"], r["band_interp_low"], r["band_interp_high"]


def panel(ax, methods, row):
    """One curve per method over the distances, its 95 % interval as error bars."""
    for k, m in enumerate(methods):
        vals = [row(d, m) for d in RUNS]
        ax.errorbar([d + (k - len(methods) // 2) * 0.18 for d in RUNS], [v for v, _, _ in vals],
                    yerr=[[v - lo for v, lo, _ in vals], [hi - v for v, _, hi in vals]],
                    marker="o", ms=4, capsize=2, label=m, color=COLOUR[m],
                    ls="--" if "body" in m else "-")


fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
panel(a, METHODS, crossval_row)
a.set(xlabel="crop camera distance (m)", ylabel="miss rate at 1e-2 FPPW, truth π/4",
      xticks=list(RUNS), title="HOG 0 → π/4 at the true elevation")
a.legend(fontsize=7, ncol=2)
panel(b, SWEEP, sweep_row)
b.axhline(0.31, color="k", lw=0.8, ls=":")
b.text(15.3, 0.315, "bar +0.31", fontsize=7, ha="right")
b.set(xlabel="crop camera distance (m)", ylabel="crossing above the truth (rad)",
      xticks=list(RUNS), title="sweep: where adapting is as bad as unadapted")
b.legend(fontsize=7)
fig.tight_layout()
fig.savefig(sys.argv[1] if len(sys.argv) > 1 else HERE / "distance.png", dpi=110)
