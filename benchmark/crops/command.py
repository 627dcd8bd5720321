"""``viewadapt bench ...``, ``viewadapt report`` and ``viewadapt reproduce``."""

from __future__ import annotations

import argparse
import importlib
import json
import sys
import time
from pathlib import Path

import numpy as np

from viewadapt.io.bounded import MAX_INPUT_BYTES, check_json_depth, read_limited_text

from benchmark.recipes import add_recipe_argument

__all__ = ["register", "check_results_dir"]

#: how long ``--scheduler`` waits for the Dask scheduler before giving up
SCHEDULER_TIMEOUT_S = 10


def _elevations(text: str) -> tuple:
    """Parse '0,pi/8,pi/4' or radians '0,0.39' into floats; an elevation given twice is
    an error."""
    out = []
    for tok in text.split(","):
        tok = tok.strip().lower().replace("π", "pi")
        try:
            if "pi" in tok:
                num, _, den = tok.partition("/")
                k = num.replace("pi", "").replace("*", "").strip()
                val = (float(k) if k else 1.0) * np.pi / (float(den) if den else 1.0)
            else:
                val = float(tok)
        except (ValueError, ZeroDivisionError):
            raise argparse.ArgumentTypeError(f"cannot read elevation {tok!r} "
                                             "(use radians or forms like pi/8, 3pi/8)") from None
        if not np.isfinite(val):
            raise argparse.ArgumentTypeError(f"elevation {tok!r} is not a finite angle")
        if any(abs(val - v) < 1e-9 for v in out):
            raise argparse.ArgumentTypeError(f"elevation {tok!r} ({val:.4f} rad) is given "
                                             "twice")
        out.append(val)
    return tuple(out)


def _read_run(run: Path) -> dict:
    """The ``run.json`` of a results directory, read within bounds (its size, then its
    nesting, before parsing); anything but a JSON object is a one-line ``ValueError``."""
    text = read_limited_text(run, "run.json", MAX_INPUT_BYTES)
    check_json_depth(text, run)
    try:
        old = json.loads(text)
    except json.JSONDecodeError:
        raise ValueError(f"{run} is corrupt; remove it or use another --out") from None
    if not isinstance(old, dict):
        raise ValueError(f"{run} is corrupt (a JSON {type(old).__name__}, not an object); "
                         "remove it or use another --out")
    return old


def check_results_dir(out: Path, fingerprint: str, recipe=None) -> None:
    """Refuse to mix results of two datasets, or of two source-training recipes
    (:mod:`benchmark.recipes`; a ``run.json`` that records none was trained the paper's way,
    ``elevation0``), in one directory."""
    run = Path(out) / "run.json"
    if run.is_file():
        old = _read_run(run)
        if old.get("fingerprint") != fingerprint:
            raise ValueError(f"{out} holds results of another dataset ({old.get('data')}, "
                             f"fingerprint {old.get('fingerprint')}); use another --out")
        had = old.get("recipe", {"name": "elevation0"})
        had = had.get("name") if isinstance(had, dict) else had
        if recipe is not None and had != recipe.name:
            raise ValueError(f"{out} holds results trained with recipe {had!r}, not "
                             f"{recipe.name!r}; use another --out")


def _incomplete(ds, args):
    """The incomplete-dataset warning (printed loudly) or None; refuses without the flag."""
    import sys

    from benchmark.crops.crossval import require_complete

    msg = require_complete(ds, allow_incomplete=getattr(args, "allow_incomplete", False))
    if msg:
        bar = "!" * 78
        print(f"{bar}\nWARNING: {msg}.\nRunning on it anyway (--allow-incomplete): the "
              f"results do not describe the planned dataset; run.json and report.md say "
              f"so.\n{bar}", file=sys.stderr, flush=True)
    return msg


def _run_json(ds, args, extra=None) -> dict:
    from viewadapt import __version__

    recipe = getattr(args, "recipe", None)
    return {"data": str(ds.root), "fingerprint": ds.fingerprint,
            "renderer": ds.config.get("renderer"), "framing": ds.config.get("framing", "plane"),
            "seed": args.seed, "viewadapt": __version__,
            "created": time.strftime("%Y-%m-%dT%H:%M:%S")} \
        | ({"recipe": recipe.to_dict()} if recipe is not None else {}) | (extra or {})


