"""Resuming a dataset: which settings may change, which kept files are sound, what is kept.

``viewadapt generate`` into a directory that already holds a dataset finishes it (or
extends it by more frames or background views): :func:`check_resumable` names every
setting that differs; :func:`check_finished_unit` checks each file a finished work unit
kept (a full PNG check, :func:`generator.png.png_problem`; depth maps read back) and
removes the bad ones so they are rendered again; :func:`count_kept_images` says what an
interrupted run leaves.
"""

from __future__ import annotations

import json
from pathlib import Path

from viewadapt.io.files import RunError, UserError

from .contents import unit_depth_paths, unit_paths
from .manifest import depth_is_complete, read_part
from .camera_effects import NO_EFFECTS
from .png import normalize_png, png_problem
from .sampling import GeneratorConfig

__all__ = ["OPTION_NAMES", "EXTENSIBLE", "config_differences", "check_resumable", "image_size",
           "check_image", "check_depth", "check_finished_unit", "count_kept_images",
           "pending_units", "remove_if_nothing_kept", "interrupted"]

#: config fields -> the ``generate`` option that sets them
OPTION_NAMES = {"preset": "--preset", "n_persons": "--persons", "n_scenes": "--scenes",
                "instances": "--instances", "elevations": "--elevations",
                "framing": "--framing", "renderer": "--renderer", "samples": "--samples",
                "frames": "--frames", "backgrounds_per_scene": "--backgrounds",
                "camera_effects": "--camera-effects"}

#: settings a finished dataset can be extended by (item k of a scene is the same whatever
#: their number: frames and background views are seeded per scene and index)
EXTENSIBLE = {"frames": ("frames", "frames"),
              "backgrounds_per_scene": ("background views per scene", "background views")}


def _normalised(config: dict) -> dict:
    """A config dict with the defaults of fields it lacks (written by an older version, or
    left out of ``dataset.json``: ``camera_effects`` while ``"none"``)."""
    try:
        d = GeneratorConfig.from_dict(config).to_dict()
    except (TypeError, ValueError):
        d = dict(config)
    d.setdefault("camera_effects", NO_EFFECTS)
    return d


def _show(v) -> str:
    if isinstance(v, list) and all(isinstance(x, float) for x in v):
        return ",".join(f"{x:.6g}" for x in v)
    return json.dumps(v) if not isinstance(v, str) else v


def config_differences(old: dict, new: dict) -> list[tuple[str, object, object]]:
    """``(setting, dataset's value, this run's value)`` for every differing setting of two
    ``dataset.json`` documents (the seed and each config field)."""
    out = []
    if old.get("seed") != new.get("seed"):
        out.append(("seed", old.get("seed"), new.get("seed")))
    a, b = _normalised(old.get("config") or {}), _normalised(new.get("config") or {})
    for k in sorted(set(a) | set(b), key=lambda k: (k not in OPTION_NAMES, k)):
        if json.dumps(a.get(k), sort_keys=True) != json.dumps(b.get(k), sort_keys=True):
            out.append((k, a.get(k), b.get(k)))
    return out


def check_resumable(old: dict, new: dict, out) -> bool:
    """Raise ``ValueError`` naming each setting that differs between the dataset in
    ``out`` (``old``) and this run (``new``), unless only settings of :data:`EXTENSIBLE`
    grew (frame k and background view k of a scene are the same whatever their number, so
    more of them extend the set). Returns True when the run extends the set."""
    diffs = config_differences(old, new)
    if not diffs:
        return False
    if all(k in EXTENSIBLE for k, _, _ in diffs):
        for k, have, want in diffs:
            if not (isinstance(have, int) and isinstance(want, int) and want > have):
                opt, (counted, noun) = OPTION_NAMES[k], EXTENSIBLE[k]
                raise ValueError(f"{out} holds a dataset of {have} {counted}; {opt} {want} "
                                 f"would leave {noun} out ({noun} can only be added): pass "
                                 f"{opt} {have} or more, or choose another --out")
        return True
    shown = []
    for k, have, want in diffs:
        opt = "--seed" if k == "seed" else OPTION_NAMES.get(k, f"config field {k!r}")
        shown.append(f"{opt} {_show(have)} (this run: {_show(want)})")
    raise ValueError(f"{out} holds a dataset with a different config or seed: it was made "
                     f"with {'; '.join(shown)}; rerun with its settings to finish it, or "
                     "choose another --out")


