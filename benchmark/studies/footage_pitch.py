"""How wrong may a real camera's calibration be: ``python -m benchmark.studies.footage_pitch``.

The real-footage counterpart of the robustness sweep (Wang et al. 2017, Fig. 6;
``viewadapt bench sweep`` on crops): the clip's camera is turned about its own x axis by
``delta`` (its centre, intrinsics and lens kept), so that it looks ``delta`` radians more
steeply down than calibrated (the tilt change is measured and reported), and the adapted
detectors run on the clip with that wrong calibration -- their windows placed, sized and
adapted from it, as ``detect`` would with a camera whose tilt was misestimated. Each
method's LAMR (Caltech protocol, 95 % block-bootstrap intervals over frames) per error, the
paired difference against the same method with the calibration as given, and against an
unadapted baseline that reads no calibration (default ``hog_pyramid``) on the same frames.

Writes ``pitch.csv``, ``pitch.md`` and ``pitch.png`` under ``--out``.
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

import numpy as np

from viewadapt.camera.calibrate import camera_height_and_tilt

from benchmark.studies import report_error

__all__ = ["pitched", "main"]

_METHODS = ("hog_adapted", "hog_adapted[paper eq.3]", "hog_adapted[S only]")
_ERRORS = (-0.2, -0.1, -0.05, 0.0, 0.05, 0.1, 0.2, 0.3)


def pitched(camera, delta: float):
    """``camera`` turned about its own x axis by ``delta`` radians, down for ``delta > 0``
    (its centre, ``K`` and image size kept): ``R' = R_x R``, ``t' = -R' C``."""
    c, s = np.cos(delta), np.sin(delta)
    Rx = np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    R = Rx @ np.asarray(camera.R, float)
    return replace(camera, R=R, t=-R @ camera.center)


def _tilt(camera) -> float:
    """The optical axis' angle below the horizontal, radians."""
    return float(np.radians(camera_height_and_tilt(camera.R, camera.t)[1]))


