"""``viewadapt generate`` and ``viewadapt dataset {verify,preview}``.

:func:`register` adds the subcommands to the main parser (``viewadapt/cli.py`` calls it);
everything heavy is imported inside the command functions, so ``viewadapt --help`` stays
instant and never imports Blender or torch. User mistakes raise ``ValueError`` /
``FileNotFoundError`` with a one-line message (the main CLI prints it, exit code 2).
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

__all__ = ["register", "cmd_generate", "cmd_verify", "cmd_preview", "parse_elevations"]


#: two elevations closer than this (radians) are one view given twice
SAME_ELEVATION = 1e-9
#: ``--preset`` and ``--camera-effects`` choices (generator.sampling.PRESETS and
#: generator.camera_effects.CAMERA_EFFECTS, written out so that ``--help`` imports neither)
PRESET_NAMES = ("tiny", "demo", "small", "paper", "realistic")
CAMERA_EFFECT_NAMES = ("none", "surveillance")


def parse_elevations(text: str) -> tuple[float, ...]:
    """Elevations from ``"0,pi/8,pi/4"``, ``"0,22.5deg,45deg"`` or ``"0:pi/4:3"`` (a range:
    start:stop:count, inclusive). An empty list, or one naming an elevation twice (which
    would render one view twice), is a ``ValueError``."""
    if not text.strip():
        raise ValueError("--elevations is empty; give e.g. 0,pi/8,pi/4 (or leave the option "
                         "out for the preset's)")
    def one(tok: str) -> float:
        tok = tok.strip().lower()
        if not tok:
            raise ValueError("empty elevation")
        if tok.endswith("deg"):
            return math.radians(float(tok[:-3]))
        if "pi" in tok:
            num, _, den = tok.partition("/")
            k = num.replace("pi", "").replace("*", "").strip()
            v = (float(k) if k else 1.0) * math.pi
            return v / float(den) if den else v
        return float(tok)

    try:
        if ":" in text:
            a, b, n = text.split(":")
            n = int(n)
            if n < 1:
                raise ValueError
            lo, hi = one(a), one(b)
            vals = [lo + (hi - lo) * i / max(n - 1, 1) for i in range(n)]
        else:
            vals = [one(t) for t in text.split(",")]
    except (ValueError, ZeroDivisionError, OverflowError):
        raise ValueError(f"--elevations: cannot parse {text!r}; use e.g. 0,pi/8,pi/4 or "
                         f"0deg,22.5deg,45deg or 0:pi/4:3") from None
    for v in vals:
        if not math.isfinite(v) or not 0 <= v < math.pi / 2:
            raise ValueError(f"--elevations: {v:.4f} rad is outside [0, pi/2)")
    for i, v in enumerate(vals):
        if any(abs(v - w) < SAME_ELEVATION for w in vals[:i]):
            raise ValueError(f"--elevations {text}: {v:.4f} rad is given twice (each elevation "
                             "is rendered once per instance)")
    return tuple(vals)


def cmd_generate(args) -> int:
    from .pipeline import generate
    from .sampling import parse_shard, preset_config

    over = {"renderer": args.renderer}
    if args.elevations is not None:
        over["elevations"] = parse_elevations(args.elevations)
    if args.framing:
        over["framing"] = args.framing
    if getattr(args, "distance", None) is not None:
        over["distance"] = args.distance
    if getattr(args, "camera_effects", None) is not None:
        over["camera_effects"] = args.camera_effects
    for name in ("samples", "instances", "persons", "scenes", "frames", "backgrounds"):
        v = getattr(args, name, None)
        if v is not None:
            if v < 1:
                raise ValueError(f"--{name} must be at least 1")
            over[{"persons": "n_persons", "scenes": "n_scenes",
                  "backgrounds": "backgrounds_per_scene"}.get(name, name)] = v
    config = preset_config(args.preset, **over)
    shard = parse_shard(args.shard) if args.shard else None
    if args.jobs == 0 or args.jobs < -1:
        raise ValueError("--jobs must be a positive number of workers or -1 (all cores)")
    res = generate(config, args.seed, args.out, jobs=args.jobs, shard=shard,
                   scheduler=args.scheduler, progress=not args.quiet,
                   overwrite=getattr(args, "overwrite", False))
    print(res.summary())
    return 0


def cmd_verify(args) -> int:
    from viewadapt.io.files import check_apart

    from .verify import verify_dataset

    check_apart({"--json": args.json}, {"DIRECTORY": args.directory})
    rep = verify_dataset(args.directory, decode=not args.fast, check_plan=not args.no_plan,
                         check_hash=args.hash)
    print(rep.summary())
    if args.json:
        from viewadapt.io.files import atomic_write_text

        atomic_write_text(args.json, json.dumps({"ok": rep.ok, "n_rows": rep.n_rows,
                                                 "n_ok": rep.n_ok, "problems": rep.problems},
                                                indent=1))
    return 0 if rep.ok else 1


def cmd_preview(args) -> int:
    from viewadapt.io.files import check_apart

    from .preview import preview_dataset

    check_apart({"--out": args.out}, {"DIRECTORY": args.directory})
    paths = preview_dataset(args.directory, args.out, columns=args.columns, rows=args.rows,
                            boxes=args.boxes)
    for p in paths:
        print(f"wrote {p}")
    return 0


def register(subparsers, common_parser: argparse.ArgumentParser) -> None:
    """Add ``generate`` and ``dataset`` to a parser's subparsers.

    ``common_parser`` supplies ``--seed``, ``--out``, ``--jobs`` (used by ``generate``).
    """
    p = subparsers.add_parser(
        "generate", parents=[common_parser],
        help="render the synthetic multi-view person dataset with Blender",
        description="Render persons (anny bodies) in 13 procedural scenes at several camera "
                    "elevations (paper: 0, pi/8, pi/4), person-free backgrounds and "
                    "calibrated surveillance frames; write images, manifest.parquet/.csv, "
                    "frames_coco.json and dataset.json into --out. Rerunning with the same "
                    "--out finishes an interrupted run (every kept file is checked and a "
                    "truncated or corrupt one rendered again) or, with a larger --frames "
                    "or --backgrounds, extends a finished one; dataset.json records the "
                    "content hash of a complete set (the same for the same seed and settings).")
    p.add_argument("--preset", choices=PRESET_NAMES, default="tiny",
                   help="dataset size (tiny: 6 persons x 3 scenes, ~1 min; demo: 18 x 9 at "
                        "elevations 0 and pi/4 only, for `viewadapt demo`; small: 24 x 9 x 2 "
                        "instances; paper: 68 x 13 x 3 = 7956 crops; realistic: small "
                        "through surveillance-camera effects)")
    p.add_argument("--renderer", choices=("cycles", "pyrender"), default="cycles")
    p.add_argument("--shard", metavar="I/N", help="render only block I of N (job arrays)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="Dask distributed scheduler (tcp://host:port) instead of local workers")
    p.add_argument("--elevations", metavar="LIST",
                   help="camera elevations, e.g. 0,pi/8,pi/4 (default) or 0:pi/3:5")
    p.add_argument("--framing", choices=("plane", "silhouette"),
                   help="crop framing (default plane: the paper's fixed camera set-up)")
    p.add_argument("--distance", type=float, metavar="METRES",
                   help="crop camera to person-centre distance, the same at every elevation "
                        "(default 10; closer means stronger perspective: the crop's focal "
                        "length scales with it, so the person stays 96 px tall at elevation 0)")
    p.add_argument("--samples", type=int, help="Cycles samples per pixel for crops")
    p.add_argument("--instances", type=int, help="placements per person and scene")
    p.add_argument("--persons", type=int, help="number of persons from the roster")
    p.add_argument("--scenes", type=int, help="number of scenes")
    p.add_argument("--frames", type=int,
                   help="calibrated surveillance frames in total, spread over the scenes "
                        "(presets: tiny 1, demo 1, small 9, paper 26); frame k of a scene is the "
                        "same whatever the total, so a larger --frames extends a set")
    p.add_argument("--backgrounds", type=int,
                   help="person-free background views per scene, each rendered at every "
                        "elevation (presets: tiny 1, demo 3, small 3, paper 7); view k of a "
                        "scene is the same whatever the number, so a larger --backgrounds "
                        "extends a set")
    p.add_argument("--camera-effects", choices=CAMERA_EFFECT_NAMES,
                   help="camera effects every image passes through before it is written, "
                        "each image its own draw, recorded in the manifest's camera_effects "
                        "column (surveillance: blur, vignetting, white balance, exposure, "
                        "sensor noise, tone curve, lower resolution, JPEG; none: clean "
                        "renders); default: the preset's (realistic: surveillance, the "
                        "others: none)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_generate)

    d = subparsers.add_parser("dataset", help="check or preview a generated dataset")
    dsub = d.add_subparsers(dest="dataset_command", metavar="ACTION", required=True)
    v = dsub.add_parser("verify", help="find missing, truncated or unreadable files",
                        description="Check every manifest row's image (exists, complete PNG, "
                                    "decodes to the recorded size), name every file anywhere "
                                    "in the folder that the dataset does not hold, and check "
                                    "that everything dataset.json plans was generated. Exit "
                                    "code 1 if anything is wrong.")
    v.add_argument("directory", type=Path)
    v.add_argument("--fast", action="store_true", help="skip decoding the images")
    v.add_argument("--no-plan", action="store_true", help="skip re-planning the dataset")
    v.add_argument("--hash", action="store_true",
                   help="also recompute the content hash (sha256 over the data files: the "
                        "images and depth maps the manifest lists, the manifest, "
                        "frames_coco.json; no other file) and compare it with the one "
                        "dataset.json records")
    v.add_argument("--json", type=Path, help="also write the report as JSON")
    v.set_defaults(func=cmd_verify)
    pv = dsub.add_parser("preview", help="contact sheets (one block per elevation) as PNG")
    pv.add_argument("directory", type=Path)
    pv.add_argument("--out", type=Path, required=True, help="output .png")
    pv.add_argument("--columns", type=int, default=12)
    pv.add_argument("--rows", type=int, default=3)
    pv.add_argument("--boxes", action="store_true", help="draw silhouette boxes")
    pv.set_defaults(func=cmd_preview)
