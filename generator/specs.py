"""Scene and person specifications: JSON files in ``assets/`` -> plain, validated dataclasses.

Nothing here imports Blender or torch. A spec that does not validate raises
:class:`SpecError`, whose message names the file and the field (``assets/scenes/shop.json:
objects[3].size: expected 3 positive numbers, got [1, 0]``).

Units: metres; angles in the JSON files are in degrees and say so in their names
(``tilt_deg``); colours are linear RGB in [0, 1]; colour temperatures in kelvin.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .specreader import SpecError, SpecReader, read_json

__all__ = [
    "SpecError",
    "ASSETS_DIR",
    "MaterialSpec",
    "ObjectSpec",
    "ClutterSpec",
    "ShellSpec",
    "SunSpec",
    "SkySpec",
    "AreaLightSpec",
    "LightingSpec",
    "FrameCameraSpec",
    "SceneSpec",
    "PhenotypeSpec",
    "GarmentSpec",
    "HairSpec",
    "PoseSpec",
    "PersonSpec",
    "PATTERNS",
    "OBJECT_TYPES",
    "TOP_KINDS",
    "BOTTOM_KINDS",
    "HAIR_STYLES",
    "ACCESSORIES",
    "POSE_KINDS",
    "load_scene",
    "load_scenes",
    "load_roster",
    "default_scene_dir",
    "default_roster_path",
]

ASSETS_DIR = Path(__file__).resolve().parent.parent / "assets"

#: Procedural patterns a material may use (each maps to a Blender texture node).
PATTERNS = ("flat", "brick", "checker", "noise", "voronoi", "wave", "stripes", "tiles")
#: Object types: primitives and composite prefabs (expanded in :mod:`generator.layout`).
OBJECT_TYPES = (
    "box", "cylinder", "sphere", "cone", "marking", "disc",
    "bench", "table", "desk", "chair", "tree", "bush", "lamp_post", "bollard", "car",
    "shelf", "pillar", "planter", "bin", "bag", "suitcase", "crate", "pallet", "kerb",
    "sign", "barrier", "bike_rack", "stall", "umbrella", "sofa", "fountain", "railing",
    "counter", "pole", "cone_marker", "poster", "door", "step",
)
TOP_KINDS = ("tshirt", "longsleeve", "tank", "jacket", "coat", "dress")
BOTTOM_KINDS = ("trousers", "shorts", "skirt", "long_skirt")
HAIR_STYLES = ("buzz", "short", "medium", "bob", "long", "ponytail", "bun", "bald")
ACCESSORIES = ("backpack", "shoulder_bag", "handbag", "cap")
POSE_KINDS = ("standing", "walking")


# --------------------------------------------------------------------------- scenes


@dataclass(frozen=True)
class MaterialSpec:
    """A procedural material.

    ``pattern`` picks the texture (``flat``, ``brick``, ``checker``, ``noise``, ``voronoi``,
    ``wave``, ``stripes``, ``tiles``); ``colors`` are the pattern's colours (the first is
    the main one; brick/tiles use the last as mortar/grout); ``scale`` is the pattern period
    in metres; ``hue_jitter`` varies the colour per object (clutter of many colours from
    one material); ``bump`` is the bump strength.
    """

    name: str
    pattern: str
    colors: tuple[tuple[float, float, float], ...]
    scale: float = 1.0
    roughness: float = 0.6
    metallic: float = 0.0
    bump: float = 0.0
    hue_jitter: float = 0.0
    value_jitter: float = 0.0
    emission: float = 0.0


@dataclass(frozen=True)
class ObjectSpec:
    """One placed object: a primitive or a prefab (see :data:`OBJECT_TYPES`).

    ``position`` is ``(x, y)`` on the ground (the object's footprint centre), ``z`` lifts it,
    ``size`` is ``(sx, sy, sz)`` in metres of the object's bounding box before ``yaw_deg``.
    """

    type: str
    position: tuple[float, float]
    size: tuple[float, float, float]
    yaw_deg: float = 0.0
    z: float = 0.0
    material: str = ""
    material2: str = ""


@dataclass(frozen=True)
class ClutterSpec:
    """``count`` random objects of ``types`` inside ``region`` (xmin, ymin, xmax, ymax).

    Sizes are the prefab's default size times a factor in ``scale``; materials are drawn
    from ``materials``. Placement is seeded by the scene's ``layout_seed``: the layout is
    part of the scene's identity and does not change with the dataset seed.
    """

    types: tuple[str, ...]
    count: int
    region: tuple[float, float, float, float]
    materials: tuple[str, ...]
    scale: tuple[float, float] = (0.85, 1.15)
    yaw: str = "random"          # random | axis (multiples of 90 degrees)
    min_gap: float = 0.3


@dataclass(frozen=True)
class ShellSpec:
    """An indoor room: walls and ceiling facing inwards, centred at ``center``.

    Seen from outside (the crop cameras stand 10 m away) the walls are transparent to
    camera rays, a cut-away like an architect's model; they still cast shadows and bound
    the light.
    """

    size: tuple[float, float, float]
    wall_material: str
    ceiling_material: str
    center: tuple[float, float] = (0.0, 0.0)


@dataclass(frozen=True)
class SunSpec:
    elevation_deg: tuple[float, float]
    strength: tuple[float, float]
    temperature: tuple[float, float]
    azimuth_deg: tuple[float, float] = (0.0, 360.0)
    angle_deg: float = 1.0


@dataclass(frozen=True)
class SkySpec:
    horizon: tuple[float, float, float]
    zenith: tuple[float, float, float]
    strength: tuple[float, float]
    tint: float = 0.08


@dataclass(frozen=True)
class AreaLightSpec:
    position: tuple[float, float, float]
    size: tuple[float, float]
    strength: tuple[float, float]
    temperature: tuple[float, float] = (3500.0, 5500.0)


@dataclass(frozen=True)
class LightingSpec:
    sun: SunSpec | None
    sky: SkySpec
    area_lights: tuple[AreaLightSpec, ...] = ()
    exposure: tuple[float, float] = (0.0, 0.0)


@dataclass(frozen=True)
class FrameCameraSpec:
    """The fixed surveillance camera of a scene (CAVIAR-like)."""

    position: tuple[float, float]
    height: float
    tilt_deg: float
    azimuth_deg: float
    hfov_deg: float = 65.0


@dataclass(frozen=True)
class SceneSpec:
    """A scene: ground, room shell, objects, random clutter, lighting ranges, frame camera."""

    id: str
    description: str
    indoor: bool
    layout_seed: int
    ground_size: tuple[float, float]
    ground_material: str
    walkable: tuple[tuple[float, float, float, float], ...]
    materials: dict[str, MaterialSpec]
    objects: tuple[ObjectSpec, ...]
    clutter: tuple[ClutterSpec, ...]
    lighting: LightingSpec
    frame_camera: FrameCameraSpec
    shell: ShellSpec | None = None
    source: str = field(default="", compare=False)


def _material(r: SpecReader, name: str) -> MaterialSpec:
    r.check_unknown({"pattern", "colors", "scale", "roughness", "metallic", "bump",
                     "hue_jitter", "value_jitter", "emission"})
    pattern = r.str("pattern", "flat", choices=PATTERNS)
    colors = r.colors("colors")
    need = {"flat": 1, "noise": 2, "brick": 3, "checker": 2, "voronoi": 2, "wave": 2,
            "stripes": 2, "tiles": 2}[pattern]
    if len(colors) < need:
        raise r.error("colors", f"pattern {pattern!r} needs at least {need} colours, "
                                f"got {len(colors)}")
    return MaterialSpec(
        name=name, pattern=pattern, colors=colors,
        scale=r.num("scale", 1.0, lo=1e-3, hi=1e3),
        roughness=r.num("roughness", 0.6, lo=0, hi=1),
        metallic=r.num("metallic", 0.0, lo=0, hi=1),
        bump=r.num("bump", 0.0, lo=0, hi=1),
        hue_jitter=r.num("hue_jitter", 0.0, lo=0, hi=0.5),
        value_jitter=r.num("value_jitter", 0.0, lo=0, hi=0.9),
        emission=r.num("emission", 0.0, lo=0, hi=100))


def _check_material_name(r: SpecReader, key: str, name: str, materials: dict, allow_empty=True):
    if name in ("", None) and allow_empty:
        return
    if name not in materials:
        raise r.error(key, f"unknown material {name!r} (defined: {', '.join(sorted(materials))})")


def _scene_from_dict(data: Any, source: str) -> SceneSpec:
    r = SpecReader(data, source)
    r.check_unknown({"id", "description", "indoor", "layout_seed", "ground", "walkable",
                     "materials", "objects", "clutter", "lighting", "frame_camera", "shell"})
    sid = r.str("id")
    if not sid.replace("_", "").isalnum():
        raise r.error("id", f"must be letters, digits and underscores, got {sid!r}")
    mats_r = r.sub("materials")
    if not isinstance(mats_r.data, dict) or not mats_r.data:
        raise r.error("materials", "expected a non-empty object of named materials")
    materials = {name: _material(mats_r.sub(name), name) for name in mats_r.data}

    g = r.sub("ground")
    g.check_unknown({"size", "material"})
    ground_size = g.vec("size", 2, positive=True)
    ground_material = g.str("material")
    _check_material_name(g, "material", ground_material, materials, allow_empty=False)

    walkable = []
    for w in r.items("walkable", required=True):
        rect = SpecReader({"rect": w.data}, source, w.path).vec("rect", 4)
        if rect[0] >= rect[2] or rect[1] >= rect[3]:
            raise SpecError(f"{source}: {w.path}: expected [xmin, ymin, xmax, ymax] with "
                            f"xmin < xmax and ymin < ymax, got {list(rect)}")
        walkable.append(rect)
    if not walkable:
        raise r.error("walkable", "needs at least one [xmin, ymin, xmax, ymax] rectangle")

    objects = []
    for o in r.items("objects"):
        o.check_unknown({"type", "position", "size", "yaw_deg", "z", "material", "material2"})
        obj = ObjectSpec(type=o.str("type", choices=OBJECT_TYPES),
                         position=o.vec("position", 2),
                         size=o.vec("size", 3, positive=True),
                         yaw_deg=o.num("yaw_deg", 0.0),
                         z=o.num("z", 0.0),
                         material=o.str("material"),
                         material2=o.str("material2", "", required=False) or "")
        _check_material_name(o, "material", obj.material, materials, allow_empty=False)
        _check_material_name(o, "material2", obj.material2, materials)
        objects.append(obj)

    clutter = []
    for c in r.items("clutter"):
        c.check_unknown({"types", "count", "region", "materials", "scale", "yaw", "min_gap"})
        types = c._get("types", None, True)
        if not isinstance(types, list) or not types:
            raise c.error("types", "expected a non-empty list of object types")
        for i, t in enumerate(types):
            if t not in OBJECT_TYPES:
                raise c.error(f"types[{i}]", f"{t!r} is not one of {', '.join(OBJECT_TYPES)}")
        mats = c._get("materials", None, True)
        if not isinstance(mats, list) or not mats:
            raise c.error("materials", "expected a non-empty list of material names")
        for i, m in enumerate(mats):
            _check_material_name(c, f"materials[{i}]", m, materials, allow_empty=False)
        region = c.vec("region", 4)
        if region[0] >= region[2] or region[1] >= region[3]:
            raise c.error("region", f"expected [xmin, ymin, xmax, ymax], got {list(region)}")
        clutter.append(ClutterSpec(types=tuple(types), count=c.num("count", lo=0, hi=5000,
                                                                     integer=True),
                                   region=region, materials=tuple(mats),
                                   scale=c.range("scale", [0.85, 1.15], lo=0.05, hi=20),
                                   yaw=c.str("yaw", "random", choices=("random", "axis")),
                                   min_gap=c.num("min_gap", 0.3, lo=0, hi=10)))

    shell = None
    s = r.sub("shell", required=False)
    if s is not None:
        s.check_unknown({"size", "wall_material", "ceiling_material", "center"})
        shell = ShellSpec(size=s.vec("size", 3, positive=True),
                          wall_material=s.str("wall_material"),
                          ceiling_material=s.str("ceiling_material"),
                          center=s.vec("center", 2, [0.0, 0.0]))
        _check_material_name(s, "wall_material", shell.wall_material, materials, False)
        _check_material_name(s, "ceiling_material", shell.ceiling_material, materials, False)

    lr = r.sub("lighting")
    lr.check_unknown({"sun", "sky", "area_lights", "exposure"})
    sun = None
    sr = lr.sub("sun", required=False)
    if sr is not None:
        sr.check_unknown({"elevation_deg", "azimuth_deg", "strength", "temperature",
                          "angle_deg"})
        sun = SunSpec(elevation_deg=sr.range("elevation_deg", lo=1, hi=90),
                      azimuth_deg=sr.range("azimuth_deg", [0.0, 360.0], lo=-360, hi=720),
                      strength=sr.range("strength", lo=0, hi=100),
                      temperature=sr.range("temperature", lo=1000, hi=20000),
                      angle_deg=sr.num("angle_deg", 1.0, lo=0, hi=45))
    kr = lr.sub("sky")
    kr.check_unknown({"horizon", "zenith", "strength", "tint"})
    sky = SkySpec(horizon=kr.color("horizon"), zenith=kr.color("zenith"),
                  strength=kr.range("strength", lo=0, hi=100),
                  tint=kr.num("tint", 0.08, lo=0, hi=1))
    lights = []
    for a in lr.items("area_lights"):
        a.check_unknown({"position", "size", "strength", "temperature"})
        lights.append(AreaLightSpec(position=a.vec("position", 3),
                                    size=a.vec("size", 2, positive=True),
                                    strength=a.range("strength", lo=0, hi=1e5),
                                    temperature=a.range("temperature", [3500.0, 5500.0],
                                                        lo=1000, hi=20000)))
    if sun is None and not lights and not r.bool("indoor"):
        raise lr.error("sun", "an outdoor scene needs a sun")
    lighting = LightingSpec(sun=sun, sky=sky, area_lights=tuple(lights),
                            exposure=lr.range("exposure", [0.0, 0.0], lo=-10, hi=10))

    fc = r.sub("frame_camera")
    fc.check_unknown({"position", "height", "tilt_deg", "azimuth_deg", "hfov_deg"})
    frame_camera = FrameCameraSpec(position=fc.vec("position", 2),
                                   height=fc.num("height", lo=0.5, hi=50),
                                   tilt_deg=fc.num("tilt_deg", lo=0, hi=89),
                                   azimuth_deg=fc.num("azimuth_deg"),
                                   hfov_deg=fc.num("hfov_deg", 65.0, lo=10, hi=150))

    return SceneSpec(id=sid, description=r.str("description", ""), indoor=r.bool("indoor"),
                     layout_seed=r.num("layout_seed", lo=0, hi=2**31 - 1, integer=True),
                     ground_size=ground_size, ground_material=ground_material,
                     walkable=tuple(walkable), materials=materials, objects=tuple(objects),
                     clutter=tuple(clutter), lighting=lighting, frame_camera=frame_camera,
                     shell=shell, source=source)


def default_scene_dir() -> Path:
    return ASSETS_DIR / "scenes"


def default_roster_path() -> Path:
    return ASSETS_DIR / "persons.json"


def load_scene(path) -> SceneSpec:
    """Load and validate one scene spec (JSON)."""
    path = Path(path)
    return _scene_from_dict(read_json(path), str(path))


def load_scenes(directory=None) -> list[SceneSpec]:
    """All ``*.json`` scene specs in ``directory`` (default ``assets/scenes``), sorted by id."""
    directory = Path(directory) if directory is not None else default_scene_dir()
    if not directory.is_dir():
        raise FileNotFoundError(f"scene directory not found: {directory}")
    scenes = [load_scene(p) for p in sorted(directory.glob("*.json"))]
    if not scenes:
        raise FileNotFoundError(f"no scene specs (*.json) in {directory}")
    ids = [s.id for s in scenes]
    dup = sorted({i for i in ids if ids.count(i) > 1})
    if dup:
        raise SpecError(f"{directory}: duplicate scene id(s): {', '.join(dup)}")
    return sorted(scenes, key=lambda s: s.id)


# --------------------------------------------------------------------------- persons


@dataclass(frozen=True)
class PhenotypeSpec:
    """anny phenotype parameters, each in [0, 1] on anny's scale (adults: age >= 0.667)."""

    gender: float
    age: float
    muscle: float
    weight: float
    height: float
    proportions: float


@dataclass(frozen=True)
class GarmentSpec:
    """A garment: ``kind``, main ``color``, optional ``pattern`` with ``color2``."""

    kind: str
    color: tuple[float, float, float]
    pattern: str = "flat"
    color2: tuple[float, float, float] = (0.0, 0.0, 0.0)
    pattern_scale: float = 0.1


@dataclass(frozen=True)
class HairSpec:
    style: str
    color: tuple[float, float, float]
    volume: float = 1.0


@dataclass(frozen=True)
class PoseSpec:
    """``standing`` (arms down) or ``walking`` (the instance draws a gait phase).

    ``stride`` scales hip/knee swing, ``arm_swing`` the arm swing, ``arm_abduction_deg``
    the arms' angle from the body, ``elbow_deg`` the rest elbow bend.
    """

    kind: str
    stride: float = 1.0
    arm_swing: float = 1.0
    arm_abduction_deg: float = 8.0
    elbow_deg: float = 10.0
    head_yaw_deg: float = 0.0


@dataclass(frozen=True)
class PersonSpec:
    """Everything that defines a person: body, stature, skin, clothes, hair, pose."""

    id: str
    phenotype: PhenotypeSpec
    stature: float
    skin: tuple[float, float, float]
    top: GarmentSpec
    bottom: GarmentSpec
    shoes: tuple[float, float, float]
    hair: HairSpec
    pose: PoseSpec
    accessories: tuple[tuple[str, tuple[float, float, float]], ...] = ()
    sleeve: float = -1.0      # fraction of the arm covered; -1: from the top's kind


def _garment(r: SpecReader, kinds) -> GarmentSpec:
    r.check_unknown({"kind", "color", "pattern", "color2", "pattern_scale"})
    return GarmentSpec(kind=r.str("kind", choices=kinds), color=r.color("color"),
                       pattern=r.str("pattern", "flat",
                                     choices=("flat", "stripes", "checker", "noise", "dots")),
                       color2=r.color("color2", [0.0, 0.0, 0.0]),
                       pattern_scale=r.num("pattern_scale", 0.1, lo=0.005, hi=2))


def _person_from_dict(r: SpecReader) -> PersonSpec:
    r.check_unknown({"id", "phenotype", "stature", "skin", "top", "bottom", "shoes", "hair",
                     "pose", "accessories", "sleeve"})
    pid = r.str("id")
    if not pid.replace("_", "").replace("-", "").isalnum():
        raise r.error("id", f"must be letters, digits, '-' and '_', got {pid!r}")
    p = r.sub("phenotype")
    p.check_unknown({"gender", "age", "muscle", "weight", "height", "proportions"})
    phen = PhenotypeSpec(gender=p.num("gender", lo=0, hi=1),
                         age=p.num("age", lo=0.667, hi=1),
                         muscle=p.num("muscle", lo=0, hi=1),
                         weight=p.num("weight", lo=0, hi=1),
                         height=p.num("height", lo=0, hi=1),
                         proportions=p.num("proportions", 0.5, lo=0, hi=1))
    h = r.sub("hair")
    h.check_unknown({"style", "color", "volume"})
    hair = HairSpec(style=h.str("style", choices=HAIR_STYLES), color=h.color("color"),
                    volume=h.num("volume", 1.0, lo=0.2, hi=3))
    q = r.sub("pose")
    q.check_unknown({"kind", "stride", "arm_swing", "arm_abduction_deg", "elbow_deg",
                     "head_yaw_deg"})
    pose = PoseSpec(kind=q.str("kind", choices=POSE_KINDS),
                    stride=q.num("stride", 1.0, lo=0, hi=2),
                    arm_swing=q.num("arm_swing", 1.0, lo=0, hi=2),
                    arm_abduction_deg=q.num("arm_abduction_deg", 8.0, lo=0, hi=45),
                    elbow_deg=q.num("elbow_deg", 10.0, lo=0, hi=120),
                    head_yaw_deg=q.num("head_yaw_deg", 0.0, lo=-60, hi=60))
    acc = []
    for a in r.items("accessories"):
        a.check_unknown({"kind", "color"})
        acc.append((a.str("kind", choices=ACCESSORIES), a.color("color")))
    return PersonSpec(id=pid, phenotype=phen, stature=r.num("stature", lo=1.3, hi=2.2),
                      skin=r.color("skin"), top=_garment(r.sub("top"), TOP_KINDS),
                      bottom=_garment(r.sub("bottom"), BOTTOM_KINDS),
                      shoes=r.color("shoes"), hair=hair, pose=pose, accessories=tuple(acc),
                      sleeve=r.num("sleeve", -1.0, lo=-1, hi=1))


def load_roster(path=None) -> list[PersonSpec]:
    """Load and validate the person roster (``assets/persons.json`` by default)."""
    path = Path(path) if path is not None else default_roster_path()
    data = read_json(path)
    r = SpecReader(data, str(path))
    r.check_unknown({"persons", "description"})
    persons = [_person_from_dict(p) for p in r.items("persons", required=True)]
    if not persons:
        raise r.error("persons", "the roster is empty")
    ids = [p.id for p in persons]
    dup = sorted({i for i in ids if ids.count(i) > 1})
    if dup:
        raise SpecError(f"{path}: persons: duplicate id(s): {', '.join(dup)}")
    return persons
