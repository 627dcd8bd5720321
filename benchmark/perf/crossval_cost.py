"""Cost of a full cross-validation and sweep on an existing dataset, stage by stage.

    python -m benchmark.perf.crossval_cost --data DIR [--out RES] [--jobs N]

Runs feature extraction (all window sets and representations the runs need), the nine-fold
cross-validation of every detector, source and method, the summaries, and the elevation
sweep, and prints the wall time of each stage and the total. The issue's target for the
paper-scale set (7956 crops + backgrounds) is <= 20 min on a 2-core machine. Not a test.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", type=Path, required=True)
    p.add_argument("--out", type=Path, default=None, help="cache directory (default: temporary)")
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--seed", type=int, default=0)
    a = p.parse_args(argv)

    from benchmark.crossval import CrossvalConfig, prepare, run_crossval
    from benchmark.data import load_dataset
    from benchmark.features import FeatureCache
    from benchmark.summarize import paired_differences, summarize
    from benchmark.sweep import run_sweep, sweep_summary

    out = a.out or Path(tempfile.mkdtemp(prefix="viewadapt-cost-"))
    times = {}
    t = time.perf_counter()
    ds = load_dataset(a.data)
    times["load + validate dataset"] = time.perf_counter() - t
    cfg = CrossvalConfig(seed=a.seed, n_jobs=a.jobs, distance=float(ds.config.get("distance", 10)),
                         framing=str(ds.config.get("framing", "plane")))
    cache = FeatureCache(ds, out / "cache", n_jobs=a.jobs)
    t = time.perf_counter()
    prepare(ds, cfg, cache)
    times["features (all sets, cached)"] = time.perf_counter() - t
    t = time.perf_counter()
    scores, _ = run_crossval(ds, cfg, cache)
    times["cross-validation (train + score)"] = time.perf_counter() - t
    t = time.perf_counter()
    rng = np.random.default_rng(a.seed)
    summarize(scores, rng=rng)
    paired_differences(scores, rng=rng)
    times["summaries + bootstrap"] = time.perf_counter() - t
    t = time.perf_counter()
    sweep_summary(run_sweep(ds, cfg, cache))
    times["elevation sweep"] = time.perf_counter() - t
    n = ds.persons.shape[0]
    print(f"dataset {a.data}: {n} person crops, {ds.backgrounds.shape[0]} background images, "
          f"{len(scores)} scored windows, jobs={a.jobs}")
    for k, v in times.items():
        print(f"  {k:36s} {v:8.1f} s")
    total = sum(times.values())
    print(f"  {'total':36s} {total:8.1f} s  ({total / 60:.1f} min; target for paper scale <= 20 min)")


if __name__ == "__main__":
    main()
