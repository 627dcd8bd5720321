"""Camera effects as a generator setting (generator.camera_effects): off leaves configs,
manifests and images as they were; on, every image passes through its own recorded draw.

The settings and the write path are checked without a renderer; the datasets are rendered
with pyrender (skipped without pyrender, anny or an OpenGL context): one person in one
scene at two elevations, a background and a frame, with effects off and twice on.
"""

import argparse
import json
import math
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest

from generator.camera_effects import (
    CAMERA_EFFECTS, NO_EFFECTS, SURVEILLANCE, check_camera_effects, draw_image_effects,
    effects_json, raw_render_path, render_with_effects,
)
from generator.manifest import MANIFEST_COLUMNS, OPTIONAL_COLUMNS, manifest_columns
from generator.sampling import PRESETS, GeneratorConfig, preset_config
from tests.folders import file_bytes
from viewadapt.camera.effects import EFFECT_KEYS, apply_camera_effects


def _parser():
    from generator.cli import register
    from viewadapt.cli import common_parser

    p = argparse.ArgumentParser(prog="viewadapt")
    sub = p.add_subparsers(dest="command")
    register(sub, common_parser())
    return p


# --------------------------------------------------------------------------- the setting


@pytest.mark.parametrize("name", [n for n in PRESETS if n != "realistic"])
def test_presets_without_effects_record_the_config_they_did_before(name):
    cfg = preset_config(name)
    assert cfg.camera_effects == NO_EFFECTS
    d = cfg.to_dict()
    assert "camera_effects" not in d
    assert set(d) == {f for f in GeneratorConfig.__dataclass_fields__} - {"camera_effects"}
    # a dataset.json written before the setting existed reads back as effects off
    assert GeneratorConfig.from_dict(json.loads(json.dumps(d))) == cfg


def test_realistic_preset_is_small_through_surveillance_effects():
    real, small = preset_config("realistic"), preset_config("small")
    assert real.camera_effects == "surveillance"
    assert real.to_dict()["camera_effects"] == "surveillance"
    assert GeneratorConfig.from_dict(json.loads(json.dumps(real.to_dict()))) == real
    same = {k: v for k, v in real.to_dict().items() if k not in ("preset", "camera_effects")}
    assert same == {k: v for k, v in small.to_dict().items() if k != "preset"}
    assert preset_config("tiny", camera_effects="surveillance").to_dict()[
        "camera_effects"] == "surveillance"


@pytest.mark.parametrize("value, message", [
    ("jpeg", "camera_effects must be one of none, surveillance, got 'jpeg'"),
    (3, "camera_effects must be a string"),
])
def test_a_bad_setting_is_a_one_line_error(value, message):
    with pytest.raises(ValueError, match=message) as exc:
        preset_config("tiny", camera_effects=value)
    assert "\n" not in str(exc.value)
    with pytest.raises(ValueError, match="must be one of"):
        check_camera_effects("jpeg")


def test_the_cli_offers_every_preset_and_setting(tmp_path):
    from generator.cli import CAMERA_EFFECT_NAMES, PRESET_NAMES

    assert PRESET_NAMES == tuple(PRESETS)
    assert CAMERA_EFFECT_NAMES == tuple(CAMERA_EFFECTS)
    p = _parser()
    a = p.parse_args(["generate", "--preset", "realistic", "--out", str(tmp_path)])
    assert (a.preset, a.camera_effects) == ("realistic", None)
    a = p.parse_args(["generate", "--out", str(tmp_path), "--camera-effects", "surveillance"])
    assert a.camera_effects == "surveillance"
    with pytest.raises(SystemExit):
        p.parse_args(["generate", "--out", str(tmp_path), "--camera-effects", "vhs"])


def test_the_generators_ranges_are_the_surveillance_ranges():
    assert SURVEILLANCE.to_dict() == {
        "blur_sigma": [0.0, 1.2], "vignetting": [0.0, 0.3], "white_balance": 0.15,
        "exposure": [0.7, 1.3], "noise_sigma": [1.0, 6.0], "gamma": [0.8, 1.25],
        "downscale": [0.5, 1.0], "jpeg_quality": [30, 90]}


