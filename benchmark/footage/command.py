"""``viewadapt bench footage``: every method on a user's calibrated, annotated clip."""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from benchmark.footage.errors import ERROR_FPPIS, clip_errors, error_lines, map_grid
from benchmark.footage.phases import phase_lines, phase_summary, run_phases
from benchmark.footage.report import evaluate_run, paired_differences, summary_lines, summary_rows
from benchmark.footage.run import FOOTAGE_METHODS, open_clip, run_footage
from benchmark.frames.phases import frame_shifts, grid_phases
from benchmark.frames.spec import expand_adapted, method_arg
from viewadapt.commands.detect import (
    DEFAULT_LENS, LENS_CHOICES, add_box_voting_option, add_cache_options,
    add_ground_stride_option, add_upsample_below_option,
    check_frame_selection, person_heights,
)
from viewadapt.detect.evaluation import BOOTSTRAP_BLOCK
from viewadapt.geometry import PERSON_HEIGHT_M
from viewadapt.objectmodel import OBJECT_MODELS
from viewadapt.remap import ANGLE_RULES

__all__ = ["cmd_bench_footage", "register_footage"]


def cmd_bench_footage(args) -> int:
    """Run every method on the clip and write the table, figures, errors, detections and
    run.json."""
    import cv2
    import pandas as pd
    from tqdm.auto import tqdm

    from viewadapt.io import SourceDetectors, plot_det_figure, shipped_model_path
    from viewadapt.io.files import atomic_output_dir, check_output_dir, run_metadata

    check_output_dir(args.out, overwrite=args.overwrite)
    check_frame_selection(args)
    if args.jobs != 1:
        raise ValueError("bench footage times every method in one process: --jobs must be 1")
    if args.bootstrap_block < 1:
        raise ValueError(f"--bootstrap-block must be at least 1 frame, got "
                         f"{args.bootstrap_block}")
    if args.phases < 1:
        raise ValueError(f"--phases must be at least 1, got {args.phases}")
    methods = expand_adapted(args.methods or list(FOOTAGE_METHODS), args.rules,
                             args.object_models)
    phases, shifts = grid_phases(args.phases), frame_shifts(args.phases)
    clip = open_clip(args.inputs, args.calibration, args.boxes, args.ignore, lens=args.lens,
                     start=args.start, every=args.every, max_frames=args.max_frames)
    needs = any(m.needs_training for m in methods)
    model_path = args.model or shipped_model_path()
    models = SourceDetectors.load(model_path) if needs else None
    t0 = time.perf_counter()
    run_kw = dict(heights=args.heights, cache_dir=args.cache or (args.out / "cache"),
                  cache_limit_gb=args.cache_limit, tolerance=args.tolerance,
                  ground_stride=args.ground_stride, box_voting=args.box_voting,
                  upsample_below=args.upsample_below)
    total = None if clip.stream.n_frames is None else clip.stream.n_frames * len(phases)
    with tqdm(total=total, desc="footage" if len(phases) == 1 else "footage x grid phases",
              unit="frame", dynamic_ncols=True, disable=args.quiet) as bar:
        run = run_footage(clip, methods, models, progress=lambda: bar.update(1), **run_kw)
        phase_dets = run_phases(clip, methods, models, phases, shifts,
                                progress=lambda: bar.update(1),
                                **run_kw) if len(phases) > 1 else {}
    if run.n_frames == 0:
        raise ValueError(f"{clip.stream.name} has no frames to evaluate")
    size = clip.camera.image_size
    kw = dict(block=args.bootstrap_block, seed=args.seed)
    evaluations, matches = evaluate_run(run, size, regions=clip.regions, **kw)
    differences = paired_differences(run, evaluations, matches, **kw)
    lines = summary_lines(run, evaluations, differences)
    block_frames = evaluations[methods[0]][0]["bootstrap"]["block_frames"]
    phase = phase_summary(run, phase_dets, evaluations, matches, size, phases, shifts,
                          regions=clip.regions, **kw) if phase_dets else None
    if phase is not None:
        lines += phase_lines(phase, evaluations, block_frames)
    n_gt = next(iter(evaluations.values()))[0]["n_gt"]
    n_ign = next(iter(evaluations.values()))[0]["n_gt_ignored"]
    head = [f"# {clip.stream.name}: {run.n_frames} frames, {n_gt} persons counted "
            f"({n_ign} ignored)", "",
            f"Caltech protocol, LAMR over 1e-2..1e0 FPPI; 95% intervals from a circular block "
            f"bootstrap over {block_frames}-frame blocks; frames/s in one process"
            + {None: "", "windows": "; the lens: candidate windows through it",
               "undistort": "; the lens: frames undistorted first (not timed), boxes "
                            "mapped back"}[clip.correction] + ".", ""]
    first = next(iter(clip.stream)).image
    errors, maps = {}, []
    for m in methods:
        errors[m.name], view = clip_errors(first, run.detections[m], run.truth, size,
                                           regions=clip.regions, fppis=ERROR_FPPIS,
                                           title=f"{m.name} @ {ERROR_FPPIS[-1]:g} FPPI")
        maps.append(view)
    with atomic_output_dir(args.out) as tmp:
        (tmp / "footage_summary.md").write_text("\n".join(head + lines) + "\n")
        (tmp / "errors.md").write_text("\n".join(
            [f"# {clip.stream.name}: what each method gets wrong", "",
             "Persons with a neighbour: another annotated person overlaps their box by a "
             "fifth of its width and half its height. False positives: localisation = best "
             "IoU with a person 0.3-0.5 (in brackets: on a person missed), duplicates = IoU "
             ">= 0.5 with a person found, background = the rest. error_map.jpg: every "
             "counted person's foot point over the clip, green found and red missed, and "
             f"the false positives' (cyan crosses), at {ERROR_FPPIS[-1]:g} FPPI.", ""]
            + error_lines(errors, ERROR_FPPIS)) + "\n")
        cv2.imwrite(str(tmp / "error_map.jpg"), cv2.cvtColor(map_grid(maps), cv2.COLOR_RGB2BGR),
                    [cv2.IMWRITE_JPEG_QUALITY, 85])
        pd.DataFrame(summary_rows(run, evaluations, differences)).to_csv(
            tmp / "footage_summary.csv", index=False, float_format="%.5f")
        (tmp / "evaluations.json").write_text(json.dumps(
            {m.name: ev for m, (ev, _) in evaluations.items()}))
        (tmp / "paired_differences.json").write_text(json.dumps(
            [dict(method=m.name, reference=r.name, **d) for m, r, d in differences], indent=1))
        (tmp / "detections.json").write_text(json.dumps(
            {m.name: dict(zip(map(str, run.keys), (_stored(d) for d in run.detections[m])))
             for m in methods}))
        if phase is not None:
            pd.DataFrame(phase.rows()).to_csv(tmp / "phases.csv", index=False,
                                              float_format="%.5f")
            (tmp / "phases.json").write_text(json.dumps(phase.json(), indent=1))
        plot_det_figure({m.name: c for m, (_, c) in evaluations.items()}, tmp / "det_footage",
                        title=f"{run.n_frames} frames, {n_gt} persons counted")
        (tmp / "run.json").write_text(json.dumps(run_metadata(
            args.seed, inputs=[str(p) for p in args.inputs], input=clip.stream.describe(),
            calibration=str(args.calibration), boxes=str(args.boxes),
            ignore=None if args.ignore is None else str(args.ignore),
            lens_correction=clip.correction, heights=list(args.heights),
            ground_stride=None if args.ground_stride is None else list(args.ground_stride),
            grid_phases=[list(p) for p in phases], frame_shifts=[list(p) for p in shifts],
            box_voting=args.box_voting, upsample_below=args.upsample_below,
            model=str(model_path) if needs else None,
            model_training=models.training if needs else None,
            methods=[m.name for m in methods], n_frames=run.n_frames, windows=run.n_windows,
            seconds_per_method={m.name: round(s, 3) for m, s in run.seconds.items()},
            prepare_seconds={m.name: round(s, 3) for m, s in run.prepare_seconds.items()},
            undistort_seconds=round(run.undistort_seconds, 3),
            seconds=round(time.perf_counter() - t0, 1)), indent=2, default=str))
    print("\n".join(lines))
    print(f"\nwrote {args.out}/footage_summary.{{md,csv}}, det_footage.{{png,pdf}}, "
          "errors.md, error_map.jpg, evaluations.json, paired_differences.json, "
          "detections.json, run.json" + (", phases.{csv,json}" if phase is not None else ""))
    return 0


