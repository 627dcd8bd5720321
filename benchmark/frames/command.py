"""``viewadapt bench frames`` and ``viewadapt bench runtime``."""

from __future__ import annotations

import argparse
import copy
import json
import time
from pathlib import Path

import numpy as np

from viewadapt.commands.detect import (
    add_box_voting_option, add_cache_options, add_upsample_below_option, person_heights,
)
from viewadapt.detect import (
    CELLS_PER_SOURCE_CELL, DEFAULT_BOX_VOTING, DEFAULT_FRAME_VIEW, FRAME_VIEW_CHOICES,
    HOG_TOLERANCE,
)
from viewadapt.detect.kinds import OPENCV_FOLD_CELLS_PER_SOURCE_CELL
from viewadapt.detect.layers import check_upsample_below
from viewadapt.geometry import PERSON_HEIGHT_M
from viewadapt.io import DEFAULT_CACHE_LIMIT_GB, plot_det_figure
from viewadapt.objectmodel import OBJECT_MODELS
from viewadapt.remap import ANGLE_RULES

from benchmark.recipes import DEFAULT_RECIPE, add_recipe_argument
from benchmark.frames.report import (
    accuracy_targets, phase_gap_lines, phase_table, plot_seed_figure, seed_summary, summary_table,
)
from benchmark.footage.command import register_footage
from benchmark.frames.runtime import TIMING_SIZE
from benchmark.frames.spec import DEFAULT_METHODS, FrameMethod, expand_adapted, method_arg

__all__ = ["register", "cmd_bench_frames", "cmd_bench_runtime", "plot_det_figure"]


# --------------------------------------------------------------------------------- detect


# --------------------------------------------------------------------------- bench frames


def _group_by_camera(frames):
    groups = {}
    for f in frames:
        key = json.dumps([f.camera.to_dict(), None if f.dist is None else f.dist.tolist()],
                         sort_keys=True)
        groups.setdefault(key, []).append(f)
    return list(groups.values())


def _detect_camera(group, models, methods, heights, cache_dir, cache_limit_gb, tolerance,
                   cells_per_source_cell, upsample_below, grid_phase=(0.0, 0.0),
                   frame_shift=(0, 0), box_voting=DEFAULT_BOX_VOTING, progress=None):
    """Every method (:class:`~benchmark.frames.spec.FrameMethod`) on the frames of one camera,
    the candidate windows at ``grid_phase`` (through the camera's lens when its frames
    record one, as ``viewadapt detect`` maps them), the pyramids on the frames moved by
    ``frame_shift``: (detections, seconds, windows), by method."""
    from benchmark.frames.methods import FrameMethods

    lens = None if group[0].dist is None else group[0].dist.tolist()
    fd = FrameMethods(group[0].camera, models, person_heights=heights, cache_dir=cache_dir,
                       cache_limit_gb=cache_limit_gb, tolerance=tolerance,
                       cells_per_source_cell=cells_per_source_cell,
                       upsample_below=upsample_below, grid_phase=grid_phase, lens=lens,
                       box_voting=box_voting, frame_shift=frame_shift)
    for m in methods:                           # offline precomputation, not timed per frame
        fd.prepare(m)
    dets = {m: [] for m in methods}
    secs = {m: 0.0 for m in methods}
    for f in group:
        img = f.image()
        for m in methods:
            t = time.perf_counter()
            dets[m].append(fd.detect(m, img))
            secs[m] += time.perf_counter() - t
        if progress is not None:
            progress.update(1)
    return dets, secs, len(fd.windows)


