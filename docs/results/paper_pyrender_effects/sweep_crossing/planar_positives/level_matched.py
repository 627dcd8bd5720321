"""One-off: where each sweep curve first reaches a fixed miss rate past its best estimate.

``python level_matched.py LABEL=RUN [LABEL=RUN ...]``: ``bench sweep`` runs (plane object
model, HOG 0 -> pi/4) -- here the render's own, that of its persons made planar
(planar_positives.py) and the planar toy's (toy_planar/sweep_seed5, sweep_seed6); per rule,
the estimate (linear between grid points) at which the curve first reaches 0.324
(unadapted on the rendered persons) and 0.796 (the paper's unadapted), in rad above the
truth. Output: level_matched.txt."""
import sys

import numpy as np
import pandas as pd

T = np.pi / 4


def reach(t, level):
    e, v = t.index.values, t.values
    for i in range(int(np.argmin(v)), len(e) - 1):
        if v[i + 1] >= level:
            return e[i] + (level - v[i]) * (e[i + 1] - e[i]) / (v[i + 1] - v[i]) \
                if v[i] < level else e[i]
    return np.nan


print("Where each curve (plane object model, HOG 0 -> pi/4) first reaches a "
      "fixed miss rate past its best estimate, linear between grid points; rad above the "
      "truth (0.785).")
print("Levels: 0.324 (unadapted on the rendered persons), 0.796 (the paper's unadapted).")
for lab, run in (a.split("=", 1) for a in sys.argv[1:]):
    s = pd.read_csv(f"{run}/sweep_summary.csv")
    print(f"\n{lab}: unadapted {s[s.method == 'unadapted']['mr_at_fppw_0.01'].iloc[0]:.3f}")
    for m in ("adapted", "adapted[paper eq.3]", "adapted[S only]"):
        t = s[(s.method == m) & (s.object_model == "plane")].set_index(
            "estimate")["mr_at_fppw_0.01"].sort_index()
        print(f"  {m:20s} " + "  ".join(f"MR {L:.3f} at {reach(t, L) - T:+.2f}"
                                        for L in (0.324, 0.796)))
