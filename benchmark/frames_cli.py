"""``viewadapt detect``, ``viewadapt bench frames`` and ``viewadapt bench runtime``."""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

__all__ = ["register", "cmd_detect", "cmd_bench_frames", "cmd_bench_runtime"]


def _heights(text):
    try:
        vals = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"cannot read person heights {text!r} "
                                         "(metres, comma-separated)") from None
    if not vals or any(not np.isfinite(v) or v <= 0 for v in vals):
        raise argparse.ArgumentTypeError("person heights must be positive metres")
    return vals


def _metadata(args, **extra):
    from viewadapt.cli import _metadata as meta

    return meta(args, **extra)


# --------------------------------------------------------------------------------- detect


def cmd_detect(args) -> int:
    """Detect persons in frames of one calibrated camera."""
    import cv2

    from viewadapt.cli import _check_out, atomic_output_dir

    from .data import read_image
    from .frames import (
        FrameDetector, FrameRecord, SourceDetectors, evaluate_method, read_boxes,
        read_calibration,
    )

    _check_out(args.out)
    cam = read_calibration(args.calibration)
    models = SourceDetectors.load(args.model)
    paths = [Path(p) for p in args.frames]
    for p in paths:
        if not p.is_file():
            raise FileNotFoundError(f"frame {p} does not exist")
    boxes = read_boxes(args.boxes, paths) if args.boxes else None
    dets = []
    from .frames import UPSAMPLE_BELOW

    det = FrameDetector(cam, models, person_heights=args.heights,
                        cache_dir=args.cache or (args.out / "cache"),
                        upsample_below=UPSAMPLE_BELOW if args.upsample_below is None
                        else args.upsample_below,
                        threshold_hog=args.threshold, threshold_acf=args.threshold)
    method = f"{args.detector}_adapted"
    rows, coco_img, coco_ann = [], [], []
    t0 = time.perf_counter()
    with atomic_output_dir(args.out) as tmp:
        (tmp / "annotated").mkdir()
        for i, p in enumerate(paths):
            img = read_image(p)
            if (img.shape[1], img.shape[0]) != tuple(cam.image_size):
                raise ValueError(f"frame {p} is {img.shape[1]}x{img.shape[0]} px, the "
                                 f"calibration is for {cam.image_size[0]}x{cam.image_size[1]}")
            d = det.detect(method, img)
            dets.append(d)
            coco_img.append({"id": i + 1, "file_name": str(p), "width": img.shape[1],
                             "height": img.shape[0]})
            vis = img[:, :, ::-1].copy()
            for x, y, w, h, s in d:
                rows.append({"frame": str(p), "x": x, "y": y, "w": w, "h": h, "score": s})
                coco_ann.append({"id": len(coco_ann) + 1, "image_id": i + 1, "category_id": 1,
                                 "bbox": [float(x), float(y), float(w), float(h)],
                                 "score": float(s)})
                cv2.rectangle(vis, (int(round(x)), int(round(y))),
                              (int(round(x + w)), int(round(y + h))), (0, 255, 0), 1)
            cv2.imwrite(str(tmp / "annotated" / f"{i:05d}_{p.stem}.png"), vis)
        import pandas as pd

        pd.DataFrame(rows, columns=["frame", "x", "y", "w", "h", "score"]).to_csv(
            tmp / "detections.csv", index=False)
        (tmp / "detections_coco.json").write_text(json.dumps(
            {"images": coco_img, "annotations": coco_ann,
             "categories": [{"id": 1, "name": "person"}]}))
        evaluation = None
        if boxes is not None:
            records = [FrameRecord(p, i + 1, "", cam, *boxes[p.name])
                       for i, p in enumerate(paths)]
            ev = evaluate_method(dets, records)
            evaluation = {"lamr": ev["lamr"], "n_gt": int(sum(len(r.gt) for r in records)),
                          "fppi": ev["fppi"].tolist(), "miss_rate": ev["miss_rate"].tolist()}
            (tmp / "evaluation.json").write_text(json.dumps(evaluation))
            plot_det_figure({method: ev}, tmp / "det",
                            title=f"{len(paths)} frames, {evaluation['n_gt']} persons")
        (tmp / "metadata.json").write_text(json.dumps(_metadata(
            args, detector=method, windows=len(det.windows), frames=len(paths),
            seconds=round(time.perf_counter() - t0, 2), camera=cam.to_dict()), indent=2))
    print(f"{len(rows)} detections in {len(paths)} frames ({len(det.windows)} candidate "
          f"windows); wrote {args.out}/detections.csv, detections_coco.json, annotated/")
    if evaluation is not None:
        print(f"against {evaluation['n_gt']} boxes of {args.boxes}: log-average miss rate "
              f"{evaluation['lamr']:.3f} over 1e-2..1e0 FPPI (evaluation.json, det.png)")
    return 0


