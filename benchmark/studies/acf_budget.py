"""ACF's training budget and channels: ``python -m benchmark.studies.acf_budget``.

Two hypotheses for why the ACF source detector trained on renders transfers worse to real
footage than the HOG/SVM trained on the same windows:

* its budget: ``bench frames`` trains 256 depth-2 trees
  (:func:`viewadapt.detect.training.acf_trees`), the toolbox's INRIA detector 2048
  (``nWeak``, Dollár et al. 2014);
* its colour channels: the LUV channels of rendered clothing and skin are not those of
  real people, and the trees may rely on them.

On the windows ``bench frames`` trains on
(:func:`benchmark.frames.methods.source_training_windows`,
:func:`viewadapt.detect.training.window_training_set`, the same seeds), the trees are trained once
with ``max(--trees)`` trees (fewer if the training loss reaches zero first, as
:class:`~viewadapt.boosting.AdaBoostTrees` stops) and saved truncated to each of
``--trees``: the first ``n`` trees of a longer run are the trees a run of ``n`` trains, so
the 256-tree model is that of ``bench frames --recipe elevation0``. ``--no-colour`` zeroes
the three LUV channels of every training window (a constant feature is never split on; at
detection the trees do not read them). The HOG/SVM is trained too, as ``bench frames``
trains it under the ``elevation0`` recipe, so that each model file is complete.

Writes ``trees_N/source_detectors.npz`` per budget and ``acf_budget.json`` (the budgets,
the trees trained, the final training loss) into ``--out``; compare the models on a real
clip with :mod:`benchmark.studies.footage_models`.
"""

from __future__ import annotations

import argparse
import json
from dataclasses import replace
from pathlib import Path

import numpy as np

__all__ = ["truncated_trees", "main"]

#: The ACF channels that carry colour: the first three (LUV) of ten per cell.
COLOUR_CHANNELS = 3


def truncated_trees(trees, n: int):
    """A copy of trained :class:`~viewadapt.boosting.AdaBoostTrees` keeping its first
    ``n`` trees (``n`` at most the trees it has)."""
    import copy

    if not 1 <= n <= trees.n_estimators_:
        raise ValueError(f"cannot keep {n} of {trees.n_estimators_} trees")
    out = copy.deepcopy(trees)
    out.n_estimators = out.n_estimators_ = int(n)
    for name in ("feature_", "threshold_", "value_", "train_loss_"):
        setattr(out, name, getattr(trees, name)[:n].copy())
    return out


def main(argv=None) -> int:
    from benchmark.data import load_dataset
    from benchmark.frames.methods import dataset_provenance, source_training_windows
    from benchmark.recipes import PAPER_RECIPE, get_recipe
    from viewadapt.detect import ACF_DETECTOR, train_on_windows
    from viewadapt.detect.training import acf_trees, window_training_set
    from viewadapt.io.files import atomic_output_dir, check_output_dir

    ap = argparse.ArgumentParser(prog="python -m benchmark.studies.acf_budget",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, required=True, help="a generated dataset")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--trees", default="256,512,1024,2048",
                    help="comma-separated tree budgets (default 256,512,1024,2048)")
    ap.add_argument("--no-colour", action="store_true",
                    help="zero the LUV channels of every training window")
    ap.add_argument("--learning-rate", type=float, default=1.0, metavar="NU",
                    help="shrinkage of every tree's outputs, in (0, 1] (default 1: plain "
                    "AdaBoost, as bench frames trains)")
    ap.add_argument("--depth", type=int, default=2,
                    help="depth of every tree (default 2, as bench frames and the toolbox)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--quick", action="store_true", help="smaller detectors (tests)")
    args = ap.parse_args(argv)
    try:
        budgets = sorted({int(v) for v in args.trees.split(",")})
    except ValueError:
        ap.error(f"--trees must be comma-separated integers, got {args.trees!r}")
    if budgets[0] < 1:
        ap.error(f"every tree budget must be at least 1, got {args.trees!r}")
    if not 1 <= args.depth <= 8:
        ap.error(f"--depth must be 1 to 8, got {args.depth!r}")
    if not 0.0 < args.learning_rate <= 1.0:
        ap.error(f"--learning-rate must be in (0, 1], got {args.learning_rate!r}")
    check_output_dir(args.out)
    ds = load_dataset(args.data)
    pos, neg = source_training_windows(ds, PAPER_RECIPE)
    # the HOG/SVM as bench frames trains it under the paper's training (so that each model
    # file is complete); the trees below are the study's, trained once
    base = train_on_windows(pos, neg, seed=args.seed, quick=args.quick, acf_members=0)
    X, y = window_training_set(ACF_DETECTOR, pos, neg, seed=args.seed + 2)
    if args.no_colour:
        per_channel = X.shape[1] // ACF_DETECTOR.features.shape[0]   # channel-major
        X[:, :COLOUR_CHANNELS * per_channel] = 0
    trees = acf_trees(seed=args.seed, quick=args.quick, n_estimators=budgets[-1],
                      learning_rate=args.learning_rate, max_depth=args.depth).fit(X, y)
    kept = [b for b in budgets if b <= trees.n_estimators_]
    if trees.n_estimators_ not in kept:
        kept.append(trees.n_estimators_)
    training = dict(base.training, recipe=get_recipe(PAPER_RECIPE).to_dict(),
                    dataset=dataset_provenance(ds),
                    acf_budget=dict(no_colour=args.no_colour, trained=trees.n_estimators_,
                                   learning_rate=args.learning_rate, depth=args.depth))
    with atomic_output_dir(args.out) as tmp:
        for n in kept:
            model = replace(base, acf=truncated_trees(trees, n),
                            training=dict(training, acf_trees=n))
            (tmp / f"trees_{n}").mkdir()
            model.save(tmp / f"trees_{n}" / "source_detectors.npz")
        (tmp / "acf_budget.json").write_text(json.dumps(dict(
            budgets=budgets, saved=kept, trained=int(trees.n_estimators_),
            final_train_loss=float(np.asarray(trees.train_loss_)[-1]),
            no_colour=args.no_colour, learning_rate=args.learning_rate, depth=args.depth,
            seed=args.seed, positives=int(y.sum()),
            negatives=int((y == 0).sum())), indent=1) + "\n")
    print(f"trained {trees.n_estimators_} trees (asked {budgets[-1]}); wrote "
          f"{', '.join(f'trees_{n}' for n in kept)} into {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