def run_frames_benchmark(data, *, methods, seed=0, quick=False, max_frames=None,
                         heights=(PERSON_HEIGHT_M,), cache_dir=None,
                         cache_limit_gb=DEFAULT_CACHE_LIMIT_GB, models=None, progress=True,
                         tolerance=HOG_TOLERANCE, cells_per_source_cell=None,
                         upsample_below=None, jobs=1, frame_view=DEFAULT_FRAME_VIEW,
                         recipe=DEFAULT_RECIPE, phases=1,
                         box_voting=DEFAULT_BOX_VOTING):
    """Detect with every method (``methods``: :class:`~benchmark.frames.spec.FrameMethod` s)
    on every frame.

    Cameras are processed in parallel with ``jobs`` worker processes (joblib); the
    seconds per frame are measured inside each worker. With ``phases`` > 1 every method
    runs again at each of ``phases x phases`` phases of its window grid -- the methods that
    score the candidate windows (``on_window_grid``) with the windows' ground grid at
    :func:`benchmark.frames.phases.grid_phases`, the pyramids on the frames moved by
    :func:`benchmark.frames.phases.frame_shifts` -- and its ``lamr`` is the mean over the
    phases (``lamr_phases``: each phase's, the default's first); curves, detections and
    seconds are the default's. ``box_voting``: every method's boxes voted after non-maximum
    suppression (:class:`viewadapt.detect.FrameDetector`'s temperature; 0 none).

    Returns
    -------
    (results, models, detections, frames, info, phase_detections)
        ``results``, ``detections`` and ``phase_detections`` by method; ``phase_detections``:
        {method: per phase, per frame detections} (empty with one phase).
    """
    from joblib import Parallel, delayed
    from tqdm.auto import tqdm

    from benchmark.data import load_dataset
    from benchmark.frames.phases import frame_shifts, grid_phases
    from benchmark.frames.methods import evaluate_method, load_frames, train_source_detectors

    check_upsample_below(upsample_below, "--upsample-below")
    phase_list, shift_list = grid_phases(phases), frame_shifts(phases)
    frames = load_frames(data)
    if max_frames:
        frames = frames[:max_frames]
    if models is None:                  # crops are needed only to train
        t0 = time.perf_counter()
        if progress:
            print("training HOG/SVM and ACF on the dataset's elevation-0 crops ...",
                  flush=True)
        models = train_source_detectors(load_dataset(data), seed=seed, quick=quick,
                                        frame_view=frame_view, recipe=recipe)
        if progress:
            print(f"  trained in {time.perf_counter() - t0:.0f} s", flush=True)
    groups = _group_by_camera(frames)
    order = [f for g in groups for f in g]
    # (group, (grid phase, frame shift)): every method at the default phase, then at each
    # other one
    where = list(zip(phase_list, shift_list))
    tasks = [(g, ph) for ph in where for g in groups]
    kw = dict(models=models, heights=heights, cache_dir=cache_dir,
              cache_limit_gb=cache_limit_gb, tolerance=tolerance,
              cells_per_source_cell=cells_per_source_cell,
              upsample_below=upsample_below, box_voting=box_voting)
    n_jobs = 1 if jobs is None else int(jobs)
    if n_jobs != 1 and len(tasks) > 1:
        par = Parallel(n_jobs=n_jobs, return_as="generator")
        out = list(tqdm(par(delayed(_detect_camera)(g, methods=methods, grid_phase=ph,
                                                    frame_shift=sh, **kw)
                            for g, (ph, sh) in tasks),
                        total=len(tasks), desc="cameras" if phases == 1
                        else "cameras x grid phases", unit="task", disable=not progress))
    else:
        with tqdm(total=sum(len(g) for g, _ in tasks), desc="frames", unit="frame",
                  disable=not progress) as bar:
            out = [_detect_camera(g, methods=methods, grid_phase=ph, frame_shift=sh,
                                  progress=bar, **kw)
                   for g, (ph, sh) in tasks]
    first = out[:len(groups)]
    dets = {m: [d for o in first for d in o[0][m]] for m in methods}
    secs = {m: sum(o[1][m] for o in first) for m in methods}
    phase_dets = {m: [[d for (_, p), o in zip(tasks, out) if p == ph for d in o[0][m]]
                      for ph in where] for m in methods} if phases > 1 else {}
    results = {}
    for m in methods:
        ev = evaluate_method(dets[m], order)
        results[m] = dict(ev, seconds_per_frame=secs[m] / len(order))
        if m in phase_dets:
            lamrs = [ev["lamr"]] + [evaluate_method(d, order)["lamr"]
                                    for d in phase_dets[m][1:]]
            results[m].update(lamr=float(np.mean(lamrs)), lamr_phases=lamrs)
    info = dict(n_frames=len(order), windows_per_camera=[o[2] for o in first],
                n_gt=int(sum(len(f.gt) for f in order)), grid_phases=phase_list,
                frame_shifts=shift_list,
                box_voting=float(box_voting))
    return results, models, dets, order, info, phase_dets