# --------------------------------------------------------------------------- bench frames


def _group_by_camera(frames):
    groups = {}
    for f in frames:
        key = json.dumps(f.camera.to_dict(), sort_keys=True)
        groups.setdefault(key, []).append(f)
    return list(groups.values())


def _detect_camera(group, models, methods, heights, cache_dir, tolerance,
                   cells_per_source_cell, upsample_below, progress=None):
    """Every method on the frames of one camera: (detections, seconds, windows)."""
    from .frames import FrameDetector

    fd = FrameDetector(group[0].camera, models, person_heights=heights, cache_dir=cache_dir,
                       tolerance=tolerance, cells_per_source_cell=cells_per_source_cell,
                       upsample_below=upsample_below)
    for kind in ("hog", "acf"):                  # offline precomputation, not timed per frame
        if f"{kind}_adapted" in methods:
            fd.operator(kind)
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
                         heights=(1.75,), cache_dir=None, models=None, progress=True,
                         tolerance=0.5, cells_per_source_cell=0.7, upsample_below=None,
                         jobs=1, frame_view="hog"):
    """Detect with every method on every frame; return (results dict, models, detections).

    Cameras are processed in parallel with ``jobs`` worker processes (joblib); the
    seconds per frame are measured inside each worker.
    """
    from joblib import Parallel, delayed
    from tqdm.auto import tqdm

    from .data import load_dataset
    from .frames import UPSAMPLE_BELOW, evaluate_method, load_frames, train_source_detectors

    if upsample_below is None:
        upsample_below = UPSAMPLE_BELOW
    if not np.isfinite(upsample_below) or upsample_below < 0:
        raise ValueError(f"--upsample-below must be >= 0, got {upsample_below}")
    frames = load_frames(data)
    if max_frames:
        frames = frames[:max_frames]
    if models is None:                  # crops are needed only to train
        t0 = time.perf_counter()
        if progress:
            print("training HOG/SVM and ACF on the dataset's elevation-0 crops ...",
                  flush=True)
        models = train_source_detectors(load_dataset(data), seed=seed, quick=quick,
                                        frame_view=frame_view)
        if progress:
            print(f"  trained in {time.perf_counter() - t0:.0f} s", flush=True)
    groups = _group_by_camera(frames)
    order = [f for g in groups for f in g]
    kw = dict(models=models, methods=methods, heights=heights, cache_dir=cache_dir,
              tolerance=tolerance, cells_per_source_cell=cells_per_source_cell,
              upsample_below=upsample_below)
    n_jobs = 1 if jobs is None else int(jobs)
    if n_jobs != 1 and len(groups) > 1:
        par = Parallel(n_jobs=n_jobs, return_as="generator")
        out = list(tqdm(par(delayed(_detect_camera)(g, **kw) for g in groups),
                        total=len(groups), desc="cameras", unit="camera",
                        disable=not progress))
    else:
        with tqdm(total=len(order), desc="frames", unit="frame",
                  disable=not progress) as bar:
            out = [_detect_camera(g, progress=bar, **kw) for g in groups]
    dets = {m: [d for o in out for d in o[0][m]] for m in methods}
    secs = {m: sum(o[1][m] for o in out) for m in methods}
    results = {}
    for m in methods:
        ev = evaluate_method(dets[m], order)
        results[m] = dict(ev, seconds_per_frame=secs[m] / len(order))
    info = dict(n_frames=len(order), windows_per_camera=[o[2] for o in out],
                n_gt=int(sum(len(f.gt) for f in order)))
    return results, models, dets, order, info


