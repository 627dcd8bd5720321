"""Usage: python distance_pairs.py RUN_A DATA_A RUN_B DATA_B  (docs/training.md point 67)

Two crossval runs on renders that share most placements (the same seed at two camera
distances): per method, each run's miss rate at its own 1e-2 FPPW threshold, restricted to the
pi/4 test crops whose placement (position, rotation, pose) is identical in both renders, and
the paired difference B - A with a 95 % bootstrap over persons."""
import sys
import numpy as np
import pandas as pd
from benchmark.crops.summarize import operating_threshold

run_a, data_a, run_b, data_b = sys.argv[1:5]
KEYS = ["ground_x", "ground_y", "rotation", "pose"]


def placements(data):
    m = pd.read_parquet(f"{data}/manifest.parquet")
    return m[m.kind == "person"].set_index("path")[KEYS]


pa, pb = placements(data_a), placements(data_b)
j = pa.join(pb, rsuffix="_b", how="inner")
same = np.ones(len(j), bool)
for k in KEYS:
    same &= (j[k] == j[k + "_b"]).to_numpy()
shared = set(j.index[same])


def detections(run):
    s = pd.read_parquet(f"{run}/scores.parquet")
    s = s[s.target_elevation > 0.7]
    out = {}
    for meth, d in s.groupby("method", sort=False):
        thr = operating_threshold(d.loc[d.label == 0, "score"], 1e-2)
        pos = d[d.label == 1]
        out[meth] = pd.Series((pos.score >= thr).to_numpy(), index=pos.path.to_numpy())
    return out, s[s.label == 1].drop_duplicates("path").set_index("path")["person_id"]


da, persons = detections(run_a)
db, _ = detections(run_b)
rng = np.random.default_rng(0)
print(f"shared placements among pi/4 test crops: {len(shared & set(persons.index))} of "
      f"{len(persons)}")
print("| method | A all | B all | A shared | B shared | B - A shared (95 % over persons) |")
print("|---|---|---|---|---|---|")
for meth in da:
    if meth not in db:
        continue
    a, b = da[meth], db[meth]
    idx = sorted(shared & set(a.index) & set(b.index))
    miss_a, miss_b = 1 - a[idx].to_numpy(float), 1 - b[idx].to_numpy(float)
    pid = persons[idx].to_numpy()
    uniq, inv = np.unique(pid, return_inverse=True)
    da_p = np.bincount(inv, weights=miss_a, minlength=len(uniq))
    db_p = np.bincount(inv, weights=miss_b, minlength=len(uniq))
    n_p = np.bincount(inv, minlength=len(uniq)).astype(float)
    draw = rng.integers(len(uniq), size=(2000, len(uniq)))
    boot = (db_p[draw].sum(1) - da_p[draw].sum(1)) / n_p[draw].sum(1)
    lo, hi = np.percentile(boot, [2.5, 97.5])
    print(f"| {meth} | {1 - a.mean():.3f} | {1 - b.mean():.3f} | {miss_a.mean():.3f} | "
          f"{miss_b.mean():.3f} | {miss_b.mean() - miss_a.mean():+.3f} ({lo:+.3f}…{hi:+.3f}) |")