def _earlier_results(out: Path, data: Path, box_voting: float) -> dict:
    """``out``'s earlier run on ``data`` with the same box voting:
    :class:`~benchmark.frames.spec.FrameMethod` -> (frame key -> detections, s / frame)."""
    from benchmark.data import read_json

    run, det = out / "run.json", out / "detections.json"
    if not (run.is_file() and det.is_file() and (out / "frames_summary.csv").is_file()):
        raise ValueError(f"--keep-other-methods: {out} holds no earlier `bench frames` run "
                         "(run.json, detections.json, frames_summary.csv)")
    old = read_json(run)
    if Path(old.get("data", "")).resolve() != Path(data).resolve():
        raise ValueError(f"--keep-other-methods: {out} holds results on {old.get('data')}, "
                         f"not on {data}")
    if float(old.get("box_voting", 0.0)) != float(box_voting):
        raise ValueError(f"--keep-other-methods: {out} holds results with --box-voting "
                         f"{old.get('box_voting', 0.0):g}, not {box_voting:g}")
    import pandas as pd

    table = pd.read_csv(out / "frames_summary.csv")
    secs = dict(zip(table["method"], table["seconds_per_frame"].astype(float)))
    return {FrameMethod.parse(m): (d, secs.get(m, float("nan")))
            for m, d in read_json(det).items()}


def curve_corners(fppi, miss_rate):
    """The points of a DET curve (one per detection, by decreasing score) where the
    staircase turns: the last point of each FPPI value, then the first of each run of equal
    miss rates, and the end point. The miss rate at any FPPI
    (:func:`viewadapt.metrics.miss_rate_at`) and so the log-average miss rate are
    unchanged; a few hundred points instead of one per detection."""
    fp, miss = np.asarray(fppi, float), np.asarray(miss_rate, float)
    if fp.size == 0:
        return fp, miss
    last = np.r_[fp[1:] != fp[:-1], True]
    fp, miss = fp[last], miss[last]
    keep = np.r_[True, miss[1:] != miss[:-1]]
    keep[-1] = True
    return fp[keep], miss[keep]


def _frame_key(f) -> str:
    return f"{f.path.name}@{f.scene_id}"