def plot_det_figure(results, path_stem, title=""):
    """Miss rate against FPPI, log-log, the legend with each method's LAMR (Fig. 3)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    styles = {"hog": ("tab:blue", ), "acf": ("tab:red", ), "opencv": ("tab:gray", )}
    dash = {"pyramid": "-", "warp": "--", "adapted": ":", "opencv": "-.", "native": "-."}
    fig, ax = plt.subplots(figsize=(5.5, 4.5))
    for m, r in sorted(results.items(), key=lambda kv: kv[1]["lamr"]):
        fam = m.split("_")[0]
        ls = dash.get(m.split("_")[-1], "-")
        fppi = np.r_[1e-3, r["fppi"]] if len(r["fppi"]) else np.array([1e-3, 10])
        mr = np.r_[1.0, r["miss_rate"]] if len(r["miss_rate"]) else np.array([1.0, 1.0])
        ax.step(np.maximum(fppi, 1e-3), mr, where="post", ls=ls, lw=2,
                color=styles.get(fam, ("k",))[0], label=f"{100 * r['lamr']:.1f}% {m}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(1e-2, 1e1)
    ax.set_ylim(5e-2, 1.0)
    ax.set_xlabel("false positives per image")
    ax.set_ylabel("miss rate")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="lower left", title="log-average miss rate")
    if title:
        ax.set_title(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(f"{path_stem}.png", dpi=150)
    fig.savefig(f"{path_stem}.pdf")
    plt.close(fig)


def _accuracy_targets(results) -> list:
    """The issue's accuracy targets, read off this run's log-average miss rates."""
    out = []
    for kind in ("hog", "acf"):
        ad = results.get(f"{kind}_adapted")
        if ad is None:
            continue
        for base, test, text in (
                ("warp", lambda a, b: a <= b + 0.03, "within 0.03 of (or below) image warping"),
                ("pyramid", lambda a, b: a < b, "below the unadapted pyramid")):
            other = results.get(f"{kind}_{base}")
            if other is not None:
                ok = test(ad["lamr"], other["lamr"])
                out.append(f"- {kind}_adapted LAMR {ad['lamr']:.3f} {text} "
                           f"({other['lamr']:.3f}): {'met' if ok else 'NOT met'}")
    return ["", "## Targets", ""] + out if out else []


def _earlier_results(out: Path, data: Path) -> dict:
    """``out``'s earlier run on ``data``: method -> (frame key -> detections, s / frame)."""
    from .data import read_json

    run, det = out / "run.json", out / "detections.json"
    if not (run.is_file() and det.is_file() and (out / "frames_summary.csv").is_file()):
        raise ValueError(f"--keep-other-methods: {out} holds no earlier `bench frames` run "
                         "(run.json, detections.json, frames_summary.csv)")
    old = read_json(run)
    if Path(old.get("data", "")).resolve() != Path(data).resolve():
        raise ValueError(f"--keep-other-methods: {out} holds results on {old.get('data')}, "
                         f"not on {data}")
    secs = {}
    for line in (out / "frames_summary.csv").read_text().splitlines()[1:]:
        m, _, sec = line.split(",")[:3]
        secs[m] = float(sec)
    return {m: (d, secs.get(m, float("nan"))) for m, d in read_json(det).items()}


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
    from viewadapt.cli import _check_out, atomic_output_dir

    from .frames import METHODS, SourceDetectors, evaluate_method

    _check_out(args.out)
    methods = args.methods or list(METHODS)
    earlier = _earlier_results(args.out, args.data) if args.keep_other_methods else {}
    models = SourceDetectors.load(args.model) if args.model else None
    t0 = time.perf_counter()
    results, models, dets, frames, info = run_frames_benchmark(
        args.data, methods=methods, seed=args.seed, quick=args.quick,
        max_frames=args.max_frames, heights=args.heights,
        cache_dir=args.cache or (args.out / "cache"), models=models,
        tolerance=args.tolerance, cells_per_source_cell=args.cells_per_source_cell,
        upsample_below=args.upsample_below, jobs=args.jobs,
        frame_view=args.frame_view)
    kept = [m for m in earlier if m not in methods]
    for m in kept:
        old, sec = earlier[m]
        missing = [_frame_key(f) for f in frames if _frame_key(f) not in old]
        if missing:
            raise ValueError(f"--keep-other-methods: {m}'s earlier results lack the frames "
                             f"{missing[:3]}{' ...' if len(missing) > 3 else ''}")
        dets[m] = [np.asarray(old[_frame_key(f)], float).reshape(-1, 5) for f in frames]
        results[m] = dict(evaluate_method(dets[m], frames), seconds_per_frame=sec)
    if kept:
        print(f"kept from the earlier run in {args.out}: {', '.join(kept)}")
        methods = list(dict.fromkeys([*earlier, *methods]))     # the earlier run's order
    with atomic_output_dir(args.out) as tmp:
        lines = ["| method | LAMR (1e-2..1e0 fppi) | s / frame |", "|---|---|---|"]
        csv = ["method,lamr,seconds_per_frame,n_frames,n_gt"]
        for m in methods:
            r = results[m]
            lines.append(f"| {m} | {r['lamr']:.3f} | {r['seconds_per_frame']:.3f} |")
            csv.append(f"{m},{r['lamr']:.5f},{r['seconds_per_frame']:.5f},"
                       f"{info['n_frames']},{info['n_gt']}")
        lines += _accuracy_targets(results)
        (tmp / "frames_summary.md").write_text("\n".join(lines) + "\n")
        (tmp / "frames_summary.csv").write_text("\n".join(csv) + "\n")
        (tmp / "det_curves.json").write_text(json.dumps(
            {m: dict(zip(("fppi", "miss_rate"), (a.tolist() for a in curve_corners(
                results[m]["fppi"], results[m]["miss_rate"]))), lamr=results[m]["lamr"])
             for m in methods}))
        (tmp / "detections.json").write_text(json.dumps(
            {m: {_frame_key(f): d.tolist() for f, d in zip(frames, dets[m])}
             for m in methods}))
        plot_det_figure(results, tmp / "det_frames",
                        title=f"{info['n_frames']} frames, {info['n_gt']} persons")
        (tmp / "models").mkdir()
        models.save(tmp / "models" / "source_detectors.pkl")
        (tmp / "run.json").write_text(json.dumps(_metadata(
            args, data=str(args.data), methods=methods, kept_from_earlier_run=kept, **info,
            seconds=round(time.perf_counter() - t0, 1)), indent=2, default=str))
    print("\n".join(lines))
    print(f"\nwrote {args.out}/frames_summary.{{md,csv}}, det_frames.{{png,pdf}}, "
          "models/source_detectors.pkl")
    return 0


