"""Camera effects of a generated dataset: the named sets of ranges a config may choose
(``GeneratorConfig.camera_effects``) and the per-image draw applied to every render.

With effects on, each image (person crop, background, frame) is rendered to a hidden
temporary file beside its final path, read back as 8-bit RGB, passed through its own draw
of :func:`viewadapt.camera.effects.apply_camera_effects` and only then written (atomically)
under its final name, so a killed run never leaves an image without its effects. The draw
is seeded (by the pipeline, :func:`generator.sampling.derive_seed`) from the seed of the
image's sample (itself derived from the master seed and the sample's ids) and the image's
path, so reruns, resumes and
other shard splits draw the same parameters. The parameters are recorded per image in the
manifest's ``camera_effects`` column (:func:`effects_json`); applying them to the image as
rendered without effects gives the image written.

With effects off (``"none"``, the default) nothing here runs and a dataset's files are
those of a generator without this module.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from viewadapt.camera.effects import SURVEILLANCE_CAMERA, CameraEffects, apply_camera_effects
from viewadapt.io.files import atomic_write_bytes

__all__ = ["CAMERA_EFFECTS", "SURVEILLANCE", "NO_EFFECTS", "check_camera_effects",
           "effects_ranges", "draw_image_effects", "effects_json",
           "raw_render_path", "render_with_effects"]

#: the setting that turns the effects off
NO_EFFECTS = "none"

#: the ``surveillance`` setting: the ranges of the ``camera`` training recipe
#: (:data:`viewadapt.camera.effects.SURVEILLANCE_CAMERA`)
SURVEILLANCE = SURVEILLANCE_CAMERA

#: setting name -> ranges (None: no effects)
CAMERA_EFFECTS = {NO_EFFECTS: None, "surveillance": SURVEILLANCE}


def check_camera_effects(name, bad=None) -> str:
    """``name`` if it names a set of :data:`CAMERA_EFFECTS`; else ``bad(message)`` (or a
    ``ValueError``) naming the choices."""
    if isinstance(name, str) and name in CAMERA_EFFECTS:
        return name
    msg = (f"camera_effects must be one of {', '.join(CAMERA_EFFECTS)}, got {name!r}")
    if bad is not None:
        bad(msg)
    raise ValueError(msg)


def effects_ranges(name: str) -> CameraEffects | None:
    """The ranges of the setting ``name`` (None for ``"none"``)."""
    return CAMERA_EFFECTS[check_camera_effects(name)]


def draw_image_effects(name: str, seed: int) -> dict | None:
    """One image's effects parameters (:meth:`~viewadapt.camera.effects.CameraEffects.draw`
    with a generator seeded by ``seed``), or None when ``name`` is ``"none"``."""
    ranges = effects_ranges(name)
    if ranges is None:
        return None
    return ranges.draw(np.random.default_rng(int(seed)))


def effects_json(params: dict | None) -> str:
    """The manifest's ``camera_effects`` text of ``params`` (compact JSON; ``""`` for
    None)."""
    if params is None:
        return ""
    return json.dumps(params, separators=(",", ":"))


def raw_render_path(path) -> Path:
    """The hidden file beside ``path`` that the renderer writes before the effects."""
    path = Path(path)
    return path.with_name(f".{path.stem}.raw.png")


def render_with_effects(renderer, path, params: dict, *, samples: int, seed: int) -> None:
    """Render with ``renderer`` (its camera set) to :func:`raw_render_path`, apply
    ``params`` to the 8-bit RGB pixels and write the result as a PNG at ``path``
    (atomically); the raw file is removed."""
    import cv2

    path = Path(path)
    raw = raw_render_path(path)
    try:
        renderer.render(raw, samples=samples, seed=seed)
        bgr = cv2.imdecode(np.frombuffer(raw.read_bytes(), np.uint8), cv2.IMREAD_COLOR)
        if bgr is None:                               # pragma: no cover - renderer failure
            raise RuntimeError(f"{raw}: the renderer wrote no readable PNG")
        rgb = apply_camera_effects(np.ascontiguousarray(bgr[..., ::-1]), params)
        ok, buf = cv2.imencode(".png", np.ascontiguousarray(rgb[..., ::-1]))
        if not ok:                                    # pragma: no cover - OpenCV failure
            raise RuntimeError(f"could not encode {path}")
        atomic_write_bytes(path, buf.tobytes())
    finally:
        raw.unlink(missing_ok=True)
