"""Paired person-bootstrap differences between two sweep runs (same test persons):
miss rate at 1e-2 fppw of 'unadapted' and of each named curve at the truth, run B - run A."""
import sys
import numpy as np, pandas as pd
from benchmark.studies.sweep_intervals import bootstrap_miss_rates, person_hits
truth = np.pi / 4
A, B = sys.argv[1:3]
curves = ["unadapted", "adapted", "adapted[paper eq.3]", "adapted[S only]"]
parts = []
for tag, run in (("A", A), ("B", B)):
    d = pd.read_parquet(f"{run}/sweep_scores.parquet")
    d = d[d.method.isin(curves)]
    est = np.sort(d.estimate.dropna().unique()); e_t = est[np.argmin(abs(est - truth))]
    d = d[d.estimate.isna() | (d.estimate == e_t)].copy()
    d["method"] = tag + ":" + d.method
    d["estimate"] = d.estimate.fillna(-1.0)
    parts.append(d)
keys, persons, hits, counts = person_hits(pd.concat(parts, ignore_index=True), 1e-2)
names = [k[0] for k in keys]
mr = bootstrap_miss_rates(hits, counts, 1000, np.random.default_rng(0))
for c in curves:
    i, j = names.index("A:" + c), names.index("B:" + c)
    diff = mr[:, j] - mr[:, i]
    lo, hi = np.percentile(diff[1:], [2.5, 97.5])
    print(f"| {c} | {mr[0, i]:.3f} | {mr[0, j]:.3f} | {diff[0]:+.3f} ({lo:+.3f}…{hi:+.3f}) |")
