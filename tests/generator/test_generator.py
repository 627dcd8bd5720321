"""Generator tests that need neither Blender nor torch: specs, layout, sampling, geometry,
manifest, verify, preview, CLI parsing."""

import argparse
import json
import math
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import cv2
import numpy as np
import pytest

from generator.layout import (
    NON_OCCLUDING, PREFAB_SIZES, SceneLayout, expand_object, footprint_distance,
    layout_scene, ray_cast, segments_clear,
)
from generator.manifest import (
    MANIFEST_COLUMNS, assemble_manifest, png_is_complete, read_manifest, write_depth, write_part,
)
from generator.sampling import (
    GeneratorConfig, blackbody_rgb, derive_seed, frame_camera, image_relpath, parse_shard,
    plan_dataset, preset_config, select_shard,
)
from generator.specs import (
    OBJECT_TYPES, ObjectSpec, SpecError, load_roster, load_scene, load_scenes,
)
from generator.verify import verify_dataset
from viewadapt.geometry import (
    apply_homography, crop_camera, crop_homography, window_to_image_homography,
)
from tests.paths import REPO as REPO_ROOT

from tests.tolerances import EXACT

ASSETS = REPO_ROOT / "assets"


@pytest.fixture(scope="module")
def scenes():
    return load_scenes()


@pytest.fixture(scope="module")
def roster():
    return load_roster()


@pytest.fixture(scope="module")
def tiny_plan(scenes, roster):
    return plan_dataset(preset_config("tiny"), 0, scenes=scenes, persons=roster)


# --------------------------------------------------------------------------- import hygiene


