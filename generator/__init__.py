"""The synthetic multi-view dataset generator (Wang et al. 2017, "Multi-view dataset").

Persons (anny bodies, clothed and posed) in 13 procedural scenes, rendered with Blender
Cycles at several camera elevations with the paper's fixed-distance camera set-up, plus
person-free backgrounds and calibrated surveillance frames.

Modules (describe first, render second):

* :mod:`generator.specs` -- scene and person specs (``assets/``) -> validated dataclasses
  (read with :mod:`generator.specreader`).
* :mod:`generator.layout` -- scenes expanded into primitives; ray casting.
* :mod:`generator.sampling` -- config, presets, seeds, the sampling plan and its cameras.
* :mod:`generator.annotate` -- silhouette boxes, frame visibility/occlusion.
* :mod:`generator.manifest` -- dataset directory, manifest, part files, depth maps, the
  content hash; :mod:`generator.contents` -- ``dataset.json`` and every planned path;
  :mod:`generator.png` -- the full PNG check and byte-reproducible PNGs.
* :mod:`generator.verify` -- checking a dataset directory (``viewadapt dataset verify``).
* :mod:`generator.body` -- posed, clothed anny meshes (imports torch/anny lazily); its gait
  cycle and rotations in :mod:`generator.kinematics`.
* :mod:`generator.blender` -- the Cycles renderer (the only module importing ``bpy``); the
  values it sets are computed in :mod:`generator.blendparams`.
* :mod:`generator.pipeline` -- workers, process pool / Dask, shards; :mod:`generator.resume`
  -- what a rerun may change, which kept files are sound, what an interrupted run kept.
* :mod:`generator.preview`, :mod:`generator.cli`, :mod:`generator.bench`.

``import generator`` imports neither bpy nor torch.
"""

from .layout import Primitive, SceneLayout, layout_scene, ray_cast, segments_clear
from .manifest import read_manifest
from .sampling import (
    PRESETS, GeneratorConfig, Plan, derive_seed, plan_dataset, preset_config,
)
from .specs import PersonSpec, SceneSpec, SpecError, load_roster, load_scene, load_scenes
from .verify import verify_dataset

__all__ = [
    "GeneratorConfig", "PRESETS", "preset_config", "plan_dataset", "Plan", "derive_seed",
    "SceneSpec", "PersonSpec", "SpecError", "load_scene", "load_scenes", "load_roster",
    "Primitive", "SceneLayout", "layout_scene", "ray_cast", "segments_clear",
    "read_manifest", "verify_dataset", "generate",
]


def generate(*args, **kwargs):
    """Generate a dataset; see :func:`generator.pipeline.generate`."""
    from .pipeline import generate as _generate

    return _generate(*args, **kwargs)
