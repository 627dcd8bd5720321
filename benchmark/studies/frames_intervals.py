"""Bootstrap intervals for a ``bench frames`` run: each method's log-average miss rate and
its paired difference from a reference method, resampling frames.

``python -m benchmark.studies.frames_intervals RESULTS --data DATA [--reference hog_adapted]``
reads ``RESULTS/detections.json`` (the detections of every method on every frame) and the
frames' ground truth from ``DATA``, draws frames with replacement (the same draw for every
method, so the differences are paired) and writes ``RESULTS/frames_intervals.csv`` and
``.md``: per method the LAMR on all frames, its 95 % percentile interval, and the interval
of ``method - reference`` on the same draws. Frames are the resampling unit because the
persons of one frame share its camera and scene.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pandas as pd

from benchmark.studies import report_error

__all__ = ["frame_bootstrap", "main"]


def frame_bootstrap(detections: dict, frames, *, reference: str, n_boot: int = 1000,
                    seed: int = 0) -> pd.DataFrame:
    """Per method: LAMR, its 95 % interval over frame resamples and the paired interval of
    its difference from ``reference``.

    Parameters
    ----------
    detections : dict method -> list of (D, 5) arrays, one per frame of ``frames``
    frames : list of :class:`benchmark.frames.methods.FrameRecord`
    reference : str
        A key of ``detections``.
    """
    from benchmark.frames.phases import frame_matches, matches_lamr

    if reference not in detections:
        raise ValueError(f"reference method {reference!r} is not among {list(detections)}")
    if n_boot < 1:
        raise ValueError(f"n_boot must be at least 1, got {n_boot}")
    for m, d in detections.items():
        if len(d) != len(frames):
            raise ValueError(f"{m} has detections for {len(d)} frames, the data {len(frames)}")
    rng = np.random.default_rng(seed)
    draws = rng.integers(len(frames), size=(n_boot, len(frames)))
    matches = {m: frame_matches(d, frames) for m, d in detections.items()}   # once per frame

    def lamr(m, idx):
        return matches_lamr([matches[m][i] for i in idx])

    boot = {m: np.array([lamr(m, idx) for idx in draws]) for m in detections}
    rows = []
    for m in detections:
        diff = boot[m] - boot[reference]
        rows.append({"method": m, "lamr": lamr(m, range(len(frames))),
                     "ci_low": float(np.percentile(boot[m], 2.5)),
                     "ci_high": float(np.percentile(boot[m], 97.5)),
                     "reference": reference,
                     "diff": lamr(m, range(len(frames))) - lamr(reference, range(len(frames))),
                     "diff_low": float(np.percentile(diff, 2.5)),
                     "diff_high": float(np.percentile(diff, 97.5))})
    return pd.DataFrame(rows)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmark.studies.frames_intervals",
                                 description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("results", type=Path, help="a `viewadapt bench frames` output directory")
    ap.add_argument("--data", type=Path, required=True, help="the dataset it ran on")
    ap.add_argument("--reference", default="hog_adapted", help="method the differences are "
                    "taken against (default hog_adapted)")
    ap.add_argument("--boot", type=int, default=1000, help="resamples (default 1000)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    from benchmark.frames.methods import load_frames

    try:
        path = args.results / "detections.json"
        if not path.is_file():
            raise ValueError(f"{args.results} holds no detections.json (not a bench frames run)")
        stored = json.loads(path.read_text())
        frames = load_frames(args.data)
        key = {f"{f.path.name}@{f.scene_id}": f for f in frames}
        names = list(next(iter(stored.values())))
        missing = [n for n in names if n not in key]
        if missing:
            raise ValueError(f"{args.data} lacks the frames {missing[:3]} of this run")
        order = [key[n] for n in names]
        dets = {m: [np.asarray(d[n], float).reshape(-1, 5) for n in names]
                for m, d in stored.items()}
        tab = frame_bootstrap(dets, order, reference=args.reference, n_boot=args.boot,
                              seed=args.seed)
    except (ValueError, FileNotFoundError) as exc:
        return report_error(ap, exc)
    tab.to_csv(args.results / "frames_intervals.csv", index=False, float_format="%.4f")
    lines = [f"{len(order)} frames, {sum(len(f.gt) for f in order)} persons; 95 % intervals "
             f"over {args.boot} frame resamples; differences paired on the same draws", "",
             f"| method | LAMR | interval | − {args.reference} | interval |",
             "|---|---|---|---|---|"]
    for _, r in tab.iterrows():
        lines.append(f"| {r['method']} | {r['lamr']:.3f} | {r['ci_low']:.3f}–{r['ci_high']:.3f}"
                     f" | {r['diff']:+.3f} | {r['diff_low']:+.3f}…{r['diff_high']:+.3f} |")
    (args.results / "frames_intervals.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