def test_import_generator_pulls_no_blender_or_torch():
    code = ("import sys, generator, generator.cli, generator.pipeline, generator.preview, "
            "generator.annotate, generator.body, generator.bench; "
            "bad = [m for m in ('bpy', 'torch', 'anny') if m in sys.modules]; "
            "print(bad); sys.exit(1 if bad else 0)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr


def test_only_one_module_imports_bpy():
    src = REPO_ROOT / "generator"
    users = sorted(p.name for p in src.glob("*.py") if "import bpy" in p.read_text())
    assert users == ["blender.py"]
    torch_users = sorted(p.name for p in src.glob("*.py")
                         if "import torch" in p.read_text() or "import anny" in p.read_text())
    assert torch_users == ["body.py"]


# --------------------------------------------------------------------------- specs


def test_assets_load_13_scenes_and_68_distinct_persons(scenes, roster):
    assert len(scenes) == 13
    assert sum(s.indoor for s in scenes) >= 4 and sum(not s.indoor for s in scenes) >= 4
    assert len(roster) == 68
    assert len({p.id for p in roster}) == 68
    looks = {(p.top.kind, p.top.color, p.bottom.kind, p.bottom.color, p.hair.style)
             for p in roster}
    assert len(looks) == 68, "every person should look different"
    assert all(p.phenotype.age >= 0.667 for p in roster)          # adults on anny's scale
    assert {p.pose.kind for p in roster} == {"walking", "standing"}
    assert len({p.hair.style for p in roster}) >= 6


def _write(tmp_path, data, name="s.json"):
    p = tmp_path / name
    p.write_text(json.dumps(data))
    return p


@pytest.mark.parametrize("mutate, field, message", [
    (lambda d: d["objects"][0].update(size=[1, 0, 1]), "objects[0].size", "positive"),
    (lambda d: d["objects"][0].update(type="spaceship"), "objects[0].type", "is not one of"),
    (lambda d: d["objects"][0].update(material="nope"), "objects[0].material",
     "unknown material"),
    (lambda d: d.pop("frame_camera"), "frame_camera", "missing required field"),
    (lambda d: d["lighting"]["sun"].update(elevation_deg=[50, 10]), "lighting.sun.elevation_deg",
     "minimum exceeds maximum"),
    (lambda d: d["materials"]["stone"].update(pattern="brick"), "materials.stone.colors",
     "needs at least 3"),
    (lambda d: d.update(colour="red"), "colour", "unknown field"),
    (lambda d: d["walkable"].__setitem__(0, [5, 0, 1, 1]), "walkable[0]", "xmin < xmax"),
])
def test_bad_scene_spec_names_file_and_field(tmp_path, mutate, field, message):
    data = json.loads((ASSETS / "scenes" / "plaza.json").read_text())
    mutate(data)
    p = _write(tmp_path, data, "bad_plaza.json")
    with pytest.raises(SpecError, match=message) as e:
        load_scene(p)
    assert str(p) in str(e.value) and field in str(e.value)


def test_bad_roster_names_person_and_field(tmp_path):
    data = json.loads((ASSETS / "persons.json").read_text())
    data["persons"][5]["phenotype"]["age"] = 0.3       # a child
    p = _write(tmp_path, data, "roster.json")
    with pytest.raises(SpecError, match=r"persons\[5\]\.phenotype\.age: 0.3 is outside"):
        load_roster(p)
    data["persons"][5]["phenotype"]["age"] = 0.8
    data["persons"][7]["id"] = data["persons"][3]["id"]
    p = _write(tmp_path, data, "roster.json")
    with pytest.raises(SpecError, match="duplicate id"):
        load_roster(p)
    with pytest.raises(FileNotFoundError):
        load_roster(tmp_path / "missing.json")
    (tmp_path / "broken.json").write_text("{nope")
    with pytest.raises(SpecError, match="not valid JSON"):
        load_roster(tmp_path / "broken.json")


# --------------------------------------------------------------------------- layout


def test_every_object_type_has_a_prefab():
    assert set(OBJECT_TYPES) == set(PREFAB_SIZES)
    for t in OBJECT_TYPES:
        prims = expand_object(ObjectSpec(t, (1.0, 2.0), PREFAB_SIZES[t], material="m"))
        assert prims
        assert all(not p.occluder for p in prims) == (t in NON_OCCLUDING)


def test_layout_is_fixed_by_the_scene_spec(scenes):
    a, b = layout_scene(scenes[0]), layout_scene(scenes[0])
    assert a.primitives == b.primitives
    assert len(a.primitives) > 100


def test_ray_cast_hits_box_cylinder_sphere_by_hand(scenes):
    from generator.layout import Primitive

    prims = (Primitive("box", (5.0, 0.0, 1.0), (2.0, 2.0, 2.0), 0.0, "m"),
             Primitive("cylinder", (0.0, 5.0, 1.0), (2.0, 2.0, 2.0), 0.3, "m"),
             Primitive("sphere", (-5.0, 0.0, 1.0), (2.0, 2.0, 2.0), 0.0, "m"),
             Primitive("box", (0.0, -5.0, 1.0), (2.0, 2.0, 2.0), math.pi / 4, "m"))
    lay = SceneLayout(scenes[0], prims)
    o = np.zeros((4, 3)) + [0, 0, 1.0]
    d = np.array([[1.0, 0, 0], [0, 1.0, 0], [-1.0, 0, 0], [0, -1.0, 0]])
    t = ray_cast(lay, o, d)
    np.testing.assert_allclose(t, [4.0, 4.0, 4.0, 5.0 - math.sqrt(2)], atol=1e-9)
    # a ray passing above everything, and a ray starting inside the box
    assert np.isinf(ray_cast(lay, [[0, 0, 3.0]], [[1.0, 0, 0]])[0])
    assert ray_cast(lay, [[5.0, 0, 1.0]], [[0, 0, 1.0]])[0] == 0.0
    assert not segments_clear(lay, [[0, 0, 1.0]], [[10.0, 0, 1.0]])
    assert segments_clear(lay, [[0, 0, 1.0]], [[3.5, 0, 1.0]])
    assert segments_clear(lay, [[0, 0, 1.0]], [[3.5, 0, 1.0]], margin=0.6) is False
    assert footprint_distance(lay, (2.0, 0.0)) == pytest.approx(2.0)


# --------------------------------------------------------------------------- sampling


def test_derive_seed_is_stable_and_distinct():
    assert derive_seed(0, "person", "shop", "p001", 0) == derive_seed(0, "person", "shop",
                                                                      "p001", 0)
    seeds = {derive_seed(s, "person", "shop", p, i) for s in (0, 1) for p in ("p001", "p002")
             for i in range(3)}
    assert len(seeds) == 12
    assert all(0 <= s < 2 ** 63 for s in seeds)
    # golden value: changing it changes every dataset
    assert derive_seed(0, "x") == derive_seed(0, "x") and derive_seed(0, "x") != derive_seed(1, "x")


def test_presets_and_fold_units():
    tiny = preset_config("tiny")
    assert tiny.n_persons >= 6 and tiny.n_scenes >= 3
    assert tiny.elevations == pytest.approx((0.0, math.pi / 8, math.pi / 4))
    paper = preset_config("paper")
    assert paper.n_persons * paper.n_scenes * paper.instances * len(paper.elevations) == 7956
    assert paper.frames >= 1 and tiny.frames >= 1 and preset_config("small").frames >= 1
    # >= 10,000 negative 64x128 windows per elevation (paper scale) at the stride the
    # cross-validation cuts them with
    from benchmark.crops.crossval import CrossvalConfig

    stride = CrossvalConfig().bg_stride
    bw, bh = paper.background_size
    per_image = ((bw - 64) // stride + 1) * ((bh - 128) // stride + 1)
    assert paper.n_scenes * paper.backgrounds_per_scene * per_image >= 10_000
    with pytest.raises(ValueError, match="unknown preset"):
        preset_config("huge")
    with pytest.raises(ValueError, match="elevation"):
        preset_config("tiny", elevations=(0.0, 2.0))
    with pytest.raises(ValueError, match="framing"):
        preset_config("tiny", framing="tight")


def test_plan_is_deterministic_and_seed_dependent(tiny_plan, scenes, roster):
    again = plan_dataset(preset_config("tiny"), 0, scenes=scenes, persons=roster)
    other = plan_dataset(preset_config("tiny"), 1, scenes=scenes, persons=roster)
    s0 = [s for u in tiny_plan.units for s in u.samples]
    s1 = [s for u in again.units for s in u.samples]
    assert [(getattr(a, "ground_xy", None), a.seed) for a in s0] == \
           [(getattr(a, "ground_xy", None), a.seed) for a in s1]
    s2 = [s for u in other.units for s in u.samples]
    assert [a.seed for a in s0] != [a.seed for a in s2]
    # a sample does not depend on which other persons/scenes are planned
    sub = plan_dataset(preset_config("tiny", person_ids=("p003",)), 0, scenes=scenes,
                       persons=roster)
    a = next(s for u in sub.units if u.kind == "person" for s in u.samples
             if s.scene_id == "plaza")
    b = next(s for u in tiny_plan.units if u.kind == "person" for s in u.samples
             if s.scene_id == "plaza" and s.person_id == "p003")
    assert a.ground_xy == b.ground_xy and a.rotation == b.rotation and a.lighting == b.lighting


def test_plan_counts_and_paths(tiny_plan):
    cfg = tiny_plan.config
    kinds = [u.kind for u in tiny_plan.units]
    assert kinds.count("person") == cfg.n_persons * cfg.n_scenes
    assert kinds.count("frame") == cfg.frames
    assert tiny_plan.n_images == (cfg.n_persons * cfg.n_scenes * cfg.instances * 3
                                  + cfg.n_scenes * cfg.backgrounds_per_scene * 3 + cfg.frames)
    assert image_relpath("person", "shop", person_id="p001", instance=2, elevation_index=1) \
        == "person/shop/p001_i2_e1.png"
    assert image_relpath("background", "shop", index=3, elevation_index=0) \
        == "background/shop/bg_i3_e0.png"
    assert image_relpath("frame", "shop", index=0) == "frames/shop/frame_0.png"


def test_more_frames_extend_the_set(tiny_plan, scenes, roster):
    cfg = tiny_plan.config
    more = plan_dataset(preset_config("tiny", frames=cfg.frames + 5), 0, scenes=scenes,
                        persons=roster)
    frames = {u.uid: u.samples[0] for u in more.units if u.kind == "frame"}
    assert len(frames) == cfg.frames + 5
    for u in tiny_plan.units:
        if u.kind == "frame":
            a, b = u.samples[0], frames[u.uid]
            assert (a.seed, a.persons, a.lighting) == (b.seed, b.persons, b.lighting)
            assert a.camera.to_dict() == b.camera.to_dict()


def test_paired_views_share_everything_but_the_camera(tiny_plan):
    s = next(s for u in tiny_plan.units if u.kind == "person" for s in u.samples)
    centres = [c.center for c in s.cameras]
    aim = np.array([s.ground_xy[0], s.ground_xy[1], 1.75 / 2])
    for c, e in zip(centres, tiny_plan.config.elevations):
        v = c - aim
        assert np.linalg.norm(v) == pytest.approx(10.0, abs=1e-9)            # same distance
        assert math.asin(v[2] / np.linalg.norm(v)) == pytest.approx(e, abs=1e-12)
        # and the same ground direction (azimuth) at every elevation
        ang = math.atan2(v[1], v[0])
        assert ang == pytest.approx(math.atan2(-math.cos(s.azimuth), math.sin(s.azimuth)),
                                    abs=1e-9) or e >= math.pi / 2
    for c in s.cameras:
        np.testing.assert_array_equal(c.K, s.cameras[0].K)                 # same intrinsics


def test_crop_geometry_matches_the_library(tiny_plan):
    """Translated crop cameras reproduce crop_homography; the feet go where H says."""
    for u in tiny_plan.units:
        if u.kind != "person":
            continue
        for s in u.samples:
            for e, (cam, H) in enumerate(zip(s.cameras, s.homographies)):
                el = tiny_plan.config.elevations[e]
                np.testing.assert_allclose(H, crop_homography(el), **EXACT)
                # aim point at the window centre, the ground point below it at the feet row
                P = np.array([[s.ground_xy[0], s.ground_xy[1], 1.75 / 2],
                              [s.ground_xy[0], s.ground_xy[1], 0.0]])
                got = cam.project(P)
                want = apply_homography(H, [[31.5, 63.5], [31.5, 111.5]])
                np.testing.assert_allclose(got, want, atol=1e-9)
            np.testing.assert_allclose(s.homographies[0], np.eye(3), atol=1e-12)


def test_background_centre_window_homography(tiny_plan):
    u = next(u for u in tiny_plan.units if u.kind == "background")
    s = u.samples[0]
    for e, (cam, H) in enumerate(zip(s.cameras, s.homographies)):
        assert cam.image_size == (256, 256)
        crop = crop_camera(tiny_plan.config.elevations[e])
        np.testing.assert_allclose(cam.K[0, 0], crop.K[0, 0])             # same focal length
        c = apply_homography(H, [[31.5, 63.5]])[0]
        np.testing.assert_allclose(c, [127.5, 127.5], atol=1e-9)          # centre window
        np.testing.assert_allclose(H, window_to_image_homography(cam, s.ground_xy),
                                   **EXACT)


def test_frame_camera_is_caviar_like(scenes):
    for spec in scenes:
        cam = frame_camera(spec, (384, 288))
        assert 3.0 <= cam.center[2] <= 6.0 + 1e-9
        fwd = cam.R[2]
        tilt = math.degrees(math.asin(-fwd[2]))
        assert 30 - 1e-6 <= tilt <= 60 + 1e-6
        assert cam.K[0, 0] < 384          # wide field of view (> 53 degrees)


def test_frame_persons_are_in_view(tiny_plan):
    u = next(u for u in tiny_plan.units if u.kind == "frame")
    s = u.samples[0]
    cfg = tiny_plan.config
    assert cfg.persons_per_frame[0] <= len(s.persons) <= cfg.persons_per_frame[1]
    for p in s.persons:
        feet = s.camera.project([p.ground_xy[0], p.ground_xy[1], 0.0])
        assert 0 <= feet[0] < 384 and 0 <= feet[1] < 288


def test_blackbody_rgb_is_warm_to_cool():
    warm, cool = blackbody_rgb(3000), blackbody_rgb(9000)
    assert warm[0] == 1.0 and warm[2] < 0.4
    assert cool[2] == 1.0 and cool[0] < 1.0


def test_shards_partition_the_units():
    units = list(range(23))
    parts = [select_shard(units, (i, 4)) for i in range(4)]
    assert sum(parts, []) == units
    assert parse_shard("2/5") == (2, 5)
    for bad in ("5/5", "a/b", "1", "-1/3"):
        with pytest.raises(ValueError, match="shard"):
            parse_shard(bad)


def test_config_round_trips_through_json():
    cfg = preset_config("small", framing="silhouette")
    again = GeneratorConfig.from_dict(json.loads(json.dumps(cfg.to_dict())))
    assert again == cfg


# --------------------------------------------------------------------------- manifest


def _fake_dataset(out: Path, plan):
    """Write PNGs and part files for a plan without rendering (grey images)."""
    from generator.pipeline import dataset_metadata, depth_relpath, unit_paths
    from generator.specs import default_roster_path, default_scene_dir

    out.mkdir(parents=True, exist_ok=True)
    meta = dataset_metadata(plan.config, plan.seed, plan, default_scene_dir(),
                            default_roster_path())
    (out / "dataset.json").write_text(json.dumps(meta))
    for u in plan.units:
        rows = []
        for rel in unit_paths(u):
            size = (plan.config.crop_size if u.kind == "person" else
                    plan.config.background_size if u.kind == "background"
                    else plan.config.frame_size)
            img = np.full((size[1], size[0], 3), 128, np.uint8)
            (out / rel).parent.mkdir(parents=True, exist_ok=True)
            cv2.imwrite(str(out / rel), img)
            row = {c: None for c in MANIFEST_COLUMNS}
            row.update(path=rel, kind=u.kind, scene_id=u.scene_id, instance=0,
                       elevation_index=0, width=size[0], height=size[1], seed=1,
                       render_seed=1, samples=1, supersample=1, n_area_lights=0,
                       n_persons=0, person_id="", box_silhouette="", depth_path="")
            if u.kind == "person":
                depth = np.full((size[1], size[0]), np.nan, np.float32)
                depth[20:110, 24:40] = 10.0
                row["depth_path"] = depth_relpath(rel)
                write_depth(out / row["depth_path"], depth)
            rows.append(row)
        coco = ({"images": [{"file_name": r["path"], "width": r["width"],
                             "height": r["height"]} for r in rows], "annotations": []}
                if u.kind == "frame" else None)
        write_part(out, u.uid, rows, coco)
    return [u.uid for u in plan.units]


def test_manifest_assembly_and_verify_find_damage(tmp_path, tiny_plan):
    out = tmp_path / "ds"
    uids = _fake_dataset(out, tiny_plan)
    df, missing = assemble_manifest(out, uids)
    assert missing == [] and len(df) == tiny_plan.n_images
    assert list(df.columns) == MANIFEST_COLUMNS
    assert read_manifest(out)["path"].tolist() == df["path"].tolist()
    import pandas as pd
    assert pd.read_csv(out / "manifest.csv")["path"].tolist() == df["path"].tolist()
    rep = verify_dataset(out)
    assert rep.ok, rep.summary()
    assert rep.n_planned == tiny_plan.n_images
    # damage: one truncated, one deleted, one garbage, one stray temp file
    paths = df["path"].tolist()
    data = (out / paths[0]).read_bytes()
    (out / paths[0]).write_bytes(data[: len(data) // 2])
    (out / paths[1]).unlink()
    (out / paths[2]).write_bytes(b"\x89PNG\r\n\x1a\n" + b"x" * 100 + b"\0\0\0\0IEND\xaeB`\x82")
    (out / "person" / "plaza" / ".p001_i0_e0.png.abc.tmp").write_bytes(b"partial")
    # depth maps: one of the wrong size, one deleted, one a pickled object array
    depths = [d for d in df["depth_path"] if d]
    write_depth(out / depths[5], np.ones((4, 4), np.float32))
    (out / depths[6]).unlink()
    np.savez(out / depths[7], depth=np.array([{"x": 1}], dtype=object))
    rep = verify_dataset(out)
    found = dict(rep.problems)
    assert "crop is 64x128" in found[depths[5]]
    assert found[depths[6]] == "missing"
    assert "unreadable" in found[depths[7]] or "pickle" in found[depths[7]].lower()
    assert "truncated" in found[paths[0]]
    assert found[paths[1]] == "missing"
    assert "unreadable" in found[paths[2]]
    assert any("leftover temporary" in m for _, m in rep.problems)
    assert not rep.ok and "problem" in rep.summary()


def test_manifest_skips_unfinished_units(tmp_path, tiny_plan):
    out = tmp_path / "ds"
    uids = _fake_dataset(out, tiny_plan)
    from generator.manifest import part_path

    part_path(out, uids[3]).unlink()
    df, missing = assemble_manifest(out, uids)
    assert missing == [uids[3]]
    rep = verify_dataset(out)
    assert any(m == "planned but not generated" for _, m in rep.problems)
    assert any(m == "not in the manifest" for _, m in rep.problems)


def test_png_is_complete(tmp_path):
    p = tmp_path / "a.png"
    cv2.imwrite(str(p), np.zeros((8, 8, 3), np.uint8))
    assert png_is_complete(p)
    p.write_bytes(p.read_bytes()[:-5])
    assert not png_is_complete(p)
    assert not png_is_complete(tmp_path / "nope.png")


def test_preview_writes_contact_sheets(tmp_path, tiny_plan):
    from generator.preview import preview_dataset

    out = tmp_path / "ds"
    uids = _fake_dataset(out, tiny_plan)
    df, _ = assemble_manifest(out, uids)
    # the fake rows lack elevations; fill what the sheets read
    import pandas as pd
    m = pd.read_parquet(out / "manifest.parquet")
    m["elevation_index"] = [int(p.rsplit("_e", 1)[1][0]) if "_e" in p else -1
                            for p in m["path"]]
    m["elevation"] = m["elevation_index"].clip(lower=0) * math.pi / 8
    m["instance"] = 0
    m["person_id"] = [p.split("/")[-1].split("_")[0] if k == "person" else ""
                      for p, k in zip(m["path"], m["kind"])]
    m["H_window_to_image"] = json.dumps(np.eye(3).tolist())
    m.to_parquet(out / "manifest.parquet", index=False)
    paths = preview_dataset(out, tmp_path / "sheet.png", columns=4, rows=2)
    img = cv2.imread(str(paths[0]))
    assert img is not None and img.shape[0] > 3 * 128
    with pytest.raises(ValueError, match=".png"):
        preview_dataset(out, tmp_path / "sheet.jpg")


# --------------------------------------------------------------------------- CLI


def _parser():
    from generator.cli import register
    from viewadapt.cli import common_parser

    p = argparse.ArgumentParser(prog="viewadapt")
    sub = p.add_subparsers(dest="command")
    register(sub, common_parser())
    return p


def test_cli_parses_generate_and_dataset(tmp_path):
    p = _parser()
    a = p.parse_args(["generate", "--preset", "small", "--out", str(tmp_path), "--seed", "3",
                      "--jobs", "2", "--shard", "1/4", "--elevations", "0,pi/8,pi/4"])
    assert (a.preset, a.seed, a.jobs, a.shard) == ("small", 3, 2, "1/4")
    a = p.parse_args(["dataset", "verify", str(tmp_path)])
    assert a.func.__name__ == "cmd_verify"
    a = p.parse_args(["dataset", "preview", str(tmp_path), "--out", "x.png"])
    assert a.func.__name__ == "cmd_preview"


def test_generate_records_the_camera_distance_it_is_given(tmp_path, monkeypatch):
    from generator import pipeline

    seen = []

    def fake_generate(config, *a, **k):
        seen.append(config)
        return SimpleNamespace(summary=lambda: "not rendered")

    monkeypatch.setattr(pipeline, "generate", fake_generate)
    p = _parser()
    for argv, distance in ((["--distance", "6.5"], 6.5), ([], 10.0)):
        a = p.parse_args(["generate", "--out", str(tmp_path / "o"), "--preset", "paper"] + argv)
        assert a.func(a) == 0
        assert seen[-1].distance == distance and seen[-1].to_dict()["distance"] == distance


def test_a_camera_too_far_for_a_scene_says_so(scenes, roster):
    with pytest.raises(ValueError, match=r"from a camera 1e\+06 m away; .*\(--distance\)"):
        plan_dataset(preset_config("tiny", distance=1e6), 0, scenes=scenes, persons=roster)


def test_cli_user_errors_are_one_line_value_errors(tmp_path):
    from generator.cli import parse_elevations

    p = _parser()
    a = p.parse_args(["generate", "--out", str(tmp_path / "o"), "--shard", "9/2"])
    with pytest.raises(ValueError, match="shard"):
        a.func(a)
    a = p.parse_args(["generate", "--out", str(tmp_path / "o"), "--elevations", "0,2"])
    with pytest.raises(ValueError, match="outside"):
        a.func(a)
    a = p.parse_args(["generate", "--out", str(tmp_path / "o"), "--frames", "0"])
    with pytest.raises(ValueError, match="--frames must be at least 1"):
        a.func(a)
    a = p.parse_args(["dataset", "verify", str(tmp_path / "nothing")])
    with pytest.raises(FileNotFoundError, match="not found"):
        a.func(a)
    assert parse_elevations("0,pi/8,pi/4") == pytest.approx((0, math.pi / 8, math.pi / 4))
    assert parse_elevations("0deg,45deg") == pytest.approx((0, math.pi / 4))
    assert parse_elevations("0:pi/4:3") == pytest.approx((0, math.pi / 8, math.pi / 4))
    with pytest.raises(ValueError, match="cannot parse"):
        parse_elevations("zero")


def test_cli_refuses_an_out_dir_with_another_config(tmp_path, tiny_plan):
    from generator.pipeline import generate

    out = tmp_path / "ds"
    _fake_dataset(out, tiny_plan)
    with pytest.raises(ValueError, match="different config or seed"):
        generate(preset_config("tiny"), 5, out, jobs=0, progress=False)


def test_verify_cli_exit_code(tmp_path, tiny_plan, capsys):
    from generator.cli import cmd_verify

    out = tmp_path / "ds"
    uids = _fake_dataset(out, tiny_plan)
    assemble_manifest(out, uids)
    p = _parser()
    assert cmd_verify(p.parse_args(["dataset", "verify", str(out)])) == 0
    assert "no problems found" in capsys.readouterr().out
    next((out / "person").rglob("*.png")).unlink()
    assert cmd_verify(p.parse_args(["dataset", "verify", str(out), "--fast"])) == 1
    assert "missing" in capsys.readouterr().out


def test_silhouette_framing_intrinsics_fit_the_box():
    from generator.annotate import fit_silhouette_intrinsics, silhouette_box
    from viewadapt.geometry import Camera

    rng = np.random.default_rng(0)
    cam = crop_camera(math.pi / 4)
    pts = rng.normal(0, 0.2, (500, 3)) * [1, 1, 3] + [0.1, 0, 0.9]
    K = fit_silhouette_intrinsics(cam, pts)
    fitted = Camera(K, cam.R, cam.t)
    uv = fitted.project(pts)
    (x0, y0), (x1, y1) = uv.min(0), uv.max(0)
    assert y1 - y0 == pytest.approx(96.0)
    assert (x0 + x1) / 2 == pytest.approx(31.5) and (y0 + y1) / 2 == pytest.approx(63.5)
    box = silhouette_box(pts, fitted, 64, 128)
    assert box[1] == pytest.approx(15.5) and box[3] == pytest.approx(96.0)


def test_frame_annotations_occlusion_by_hand(scenes):
    """A box in front of half a person's silhouette hides about half of it."""
    from generator.annotate import frame_annotations
    from generator.layout import Primitive
    from viewadapt.geometry import camera_from_pose

    cam = camera_from_pose(focal=300.0, principal_point=(191.5, 143.5), height=1.0,
                           tilt=0.0, azimuth=math.pi / 2, image_size=(384, 288))
    # a flat 0.6 x 1.8 m "person" (two triangles) 8 m in front of the camera
    quad = np.array([[-0.3, 8.0, 0.0], [0.3, 8.0, 0.0], [0.3, 8.0, 1.8], [-0.3, 8.0, 1.8]])
    tris = quad[[[0, 1, 2], [0, 2, 3]]]
    free = SceneLayout(scenes[0], ())
    a = frame_annotations(cam, 384, 288, [(tris, quad, (0.0, 8.0))], free)[0]
    assert a["occlusion"] == 0.0 and a["truncation"] == 0.0
    x, y, w, h = a["bbox"]
    assert w == pytest.approx(0.6 * 300 / 8) and h == pytest.approx(1.8 * 300 / 8)
    wall = SceneLayout(scenes[0], (Primitive("box", (-0.5, 6.0, 1.0), (1.0, 0.2, 2.0), 0.0,
                                             "m"),))
    b = frame_annotations(cam, 384, 288, [(tris, quad, (0.0, 8.0))], wall)[0]
    assert b["occlusion"] == pytest.approx(0.5, abs=0.08)
    vx, vy, vw, vh = b["bbox_visible"]
    assert vx == pytest.approx(191.5, abs=1.5) and vw == pytest.approx(w / 2, abs=1.5)
