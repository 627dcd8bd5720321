"""What a detector's errors on a real clip are: ``python -m benchmark.studies.footage_errors``.

Reads the detections ``viewadapt bench footage`` stored (``detections.json``) and the
clip's ground truth, and sorts each method's errors at the operating points asked for
(:mod:`benchmark.footage.errors`, which ``bench footage`` itself writes at 0.1 and 1 FPPI):
misses of persons with a neighbour and alone and by box height; false positives as
localisation errors, duplicates and background.

Writes ``errors.md``, ``errors.csv`` and ``error_map.jpg`` (per method, every counted
person's foot point on the clip's first frame, found or missed, and the false positives'
foot points, at the last operating point; at most 640 px wide) under ``--out``. (Runs
before 2026-12-05 stored scores rounded to three decimals, so a LAMR read back from them
can differ from the run's in the fourth.)
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from benchmark.footage.errors import clip_errors, error_lines, map_grid

__all__ = ["main"]

def main(argv=None) -> int:
    import cv2
    import pandas as pd

    from benchmark.footage.run import add_clip_arguments, open_clip, stored_detections
    from viewadapt.io.files import atomic_output_dir, check_output_dir, run_metadata

    ap = argparse.ArgumentParser(prog="python -m benchmark.studies.footage_errors",
                                 description=__doc__.split("\n\n")[1])
    add_clip_arguments(ap)
    ap.add_argument("--detections", type=Path, required=True,
                    help="a bench footage output folder, or its detections.json")
    ap.add_argument("--methods", nargs="+", default=None,
                    help="methods to look at (default: every one in the file)")
    ap.add_argument("--fppi", type=float, nargs="+", default=[0.1, 1.0],
                    help="operating points, false positives per image (default 0.1 1)")
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args(argv)
    path = args.detections / "detections.json" if args.detections.is_dir() else args.detections
    try:
        stored = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        ap.error(f"cannot read detections from {path}: {exc}")
    methods = args.methods or list(stored)
    unknown = [m for m in methods if m not in stored]
    if unknown:
        ap.error(f"{path} has no detections of {', '.join(unknown)} "
                 f"(it has {', '.join(stored)})")
    if any(not np.isfinite(f) or f <= 0 for f in args.fppi):
        ap.error(f"--fppi must be positive, got {args.fppi}")
    check_output_dir(args.out)
    clip = open_clip(args.inputs, args.calibration, args.boxes, args.ignore)
    size = clip.camera.image_size
    keys = list(stored[methods[0]])                 # the run's frames, in its order
    truth = clip.stored_truth(keys)
    first = next(iter(clip.stream)).image
    results, maps = {}, []
    for m in methods:
        results[m], view = clip_errors(first, stored_detections(stored[m], keys), truth, size,
                                       regions=clip.regions, fppis=args.fppi,
                                       title=f"{m} @ {args.fppi[-1]:g} FPPI")
        maps.append(view)
    lines = error_lines(results, args.fppi)
    rows = [dict(method=m, fppi=f, **{k: v for k, v in r.items() if k != "height_bands"})
            for m, per in results.items() for f, r in per.items()]
    with atomic_output_dir(args.out) as tmp:
        (tmp / "errors.md").write_text("\n".join(lines) + "\n")
        pd.DataFrame(rows).to_csv(tmp / "errors.csv", index=False, float_format="%.5f")
        cv2.imwrite(str(tmp / "error_map.jpg"), cv2.cvtColor(map_grid(maps), cv2.COLOR_RGB2BGR),
                    [cv2.IMWRITE_JPEG_QUALITY, 85])
        (tmp / "run.json").write_text(json.dumps(run_metadata(
            0, inputs=[str(p) for p in args.inputs], detections=str(path), methods=methods,
            fppi=args.fppi), indent=2, default=str))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