def test_draws_depend_on_the_seed_alone():
    assert draw_image_effects(NO_EFFECTS, 5) is None
    a, b = draw_image_effects("surveillance", 5), draw_image_effects("surveillance", 5)
    assert a == b and set(EFFECT_KEYS) <= set(a)
    assert draw_image_effects("surveillance", 6) != a
    assert json.loads(effects_json(a)) == a and effects_json(None) == ""


def test_the_manifest_has_the_column_only_when_a_row_has_it():
    assert OPTIONAL_COLUMNS == ["camera_effects"]
    assert manifest_columns([{"path": "a"}, {"path": "b"}]) == MANIFEST_COLUMNS
    assert manifest_columns([{"path": "a", "camera_effects": "{}"}]) == \
        MANIFEST_COLUMNS + ["camera_effects"]


class _FakeRenderer:
    """Writes a fixed image as a PNG (or fails), as a renderer's ``render`` does."""

    def __init__(self, image, fail=False):
        self.image, self.fail, self.paths = image, fail, []

    def render(self, path, *, samples, seed):
        self.paths.append(Path(path))
        ok, buf = cv2.imencode(".png", self.image[..., ::-1])
        Path(path).write_bytes(buf.tobytes())
        if self.fail:
            raise RuntimeError("render failed")


def test_render_with_effects_writes_the_effects_of_the_render(tmp_path):
    rng = np.random.default_rng(1)
    img = rng.integers(0, 256, (128, 64, 3), dtype=np.uint8)
    params = draw_image_effects("surveillance", 11)
    path = tmp_path / "person" / "p_i0_e0.png"
    path.parent.mkdir(parents=True)
    r = _FakeRenderer(img)
    render_with_effects(r, path, params, samples=1, seed=0)
    assert r.paths == [raw_render_path(path)] and r.paths[0].name.startswith(".")
    got = cv2.imread(str(path))[..., ::-1]
    assert np.array_equal(got, apply_camera_effects(img, params))
    assert not np.array_equal(got, img)
    assert sorted(p.name for p in path.parent.iterdir()) == [path.name]
    # a failed render leaves neither the image nor the raw file
    path2 = path.with_name("p_i0_e1.png")
    with pytest.raises(RuntimeError, match="render failed"):
        render_with_effects(_FakeRenderer(img, fail=True), path2, params, samples=1, seed=0)
    assert sorted(p.name for p in path.parent.iterdir()) == [path.name]


# --------------------------------------------------------------------------- rendered


def _micro(effects=NO_EFFECTS):
    return GeneratorConfig(preset="micro", renderer="pyrender", person_ids=("p001",),
                           scene_ids=("plaza",), elevations=(0.0, math.pi / 4),
                           backgrounds_per_scene=1, frames=1, persons_per_frame=(1, 1),
                           camera_effects=effects).validate()


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    pytest.importorskip("pyrender", reason="optional: pip install pyrender")
    pytest.importorskip("anny", reason="needs the generator extra: pip install -e '.[generator]'")
    from generator import pipeline
    from generator.raster import RasterRenderer

    try:
        RasterRenderer(n_slots=1, supersample=1, shadows=False)._renderer(8, 8)
    except Exception as exc:  # noqa: BLE001 - no GL context on this machine
        pytest.skip(f"no OpenGL context for pyrender: {exc}")
    root = tmp_path_factory.mktemp("effects")
    outs = {"off": root / "off", "on": root / "on", "again": root / "again"}
    for key, out in outs.items():
        cfg = _micro(NO_EFFECTS if key == "off" else "surveillance")
        assert pipeline.generate(cfg, 4, out, jobs=0, progress=False).complete
    return outs


def _manifest(out):
    from generator.manifest import read_manifest

    return read_manifest(out)


@pytest.mark.blender
@pytest.mark.filterwarnings("ignore:tostring.. is deprecated:DeprecationWarning")
def test_effects_off_writes_no_effects_anywhere(rendered):
    off = rendered["off"]
    df = _manifest(off)
    assert list(df.columns) == MANIFEST_COLUMNS
    meta = json.loads((off / "dataset.json").read_text())
    assert "camera_effects" not in meta and "camera_effects" not in meta["config"]
    assert all("camera_effects" not in row for part in (off / ".parts").glob("*.json")
               for row in json.loads(part.read_text())["rows"])
    assert not list(off.rglob("*.raw.png*"))