def _elevation(text: str) -> float:
    """Parse one elevation ('pi/4' or radians) into a float."""
    vals = _elevations(text)
    if len(vals) != 1:
        raise argparse.ArgumentTypeError(f"give one target elevation, got {text!r}")
    return vals[0]


def _config(args, ds):
    from benchmark.crops.crossval import CrossvalConfig

    cfg = CrossvalConfig.for_dataset(ds, seed=args.seed, n_jobs=args.jobs)
    if getattr(args, "sources", None):
        cfg.sources = args.sources
    if getattr(args, "target", None) is not None:
        cfg.target = args.target
    if getattr(args, "detectors", None):
        from benchmark.crops.detectors import detector_spec

        for d in args.detectors:               # every name resolves, before any work
            detector_spec(d)
        cfg.detectors = tuple(args.detectors)
    if getattr(args, "object_models", None):
        cfg.object_models = tuple(args.object_models)
    if getattr(args, "no_upper_bound", False):
        cfg.upper_bound = False
    if getattr(args, "recipe", None) is not None:
        cfg.recipe = args.recipe
    if getattr(args, "quick", False):
        cfg.acf_estimators, cfg.acf_stages = 32, (16, 32)
        cfg.acf_max_bins, cfg.acf_max_features = 32, 0.25
        cfg.initial_negatives = 2000
    return cfg


def _scheduler(args):
    """A joblib backend context: Dask when --scheduler is given, else a no-op."""
    import contextlib

    if not getattr(args, "scheduler", None):
        return contextlib.nullcontext()
    try:
        from dask.distributed import Client
    except ImportError:
        raise ValueError("--scheduler needs dask.distributed: pip install 'viewadapt[scale]'") from None
    import joblib

    from viewadapt.io.files import UserError

    try:
        client = Client(args.scheduler, timeout=f"{SCHEDULER_TIMEOUT_S}s")
    except (OSError, TimeoutError, ValueError) as exc:
        raise UserError(f"--scheduler {args.scheduler}: cannot reach a Dask scheduler there "
                        f"within {SCHEDULER_TIMEOUT_S} s ({exc.__class__.__name__})") from None
    stack = contextlib.ExitStack()
    stack.callback(client.close)
    stack.enter_context(joblib.parallel_backend("dask"))
    return stack


def cmd_crossval(args) -> int:
    import matplotlib.pyplot as plt

    from viewadapt.io.files import atomic_output_dir, check_output_dir

    from benchmark.crops.crossval import config_dict, exact_geometry_wanted, run_crossval
    from benchmark.data import load_dataset
    from benchmark.crops.detectors import detector_spec
    from benchmark.crops.features import FeatureCache
    from benchmark.crops.figures import save_figure
    from benchmark.crops.report import plot_det, plot_score_shift, write_report
    from benchmark.crops.summarize import paired_differences, summarize

    check_output_dir(args.out, overwrite=args.overwrite)
    ds = load_dataset(args.data)
    check_results_dir(args.out, ds.fingerprint, args.recipe)
    cfg = _config(args, ds)
    if ("plane" not in cfg.object_models
            and any(exact_geometry_wanted(detector_spec(d), cfg) for d in cfg.detectors)):
        print("note: no exact-geometry rows without the plane among --object-models (they "
              "share its adapted rows' negatives); add plane, or pass --no-upper-bound",
              file=sys.stderr)
    incomplete = _incomplete(ds, args)
    cache = FeatureCache(ds, args.cache or (args.out / "cache"), n_jobs=args.jobs)
    t0 = time.perf_counter()
    with _scheduler(args):
        scores, folds = run_crossval(ds, cfg, cache)
    rng = np.random.default_rng(args.seed)
    summary = summarize(scores, rng=rng)
    pairs = paired_differences(scores, rng=rng)
    with atomic_output_dir(args.out) as tmp:
        scores.to_parquet(tmp / "scores.parquet", index=False)
        summary.to_csv(tmp / "summary.csv", index=False)
        (tmp / "summary.md").write_text(_markdown(summary))
        pairs.to_csv(tmp / "paired_differences.csv", index=False)
        (tmp / "folds.json").write_text(json.dumps(
            [{"fold": f.name, "train_persons": sorted(f.train_persons),
              "train_scenes": sorted(f.train_scenes), "test_persons": sorted(f.test_persons),
              "test_scenes": sorted(f.test_scenes)} for f in folds], indent=1))
        for det in cfg.detectors:
            name = detector_spec(det).name
            fig = plot_det(scores, summary, name)
            save_figure(fig, tmp / f"det_{name}")
            plt.close(fig)
        if "hog" in cfg.detectors and 0.0 in cfg.sources:
            fig = plot_score_shift(scores, "hog", 0.0)
            save_figure(fig, tmp / "score_shift")
            plt.close(fig)
        _remap_figure(tmp, ds, cfg)
        (tmp / "run.json").write_text(json.dumps(_run_json(ds, args, {
            "crossval": config_dict(cfg), "crossval_seconds": round(time.perf_counter() - t0, 1),
            "incomplete_dataset": incomplete}),
            indent=2, default=str))
    write_report(args.out)
    print(_markdown(summary))
    print(f"\nwrote {args.out}/ (summary.csv, scores.parquet, det_*.png, report.md)")
    return 0