def _stored(boxes) -> list:
    """(D, 5) detections as ``detections.json`` stores them: unrounded (rounded scores tie
    and rounded boxes can cross the protocol's IoU of 0.5), so that evaluating the file
    again gives the run's numbers and curves."""
    return np.asarray(boxes, float).reshape(-1, 5).tolist()


def register_footage(bsub, common) -> None:
    """Add ``bench footage`` to the ``viewadapt bench`` subcommands."""
    p = bsub.add_parser(
        "footage", parents=[common], help="every method on your calibrated, annotated clip",
        description="Run every full-frame method on a calibrated clip with ground truth: "
                    "OpenCV's detectMultiScale (its INRIA and its Daimler detector) at 1x, "
                    "2x and 4x without and with the ground-plane filter, our unadapted "
                    "pyramids, the adapted HOG, ACF, OpenCV and Daimler detectors, and image "
                    "warping of each adapted model; write the "
                    "LAMR table with block-bootstrap intervals, paired differences against "
                    "the best unadapted baseline and against warping, frames per second, "
                    "the DET figure and every detection. Reads what viewadapt detect reads "
                    "(MOTChallenge gt.txt, CAVIAR XML, COCO, CSV; PETS/Tsai XML or OpenCV "
                    "calibrations) and handles the lens as detect does.")
    p.add_argument("inputs", nargs="+", metavar="INPUT",
                   help="a video file, a folder of images, a quoted glob pattern or image files")
    p.add_argument("--calibration", type=Path, required=True,
                   help="the camera's calibration (as viewadapt detect reads it)")
    p.add_argument("--boxes", type=Path, required=True,
                   help="ground truth: MOTChallenge gt.txt, CAVIAR XML, COCO JSON or CSV")
    p.add_argument("--ignore", type=Path, default=None,
                   help="ignore regions (JSON polygons): boxes whose bottom-centre lies "
                        "inside are ignored, detections and ground truth alike")
    p.add_argument("--methods", nargs="+", type=method_arg, default=None, metavar="METHOD",
                   help="methods to run (default: " + " ".join(m.name for m in FOOTAGE_METHODS)
                        + "); any method of bench frames, e.g. 'opencv_adapted[body]', or "
                          "'hog_adapted[fold]' without the per-window normalisation stage "
                          "(quoted)")
    p.add_argument("--rules", nargs="+", choices=list(ANGLE_RULES), default=None,
                   help="run every adapted method once per angle rule of A")
    p.add_argument("--object-models", nargs="+", choices=list(OBJECT_MODELS), default=None,
                   help="and once per object model (body: every method reads undistorted "
                        "frames when the calibration has a lens)")
    p.add_argument("--model", type=Path, default=None,
                   help="our source detectors (default: the shipped models)")
    p.add_argument("--heights", type=person_heights, default=(PERSON_HEIGHT_M,),
                   help="assumed person heights, metres, comma-separated (default 1.75); the "
                        "ground-plane filter keeps boxes within 20%% of one of them")
    add_ground_stride_option(p)
    add_box_voting_option(p)
    add_upsample_below_option(p)
    p.add_argument("--phases", type=int, default=1, metavar="N",
                   help="also run every method with its window grid at N x N phases: "
                        "the methods that score the candidate windows (adapted, warp) with "
                        "the windows' ground grid at fractions of its stride, the pyramids "
                        "on the frame moved by 0..N-1 whole pixels each way; a LAMR moves "
                        "with where the grid falls. Adds each one's mean, spread and range "
                        "over the phases and paired differences averaged over them to the "
                        "report (phases.csv, phases.json); the table above it, the figures "
                        "and detections stay those of phase (0, 0). Costs N x N runs of "
                        "every method (default 1)")
    p.add_argument("--lens", choices=LENS_CHOICES, default=DEFAULT_LENS,
                   help="with dist in the calibration: as viewadapt detect --lens (default "
                        "auto: windows through the lens, for either object model)")
    p.add_argument("--tolerance", type=float, default=None,
                   help="shape tolerance of shared templates, HOG frame cells (default the "
                        "detector's)")
    p.add_argument("--start", type=int, default=0, metavar="K",
                   help="index of the first frame read (default 0)")
    p.add_argument("--every", type=int, default=1, metavar="N",
                   help="read every N-th frame (default 1)")
    p.add_argument("--max-frames", type=int, default=None, metavar="M",
                   help="read at most M frames (default: all)")
    p.add_argument("--bootstrap-block", type=int, default=BOOTSTRAP_BLOCK, metavar="FRAMES",
                   help=f"frames per block of the bootstrap (default {BOOTSTRAP_BLOCK})")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    add_cache_options(p)
    p.set_defaults(func=cmd_bench_footage)
