"""Source models compared on one real clip, paired: ``python -m benchmark.studies.footage_models``.

Runs the same methods (default: adapted HOG and ACF) with each of several source-detector
files (``SourceDetectors``, e.g. ``models/source_detectors.npz`` of ``bench frames`` runs
trained under different recipes or on different renders) on one calibrated, annotated
clip, as ``viewadapt bench footage`` runs them, and writes each (model, method)'s LAMR with
its block-bootstrap interval and, for every model after the first, the paired LAMR
difference from the first model's same method (the same resampled blocks of frames:
:func:`viewadapt.detect.evaluation.paired_groups_bootstrap`). A label may name several
files (``LABEL=A,B,C``: the same training at several seeds, whose spread on a real clip
can be as large as a recipe's effect); it is then compared by its mean LAMR, with the
lowest and highest beside it.

Writes ``models_summary.md``, ``models_summary.csv`` and ``run.json`` under ``--out``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

__all__ = ["compare_models", "main"]


def compare_models(clip, models: dict, methods, *, heights, block: int = 10,
                   seed: int = 0) -> list[dict]:
    """One row per (model label, method): LAMR, its interval and, for every model after
    the first, the paired difference from the first model's same method.

    ``models`` maps a label to a loaded :class:`viewadapt.io.SourceDetectors`, or to a list
    of them (e.g. one per training seed): a label's LAMR is then the mean over its models,
    ``lamr_low``/``lamr_high`` the lowest and highest of them (the spread over seeds, not
    an interval), and its difference from the first label is that of the means, with a
    block-bootstrap interval over frames. The clip is read once per model (frames in the
    same order each time).
    """
    from benchmark.footage.run import run_footage
    from viewadapt.detect.evaluation import (
        evaluation_matches, matches_lamr, matches_summary, paired_groups_bootstrap,
    )

    size = clip.camera.image_size
    groups = {label: (list(m) if isinstance(m, (list, tuple)) else [m])
              for label, m in models.items()}
    runs = {label: [run_footage(clip, methods, m, heights=heights) for m in ms]
            for label, ms in groups.items()}
    first = next(iter(runs))
    truth = runs[first][0].truth
    keys = runs[first][0].keys
    if any(run.keys != keys for group in runs.values() for run in group):  # pragma: no cover
        raise RuntimeError("the clip's frames were read in another order")
    rows = []
    for m in methods:
        matched = {label: [evaluation_matches(run.detections[m], truth, size,
                                              regions=clip.regions) for run in group]
                   for label, group in runs.items()}
        matches = {label: [mt for mt, _ in group] for label, group in matched.items()}
        for label, group in runs.items():
            fps = [run.n_frames / run.seconds[m] if run.seconds[m] else float("inf")
                   for run in group]
            if len(group) == 1:                      # one model: LAMR with its interval
                ev = matches_summary(*matched[label][0], block=block, seed=seed)[0]
                row = {"model": label, "method": m.name, "models": 1, "lamr": ev["lamr"],
                       "lamr_low": ev["lamr_ci95"][0], "lamr_high": ev["lamr_ci95"][1],
                       "fps": fps[0]}
            else:                                    # several: their mean and spread
                lamrs = [matches_lamr(ms) for ms in matches[label]]
                row = {"model": label, "method": m.name, "models": len(group),
                       "lamr": float(np.mean(lamrs)), "lamr_low": min(lamrs),
                       "lamr_high": max(lamrs), "fps": float(np.median(fps)),
                       "lamr_each": " ".join(f"{v:.3f}" for v in lamrs)}
            if label != first:
                d = paired_groups_bootstrap(matches[label], matches[first], block=block,
                                            seed=seed)
                row.update(reference=first, difference=d["difference"],
                           difference_low=d["ci"][0], difference_high=d["ci"][1])
            rows.append(row)
    return rows


def _lines(rows, first) -> list[str]:
    out = ["| model | method | LAMR (95 %; of several models: their mean (lowest–highest)) "
           "| − " + first + " (paired 95 %, over frames) | frames/s |",
           "|---|---|---|---|---|"]
    for r in rows:
        diff = (f"{r['difference']:+.3f} ({r['difference_low']:+.3f}…{r['difference_high']:+.3f})"
                if "difference" in r else "–")
        n = f" [{r['models']} models]" if r["models"] > 1 else ""
        out.append(f"| {r['model']}{n} | {r['method']} | {r['lamr']:.3f} ({r['lamr_low']:.3f}–"
                   f"{r['lamr_high']:.3f}) | {diff} | {r['fps']:.1f} |")
    return out


def main(argv=None) -> int:
    import pandas as pd

    from benchmark.footage.run import add_clip_arguments, open_clip
    from benchmark.frames.spec import FrameMethod
    from viewadapt.geometry import PERSON_HEIGHT_M
    from viewadapt.io import SourceDetectors
    from viewadapt.io.files import atomic_output_dir, check_output_dir, run_metadata

    ap = argparse.ArgumentParser(prog="python -m benchmark.studies.footage_models",
                                 description=__doc__.split("\n\n")[1])
    add_clip_arguments(ap)
    ap.add_argument("--model", action="append", required=True, metavar="LABEL=FILE[,FILE...]",
                    help="a source-detector file and its label, or several files (e.g. one "
                         "per training seed) compared by their mean LAMR; the first label "
                         "is the reference")
    ap.add_argument("--methods", nargs="+", default=["hog_adapted", "acf_adapted"])
    ap.add_argument("--every", type=int, default=1)
    ap.add_argument("--block", type=int, default=10, help="bootstrap block, frames")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args(argv)
    models, paths = {}, {}
    for item in args.model:
        label, sep, path = item.partition("=")
        files = [p for p in path.split(",") if p]
        if not sep or not label or not files:
            ap.error(f"--model must be LABEL=FILE[,FILE...], got {item!r}")
        if label in models:
            ap.error(f"--model label {label!r} given twice")
        paths[label] = files
        models[label] = [SourceDetectors.load(Path(p)) for p in files]
    check_output_dir(args.out)
    methods = [FrameMethod.parse(m) for m in args.methods]
    clip = open_clip(args.inputs, args.calibration, args.boxes, args.ignore,
                     every=args.every)
    rows = compare_models(clip, models, methods, heights=(PERSON_HEIGHT_M,),
                          block=args.block, seed=args.seed)
    lines = _lines(rows, next(iter(models)))
    with atomic_output_dir(args.out) as tmp:
        (tmp / "models_summary.md").write_text("\n".join(lines) + "\n")
        pd.DataFrame(rows).to_csv(tmp / "models_summary.csv", index=False,
                                  float_format="%.5f")
        (tmp / "run.json").write_text(json.dumps(run_metadata(
            args.seed, inputs=[str(p) for p in args.inputs], models={
                label: [{"path": p, "training": m.training}
                        for p, m in zip(paths[label], models[label])]
                for label in models},
            methods=args.methods, every=args.every, block=args.block), indent=2,
            default=str))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