@pytest.mark.blender
@pytest.mark.filterwarnings("ignore:tostring.. is deprecated:DeprecationWarning")
def test_effects_on_change_every_image_and_record_what_reproduces_it(rendered):
    from generator.verify import verify_dataset

    off, on = rendered["off"], rendered["on"]
    df_off, df_on = _manifest(off), _manifest(on)
    assert list(df_on.columns) == MANIFEST_COLUMNS + ["camera_effects"]
    assert df_on["path"].tolist() == df_off["path"].tolist()
    assert sorted(set(df_on["kind"])) == ["background", "frame", "person"]
    # the same rows but for the recorded effects
    assert df_on.drop(columns="camera_effects").equals(df_off)
    for row in df_on.itertuples():
        params = json.loads(row.camera_effects)
        assert set(EFFECT_KEYS) <= set(params)
        raw = cv2.imread(str(off / row.path))[..., ::-1]
        got = cv2.imread(str(on / row.path))[..., ::-1]
        assert got.shape == raw.shape
        assert not np.array_equal(got, raw), row.path
        assert np.array_equal(got, apply_camera_effects(np.ascontiguousarray(raw), params)), \
            row.path
    # each image its own draw
    assert df_on["camera_effects"].nunique() == len(df_on)
    meta = json.loads((on / "dataset.json").read_text())
    assert meta["config"]["camera_effects"] == "surveillance"
    assert meta["camera_effects"]["ranges"] == SURVEILLANCE.to_dict()
    coco = json.loads((on / "frames_coco.json").read_text())
    frame = df_on.loc[df_on["kind"] == "frame"].iloc[0]
    assert coco["images"][0]["camera_effects"] == json.loads(frame["camera_effects"])
    rep = verify_dataset(on, check_hash=True)
    assert rep.ok and rep.hash_ok, rep.summary()
    assert not list(on.rglob("*.raw.png*"))


@pytest.mark.blender
@pytest.mark.filterwarnings("ignore:tostring.. is deprecated:DeprecationWarning")
def test_effects_on_are_byte_identical_across_runs(rendered):
    a, b = file_bytes(rendered["on"]), file_bytes(rendered["again"])
    assert a.keys() == b.keys()
    assert [k for k in a if a[k] != b[k]] == []


@pytest.mark.blender
@pytest.mark.filterwarnings("ignore:tostring.. is deprecated:DeprecationWarning")
def test_a_resumed_run_with_effects_gives_the_samefile_bytes(rendered, tmp_path):
    from generator import pipeline
    from generator.manifest import part_path

    out = tmp_path / "resumed"
    shutil.copytree(rendered["on"], out)
    df = _manifest(out)
    crop = df.loc[df["kind"] == "person", "path"].iloc[0]
    frame = df.loc[df["kind"] == "frame", "path"].iloc[0]
    (out / crop).unlink()                            # a finished unit lost an image
    (out / frame).unlink()                           # an unfinished unit (no part file)
    part_path(out, "frame/plaza/0").unlink()
    # what a run killed between the raw render and the effects leaves behind
    stale = [raw_render_path(out / crop), out / Path(crop).parent /
             f".{raw_render_path(out / crop).name}.x1y2.png"]
    for p in stale:
        p.write_bytes(b"raw")
    res = pipeline.generate(_micro("surveillance"), 4, out, jobs=0, progress=False)
    assert res.complete and res.n_rendered == 2
    assert not any(p.exists() for p in stale)
    want, got = file_bytes(rendered["on"]), file_bytes(out)
    assert want.keys() == got.keys()
    assert [k for k in want if want[k] != got[k]] == []


@pytest.mark.blender
@pytest.mark.filterwarnings("ignore:tostring.. is deprecated:DeprecationWarning")
def test_resuming_with_another_setting_is_refused(rendered, tmp_path):
    from generator import pipeline

    out = tmp_path / "other"
    shutil.copytree(rendered["on"], out)
    with pytest.raises(ValueError, match=r"--camera-effects surveillance \(this run: none\)"):
        pipeline.generate(_micro(NO_EFFECTS), 4, out, jobs=0, progress=False)