def _plot(rows, base_name, base_lamr, tilt, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4))
    for m in dict.fromkeys(r["method"] for r in rows):
        r = sorted((x for x in rows if x["method"] == m), key=lambda x: x["tilt_error"])
        e = [x["tilt_error"] for x in r]
        ax.errorbar(e, [x["lamr"] for x in r],
                    yerr=[[x["lamr"] - x["lamr_low"] for x in r],
                          [x["lamr_high"] - x["lamr"] for x in r]],
                    marker="o", ms=3, capsize=2, lw=1.2, label=m)
    ax.axhline(base_lamr, color="#c0392b", lw=1, label=f"{base_name} ({base_lamr:.3f})")
    ax.axvline(0, color="0.4", ls=":", lw=1)
    ax.set_xlabel(f"tilt error (rad; calibrated tilt {tilt:.3f} rad, > 0: assumed steeper)")
    ax.set_ylabel("LAMR (10⁻²…10⁰ FPPI)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=150)
    plt.close(fig)


def main(argv=None) -> int:
    import csv

    from benchmark.footage.run import add_clip_arguments, open_clip, run_footage
    from benchmark.frames.spec import FrameMethod
    from viewadapt.detect.evaluation import (
        evaluation_matches, matches_bootstrap, matches_lamr, paired_matches_bootstrap,
        summary_numbers,
    )
    from viewadapt.metrics import accumulate_frames
    from viewadapt.io import SourceDetectors
    from viewadapt.io.files import atomic_output_dir, check_output_dir
    from viewadapt.io.models import shipped_model_path

    ap = argparse.ArgumentParser(prog="python -m benchmark.studies.footage_pitch",
                                 description=__doc__.split("\n\n")[1])
    add_clip_arguments(ap)
    ap.add_argument("--model", type=Path, default=None,
                    help="source detectors (default: the shipped file)")
    ap.add_argument("--methods", nargs="+", default=list(_METHODS),
                    help=f"adapted methods (default {' '.join(_METHODS)})")
    ap.add_argument("--baseline", default="hog_pyramid",
                    help="a method that reads no calibration (default hog_pyramid)")
    ap.add_argument("--errors", type=float, nargs="+", default=list(_ERRORS),
                    help="tilt errors, rad (default %(default)s)")
    ap.add_argument("--heights", type=float, nargs="+", default=[1.75])
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args(argv)
    try:
        methods = [FrameMethod.parse(m) for m in args.methods]
        base = FrameMethod.parse(args.baseline)
        if not base.how.startswith("pyramid") or base.ground:
            raise ValueError(f"--baseline {args.baseline!r} reads the calibration; give an "
                             "unfiltered pyramid")
        if any(m.how not in ("adapted", "warp") for m in methods):
            raise ValueError("--methods takes adapted or warping methods (they read the "
                             "calibration)")
        if not all(-0.6 <= e <= 0.6 for e in args.errors):
            raise ValueError("--errors must lie in [-0.6, 0.6] rad")
        check_output_dir(args.out)
        models = SourceDetectors.load(args.model or shipped_model_path())
        clip0 = open_clip(args.inputs, args.calibration, args.boxes, args.ignore)
    except (ValueError, OSError) as exc:
        return report_error(ap, exc)
    size = clip0.camera.image_size
    tilt = _tilt(clip0.camera)

    def matched(run, m):
        return evaluation_matches(run.detections[m], run.truth, size, regions=clip0.regions)[0]

    base_run = run_footage(clip0, [base], None if not base.needs_training else models,
                           heights=args.heights)
    mb = matched(base_run, base)
    base_lamr = matches_lamr(mb)
    errors = sorted(set(args.errors) | {0.0})
    runs = {}
    for e in errors:                    # the clip read once, its camera pitched per error
        clip = replace(clip0, camera=pitched(clip0.camera, e)) if e else clip0
        run = run_footage(clip, methods, models, heights=args.heights)
        runs[e] = ({m: matched(run, m) for m in methods}, _tilt(clip.camera) - tilt,
                   {m: run.n_frames / max(run.seconds[m], 1e-9) for m in methods})
        print(f"tilt error {e:+.2f}: " + ", ".join(f"{m.name} {matches_lamr(ms):.3f}"
                                                   for m, ms in runs[e][0].items()), flush=True)
    rows = []
    for e in errors:
        ms, dt, fps = runs[e]
        for m in methods:
            ci = matches_bootstrap(ms[m])
            own = paired_matches_bootstrap(ms[m], runs[0.0][0][m]) if e else \
                {"difference": 0.0, "ci": (0.0, 0.0)}           # the calibrated run itself
            vs = paired_matches_bootstrap(ms[m], mb)
            numbers = summary_numbers(*accumulate_frames(ms[m])[:2])
            rows.append({"method": m.name, "tilt_error": e, "tilt_change": dt,
                         "lamr": matches_lamr(ms[m]), "lamr_low": ci["lamr"][0],
                         "lamr_high": ci["lamr"][1],
                         "mr_at_0.1_fppi": numbers["miss_rate_at_0.1_fppi"],
                         "mr_at_1_fppi": numbers["miss_rate_at_1_fppi"],
                         "minus_calibrated": own["difference"],
                         "minus_calibrated_low": own["ci"][0],
                         "minus_calibrated_high": own["ci"][1],
                         "minus_baseline": vs["difference"], "minus_baseline_low": vs["ci"][0],
                         "minus_baseline_high": vs["ci"][1], "fps": fps[m]})
    lines = [f"# Adapted detectors under a wrong camera tilt: {args.calibration}", "",
             f"{base_run.n_frames} frames; calibrated tilt {tilt:.3f} rad; unadapted baseline "
             f"`{base.name}` (reads no calibration) LAMR {base_lamr:.3f}. Intervals: 95 %, "
             "circular block bootstrap over 10-frame blocks; differences paired.", "",
             "| method | tilt error (rad) | LAMR | MR @ 0.1 FPPI | MR @ 1 FPPI | − calibrated | "
             "− baseline |", "|---|---|---|---|---|---|---|"]

    def iv(r, k):
        return f"{r[k]:+.3f} ({r[k + '_low']:+.3f}…{r[k + '_high']:+.3f})"

    for r in rows:
        lines.append(f"| {r['method']} | {r['tilt_error']:+.2f} | {r['lamr']:.3f} "
                     f"({r['lamr_low']:.3f}–{r['lamr_high']:.3f}) | {r['mr_at_0.1_fppi']:.3f} | "
                     f"{r['mr_at_1_fppi']:.3f} | {iv(r, 'minus_calibrated')} | "
                     f"{iv(r, 'minus_baseline')} |")
    with atomic_output_dir(args.out) as tmp:
        with open(tmp / "pitch.csv", "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
        (tmp / "pitch.md").write_text("\n".join(lines) + "\n")
        _plot(rows, base.name, base_lamr, tilt, tmp / "pitch.png")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
