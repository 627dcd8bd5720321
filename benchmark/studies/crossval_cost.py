"""Cost of a full cross-validation and sweep on an existing dataset, stage by stage.

    python -m benchmark.studies.crossval_cost --data DIR [--out RES] [--jobs N] [--compare RES2]

Runs feature extraction (all window sets and representations the runs need), the nine-fold
cross-validation of every detector, source and method, the summaries, and the elevation
sweep, and prints the wall time of each stage and the total. With ``--out`` the summaries
(``summary.csv``, ``paired.csv``, ``sweep.csv``) and the stage times (``cost.json``) are
written there, and ``--compare`` names an earlier run's directory whose summaries must be
identical (an optimisation must not change a number). Target for the paper-scale set
(7956 crops + backgrounds): <= 10 min on a 2-core machine. Not a test.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

import numpy as np


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", type=Path, required=True, help="a dataset from `viewadapt generate`")
    p.add_argument("--out", type=Path, default=None,
                   help="directory for the feature cache, the summaries and the stage times "
                   "(default: a temporary cache, nothing written)")
    p.add_argument("--compare", type=Path, default=None,
                   help="an earlier --out: report whether its summaries equal this run's")
    p.add_argument("--jobs", type=int, default=2, help="worker processes (default 2)")
    p.add_argument("--seed", type=int, default=0, help="cross-validation seed (default 0)")
    a = p.parse_args(argv)

    from benchmark.crops.crossval import CrossvalConfig, prepare, run_crossval
    from benchmark.data import load_dataset
    from benchmark.crops.features import FeatureCache
    from benchmark.crops.summarize import paired_differences, summarize
    from benchmark.crops.sweep import run_sweep, sweep_summary
    from benchmark.recipes import PAPER_RECIPE

    out = a.out or Path(tempfile.mkdtemp(prefix="viewadapt-cost-"))
    times = {}
    t = time.perf_counter()
    ds = load_dataset(a.data)
    times["load + validate dataset"] = time.perf_counter() - t
    cfg = CrossvalConfig.for_dataset(ds, seed=a.seed, n_jobs=a.jobs, recipe=PAPER_RECIPE)
    cache = FeatureCache(ds, out / "cache", n_jobs=a.jobs)
    t = time.perf_counter()
    data = prepare(ds, cfg, cache)
    times["features (all sets, cached)"] = time.perf_counter() - t
    t = time.perf_counter()
    models = {}          # the source models, for the sweep (it trains the same ones)
    scores, _ = run_crossval(ds, cfg, cache, data=data, models=models)
    times["cross-validation (train + score)"] = time.perf_counter() - t
    t = time.perf_counter()
    rng = np.random.default_rng(a.seed)
    tables = {"summary": summarize(scores, rng=rng),
              "paired": paired_differences(scores, rng=rng)}
    times["summaries + bootstrap"] = time.perf_counter() - t
    t = time.perf_counter()
    tables["sweep"] = sweep_summary(run_sweep(ds, cfg, cache, models=models))
    times["elevation sweep"] = time.perf_counter() - t
    n = ds.persons.shape[0]
    print(f"dataset {a.data}: {n} person crops, {ds.backgrounds.shape[0]} background images, "
          f"{len(scores)} scored windows, jobs={a.jobs}")
    for k, v in times.items():
        print(f"  {k:36s} {v:8.1f} s")
    total = sum(times.values())
    print(f"  {'total':36s} {total:8.1f} s  ({total / 60:.1f} min; target for paper scale <= 10 min)")
    if a.out is not None:
        for name, df in tables.items():
            df.to_csv(out / f"{name}.csv", index=False)
        (out / "cost.json").write_text(json.dumps(
            {"data": str(a.data), "jobs": a.jobs, "seed": a.seed, "cpus": os.cpu_count(),
             "seconds": {k: round(v, 2) for k, v in times.items()},
             "total_s": round(total, 2)}, indent=2) + "\n")
    if a.compare is not None:
        same = compare_summaries(a.compare, tables)
        print("summaries " + ("identical to " if not same else "DIFFER from ") + str(a.compare)
              + ("" if not same else ": " + ", ".join(same)))
        return 1 if same else 0
    return 0


def compare_summaries(earlier: Path, tables: dict) -> list:
    """Names of the tables that differ from (or are missing in) the earlier run's CSVs; the
    tables are compared as written (the same CSV text), so any changed digit counts."""
    import io

    differ = []
    for name, df in tables.items():
        f = Path(earlier) / f"{name}.csv"
        buf = io.StringIO()
        df.to_csv(buf, index=False)
        if not f.is_file() or f.read_text() != buf.getvalue():
            differ.append(name)
    return differ


if __name__ == "__main__":
    raise SystemExit(main())