def cmd_bench_frames(args) -> int:
    from viewadapt.io.files import atomic_output_dir, check_output_dir, run_metadata

    from viewadapt.io import SourceDetectors

    from benchmark.frames.methods import evaluate_method

    check_output_dir(args.out, overwrite=args.overwrite)
    if args.seeds < 1:
        raise ValueError(f"--seeds must be at least 1, got {args.seeds}")
    if args.seeds > 1 and (args.model or args.keep_other_methods):
        raise ValueError("--seeds trains the detectors once per seed; it does not combine "
                         "with --model or --keep-other-methods")
    if args.phases < 1:
        raise ValueError(f"--phases must be at least 1, got {args.phases}")
    if args.phases > 1 and args.keep_other_methods:
        raise ValueError("--phases does not combine with --keep-other-methods (an earlier "
                         "run holds the default grid's detections only)")
    methods = expand_adapted(args.methods or list(DEFAULT_METHODS), args.rules,
                             args.object_models)
    earlier = _earlier_results(args.out, args.data, args.box_voting) \
        if args.keep_other_methods else {}
    models = SourceDetectors.load(args.model) if args.model else None
    seeds = [args.seed + i for i in range(args.seeds)]
    t0 = time.perf_counter()
    kw = dict(quick=args.quick, max_frames=args.max_frames, heights=args.heights,
              cache_dir=args.cache or (args.out / "cache"), cache_limit_gb=args.cache_limit,
              tolerance=args.tolerance,
              cells_per_source_cell=args.cells_per_source_cell,
              upsample_below=args.upsample_below, jobs=args.jobs, frame_view=args.frame_view,
              recipe=args.recipe, phases=args.phases, box_voting=args.box_voting)
    if len(seeds) > 1:
        print(f"seed {seeds[0]} (1 of {len(seeds)})", flush=True)
    results, models, dets, frames, info, phase_dets = run_frames_benchmark(
        args.data, methods=methods, seed=seeds[0], models=models, **kw)
    per_seed = {seeds[0]: {m: results[m] for m in methods}}
    seed_models = {}
    trained = [m for m in methods if m.needs_training]        # OpenCV's: run once
    for i, seed in enumerate(seeds[1:], 2):
        print(f"\nseed {seed} ({i} of {len(seeds)}; {', '.join(m.name for m in trained)})",
              flush=True)
        per_seed[seed], seed_models[seed], *_ = run_frames_benchmark(
            args.data, methods=trained, seed=seed, **kw)
    kept = [m for m in earlier if m not in methods]
    for m in kept:
        old, sec = earlier[m]
        missing = [_frame_key(f) for f in frames if _frame_key(f) not in old]
        if missing:
            raise ValueError(f"--keep-other-methods: {m.name}'s earlier results lack the frames "
                             f"{missing[:3]}{' ...' if len(missing) > 3 else ''}")
        dets[m] = [np.asarray(old[_frame_key(f)], float).reshape(-1, 5) for f in frames]
        results[m] = dict(evaluate_method(dets[m], frames), seconds_per_frame=sec)
    if kept:
        print(f"kept from the earlier run in {args.out}: {', '.join(m.name for m in kept)}")
        methods = list(dict.fromkeys([*earlier, *methods]))     # the earlier run's order
    with atomic_output_dir(args.out) as tmp:
        n_phases = len(info["grid_phases"])
        lines = summary_table(results, methods, n_phases=n_phases,
                              seed_note=f", seed {seeds[0]}" if len(seeds) > 1 else "")
        csv = []
        for m in methods:
            r = results[m]
            csv.append(dict(method=m.name, lamr=r["lamr"],
                            lamr_default_grid=r.get("lamr_phases", [r["lamr"]])[0],
                            grid_phases=len(r.get("lamr_phases", [0])),
                            seconds_per_frame=r["seconds_per_frame"],
                            n_frames=info["n_frames"], n_gt=info["n_gt"], rule=m.rule or "",
                            object_model=m.object_model or ""))
        lamrs = {s: {m: r["lamr"] for m, r in res.items()} for s, res in per_seed.items()}
        lines += accuracy_targets(results, lamrs)
        if phase_dets:
            lines += phase_gap_lines(phase_dets, frames, seed=args.seed)
            (tmp / "phases.csv").write_text(phase_table(results, info["grid_phases"],
                                                        info["frame_shifts"]))
            plot_seed_figure({f"{a:g}, {b:g}": {m: results[m]["lamr_phases"][i]
                                                for m in phase_dets}
                              for i, (a, b) in enumerate(info["grid_phases"])},
                             tmp / "phases", what="grid phases")
        if len(seeds) > 1:
            seed_lines = seed_summary(lamrs)
            lines += ["", *seed_lines]
            (tmp / "seeds.md").write_text("\n".join(seed_lines) + "\n")
            (tmp / "seeds.csv").write_text("seed,method,lamr,seconds_per_frame\n" + "".join(
                f"{s},{m.name},{r['lamr']:.5f},{r['seconds_per_frame']:.5f}\n"
                for s, res in per_seed.items() for m, r in res.items()))
            plot_seed_figure(lamrs, tmp / "seeds")
        (tmp / "frames_summary.md").write_text("\n".join(lines) + "\n")
        import pandas as pd

        pd.DataFrame(csv).to_csv(tmp / "frames_summary.csv", index=False, float_format="%.5f")
        # the curves are the default grid's, with their own LAMR
        curves = {m.name: dict(results[m],
                               lamr=results[m].get("lamr_phases", [results[m]["lamr"]])[0])
                  for m in methods}
        (tmp / "det_curves.json").write_text(json.dumps(
            {m: dict(zip(("fppi", "miss_rate"), (a.tolist() for a in curve_corners(
                c["fppi"], c["miss_rate"]))), lamr=c["lamr"]) for m, c in curves.items()}))
        (tmp / "detections.json").write_text(json.dumps(
            {m.name: {_frame_key(f): d.tolist() for f, d in zip(frames, dets[m])}
             for m in methods}))
        plot_det_figure(curves, tmp / "det_frames",
                        title=f"{info['n_frames']} frames, {info['n_gt']} persons"
                        + (", default grid" if n_phases > 1 else ""))
        (tmp / "models").mkdir()
        models.save(tmp / "models" / "source_detectors.npz")
        for seed, m in seed_models.items():
            m.save(tmp / "models" / f"source_detectors_seed{seed}.npz")
        (tmp / "run.json").write_text(json.dumps(run_metadata(
            args.seed, data=str(args.data), methods=[m.name for m in methods],
            kept_from_earlier_run=[m.name for m in kept], **info,
            seeds=seeds, training=models.training,
            seconds=round(time.perf_counter() - t0, 1)), indent=2, default=str))
    print("\n".join(lines))
    print(f"\nwrote {args.out}/frames_summary.{{md,csv}}, det_frames.{{png,pdf}}, "
          "models/source_detectors.npz" + (", phases.{csv,png}" if phase_dets else "")
          + (", seeds.{md,csv,png} (per seed; the rest is seed "
             f"{seeds[0]}'s)" if len(seeds) > 1 else ""))
    return 0