def _remap_figure(tmp, ds, cfg):
    """Fig. 4 on a real target crop of the dataset (first person at the target elevation)."""
    import matplotlib.pyplot as plt

    from viewadapt.geometry import elevation_homography

    from benchmark.data import read_image
    from benchmark.crops.figures import plot_remap_illustration, save_figure

    p = ds.persons
    row = p[p["elevation_index"] == ds.elevation_index(cfg.target)].iloc[0]
    img = read_image(ds.root / row["path"])
    pad = np.pad(img, ((40, 40), (40, 40), (0, 0)), mode="edge")
    fig = plot_remap_illustration(pad, 40, 40, elevation_homography(
                                      0.0, cfg.target, distance=cfg.distance,
                                      framing=cfg.framing),
                                  title=f"{row['person_id']} in {row['scene_id']}, 0 → π/4,")
    save_figure(fig, tmp / "remap_illustration")
    plt.close(fig)


def _markdown(summary) -> str:
    from benchmark.crops.report import elevation_label

    cols = ["detector", "pair", "method", "mr_at_fppw_0.01", "ci", "fold mean±std", "lamr", "n_pos"]
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for _, r in summary.iterrows():
        lines.append(
            f"| {r['detector']} | {elevation_label(r['source_elevation'])}→"
            f"{elevation_label(r['target_elevation'])} | {r['method']} | {r['mr_at_fppw_0.01']:.3f} | "
            f"{r['ci_low']:.2f}–{r['ci_high']:.2f} | {r['mr_at_fppw_0.01_mean']:.2f}±"
            f"{r['mr_at_fppw_0.01_std']:.2f} | {r['lamr']:.3f} | {int(r['n_pos'])} |")
    return "\n".join(lines) + "\n"


def cmd_sweep(args) -> int:
    import matplotlib.pyplot as plt

    from viewadapt.io.files import atomic_output_dir, check_output_dir

    from benchmark.data import load_dataset
    from benchmark.crops.features import FeatureCache
    from benchmark.crops.figures import save_figure
    from benchmark.crops.report import plot_sweep, write_report
    from benchmark.crops.sweep import run_sweep, sweep_summary

    check_output_dir(args.out, overwrite=args.overwrite)
    ds = load_dataset(args.data)
    check_results_dir(args.out, ds.fingerprint, args.recipe)
    cfg = _config(args, ds)
    incomplete = _incomplete(ds, args)
    from benchmark.crops.detectors import detector_spec

    detector_spec(args.detector)                 # resolves, before any work
    if not 0 < args.step <= np.pi / 36 + 1e-12:
        raise ValueError("--step must lie in (0, pi/36] radians")
    cache = FeatureCache(ds, args.cache or (args.out / "cache"), n_jobs=args.jobs)
    t0 = time.perf_counter()
    rows = run_sweep(ds, cfg, cache, detector=args.detector, source=args.source, step=args.step,
                     sigma=args.sigma)
    summ = sweep_summary(rows)
    with atomic_output_dir(args.out) as tmp:
        rows.to_parquet(tmp / "sweep_scores.parquet", index=False)
        summ.to_csv(tmp / "sweep_summary.csv", index=False)
        fig = plot_sweep(summ, true_elevation=cfg.target,
                         title=f"{args.detector} trained at {args.source:.3f} rad, tested at "
                               f"{cfg.target:.3f} rad ({int(summ['n_pos'].iloc[0])} positives, 9 folds pooled)")
        save_figure(fig, tmp / "sweep")
        plt.close(fig)
        run_path = Path(args.out) / "run.json"
        run = _read_run(run_path) if run_path.is_file() else _run_json(ds, args)
        run["recipe"] = args.recipe.to_dict()
        run["sweep"] = {"detector": args.detector, "source": args.source,
                        "target": float(cfg.target), "step": args.step,
                        "sigma": args.sigma, "seconds": round(time.perf_counter() - t0, 1),
                        "incomplete_dataset": incomplete}
        (tmp / "run.json").write_text(json.dumps(run, indent=2, default=str))
    write_report(args.out)
    print(summ.to_string(index=False))
    return 0


