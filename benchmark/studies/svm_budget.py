"""The HOG/SVM's regularisation and negatives: ``python -m benchmark.studies.svm_budget``.

The hypothesis under test: a source detector trained on renders alone fits what separates
rendered persons from rendered backgrounds, details real footage does not share, and a
more strongly regularised SVM (smaller ``C``) transfers better; or that the hard-negative
round leaves out negatives that matter. The models are trained as ``bench frames`` trains
them under the paper's training (:func:`benchmark.frames.methods.train_source_detectors`,
recipe ``elevation0``: the same windows, seeds, frame-view copies and boosted trees) with
the SVM's ``C`` (default Dalal & Triggs' 0.01)
and, with ``--all-negatives``, every negative window from the start and no mining round
(:func:`viewadapt.detect.training.hog_svm`).

Writes ``source_detectors.npz`` (its training record names the SVM's parameters) into
``--out``; compare models on a real clip with :mod:`benchmark.studies.footage_models`.
"""

from __future__ import annotations

import argparse
from pathlib import Path

__all__ = ["main"]


def main(argv=None) -> int:
    from benchmark.data import load_dataset
    from benchmark.frames.methods import train_source_detectors
    from benchmark.recipes import PAPER_RECIPE
    from viewadapt.io.files import atomic_output_dir, check_output_dir

    ap = argparse.ArgumentParser(prog="python -m benchmark.studies.svm_budget",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, required=True, help="a generated dataset")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--C", type=float, default=0.01, dest="C",
                    help="the SVM's regularisation (default 0.01)")
    ap.add_argument("--all-negatives", action="store_true",
                    help="train on every negative window at once, no hard-negative round")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--quick", action="store_true", help="smaller detectors (tests)")
    args = ap.parse_args(argv)
    if not 0 < args.C < float("inf"):
        ap.error(f"--C must be positive, got {args.C}")
    check_output_dir(args.out)
    params = {"C": args.C}
    if args.all_negatives:
        params.update(initial_negatives=2**62, mining_rounds=0)
    models = train_source_detectors(load_dataset(args.data), seed=args.seed, quick=args.quick,
                                    svm_params=params, recipe=PAPER_RECIPE)
    with atomic_output_dir(args.out) as tmp:
        models.save(tmp / "source_detectors.npz")
    print(f"trained with {params}; wrote {args.out / 'source_detectors.npz'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