def image_size(config: GeneratorConfig, kind: str) -> tuple[int, int]:
    """``(width, height)`` of an image of ``kind`` (person, background, frame)."""
    return tuple({"person": config.crop_size, "background": config.background_size,
                  "frame": config.frame_size}[kind])


def check_image(path: Path, size) -> str | None:
    """None if ``path`` is a sound PNG of ``size`` (its text/time chunks dropped in place,
    so an image rendered before they were is byte-reproducible too); else the problem,
    and a bad file is removed (it is rendered again)."""
    problem = png_problem(path, size)
    if problem is None:
        normalize_png(path)
        return None
    if problem != "missing":
        path.unlink(missing_ok=True)
    return problem


def check_depth(path: Path, shape) -> str | None:
    """None if ``path`` is a sound depth map of ``shape`` ((height, width)); else the
    problem (a bad file is removed)."""
    if not path.is_file():
        return "missing"
    if not depth_is_complete(path, shape):
        path.unlink(missing_ok=True)
        return "unreadable or of the wrong size"
    return None


def check_finished_unit(out: Path, unit, config: GeneratorConfig, images, depths) -> list:
    """``(relative path, problem)`` of each file of a finished unit that is missing or
    bad (bad files are removed, so the unit renders them again)."""
    size = image_size(config, unit.kind)
    bad = []
    for rel in images:
        p = check_image(out / rel, size)
        if p is not None:
            bad.append((rel, p))
    for rel in depths:
        p = check_depth(out / rel, (size[1], size[0]))
        if p is not None:
            bad.append((rel, p))
    return bad


def count_kept_images(out: Path, paths) -> int:
    """How many of the planned image ``paths`` lie in ``out``."""
    return sum(1 for rel in paths if (out / rel).is_file())


def pending_units(out: Path, units, config: GeneratorConfig):
    """The units to run, and how many kept files of finished units were bad (removed, so
    they are rendered again; said on stderr)."""
    import sys

    pending, bad = [], []
    for u in units:
        if read_part(out, u.uid) is None:
            pending.append(u)
            continue
        problems = check_finished_unit(out, u, config, unit_paths(u), unit_depth_paths(u))
        if problems:
            pending.append(u)
            bad += [(rel, p) for rel, p in problems if p != "missing"]
    if bad:
        rel, p = bad[0]
        print(f"viewadapt generate: {len(bad)} kept file(s) are truncated or corrupt (e.g. "
              f"{rel}: {p}); rendering them again", file=sys.stderr, flush=True)
    return pending, len(bad)


def remove_if_nothing_kept(out: Path, plan) -> bool:
    """Remove ``out`` (which this run made) if no image and no finished unit lies in it."""
    import shutil

    if count_kept_images(out, (p for u in plan.units for p in unit_paths(u))):
        return False
    if any(read_part(out, u.uid) is not None for u in plan.units):
        return False
    shutil.rmtree(out, ignore_errors=True)
    return True


def interrupted(exc: BaseException, out: Path, plan, created: bool) -> BaseException:
    """The exception an interrupted or failed run raises: what it kept, how to resume."""
    from concurrent.futures.process import BrokenProcessPool

    if created and remove_if_nothing_kept(out, plan):
        kept = f"nothing was kept ({out} removed)"
    else:
        n = count_kept_images(out, (p for u in plan.units for p in unit_paths(u)))
        done = sum(read_part(out, u.uid) is not None for u in plan.units)
        kept = (f"kept {n} of {plan.n_images} images ({done} of {len(plan.units)} work units "
                f"finished) in {out}; rerun the same command to resume (the manifest is "
                "written when a run ends cleanly)")
    if isinstance(exc, KeyboardInterrupt):
        return KeyboardInterrupt(kept)
    if isinstance(exc, BrokenProcessPool) or type(exc).__name__ == "KilledWorker":
        return RunError(f"a render worker process died (killed, or out of memory?); {kept}")
    if isinstance(exc, (ValueError, OSError, RunError, UserError)):
        try:                                  # the same one-line error, saying what was kept
            return type(exc)(f"{exc}; {kept}")
        except Exception:  # noqa: BLE001 - an exception type that takes other arguments
            return exc
    exc.add_note(kept)
    return exc