# -------------------------------------------------------------------------- bench runtime


def cmd_bench_runtime(args) -> int:
    from viewadapt.io import SourceDetectors
    from viewadapt.io.files import atomic_output_dir, check_output_dir, run_metadata

    from benchmark.frames.runtime import format_table, run_runtime

    check_output_dir(args.out, overwrite=args.overwrite)
    models = SourceDetectors.load(args.model) if args.model else None
    t0 = time.perf_counter()
    table, info = run_runtime(args.data, n_frames=args.frames, warp_windows=args.warp_windows,
                              heights=args.heights, jobs=args.jobs, seed=args.seed,
                              quick=args.quick, cache_dir=args.cache,
                              cache_limit_gb=args.cache_limit,
                              frame_view=args.frame_view, recipe=args.recipe,
                              size=_frame_size(args.size), models=models)
    md = format_table(table, info)
    with atomic_output_dir(args.out) as tmp:
        (tmp / "runtime.md").write_text(md)
        import pandas as pd

        pd.DataFrame(table).to_csv(tmp / "runtime.csv", index=False)
        (tmp / "run.json").write_text(json.dumps(run_metadata(
            args.seed, data=str(args.data), **info, seconds=round(time.perf_counter() - t0, 1)),
            indent=2, default=str))
    print(md)
    return 0


# ------------------------------------------------------------------------------ register


def _bench_subparsers(sub, common):
    bench = sub.choices.get("bench")
    if bench is None:
        bench = sub.add_parser("bench", help="run benchmarks on a generated dataset")
        return bench.add_subparsers(dest="bench_command", metavar="BENCH", required=True)
    for action in bench._actions:
        if isinstance(action, argparse._SubParsersAction):
            return action
    return bench.add_subparsers(dest="bench_command", metavar="BENCH", required=True)