# -------------------------------------------------------------------------- bench runtime


def cmd_bench_runtime(args) -> int:
    from viewadapt.cli import _check_out, atomic_output_dir

    from .perf.runtime import format_table, run_runtime

    _check_out(args.out)
    t0 = time.perf_counter()
    table, info = run_runtime(args.data, n_frames=args.frames, warp_windows=args.warp_windows,
                              heights=args.heights, jobs=args.jobs, seed=args.seed,
                              quick=args.quick, cache_dir=args.cache,
                              frame_view=args.frame_view)
    md = format_table(table, info)
    with atomic_output_dir(args.out) as tmp:
        (tmp / "runtime.md").write_text(md)
        import pandas as pd

        pd.DataFrame(table).to_csv(tmp / "runtime.csv", index=False)
        (tmp / "run.json").write_text(json.dumps(_metadata(
            args, data=str(args.data), **info, seconds=round(time.perf_counter() - t0, 1)),
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


def register(sub, common) -> None:
    """Add ``detect`` and ``bench frames`` / ``bench runtime`` to the ``viewadapt`` parser."""
    p = sub.add_parser(
        "detect", parents=[common], help="detect persons in calibrated frames",
        description="Viewpoint-adapted detection over world-space windows of one calibrated "
                    "camera. The calibration file is YAML or JSON with image_size and either "
                    "K, R, t (OpenCV convention, world Z up, ground Z = 0) or focal, height "
                    "(m), tilt (degrees below horizontal) [, principal_point, roll]. Writes "
                    "detections.csv, detections_coco.json and annotated/*.png.")
    p.add_argument("frames", nargs="+", type=Path, help="frame images (PNG, JPEG)")
    p.add_argument("--calibration", type=Path, required=True, help="calibration YAML/JSON")
    p.add_argument("--model", type=Path, required=True,
                   help="source detectors (models/source_detectors.pkl of `bench frames`)")
    p.add_argument("--detector", choices=["hog", "acf"], default="hog")
    p.add_argument("--threshold", type=float, default=0.0, help="score threshold (default 0)")
    p.add_argument("--heights", type=_heights, default=(1.75,),
                   help="assumed person heights, metres, comma-separated (default 1.75)")
    p.add_argument("--cache", type=Path, default=None,
                   help="operator cache directory (default OUT/cache)")
    p.add_argument("--upsample-below", type=float, default=None,
                   help="windows of persons smaller than 96 x this many px read the frame "
                        "upsampled 2x (default 0.5, i.e. 48 px; 0 = never)")
    p.add_argument("--boxes", type=Path, default=None,
                   help="optional ground truth to evaluate against: CSV with frame,x,y,w,h"
                        "[,occlusion] or COCO JSON; writes evaluation.json and det.png "
                        "(miss rate vs FPPI, log-average miss rate)")
    p.set_defaults(func=cmd_detect)

    bsub = _bench_subparsers(sub, common)
    opts = argparse.ArgumentParser(add_help=False)
    opts.add_argument("--data", type=Path, required=True,
                      help="dataset directory with crops and frames_coco.json")
    opts.add_argument("--heights", type=_heights, default=(1.75,),
                      help="assumed person heights, metres (default 1.75)")
    opts.add_argument("--cache", type=Path, default=None,
                      help="operator cache directory (default OUT/cache)")
    opts.add_argument("--quick", action="store_true", help="smaller detectors (tests)")
    opts.add_argument("--frame-view", choices=["hog", "acf", "both", "none"], default="hog",
                      help="which detectors also train on a frame-view copy of every crop "
                           "(the crop as the adapted detector reads it from a frame; "
                           "viewadapt.frameview): default hog; none = crops alone. Ignored "
                           "with --model")
    p = bsub.add_parser("frames", parents=[common, opts],
                        help="miss rate vs FPPI on calibrated frames (Fig. 3)",
                        description="Train HOG/SVM and ACF on the dataset's elevation-0 crops, "
                                    "detect on its surveillance frames with the adapted "
                                    "detectors and the baselines, and write DET curves, "
                                    "log-average miss rates and a table.")
    p.add_argument("--methods", nargs="+", default=None,
                   choices=["hog_adapted", "hog_warp", "hog_pyramid", "opencv",
                            "opencv_native", "acf_adapted", "acf_warp", "acf_pyramid"])
    p.add_argument("--max-frames", type=int, default=None)
    p.add_argument("--tolerance", type=float, default=0.5,
                   help="shape tolerance (HOG frame cells) for windows sharing an adapted "
                        "template; 0 = an exact template per window (default 0.5)")
    p.add_argument("--cells-per-source-cell", type=float, default=0.7,
                   help="frame cells per source cell along each axis when choosing a "
                        "window's frame cell size (default 0.7)")
    p.add_argument("--upsample-below", type=float, default=None,
                   help="windows of persons smaller than 96 x this many px read the frame "
                        "upsampled 2x (default 0.5, i.e. 48 px; 0 = never)")
    p.add_argument("--model", type=Path, default=None,
                   help="reuse trained source detectors instead of training")
    p.add_argument("--keep-other-methods", action="store_true",
                   help="run only --methods and keep the other methods' results of the "
                        "earlier run in --out on the same --data (e.g. rerun the adapted "
                        "detectors without the slow image-warping baselines); the table "
                        "and figure show all. Pass that run's --model so the detectors "
                        "are the same")
    p.set_defaults(func=cmd_bench_frames)
    p = bsub.add_parser("runtime", parents=[common, opts],
                        help="frames per second per method (Table 1)",
                        description="The paper's Table 1 for this implementation.")
    p.add_argument("--frames", type=int, default=3, help="frames timed (default 3)")
    p.add_argument("--warp-windows", type=int, default=1000,
                   help="windows timed for the image-warping methods, extrapolated to all "
                        "(default 1000)")
    # two heights on the CAVIAR-like timing camera give ~30,000 windows (the paper's 31,603)
    p.set_defaults(func=cmd_bench_runtime, heights=(1.65, 1.85))