def cmd_report(args) -> int:
    from benchmark.crops.report import write_report

    out = Path(args.results)
    if not out.is_dir() or not (out / "run.json").is_file():
        raise ValueError(f"{out} is not a results directory (no run.json); run "
                         "`viewadapt bench crossval` first")
    print(write_report(out))
    return 0


def register(sub, common) -> None:
    """Add ``bench``, ``report`` to the ``viewadapt`` parser."""
    bench = sub.add_parser("bench", help="run benchmarks on a generated dataset",
                           description="Benchmarks of viewpoint adaptation on a dataset "
                                       "written by `viewadapt generate`.")
    bsub = bench.add_subparsers(dest="bench_command", metavar="BENCH", required=True)
    data_opts = argparse.ArgumentParser(add_help=False)
    data_opts.add_argument("--data", type=Path, required=True, help="dataset directory")
    data_opts.add_argument("--cache", type=Path, default=None,
                           help="feature cache directory (default OUT/cache); reruns reuse it")
    data_opts.add_argument("--target", type=_elevation, default=None,
                           help="target elevation (default pi/4)")
    data_opts.add_argument("--scheduler", default=None,
                           help="address of a Dask scheduler to run the folds on")
    data_opts.add_argument("--quick", action="store_true",
                           help="smaller boosted detectors and negative sets (tests, demos)")
    data_opts.add_argument("--allow-incomplete", action="store_true",
                           help="run on a dataset missing images its dataset.json plans (an "
                                "unfinished generate): warns, and run.json and report.md say so")
    add_recipe_argument(data_opts, what="every detector that trains")
    data_opts.add_argument("--object-models", nargs="+", choices=["plane", "body"],
                           default=None, help="object models of the adapted and image-warping "
                           "rows (default both: the person plane and the mean body)")

    p = bsub.add_parser("crossval", parents=[common, data_opts],
                        help="nine-fold cross-validation (Fig. 5 and beyond)",
                        description=importlib.import_module("benchmark.crops.crossval").__doc__,
                        formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--sources", type=_elevations, default=None,
                   help="source elevations (default 0,pi/8,pi/4)")
    p.add_argument("--detectors", nargs="+", default=None, metavar="DETECTOR",
                   help="detectors: built-in hog, hog_local, acf, opencv (default all four) "
                        "and/or your own as package.module:Object implementing the detector "
                        "protocol (benchmark.crops.detectors; docs/detectors.md)")
    p.add_argument("--no-upper-bound", action="store_true",
                   help="skip the exact-geometry rows (each test positive adapted through its "
                        "own rendered correspondences; HOG detectors, needs depth maps and the "
                        "plane among --object-models, whose adapted negatives they share)")
    p.set_defaults(func=cmd_crossval)

    p = bsub.add_parser("sweep", parents=[common, data_opts],
                        help="robustness to a wrong elevation estimate (Fig. 6)",
                        description=importlib.import_module("benchmark.crops.sweep").__doc__,
                        formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--detector", default="hog", metavar="DETECTOR",
                   help="hog (default), hog_local, acf, opencv or package.module:Object "
                        "(docs/detectors.md)")
    p.add_argument("--source", type=float, default=0.0, help="training elevation (default 0)")
    p.add_argument("--step", type=float, default=np.pi / 72,
                   help="grid step of estimated elevations, radians (default pi/72)")
    p.add_argument("--sigma", type=float, default=0.1,
                   help="std of the elevation prior for the uncertain-elevation curve "
                        "(radians; 0 disables it; default 0.1)")
    p.set_defaults(func=cmd_sweep)

    p = sub.add_parser("report", help="(re)write report.md of a results directory")
    p.add_argument("results", type=Path, help="results directory of `viewadapt bench`")
    p.set_defaults(func=cmd_report)
