"""Dataset configuration, presets and the sampling plan (numpy only, no Blender).

The plan says everything about every image before anything is rendered: which person
stands where in which scene, facing which way, under which light, and where each camera
is. Geometry comes from :mod:`viewadapt.geometry` (:func:`~viewadapt.geometry.crop_camera`,
:func:`~viewadapt.geometry.window_to_image_homography`,
:func:`~viewadapt.geometry.camera_from_pose`); the renderer only translates it.

Randomness: every sample has its own seed, derived from the master seed and the sample's
ids by :func:`derive_seed`, and its own ``numpy.random.Generator``. Nothing draws from a
global RNG, so a sample is the same whichever subset, shard or order is generated.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
from dataclasses import dataclass, field

import numpy as np

from viewadapt.geometry import (
    PERSON_HEIGHT_M, Camera, camera_from_pose, crop_camera, window_to_image_homography,
)

from .camera_effects import NO_EFFECTS, check_camera_effects
from .layout import SceneLayout, footprint_distance, layout_scene, segments_clear
from .lighting import Lighting, blackbody_rgb, sample_lighting
from .specreader import check_field_types
from .specs import PersonSpec, SceneSpec, load_roster, load_scenes

__all__ = [
    "GeneratorConfig", "PRESETS", "preset_config", "derive_seed", "Lighting",
    "PersonSample", "BackgroundSample", "FramePerson", "FrameSample", "WorkUnit", "Plan",
    "plan_dataset", "translate_camera", "blackbody_rgb", "parse_shard", "select_shard",
    "image_relpath", "frame_camera", "sample_lighting",
]

# --------------------------------------------------------------------------- config


@dataclass(frozen=True)
class GeneratorConfig:
    """The whole dataset configuration (written to ``dataset.json``).

    Parameters
    ----------
    preset : str
        Name of the preset this config came from (informational).
    n_persons, n_scenes : int
        The first ``n`` persons of the roster / scenes (sorted by id) are used; 0 = all.
    instances : int
        Random placements (position, rotation, lighting, pose) per person and scene.
    elevations : tuple of float
        Camera elevations, radians (paper: 0, pi/8, pi/4).
    distance : float
        Camera to person-centre distance, metres (the same at every elevation).
    person_height : float
        Height of the person plane (96 px at elevation 0), metres.
    framing : {"plane", "silhouette"}
        ``plane``: a fixed window around the aim point (the paper's set-up, default);
        ``silhouette``: each crop's intrinsics fitted so the silhouette is 96 px tall and
        centred, for comparison.
    backgrounds_per_scene : int
        Person-free views per scene (each rendered at every elevation).
    background_size : (int, int)
        (width, height) of background images, same focal length as the crops.
    frames : int
        Surveillance frames in total, spread over the scenes round-robin.
    frame_size : (int, int)
    persons_per_frame : (int, int)
        Inclusive range of persons in a frame.
    samples, background_samples, frame_samples : int
        Cycles samples per pixel for crops / backgrounds / frames.
    supersample : int
        Render at this factor and area-downsample (1 = rely on the pixel filter).
    camera_effects : str
        Camera effects every image passes through before it is written
        (:data:`generator.camera_effects.CAMERA_EFFECTS`: ``"none"``, the default, or
        ``"surveillance"``); each image gets its own draw, recorded in the manifest.
        ``to_dict`` leaves the field out while it is ``"none"``, so the ``dataset.json`` of
        a dataset without effects is that of a generator without the setting.
    """

    preset: str = "custom"
    n_persons: int = 0
    n_scenes: int = 0
    instances: int = 1
    elevations: tuple = (0.0, math.pi / 8, math.pi / 4)
    distance: float = 10.0
    person_height: float = PERSON_HEIGHT_M
    framing: str = "plane"
    crop_size: tuple = (64, 128)
    backgrounds_per_scene: int = 1
    background_size: tuple = (256, 256)
    frames: int = 1
    frame_size: tuple = (384, 288)
    persons_per_frame: tuple = (3, 6)
    renderer: str = "cycles"
    samples: int = 8
    background_samples: int = 8
    frame_samples: int = 16
    denoise: bool = True
    supersample: int = 1
    light_tree: bool = False
    fast_gi: bool = True
    max_bounces: int = 4
    scene_ids: tuple = ()
    person_ids: tuple = ()
    camera_effects: str = NO_EFFECTS

    def validate(self) -> "GeneratorConfig":
        def bad(msg):
            raise ValueError(f"generator config: {msg}")
        check_field_types(self, bad)
        if self.instances < 1:
            bad(f"instances must be >= 1, got {self.instances}")
        if not self.elevations or len(set(self.elevations)) < len(self.elevations):
            bad(f"elevations must be distinct and not empty, got {tuple(self.elevations)}")
        for e in self.elevations:
            if not (0.0 <= float(e) < math.pi / 2):
                bad(f"elevation {e!r} is outside [0, pi/2) radians")
        if not math.isfinite(self.distance) or self.distance <= self.person_height:
            bad(f"distance {self.distance} m must be finite and exceed the person height "
                f"({self.person_height} m)")
        if self.framing not in ("plane", "silhouette"):
            bad(f"framing must be 'plane' or 'silhouette', got {self.framing!r}")
        if self.renderer not in ("cycles", "pyrender"):
            bad(f"renderer must be 'cycles' or 'pyrender', got {self.renderer!r}")
        for name in ("samples", "background_samples", "frame_samples", "supersample"):
            if getattr(self, name) < 1:
                bad(f"{name} must be >= 1")
        lo, hi = self.persons_per_frame
        if not 1 <= lo <= hi <= 8:
            bad(f"persons_per_frame must satisfy 1 <= min <= max <= 8, got {lo, hi}")
        for name in ("crop_size", "background_size", "frame_size"):
            w, h = getattr(self, name)
            if w < 8 or h < 8:
                bad(f"{name} too small: {w}x{h}")
        bw, bh = self.background_size
        cw, ch = self.crop_size
        if bw < cw or bh < ch:
            bad(f"background_size {bw}x{bh} must hold a {cw}x{ch} window")
        check_camera_effects(self.camera_effects, bad)
        return self

    def to_dict(self) -> dict:
        d = dataclasses.asdict(self)
        for k, v in d.items():
            if isinstance(v, tuple):
                d[k] = list(v)
        if d["camera_effects"] == NO_EFFECTS:     # off: the config of a generator without it
            del d["camera_effects"]
        return d

    @classmethod
    def from_dict(cls, d: dict) -> "GeneratorConfig":
        names = {f.name for f in dataclasses.fields(cls)}
        kw = {k: (tuple(v) if isinstance(v, list) else v) for k, v in d.items() if k in names}
        return cls(**kw).validate()


PAPER_ELEVATIONS = (0.0, math.pi / 8, math.pi / 4)

#: the ``small`` preset's sizes, which ``realistic`` shares
_SMALL = dict(n_persons=24, n_scenes=9, instances=2, backgrounds_per_scene=3, frames=9)

PRESETS = {
    # renders in well under 3 minutes on 2 cores; supports 3x3 person/scene folds
    "tiny": dict(n_persons=6, n_scenes=3, instances=1, backgrounds_per_scene=1, frames=1),
    # `viewadapt demo`: only the elevations of the headline comparison (0 -> pi/4 and the
    # oracle at pi/4); 18 x 9 = 162 test positives and 9 x 3 x 117 background windows per
    # elevation, so the cross-validation's intervals separate; ~1 min with pyrender on 2 cores
    "demo": dict(n_persons=18, n_scenes=9, instances=1, backgrounds_per_scene=3, frames=1,
                 elevations=(0.0, math.pi / 4)),
    # enough crops for meaningful DET curves
    "small": _SMALL,
    # Wang et al. 2017: 3 instances x 68 persons x 13 scenes x 3 elevations = 7956 crops
    # 7 backgrounds of 256x256 per scene: 13 x 7 x 117 = 10,647 negative windows per
    # elevation at the cross-validation's 16 px stride (at least 10,000, as the paper's)
    "paper": dict(n_persons=68, n_scenes=13, instances=3, backgrounds_per_scene=7, frames=26),
    # `small` through surveillance-camera effects (blur, noise, JPEG, ...), per image
    "realistic": dict(_SMALL, camera_effects="surveillance"),
}


def preset_config(name: str, **overrides) -> GeneratorConfig:
    """The :class:`GeneratorConfig` of a preset (``tiny``, ``demo``, ``small``, ``paper``,
    ``realistic``)."""
    if name not in PRESETS:
        raise ValueError(f"unknown preset {name!r}; choose one of {', '.join(PRESETS)}")
    kw = dict(PRESETS[name], preset=name)
    kw.update(overrides)
    return GeneratorConfig(**kw).validate()


# --------------------------------------------------------------------------- seeds


def derive_seed(master: int, *ids) -> int:
    """A 63-bit seed from the master seed and a sample's ids (stable across runs/platforms).

    >>> derive_seed(0, "person", "p001", "shop", 2) == derive_seed(0, "person", "p001", "shop", 2)
    True
    """
    key = "/".join([str(int(master))] + [str(i) for i in ids]).encode()
    return int.from_bytes(hashlib.blake2b(key, digest_size=8).digest(), "little") >> 1


def parse_shard(text: str) -> tuple[int, int]:
    """Parse ``I/N`` (0-based shard ``I`` of ``N``)."""
    try:
        i, n = (int(x) for x in str(text).split("/"))
    except ValueError:
        raise ValueError(f"--shard must look like I/N (e.g. 0/4), got {text!r}") from None
    if n < 1 or not 0 <= i < n:
        raise ValueError(f"--shard {text}: need 0 <= I < N")
    return i, n


def select_shard(units: list, shard: tuple[int, int] | None) -> list:
    """Contiguous blocks of units per shard (keeps each scene's units together)."""
    if shard is None:
        return list(units)
    i, n = shard
    k = len(units)
    return list(units[(i * k) // n:((i + 1) * k) // n])


# --------------------------------------------------------------------------- samples


def translate_camera(camera: Camera, offset_xy, image_size=None) -> Camera:
    """The same camera moved by ``(dx, dy, 0)`` in the world."""
    d = np.array([offset_xy[0], offset_xy[1], 0.0])
    return Camera(camera.K, camera.R, camera.t - camera.R @ d,
                  image_size if image_size is not None else camera.image_size)


@dataclass(frozen=True)
class PersonSample:
    """One (person, scene, instance): placement, pose, lighting; cameras per elevation."""

    person_id: str
    scene_id: str
    instance: int
    seed: int
    ground_xy: tuple
    rotation: float               # person yaw, radians CCW; 0 = facing -Y
    azimuth: float                # camera direction from the person, radians CCW from -Y
    pose: str
    gait_phase: float             # [0, 1) for walking, NaN for standing
    pose_jitter: tuple            # small per-instance pose variations (radians)
    lighting: Lighting
    cameras: tuple                # Camera per elevation (crop intrinsics)
    homographies: tuple           # canonical window -> crop, per elevation


@dataclass(frozen=True)
class BackgroundSample:
    scene_id: str
    index: int
    seed: int
    ground_xy: tuple
    azimuth: float
    lighting: Lighting
    cameras: tuple
    homographies: tuple           # canonical window -> centre window of the image


@dataclass(frozen=True)
class FramePerson:
    person_id: str
    ground_xy: tuple
    rotation: float
    pose: str
    gait_phase: float
    pose_jitter: tuple


@dataclass(frozen=True)
class FrameSample:
    scene_id: str
    index: int
    seed: int
    camera: Camera
    persons: tuple
    lighting: Lighting


@dataclass(frozen=True)
class WorkUnit:
    """What one worker renders in one go (all elevations of its samples)."""

    uid: str
    kind: str                     # person | background | frame
    scene_id: str
    samples: tuple

    @property
    def n_images(self) -> int:
        if self.kind == "frame":
            return len(self.samples)
        return sum(len(s.cameras) for s in self.samples)


@dataclass
class Plan:
    config: GeneratorConfig
    seed: int
    scenes: dict                  # id -> SceneSpec
    persons: dict                 # id -> PersonSpec
    units: list = field(default_factory=list)

    @property
    def n_images(self) -> int:
        return sum(u.n_images for u in self.units)


def _person_points(ground_xy, azimuth, person_height):
    """Points on a person's bounding cylinder facing a camera at ``azimuth``."""
    gx, gy = ground_xy
    side = np.array([np.cos(azimuth), np.sin(azimuth)])  # perpendicular to the view ray
    pts = []
    for z in (0.1, 0.5 * person_height, 1.05 * person_height):
        for u in (-0.3, 0.0, 0.3):
            pts.append([gx + u * side[0], gy + u * side[1], z])
    return np.array(pts)


def _crop_cameras(config: GeneratorConfig, ground_xy, azimuth, size=None):
    cams, Hs = [], []
    for e in config.elevations:
        cam0 = crop_camera(float(e), distance=config.distance,
                           person_height=config.person_height, azimuth=azimuth)
        if size is not None:
            # same focal length, larger image centred on the aim point
            K = cam0.K.copy()
            K[0, 2], K[1, 2] = (size[0] - 1) / 2.0, (size[1] - 1) / 2.0
            cam0 = Camera(K, cam0.R, cam0.t, tuple(size))
        cam = translate_camera(cam0, ground_xy)
        cams.append(cam)
        Hs.append(window_to_image_homography(cam, ground_xy, config.person_height))
    return tuple(cams), tuple(Hs)


def _in_walkable(spec: SceneSpec, xy, margin=0.0) -> bool:
    return any(r[0] + margin <= xy[0] <= r[2] - margin and r[1] + margin <= xy[1] <= r[3] - margin
               for r in spec.walkable)


def _sample_walkable(spec: SceneSpec, rng) -> tuple[float, float]:
    areas = np.array([(r[2] - r[0]) * (r[3] - r[1]) for r in spec.walkable])
    r = spec.walkable[int(rng.choice(len(areas), p=areas / areas.sum()))]
    return float(rng.uniform(r[0], r[2])), float(rng.uniform(r[1], r[3]))


def _camera_centres(config: GeneratorConfig, ground_xy, azimuth) -> np.ndarray:
    """Crop camera centres (one per elevation), as in :func:`viewadapt.geometry.crop_camera`."""
    e = np.asarray(config.elevations, dtype=np.float64)
    horiz = np.array([math.sin(azimuth), -math.cos(azimuth), 0.0])
    aim = np.array([ground_xy[0], ground_xy[1], config.person_height / 2.0])
    return aim + config.distance * (np.cos(e)[:, None] * horiz + np.sin(e)[:, None] *
                                    np.array([0.0, 0.0, 1.0]))


def _sample_view(spec: SceneSpec, layout: SceneLayout, config: GeneratorConfig, rng,
                 what: str, clearance: float = 0.45, tries: int = 400):
    """A free ground position and camera azimuth with clear sight lines at every elevation."""
    for _ in range(tries):
        xy = _sample_walkable(spec, rng)
        azimuth = float(rng.uniform(0, 2 * math.pi))
        if footprint_distance(layout, xy) < clearance:
            continue
        pts = _person_points(xy, azimuth, config.person_height)
        centres = _camera_centres(config, xy, azimuth)
        starts = np.repeat(centres, len(pts), axis=0)
        ends = np.tile(pts, (len(centres), 1))
        if segments_clear(layout, starts, ends, margin=0.05):
            return xy, azimuth
    raise ValueError(f"scene {spec.id!r} ({spec.source}): found no free {what} position "
                     f"with clear sight lines in {tries} tries from a camera "
                     f"{config.distance:g} m away; widen 'walkable', remove clutter or "
                     f"bring the camera closer (--distance)")


def _sample_pose(person: PersonSpec, rng) -> tuple[str, float, tuple]:
    phase = float(rng.uniform(0, 1)) if person.pose.kind == "walking" else math.nan
    jitter = tuple(float(v) for v in rng.normal(0, 0.06, 6))
    return person.pose.kind, phase, jitter


def _sample_person(config, spec, layout, person, instance, seed) -> PersonSample:
    rng = np.random.default_rng(seed)
    xy, azimuth = _sample_view(spec, layout, config, rng, "person")
    rotation = float(rng.uniform(0, 2 * math.pi))
    pose, phase, jitter = _sample_pose(person, rng)
    lighting = sample_lighting(spec, rng)
    cams, Hs = _crop_cameras(config, xy, azimuth)
    return PersonSample(person.id, spec.id, instance, seed, xy, rotation, azimuth, pose,
                        phase, jitter, lighting, cams, Hs)


def _sample_background(config, spec, layout, index, seed) -> BackgroundSample:
    """A person-free view: same cameras as the crops, aimed at a free ground point; most
    often next to an object, so that negatives are cluttered at every elevation."""
    rng = np.random.default_rng(seed)
    near = [p for p in layout.primitives
            if p.occluder and p.center[2] - p.size[2] / 2 < 0.5 and _in_walkable(spec, p.center)]
    xy = azimuth = None
    if near and rng.random() < 0.7:
        for _ in range(200):
            p = near[int(rng.integers(len(near)))]
            ang = rng.uniform(0, 2 * math.pi)
            reach = 0.5 * math.hypot(p.size[0], p.size[1]) + rng.uniform(0.2, 1.5)
            cand = (p.center[0] + reach * math.cos(ang), p.center[1] + reach * math.sin(ang))
            if not _in_walkable(spec, cand) or footprint_distance(layout, cand) < 0.05:
                continue
            az = float(rng.uniform(0, 2 * math.pi))
            aim = np.array([cand[0], cand[1], 0.5 * config.person_height])
            if segments_clear(layout, _camera_centres(config, cand, az), aim[None]):
                xy, azimuth = (float(cand[0]), float(cand[1])), az
                break
    if xy is None:
        xy, azimuth = _sample_view(spec, layout, config, rng, "background", clearance=0.1)
    lighting = sample_lighting(spec, rng)
    cams, Hs = _crop_cameras(config, xy, azimuth, size=config.background_size)
    return BackgroundSample(spec.id, index, seed, xy, azimuth, lighting, cams, Hs)


def frame_camera(spec: SceneSpec, size) -> Camera:
    """The scene's fixed surveillance camera (from its spec)."""
    fc = spec.frame_camera
    w, h = size
    f = (w / 2.0) / math.tan(math.radians(fc.hfov_deg) / 2)
    return camera_from_pose(focal=f, principal_point=((w - 1) / 2.0, (h - 1) / 2.0),
                            height=fc.height, tilt=math.radians(fc.tilt_deg),
                            azimuth=math.radians(fc.azimuth_deg), position_xy=fc.position,
                            image_size=tuple(size))


def _sample_frame(config, spec, layout, persons, index, seed) -> FrameSample:
    rng = np.random.default_rng(seed)
    cam = frame_camera(spec, config.frame_size)
    w, h = config.frame_size
    n = int(rng.integers(config.persons_per_frame[0], config.persons_per_frame[1] + 1))
    order = rng.permutation(len(persons))[:n]
    placed = []
    for pi in order:
        person = persons[int(pi)]
        for _ in range(300):
            xy = _sample_walkable(spec, rng)
            if footprint_distance(layout, xy) < 0.4:
                continue
            if any(math.hypot(xy[0] - q.ground_xy[0], xy[1] - q.ground_xy[1]) < 0.8
                   for q in placed):
                continue
            feet = np.array([xy[0], xy[1], 0.0])
            head = np.array([xy[0], xy[1], 1.8])
            if (cam.R @ head + cam.t)[2] <= 0.5 or (cam.R @ feet + cam.t)[2] <= 0.5:
                continue
            (fx, fy), (hx, hy) = cam.project(np.stack([feet, head]))
            if not (4 <= fx <= w - 5 and 0 <= hx <= w - 1 and hy >= -0.2 * (fy - hy)
                    and fy <= h - 3 and (fy - hy) >= 20):
                continue
            pose, phase, jitter = _sample_pose(person, rng)
            placed.append(FramePerson(person.id, xy, float(rng.uniform(0, 2 * math.pi)),
                                      pose, phase, jitter))
            break
    if not placed:
        raise ValueError(f"scene {spec.id!r} ({spec.source}): frame camera sees no free "
                         f"ground to place persons on; check frame_camera and walkable")
    lighting = sample_lighting(spec, rng)
    return FrameSample(spec.id, index, seed, cam, tuple(placed), lighting)


def _choose(items: list, ids, n, what: str, *, spread: bool) -> list:
    """The ``ids`` of ``items`` in that order, or ``n`` of them (evenly spread or the first
    ``n``), or all; unknown ids or too large an ``n`` are a ValueError."""
    if ids:
        by_id = {x.id: x for x in items}
        missing = [i for i in ids if i not in by_id]
        if missing:
            raise ValueError(f"unknown {what} id(s): {', '.join(missing)}")
        return [by_id[i] for i in ids]
    if n:
        if n > len(items):
            raise ValueError(f"config asks for {n} {what}s, only {len(items)} exist")
        if spread and n < len(items):
            idx = np.round(np.linspace(0, len(items) - 1, n)).astype(int)
            return [items[i] for i in idx]
        return items[:n]
    return items


def plan_dataset(config: GeneratorConfig, seed: int, *, scenes=None, persons=None) -> Plan:
    """Plan every image of a dataset (numpy only).

    Parameters
    ----------
    config : GeneratorConfig
    seed : int
        Master seed.
    scenes, persons : list, optional
        Scene and person specs (default: ``assets/``).

    Returns
    -------
    Plan whose ``units`` are ordered by scene: backgrounds, persons, frames.
    """
    config = config.validate()
    scenes = list(scenes) if scenes is not None else load_scenes()
    persons = list(persons) if persons is not None else load_roster()
    # spread the scene choice over the (id-sorted) list so small presets mix indoor/outdoor
    scenes = _choose(scenes, config.scene_ids, config.n_scenes, "scene", spread=True)
    persons = _choose(persons, config.person_ids, config.n_persons, "person", spread=False)
    plan = Plan(config, int(seed), {s.id: s for s in scenes}, {p.id: p for p in persons})
    frames_per_scene = [len(range(k, config.frames, len(scenes))) for k in range(len(scenes))]
    for si, spec in enumerate(scenes):
        layout = layout_scene(spec)
        if config.backgrounds_per_scene:
            bgs = tuple(_sample_background(config, spec, layout, k,
                                           derive_seed(seed, "background", spec.id, k))
                        for k in range(config.backgrounds_per_scene))
            plan.units.append(WorkUnit(f"background/{spec.id}", "background", spec.id, bgs))
        for person in persons:
            samples = tuple(
                _sample_person(config, spec, layout, person, i,
                               derive_seed(seed, "person", spec.id, person.id, i))
                for i in range(config.instances))
            plan.units.append(WorkUnit(f"person/{spec.id}/{person.id}", "person", spec.id,
                                       samples))
        for k in range(frames_per_scene[si]):
            fs = _sample_frame(config, spec, layout, persons, k,
                               derive_seed(seed, "frame", spec.id, k))
            plan.units.append(WorkUnit(f"frame/{spec.id}/{k}", "frame", spec.id, (fs,)))
    return plan


def image_relpath(kind: str, scene_id: str, *, person_id: str = "", instance: int = 0,
                  elevation_index: int = 0, index: int = 0) -> str:
    """Relative POSIX path of an image in the dataset directory."""
    if kind == "person":
        return f"person/{scene_id}/{person_id}_i{instance}_e{elevation_index}.png"
    if kind == "background":
        return f"background/{scene_id}/bg_i{index}_e{elevation_index}.png"
    if kind == "frame":
        return f"frames/{scene_id}/frame_{index}.png"
    raise ValueError(f"unknown image kind {kind!r}")

