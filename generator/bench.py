"""Throughput benchmark of the renderers (not a test): ``python -m generator.bench``.

Renders a sample of the paper-scale plan (crops, backgrounds, frames) into a temporary
directory with the same code path as ``viewadapt generate`` (one process, all cores) and
prints images/s per image kind, then extrapolates the time of the paper-scale dataset
(7956 crops + backgrounds + frames). Warm-up (Blender, anny, the first scene) is timed
separately and excluded from the rates.

``--camera-effects surveillance`` renders the same sample twice in one run, without and
with the camera effects (:mod:`generator.camera_effects`), and prints each image kind's
cost with effects as a ratio of its cost without; the target is at most
:data:`EFFECTS_COST_TARGET` times.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

__all__ = ["run_benchmark", "time_preset", "effects_cost", "main", "EFFECTS_COST_TARGET"]

#: the most an image with camera effects may cost, as a multiple of the same image without
EFFECTS_COST_TARGET = 1.5


def run_benchmark(*, persons: int = 6, scenes: int = 3, samples: int | None = None,
                  threads: int | None = None, renderer: str = "cycles", out=None,
                  camera_effects: str = "none") -> dict:
    """Time crops, backgrounds and frames; returns a dict of rates and the extrapolation."""
    from . import pipeline
    from .sampling import plan_dataset, preset_config
    from .specs import load_roster, load_scenes

    over = {"renderer": renderer, "camera_effects": camera_effects}
    if samples:
        over["samples"] = samples
    paper = preset_config("paper", **over)
    sub = preset_config("paper", n_persons=persons, n_scenes=scenes, frames=scenes,
                        backgrounds_per_scene=1, instances=1, **over)
    plan = plan_dataset(sub, 0, scenes=load_scenes(), persons=load_roster())
    tmp = tempfile.TemporaryDirectory(prefix="viewadapt-bench-") if out is None else None
    out = Path(out or tmp.name)
    ncpu = pipeline.cpu_count()
    threads = threads or ncpu
    pipeline.STATE.setdefault("threads", threads)
    t0 = time.perf_counter()
    pipeline.worker_state(sub, threads)               # Blender + anny start-up
    warm = time.perf_counter() - t0
    per_kind: dict[str, list] = {"person": [0, 0.0], "background": [0, 0.0], "frame": [0, 0.0]}
    seen_scenes = set()
    for u in plan.units:
        payload = {"unit": u, "scene": plan.scenes[u.scene_id],
                   "persons": {pid: plan.persons[pid]
                               for pid in pipeline.unit_person_ids(u)},
                   "config": sub, "out": str(out), "threads": threads}
        if u.scene_id not in seen_scenes:             # scene build is a one-off per scene
            t1 = time.perf_counter()
            pipeline.STATE["renderer"].load_scene(pipeline.scene_layout(plan.scenes[u.scene_id]))
            warm += time.perf_counter() - t1
            seen_scenes.add(u.scene_id)
        res = pipeline.run_unit(payload)
        per_kind[u.kind][0] += res["rendered"]
        per_kind[u.kind][1] += res["seconds"]
    rates = {k: (n / s if s > 0 else float("nan")) for k, (n, s) in per_kind.items()}
    n_crops = paper.n_persons * paper.n_scenes * paper.instances * len(paper.elevations)
    n_bg = paper.n_scenes * paper.backgrounds_per_scene * len(paper.elevations)
    n_frames = paper.frames
    est = n_crops / rates["person"] + n_bg / rates["background"] + n_frames / rates["frame"]
    if tmp is not None:
        tmp.cleanup()
    return {"renderer": renderer, "camera_effects": camera_effects, "threads": threads,
            "cpus": ncpu,
            "samples": sub.samples, "warmup_s": warm, "rates": rates,
            "counts": {k: v[0] for k, v in per_kind.items()},
            "paper": {"crops": n_crops, "backgrounds": n_bg, "frames": n_frames,
                      "estimated_s": est}}


def effects_cost(without: dict, with_effects: dict) -> dict:
    """Per image kind, the cost (seconds per image) with camera effects as a multiple of
    the cost without, from two :func:`run_benchmark` results of the same sample."""
    return {k: without["rates"][k] / with_effects["rates"][k] for k in without["rates"]}


def time_preset(name: str = "tiny", *, renderer: str = "cycles", jobs: int = 1) -> dict:
    """Render a whole preset end to end (start-up included) into a temporary directory,
    as ``viewadapt generate --preset NAME`` does; returns its images and seconds."""
    from . import pipeline
    from .sampling import preset_config

    with tempfile.TemporaryDirectory(prefix="viewadapt-bench-") as tmp:
        t0 = time.perf_counter()
        res = pipeline.generate(preset_config(name, renderer=renderer), 0, Path(tmp) / name,
                                jobs=jobs, progress=False)
        seconds = time.perf_counter() - t0
    return {"preset": name, "renderer": renderer, "images": res.n_images,
            "complete": res.complete, "seconds": seconds}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m generator.bench", description=__doc__)
    ap.add_argument("--persons", type=int, default=6)
    ap.add_argument("--scenes", type=int, default=3)
    ap.add_argument("--samples", type=int)
    ap.add_argument("--threads", type=int)
    ap.add_argument("--renderer", choices=("cycles", "pyrender", "both"), default="both")
    ap.add_argument("--camera-effects", choices=("none", "surveillance"), default="none",
                    help="surveillance: render the sample without and with camera effects "
                         f"and print the cost ratio (target <= {EFFECTS_COST_TARGET}x)")
    ap.add_argument("--preset", choices=("tiny", "small"),
                    help="instead: time the whole preset end to end with Cycles "
                         "(the tiny preset's target is <= 3 min here)")
    args = ap.parse_args(argv)
    if args.preset:
        r = time_preset(args.preset)
        print(f"preset {r['preset']}: {r['images']} images with {r['renderer']} in "
              f"{r['seconds']:.0f} s ({r['images'] / r['seconds']:.2f} images/s, "
              f"start-up included)" + ("" if r["complete"] else "  INCOMPLETE"))
        return 0 if r["complete"] else 1
    for renderer in (("cycles", "pyrender") if args.renderer == "both" else (args.renderer,)):
        if renderer == "pyrender":
            try:
                import warnings

                warnings.filterwarnings("ignore", message="tostring", category=DeprecationWarning)
                import pyrender  # noqa: F401
            except ImportError:
                print("pyrender: not installed here (optional: pip install pyrender); skipping")
                continue
        kw = dict(persons=args.persons, scenes=args.scenes, samples=args.samples,
                  threads=args.threads, renderer=renderer)
        plain = run_benchmark(**kw)
        _report(plain)
        if args.camera_effects != "none":
            fx = run_benchmark(camera_effects=args.camera_effects, **kw)
            _report(fx)
            ratios = effects_cost(plain, fx)
            print(f"  cost with {args.camera_effects} effects / without: " + ", ".join(
                f"{k} {v:.2f}x" for k, v in ratios.items())
                + f"  (target <= {EFFECTS_COST_TARGET}x: "
                + ("met" if max(ratios.values()) <= EFFECTS_COST_TARGET else "NOT met") + ")")
    return 0


def _report(r) -> None:
    print(f"renderer {r['renderer']}  effects {r['camera_effects']}  "
          f"threads {r['threads']}/{r['cpus']} cpus  "
          f"crop samples {r['samples']}  warm-up {r['warmup_s']:.1f} s")
    for k in ("person", "background", "frame"):
        print(f"  {k:10s} {r['counts'][k]:4d} images  {r['rates'][k]:6.2f} images/s")
    p = r["paper"]
    print(f"paper scale ({p['crops']} crops + {p['backgrounds']} backgrounds + "
          f"{p['frames']} frames): ~{p['estimated_s'] / 60:.1f} min")


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
