"""One-off: what the body-model rules' scores do past the truth, per estimate.

``python plateau_scores.py SWEEP ...``: for each sweep run (``bench sweep``'s
``sweep_scores.parquet``) and each of ``adapted[body, paper eq.3]`` and ``adapted[body, S
only]``, per estimate from the truth (pi/4) to 1.36 rad: the threshold at 1e-2 FPPW (of
that estimate's negatives), the medians of the positives' and the negatives' scores, and
the share of positives below the threshold (pooled over persons, so it differs slightly
from the sweep's per-person bootstrap point estimate). Output: plateau_scores.txt."""
import sys

import numpy as np
import pandas as pd

from benchmark.crops.summarize import operating_threshold

for run in sys.argv[1:]:
    d = pd.read_parquet(f"{run}/sweep_scores.parquet",
                        columns=["method", "estimate", "label", "score"])
    for m in ("adapted[body, paper eq.3]", "adapted[body, S only]"):
        x = d[d.method == m]
        print(f"{run}: {m}\n  estimate  threshold  positives' median  negatives' median  miss")
        for e in sorted(x.estimate.unique()):
            if not np.pi / 4 - 1e-3 < e < 1.36:
                continue
            y = x[x.estimate == e]
            neg, pos = y.score[y.label == 0].to_numpy(), y.score[y.label == 1].to_numpy()
            thr = operating_threshold(neg, 1e-2)
            print(f"  {e:.3f}     {thr:+.3f}     {np.median(pos):+.3f}             "
                  f"{np.median(neg):+.3f}             {(pos < thr).mean():.3f}")
