"""How well persons and backgrounds separate when a crop is read through a frame.

    python -m benchmark.studies.frameview_separation --data DIR --model A.npz [--model B.npz ...]
        [--scales 0.3,0.45,0.7,1.0] [--seed 0]

A pure-scale test: no perspective, only the resolution and the frame's cell grid. Each
elevation-0 person crop and background window of ``--data`` is shrunk into a small frame
(:func:`viewadapt.detect.frame_view`: ``scale`` frame pixels per canonical pixel, random
offset against the cell grid) and scored two ways with each model's HOG/SVM:

* adapted: the cells the full-frame operator reads, remapped by ``G``
  (:func:`viewadapt.detect.frame_view_features`);
* warped: the window warped back to 64x128 and featurised (image warping).

Printed per scale: ``d' = (mean person score - mean background score) / background sd``.
Models come from ``viewadapt bench frames`` (``OUT/models/source_detectors.npz``), e.g. one
trained with the default ``--frame-view hog`` and one with ``--frame-view none``. Use crops
the models were not trained on. Not a test.
"""

from __future__ import annotations

import argparse

import numpy as np

from benchmark.studies import report_error


def separation(data, models: dict, scales, *, seed: int = 0) -> list:
    """Rows ``(scale, model name, "adapted" | "warped", d')``."""
    from benchmark.data import load_dataset
    from benchmark.crops.features import background_windows, person_windows
    from viewadapt.detect import frame_view, frame_view_features
    from viewadapt.detect import hog_window_features
    from viewadapt.warp import warp_to_source_view

    ds = load_dataset(data)
    pos = list(person_windows(ds, 0).images(ds.root))
    neg = list(background_windows(ds, 0, stride=32).images(ds.root))
    if not pos or not neg:
        raise ValueError(f"{data} has no elevation-0 person crops or backgrounds")
    is_pos = np.r_[np.ones(len(pos), bool), np.zeros(len(neg), bool)]
    rng = np.random.default_rng(seed)
    rows = []
    for s in scales:
        offsets = [tuple(int(v) for v in rng.integers(0, 8, 2)) for _ in range(len(is_pos))]
        A, W = [], []
        for w, o in zip(pos + neg, offsets):
            A.append(frame_view_features(w, s, offset=o).ravel())
            frame, H = frame_view(w, s, offset=o)
            W.append(hog_window_features(warp_to_source_view(frame, H)).ravel())
        for name, m in models.items():
            for how, X in (("adapted", np.stack(A)), ("warped", np.stack(W))):
                sc = X @ np.ravel(m.hog_weights) + m.hog_bias
                p, n = sc[is_pos], sc[~is_pos]
                rows.append((s, name, how, float((p.mean() - n.mean()) / n.std())))
    return rows


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmark.studies.frameview_separation",
                                description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", required=True, help="dataset directory (crops, backgrounds)")
    p.add_argument("--model", action="append", required=True,
                   help="source_detectors.npz from `viewadapt bench frames` (repeatable)")
    p.add_argument("--scales", default="0.3,0.45,0.7,1.0",
                   help="frame px per canonical px, comma-separated (default 0.3,0.45,0.7,1.0)")
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args(argv)
    from viewadapt.io import SourceDetectors

    try:
        scales = [float(v) for v in args.scales.split(",")]
        if not all(np.isfinite(v) and v > 0 for v in scales):
            raise ValueError
    except ValueError:
        p.error(f"--scales must be positive numbers, got {args.scales!r}")
    try:
        models = {m: SourceDetectors.load(m) for m in args.model}
        rows = separation(args.data, models, scales, seed=args.seed)
    except (OSError, ValueError) as e:
        return report_error(p, e)
    print("| scale | model | adapted d' | warped d' |\n|---|---|---|---|")
    for s in scales:
        for name in models:
            d = {how: v for s_, n_, how, v in rows if s_ == s and n_ == name}
            print(f"| {s:g} | {name} | {d['adapted']:.2f} | {d['warped']:.2f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