#: person heights the frame benchmarks assume: two heights on the CAVIAR-like timing camera
#: give ~30,000 windows (the paper's 31,603)
BENCH_HEIGHTS = (1.65, 1.85)


def _frame_options() -> argparse.ArgumentParser:
    """The options ``bench frames`` and ``bench runtime`` share, as new argument objects per
    call: ``set_defaults`` on a subcommand would otherwise change its siblings' defaults."""
    opts = argparse.ArgumentParser(add_help=False)
    opts.add_argument("--data", type=Path, required=True,
                      help="dataset directory with crops and frames_coco.json")
    opts.add_argument("--heights", type=person_heights, default=BENCH_HEIGHTS,
                      help="assumed person heights, metres, comma-separated (default "
                           + ",".join(f"{h:g}" for h in BENCH_HEIGHTS) + ")")
    add_cache_options(opts)
    opts.add_argument("--quick", action="store_true", help="smaller detectors (tests)")
    opts.add_argument("--frame-view", choices=list(FRAME_VIEW_CHOICES),
                      default=DEFAULT_FRAME_VIEW,
                      help="which detectors also train on a frame-view copy of every crop "
                           "(the crop as the adapted detector reads it from a frame; "
                           f"viewadapt.detect.frameview): default {DEFAULT_FRAME_VIEW}; none = crops "
                           "alone. Ignored with --model")
    add_recipe_argument(opts, what="HOG/SVM and ACF (ignored with --model, whose file "
                                   "records its own)")
    return opts


def _frame_size(text: str) -> tuple:
    """'768x576' -> (768, 576): a frame size of at least 64x128 and at most 8192 a side."""
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"give the size as WIDTHxHEIGHT, e.g. 768x576, "
                                         f"not {text!r}") from None
    if not (64 <= w <= 8192 and 128 <= h <= 8192):
        raise argparse.ArgumentTypeError(f"a frame size from 64x128 to 8192x8192, got {text!r}")
    return w, h


def _size_text(text: str) -> str:
    """``--size`` checked (:func:`_frame_size`) and kept as text, ``WIDTHxHEIGHT``."""
    w, h = _frame_size(text)
    return f"{w}x{h}"


def _all_cores_common(common) -> argparse.ArgumentParser:
    """A copy of the shared options whose ``--jobs`` defaults to every core (help included)."""
    own = copy.deepcopy(common)
    for action in own._actions:
        if action.dest == "jobs":
            action.default = -1
            action.help = "parallel worker processes (default all cores; -1 = all cores)"
    return own


