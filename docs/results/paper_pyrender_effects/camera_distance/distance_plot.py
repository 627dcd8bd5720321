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

fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
for k, m in enumerate(METHODS):
    xs, ys, lo, hi = [], [], [], []
    for d, (cv, _) in RUNS.items():
        s = pd.read_csv(cv)
        r = s[(s["method"] == m) & (s["target_elevation"] > 0.7)
              & (s["source_elevation"] == 0)].iloc[0]
        xs.append(d + (k - 4) * 0.18)
        ys.append(r["mr_at_fppw_0.01"])
        lo.append(r["mr_at_fppw_0.01"] - r["ci_low"])
        hi.append(r["ci_high"] - r["mr_at_fppw_0.01"])
    a.errorbar(xs, ys, yerr=[lo, hi], marker="o", ms=4, capsize=2, label=m, color=COLOUR[m],
               ls="--" if "body" in m else "-")
a.set(xlabel="crop camera distance (m)", ylabel="miss rate at 1e-2 FPPW, truth π/4",
      xticks=list(RUNS), title="HOG 0 → π/4 at the true elevation")
a.legend(fontsize=7, ncol=2)
for k, m in enumerate(SWEEP):
    xs, ys, lo, hi = [], [], [], []
    for d, (_, sw) in RUNS.items():
        s = pd.read_csv(sw)
        r = s[s["method"] == m].iloc[0]
        xs.append(d + (k - 3) * 0.18)
        ys.append(r["band_interp"])
        lo.append(r["band_interp"] - r["band_interp_low"])
        hi.append(r["band_interp_high"] - r["band_interp"])
    b.errorbar(xs, ys, yerr=[lo, hi], marker="o", ms=4, capsize=2, label=m, color=COLOUR[m],
               ls="--" if "body" in m else "-")
b.axhline(0.31, color="k", lw=0.8, ls=":")
b.text(15.3, 0.315, "bar +0.31", fontsize=7, ha="right")
b.set(xlabel="crop camera distance (m)", ylabel="crossing above the truth (rad)",
      xticks=list(RUNS), title="sweep: where adapting is as bad as unadapted")
b.legend(fontsize=7)
fig.tight_layout()
fig.savefig(sys.argv[1] if len(sys.argv) > 1 else HERE / "distance.png", dpi=110)
