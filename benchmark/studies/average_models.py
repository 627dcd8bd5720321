"""Average source-detector files: ``python -m benchmark.studies.average_models A B ... --out M``.

Models trained on renders of other seeds (``bench frames --data DS_s --recipe R``, one per
render) differ in what the draw of each render gave them; their average
(:func:`viewadapt.ensembles.average_source_detectors`: the HOG/SVMs' weights averaged, the
ACF models averaged tree by tree) removes that part of the error, as averaging training
seeds does within one render (docs/training.md points 38 and 41). Writes one
``source_detectors.npz`` (``--out``, a new file) whose training record lists every
member's; ``viewadapt detect --model`` and ``bench footage --model`` read it as any other.
The ACF models are split into the boosted models each averages and the first of them
gates the others (:func:`viewadapt.ensembles.average_trees`' ``gate``), so that a window it
rejects costs one model's trees instead of all of them; ``--plain`` interleaves them all
instead (the same mean, every tree for every window the cascade does not stop).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from benchmark.studies import report_error

__all__ = ["main"]


def main(argv=None) -> int:
    from viewadapt.ensembles import average_source_detectors
    from viewadapt.io import SourceDetectors

    ap = argparse.ArgumentParser(prog="python -m benchmark.studies.average_models",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("models", type=Path, nargs="+", help="source_detectors.npz files (two or more)")
    ap.add_argument("--out", type=Path, required=True, help="the averaged model file to write")
    ap.add_argument("--plain", action="store_true",
                    help="no gate: every member's trees interleaved (the same mean, more "
                         "trees per window)")
    args = ap.parse_args(argv)
    if len(args.models) < 2:
        ap.error("give at least two model files")
    if args.out.exists():
        ap.error(f"{args.out} exists; choose a new file")
    try:
        models = [SourceDetectors.load(p) for p in args.models]
        avg = average_source_detectors(models, gate=not args.plain)
    except (ValueError, FileNotFoundError) as exc:
        return report_error(ap, exc)
    avg.training["average_of_files"] = [str(p) for p in args.models]
    avg.save(args.out)
    print(f"averaged {len(models)} models ({avg.acf.n_estimators_} trees) into {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