def register(sub, common) -> None:
    """Add ``bench frames``, ``bench runtime`` and ``bench footage`` to the ``viewadapt``
    parser."""
    bsub = _bench_subparsers(sub, common)
    opts = _frame_options()
    p = bsub.add_parser("frames", parents=[common, opts],
                        help="miss rate vs FPPI on calibrated frames (Fig. 3)",
                        description="Train HOG/SVM and ACF on the dataset's elevation-0 crops, "
                                    "detect on its surveillance frames with the adapted "
                                    "detectors and the baselines, and write DET curves, "
                                    "log-average miss rates and a table.")
    p.add_argument("--methods", nargs="+", default=None, type=method_arg, metavar="METHOD",
                   help="methods to run (default: " + " ".join(m.name for m in DEFAULT_METHODS)
                        + "); also "
                        "opencv_native and adapted variants such as 'hog_adapted[body]' "
                        "(quoted); 'hog_adapted[fold]': without the per-window normalisation "
                        "stage")
    p.add_argument("--rules", nargs="+", choices=list(ANGLE_RULES), default=None,
                   help="run every adapted method once per angle rule of A: covariant "
                        "(default), paper (the literal eq. 3), none (S only); one row each")
    p.add_argument("--object-models", nargs="+", choices=list(OBJECT_MODELS), default=None,
                   help="and once per object model: plane (default, the paper's) or body "
                        "(the shipped mean body); one row each")
    p.add_argument("--max-frames", type=int, default=None)
    p.add_argument("--tolerance", type=float, default=HOG_TOLERANCE,
                   help="shape tolerance (HOG frame cells) for windows sharing an adapted "
                        f"template; 0 = an exact template per window (default {HOG_TOLERANCE:g})")
    p.add_argument("--cells-per-source-cell", type=float, default=None,
                   help="frame cells per source cell along each axis when choosing a "
                        "window's frame cell size (default: each detector's own, "
                        f"{CELLS_PER_SOURCE_CELL:g}; {OPENCV_FOLD_CELLS_PER_SOURCE_CELL:g} for "
                        "opencv's fold, which its stage rescores)")
    add_upsample_below_option(p)
    p.add_argument("--model", type=Path, default=None,
                   help="reuse trained source detectors (models/source_detectors.npz of "
                        "an earlier run) instead of training")
    p.add_argument("--seeds", type=int, default=1,
                   help="train and detect with this many training seeds (--seed, --seed + "
                        "1, ...) and write each method's LAMR per seed, its mean and spread "
                        "and the adapted - warping gap per seed (seeds.md, seeds.csv, "
                        "seeds.png); the accuracy targets are then judged on the seed "
                        "means. The DET figure and detections are the first seed's; "
                        "OpenCV, which trains nothing, runs once (default 1)")
    add_box_voting_option(p)
    p.add_argument("--phases", type=int, default=1,
                   help="run every method with its window grid at N x N phases -- the "
                        "methods that score the candidate windows (adapted, warp) with the "
                        "windows' ground grid at fractions of its stride, the pyramids and "
                        "OpenCV on the frames moved by 0..N-1 whole pixels each way -- and "
                        "report their mean LAMR, its spread and the adapted - warping gap "
                        "with a paired bootstrap interval (phases.csv). The LAMR moves with "
                        "where the grid falls (default 1: the default grid only)")
    p.add_argument("--keep-other-methods", action="store_true",
                   help="run only --methods and keep the other methods' results of the "
                        "earlier run in --out on the same --data (e.g. rerun the adapted "
                        "detectors without the slow image-warping baselines); the table "
                        "and figure show all. Pass that run's --model so the detectors "
                        "are the same")
    p.set_defaults(func=cmd_bench_frames)
    p = bsub.add_parser("runtime", parents=[_all_cores_common(common), _frame_options()],
                        help="frames per second per method (Table 1)",
                        description="The paper's Table 1 for this implementation: frames "
                                    "per second per method on one core, and on all cores "
                                    "(--jobs processes, each detecting on its own frames; "
                                    "default here: every core).")
    p.add_argument("--frames", type=int, default=3, help="frames timed (default 3)")
    p.add_argument("--warp-windows", type=int, default=1000,
                   help="windows timed for the image-warping methods, extrapolated to all "
                        "(default 1000)")
    p.add_argument("--size", type=_size_text, default=f"{TIMING_SIZE[0]}x{TIMING_SIZE[1]}",
                   metavar="WxH",
                   help="frame size every method is timed on, e.g. 768x576 (default "
                        f"{TIMING_SIZE[0]}x{TIMING_SIZE[1]}, the paper's); the camera keeps "
                        "its field of view")
    p.add_argument("--model", type=Path, default=None,
                   help="time these trained source detectors (e.g. the shipped "
                        "viewadapt/data/source_detectors.npz, or models/source_detectors.npz "
                        "of a bench frames run) instead of training quick ones: the adapted "
                        "HOG's normalisation stage rescores the windows its fold calls a "
                        "person, so its speed depends on the model")
    p.set_defaults(func=cmd_bench_runtime)
    register_footage(bsub, common)
