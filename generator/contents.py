"""What a dataset holds: its ``dataset.json`` and the path of every planned file.

Numpy only (the plan is re-made from ``dataset.json`` without rendering), shared by the
pipeline that writes a dataset, the resume checks and ``dataset verify``.

``dataset.json`` names the spec files a dataset was made from (``specs``) relative to the
project (``"assets/scenes"``, ``"assets/persons.json"``) when they are the project's own,
so the same seed gives the same bytes from any checkout; a folder elsewhere is named by
its absolute path. Datasets of older versions name the project's assets by the absolute
path of the checkout that made them: such a path is used while it exists, else the same
file of this checkout's ``assets/``.
"""

from __future__ import annotations

import os
from pathlib import Path, PurePosixPath

from . import specs
from .camera_effects import effects_ranges
from .manifest import spec_hashes, versions
from .sampling import GeneratorConfig, Plan, WorkUnit, image_relpath, plan_dataset
from .specs import default_roster_path, default_scene_dir, load_roster, load_scenes

__all__ = ["dataset_metadata", "planned_paths", "unit_paths", "unit_depth_paths",
           "depth_relpath", "spec_path_record", "spec_path", "dataset_spec_paths", "replan"]


def spec_path_record(path) -> str:
    """How ``dataset.json`` names a spec file or folder: ``assets/...`` inside the
    project's assets (:data:`generator.specs.ASSETS_DIR`), else the absolute path."""
    path = Path(os.path.realpath(path))
    assets = Path(os.path.realpath(specs.ASSETS_DIR))
    if path == assets or assets in path.parents:
        return (PurePosixPath(assets.name) / path.relative_to(assets).as_posix()).as_posix()
    return str(path)


def spec_path(recorded: str | None, default: Path) -> Path:
    """The spec file or folder ``dataset.json`` names (``default`` if it names none): an
    ``assets/...`` name lies in this project's assets; an absolute path is used while it
    exists, else (a checkout since moved) its part from the last ``assets`` folder on
    lies in this project's assets."""
    if not recorded:
        return Path(default)
    p = Path(recorded)
    if not p.is_absolute():
        return Path(specs.ASSETS_DIR).parent / p
    if p.exists():
        return p
    parts = p.parts
    if "assets" in parts:
        k = len(parts) - 1 - parts[::-1].index("assets")
        moved = Path(specs.ASSETS_DIR).joinpath(*parts[k + 1:])
        if moved.exists():
            return moved
    return p


def dataset_spec_paths(meta: dict) -> tuple[Path, Path]:
    """``(scene folder, roster)`` a dataset's ``dataset.json`` was made from."""
    recorded = meta.get("specs") if isinstance(meta.get("specs"), dict) else {}
    return (spec_path(recorded.get("scene_dir"), default_scene_dir()),
            spec_path(recorded.get("roster"), default_roster_path()))


def dataset_metadata(config: GeneratorConfig, seed: int, plan: Plan, scene_dir, roster) -> dict:
    """The ``dataset.json`` of a plan; with camera effects on, ``camera_effects`` records
    the setting's name and the ranges each image's parameters were drawn from."""
    scene_dir = Path(scene_dir)
    ranges = effects_ranges(config.camera_effects)
    effects = ({"camera_effects": {"name": config.camera_effects, "ranges": ranges.to_dict(),
                                   "per_image": "manifest column camera_effects"}}
               if ranges is not None else {})
    return {
        "format": "viewadapt-multiview-v1",
        "preset": config.preset,
        "seed": int(seed),
        "framing": config.framing,
        "elevations": [float(e) for e in config.elevations],
        "distance": config.distance,
        "person_height": config.person_height,
        "counts": {"persons": len(plan.persons), "scenes": len(plan.scenes),
                   "instances": config.instances,
                   "backgrounds_per_scene": config.backgrounds_per_scene,
                   "frames": config.frames, "images": plan.n_images},
        "renderer": {"name": config.renderer, "samples": config.samples,
                     "background_samples": config.background_samples,
                     "frame_samples": config.frame_samples, "denoise": config.denoise,
                     "supersample": config.supersample, "light_tree": config.light_tree,
                     "fast_gi": config.fast_gi, "max_bounces": config.max_bounces},
        "config": config.to_dict(),
        **effects,
        "persons": list(plan.persons),
        "scenes": list(plan.scenes),
        "specs": {"scene_dir": spec_path_record(scene_dir),
                  "roster": spec_path_record(roster),
                  "hashes": spec_hashes(sorted(scene_dir.glob("*.json")) + [Path(roster)])},
        "versions": versions(),
        "conventions": {
            "world": "metres, Z up, ground Z=0; person yaw 0 faces -Y",
            "camera": "OpenCV: x_cam = R X + t, x right, y down, z forward",
            "azimuth": "crops/backgrounds: direction from the person (aim point) to the "
                       "camera, radians counter-clockwise from -Y (viewadapt crop_camera); "
                       "NaN for frames",
            "rotation": "person yaw, radians counter-clockwise about +Z; 0 faces -Y",
            "pixels": "pixel centres at integer coordinates; boxes [x, y, w, h] in that frame",
            "H_window_to_image": "canonical 64x128 window (person plane, 96 px tall "
                                 "person_height) -> image; identity at elevation 0 for "
                                 "plane framing; centre window for backgrounds",
            "H_plane_to_image": "person-plane metres (u right, z up, origin at the feet) "
                                "-> image",
        },
    }


def replan(meta: dict) -> Plan:
    """The plan of a dataset's ``dataset.json`` (re-made in numpy)."""
    config = GeneratorConfig.from_dict(meta["config"])
    scene_dir, roster = dataset_spec_paths(meta)
    return plan_dataset(config, meta["seed"], scenes=load_scenes(scene_dir),
                        persons=load_roster(roster))


def planned_paths(meta: dict, plan: Plan | None = None) -> list[str]:
    """Every image path a dataset's ``dataset.json`` plans (``plan``: its plan, if made)."""
    plan = plan if plan is not None else replan(meta)
    return [p for u in plan.units for p in unit_paths(u)]


def unit_depth_paths(unit: WorkUnit) -> list[str]:
    """Depth maps of a person unit's crops (one per image; none for other units)."""
    if unit.kind != "person":
        return []
    return [depth_relpath(p) for p in unit_paths(unit)]


def depth_relpath(image_path: str) -> str:
    """``person/<scene>/<name>.png`` -> ``depth/<scene>/<name>.npz``."""
    head, rest = image_path.split("/", 1)
    if head != "person" or not rest.endswith(".png"):
        raise ValueError(f"only person crops have depth maps, got {image_path!r}")
    return f"depth/{rest[:-4]}.npz"


def unit_paths(unit: WorkUnit) -> list[str]:
    out = []
    for s in unit.samples:
        if unit.kind == "person":
            out += [image_relpath("person", s.scene_id, person_id=s.person_id,
                                  instance=s.instance, elevation_index=e)
                    for e in range(len(s.cameras))]
        elif unit.kind == "background":
            out += [image_relpath("background", s.scene_id, index=s.index, elevation_index=e)
                    for e in range(len(s.cameras))]
        else:
            out.append(image_relpath("frame", s.scene_id, index=s.index))
    return out
