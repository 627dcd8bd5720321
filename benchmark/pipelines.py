"""The end-to-end commands above the benchmarks: ``viewadapt demo`` (behind ``make demo``),
``viewadapt reproduce`` (the paper-scale run) and ``viewadapt fidelity`` (how well remapped
features match those of warped windows).

``demo`` and ``reproduce`` chain the other commands (``generate``, ``bench crossval``,
``bench sweep``, ``bench frames``, ``detect``) through :func:`viewadapt.cli.main`, exactly
as a user would type them.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from viewadapt.cli import common_parser, main

from benchmark.recipes import PAPER_RECIPE, add_recipe_argument
from viewadapt.io.files import (
    UserError, atomic_output_dir, atomic_write_text, check_output_dir, claim_output_dir,
    run_metadata,
)

__all__ = ["register", "DEMO_CROSSVAL", "DEMO_RECIPE", "blender_available", "demo_frames"]


def _cmd_fidelity(args) -> int:
    from benchmark.crops.fidelity import (
        remap_fidelity, sample_images, summarize_fidelity, synthetic_images,
    )
    from benchmark.crops.figures import plot_fidelity, plot_remap_illustration, save_figure
    from viewadapt.geometry import check_distance, elevation_homography

    check_output_dir(args.out, overwrite=args.overwrite)
    if args.windows < 1:
        raise UserError("--windows must be at least 1")
    try:
        check_distance(args.distance)
    except ValueError as exc:
        raise UserError(f"--distance: {exc}") from None
    rng = np.random.default_rng(args.seed)
    images = sample_images() | synthetic_images(rng, n=args.synthetic)
    t0 = time.perf_counter()
    df = remap_fidelity(images, windows_per_image=args.windows, rng=rng, progress=True,
                        distance=args.distance)
    summary = summarize_fidelity(df)
    with atomic_output_dir(args.out) as tmp:
        df.to_csv(tmp / "fidelity_windows.csv", index=False)
        summary.to_csv(tmp / "fidelity_summary.csv", index=False)
        (tmp / "fidelity_summary.md").write_text(_fidelity_markdown(summary))
        import matplotlib.pyplot as plt

        for tc in (8, 4):
            fig = plot_fidelity(summary, target_cell_size=tc)
            save_figure(fig, tmp / f"fidelity_{tc}px")
            plt.close(fig)
        img = images["astronaut"]
        fig = plot_remap_illustration(img, 200, 60, elevation_homography(
            0.0, np.pi / 4, distance=args.distance), title="0 → π/4,")
        save_figure(fig, tmp / "remap_illustration")
        plt.close(fig)
        (tmp / "metadata.json").write_text(json.dumps(
            run_metadata(args.seed, windows_per_image=args.windows, images=sorted(images),
                         distance=args.distance,
                         seconds=round(time.perf_counter() - t0, 1)), indent=2))
    print(_fidelity_markdown(summary, compact=True))
    print(f"\nwrote {args.out}/fidelity_summary.{{csv,md}}, fidelity_*px.{{png,pdf}}, "
          f"remap_illustration.{{png,pdf}}")
    return 0


def _fidelity_markdown(summary, compact: bool = False) -> str:
    s = summary.copy()
    s["pair"] = [f"{np.rad2deg(a):.1f}°→{np.rad2deg(b):.1f}°"
                 for a, b in zip(s["source_elevation"], s["target_elevation"])]
    if compact:
        s = s[(s["form"].isin(["per-cell", "-"]))]
        s = s[(s["rule"] == "unadapted") | (s["target_cell_size"].isin([4])) |
              s["feature"].str.startswith("acf")]
        piv = s.pivot_table(index=["feature", "pair"], columns="rule", values="median")
        cols = [c for c in ("unadapted", "none", "paper", "covariant") if c in piv.columns]
        return ("Median per-window Pearson r of G·x_target vs features of the warped window "
                "(per-cell A; HOG target cells 4 px):\n" + piv[cols].round(3).to_string())
    cols = ["feature", "pair", "rule", "form", "target_cell_size", "median", "mean", "p10",
            "n_windows"]
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for _, r in s[cols].iterrows():
        lines.append("| " + " | ".join(f"{v:.3f}" if isinstance(v, float) else str(v)
                                       for v in r) + " |")
    return "\n".join(lines) + "\n"


def blender_available() -> bool:
    import importlib.util

    return (importlib.util.find_spec("bpy") is not None
            and importlib.util.find_spec("generator.cli") is not None)


#: what the demo cross-validates: the paper's headline pair (train at 0, test at pi/4, and
#: the oracle trained at pi/4) for HOG/SVM (the paper's detector) and ACF, plane object model,
#: without the per-positive exact-geometry rows (the slowest, a diagnostic)
#: the demo's source-training recipe: at the demo's size (18 persons x 9 scenes) the rotated
#: negatives take adapted HOG clearly past unadapted; at the paper's size they make every row
#: worse, so the other commands default to :data:`benchmark.recipes.DEFAULT_RECIPE`
#: (docs/training.md)
DEMO_RECIPE = "rotated"
DEMO_CROSSVAL = ["--quick", "--detectors", "hog", "acf", "--sources", "0,pi/4",
                 "--object-models", "plane", "--no-upper-bound"]


def _cmd_demo(args) -> int:
    """demo dataset -> cross-validation -> full frames, end to end, then a short summary."""
    import importlib.util

    from benchmark.crops.report import closing_summary

    overwrite = getattr(args, "overwrite", False)
    claim_output_dir(args.out, overwrite=overwrite)
    out = Path(args.out)
    data, results = out / "data", out / "results"
    t0 = time.perf_counter()
    seed = ["--seed", str(args.seed)] + (["--overwrite"] if overwrite else [])
    jobs = ["--jobs", str(args.jobs)]
    recipe = ["--recipe", args.recipe.name]
    timings = []

    def stage(k, name, fn):
        print(f"[{k}/3] {name}", flush=True)
        t = time.perf_counter()
        rc = fn()
        timings.append(f"{name.split(' ')[0]} {time.perf_counter() - t:.0f} s")
        return rc

    if args.toy or not blender_available():
        if not args.toy:
            print("viewadapt demo: Blender (bpy) is not installed, so the demo uses the "
                  "numpy planar toy dataset instead of Blender renders "
                  "(pip install -e '.[generator]' for the real one)")
        from benchmark.toyframes import make_toy_frame_dataset

        what = "the numpy planar toy dataset (9 persons x 3 scenes)"

        def render():
            if not (data / "dataset.json").is_file():
                check_output_dir(data, overwrite=overwrite)
                with atomic_output_dir(data) as tmp:
                    make_toy_frame_dataset(tmp, n_persons=9, n_scenes=3, n_backgrounds=3,
                                           n_frame_scenes=1, frames_per_scene=2,
                                           seed=args.seed)
            return 0
    else:
        renderer = "pyrender" if importlib.util.find_spec("pyrender") else "cycles"
        if renderer == "cycles":
            print("viewadapt demo: pyrender is not installed, so the demo renders with "
                  "Blender Cycles, about 3x slower (pip install -e '.[raster]')")
        from benchmark.crops.report import elevation_label
        from generator.sampling import preset_config

        c = preset_config("demo")
        what = (f"the demo preset ({c.n_persons} persons x {c.n_scenes} scenes, elevations "
                f"{' and '.join(map(elevation_label, c.elevations))}, {renderer})")

        def render():
            return main(["generate", "--preset", "demo", "--renderer", renderer, "--quiet",
                         "--out", str(data)] + jobs + seed)
    rc = stage(1, f"rendering {what}", render)
    if rc:
        return rc
    rc = stage(2, "cross-validation (nine person/scene-disjoint folds)", lambda: main(
        ["bench", "crossval", "--data", str(data), "--out", str(results)] + DEMO_CROSSVAL
        + jobs + seed + recipe))
    if rc:
        return rc
    rc = stage(3, "full-frame detection on the dataset's calibrated frames",
               lambda: demo_frames(data, out, jobs + seed + recipe))
    if rc:
        return rc
    print(f"\n== viewadapt demo: {what}; HOG/SVM and ACF trained at elevation 0 (recipe "
          f"{args.recipe.name}), tested at "
          f"π/4, against the oracle trained at π/4 ({time.perf_counter() - t0:.0f} s: "
          f"{', '.join(timings)})")
    for line in closing_summary(results):
        print(line)
    print(f"report and DET figures: {results / 'report.md'}, {results}/det_*.png; full frames "
          f"(a small illustration, not a measurement): {out / 'frames' / 'frames_summary.md'}, "
          f"{out / 'detections' / 'annotated'} (at 1 false positive per frame: hits green, "
          f"false positives red, misses orange)")
    return 0


def demo_frames(data: Path, out: Path, extra: list) -> int:
    """The demo's last stage: ``bench frames`` (the adapted detectors and OpenCV's; quick
    detectors trained on the crops alone: frame-view copies would quadruple the training
    time, and the image-warping baselines take 10-20 s a frame) on the dataset's frames,
    then ``detect`` on one camera's frames through a calibration file written in the
    documented format, as a user would, scored against the dataset's ``frames_coco.json``
    and drawn where it has one false positive per frame (hits, misses and false positives
    in their colours)."""
    from benchmark.frames.methods import load_frames

    frames = load_frames(data)
    rc = main(["bench", "frames", "--data", str(data), "--out", str(out / "frames"), "--quick",
               "--frame-view", "none",
               "--methods", "hog_adapted", "acf_adapted", "opencv_native"] + extra)
    if rc:
        return rc
    cam = frames[0].camera.to_dict()
    same = [f for f in frames if f.camera.to_dict() == cam]
    calib = out / "frames" / "camera.json"
    calib.write_text(json.dumps(cam, indent=2))
    return main(["detect", "--calibration", str(calib), "--model",
                 str(out / "frames" / "models" / "source_detectors.npz"),
                 "--boxes", str(Path(data) / "frames_coco.json"), "--annotate-fppi", "1",
                 "--out", str(out / "detections")] + [x for x in extra if x == "--overwrite"]
                + [str(f.path) for f in same])


def _cmd_reproduce(args) -> int:
    """paper-scale dataset -> cross-validation -> sweep -> full frames, end to end."""
    overwrite = getattr(args, "overwrite", False)
    check_output_dir(args.out, overwrite=overwrite)
    if not blender_available():
        raise UserError("reproduce renders the paper-scale dataset with Blender: install the "
                        "generator extra (pip install -e '.[generator]')")
    claim_output_dir(args.out, overwrite=overwrite)
    out = Path(args.out)
    data, results, frames = out / "data", out / "results", out / "frames"
    seed = ["--seed", str(args.seed)] + (["--overwrite"] if overwrite else [])
    jobs = ["--jobs", str(args.jobs)] + ["--recipe", args.recipe.name]
    stages = {}

    def stage(name, argv):
        print(f"[{len(stages) + 1}/4] {name}", flush=True)
        t = time.perf_counter()
        rc = main(argv)
        stages[name] = round(time.perf_counter() - t, 1)
        print(f"    {name}: {stages[name] / 60:.1f} min", flush=True)
        return rc

    steps = [
        ("render the paper-scale dataset (resumes an interrupted run)",
         ["generate", "--preset", "paper", "--framing", args.framing, "--out", str(data),
          "--jobs", "1"] + seed),
        ("nine-fold cross-validation", ["bench", "crossval", "--data", str(data), "--out",
                                        str(results)] + jobs + seed),
        ("elevation sweep", ["bench", "sweep", "--data", str(data), "--out", str(results)]
         + jobs + seed),
        ("full-frame detection", ["bench", "frames", "--data", str(data), "--out",
                                  str(frames), "--heights", "1.65,1.85"] + jobs + seed),
    ]
    for name, argv in steps:
        rc = stage(name, argv)
        if rc:
            return rc
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out / "reproduce.json", json.dumps({"stage_seconds": stages}, indent=2))
    print(f"\nreproduce finished; open {results / 'report.md'} and {frames / 'frames_summary.md'}")
    return 0


def register(sub, common) -> None:
    """Add ``fidelity``, ``demo`` and ``reproduce`` to the ``viewadapt`` parser."""
    p = sub.add_parser(
        "fidelity", parents=[common],
        help="measure how well remapped features match features of warped windows",
        description="For elevation pairs 0→π/8, 0→π/4, π/8→π/4, compare G·x_target with "
                    "the features of the window warped into the source view, for HOG cells, "
                    "block-normalised HOG, locally normalised HOG and ACF, every angle rule "
                    "(covariant J^-T, the paper's literal eq. 3, none), single vs per-cell A "
                    "and 8 vs 4 px target cells. Writes CSV/Markdown tables and figures.")
    p.add_argument("--windows", type=int, default=20, help="windows per image (default 20)")
    p.add_argument("--synthetic", type=int, default=3,
                   help="synthetic pattern images added to the natural ones (default 3)")
    p.add_argument("--distance", type=float, default=10.0, metavar="METRES",
                   help="the crop camera's distance, which sets the homographies' perspective "
                        "(default 10, the generator's default)")
    p.set_defaults(func=_cmd_fidelity)

    p = sub.add_parser("demo", parents=[common_parser(jobs=-1)],
                       help="show the effect in a few minutes (behind `make demo`)",
                       description="The short run behind `make demo` (about 3-4 min on 2 "
                                   "cores): render the demo preset (18 persons x 9 scenes at "
                                   "elevations 0 and pi/4, with pyrender; the numpy planar toy "
                                   "set when Blender is not installed), cross-validate HOG/SVM "
                                   "and ACF trained at 0 and tested at pi/4 against the oracle "
                                   "(quick detectors, plane object model, no exact-geometry "
                                   "rows), write OUT/results/report.md, detect on the "
                                   "dataset's calibrated frame with the adapted detectors and "
                                   "OpenCV's (an illustration; `viewadapt bench frames` for "
                                   "the image-warping baselines), and end with a short "
                                   "summary read from the results files. The elevation sweep and the remap fidelity "
                                   "are not part of the demo: run `viewadapt bench sweep` and "
                                   "`viewadapt fidelity`. --jobs defaults to all cores here.")
    p.add_argument("--toy", action="store_true",
                   help="use the numpy planar toy dataset even when Blender is installed")
    add_recipe_argument(p, what="HOG/SVM and ACF", default=DEMO_RECIPE,
                        why="; at the demo's size it is what lets adaptation show, at the "
                            "paper's size it costs every row: docs/training.md")
    p.set_defaults(func=_cmd_demo)

    p = sub.add_parser("reproduce", parents=[common_parser(jobs=-1)],
                       help="the paper-scale run end to end (render, cross-validate, sweep, "
                            "frames)",
                       description="Render the paper-scale dataset (68 persons x 13 scenes x "
                                   "3 instances x 3 elevations = 7956 crops, backgrounds, "
                                   "frames; about 25 min with Cycles on 2 cores), run the "
                                   "nine-fold cross-validation of every detector and method, "
                                   "the elevation sweep and the full-frame benchmark, and "
                                   "write OUT/results/report.md and OUT/frames/. Rerunning "
                                   "finishes an interrupted render.")
    p.add_argument("--framing", choices=["plane", "silhouette"], default="plane",
                   help="crop framing of the rendered dataset (default plane, the paper's)")
    add_recipe_argument(p, what="every detector that trains", default=PAPER_RECIPE,
                        why="; the paper's training, as the paper's protocol on its clean "
                            "renders: docs/training.md")
    p.set_defaults(func=_cmd_reproduce)
