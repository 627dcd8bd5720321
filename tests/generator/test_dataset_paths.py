"""``dataset.json`` names the specs it was made from without the install's path, so two
checkouts render byte-identical datasets; datasets recording absolute paths still load,
re-plan and resume."""

from __future__ import annotations

import json
import shutil

import pytest

from generator import specs
from tests.folders import file_hashes, micro_config
from tests.paths import REPO


def test_dataset_json_names_the_project_assets_relatively():
    from generator.contents import dataset_metadata
    from generator.sampling import plan_dataset, preset_config

    cfg = preset_config("tiny")
    plan = plan_dataset(cfg, 0)
    meta = dataset_metadata(cfg, 0, plan, specs.default_scene_dir(), specs.default_roster_path())
    assert meta["specs"]["scene_dir"] == "assets/scenes"
    assert meta["specs"]["roster"] == "assets/persons.json"
    assert str(REPO) not in json.dumps(meta)


def test_old_absolute_spec_paths_still_re_plan(tmp_path):
    from generator.contents import dataset_metadata, planned_paths
    from generator.sampling import plan_dataset, preset_config

    cfg = preset_config("tiny")
    plan = plan_dataset(cfg, 0)
    meta = dataset_metadata(cfg, 0, plan, specs.default_scene_dir(), specs.default_roster_path())
    want = planned_paths(meta)
    assert len(want) == plan.n_images
    here = dict(meta, specs=dict(meta["specs"], scene_dir=str(specs.default_scene_dir()),
                                 roster=str(specs.default_roster_path())))
    assert planned_paths(here) == want                 # written by this checkout before
    gone = dict(meta, specs=dict(meta["specs"], scene_dir="/old/checkout/assets/scenes",
                                 roster="/old/checkout/assets/persons.json"))
    assert planned_paths(gone) == want                 # by a checkout no longer there
    mine = tmp_path / "my_scenes"
    shutil.copytree(specs.default_scene_dir(), mine)
    other = dict(meta, specs=dict(meta["specs"], scene_dir=str(mine)))
    assert planned_paths(other) == want                # a folder of one's own, kept absolute
    assert dataset_metadata(cfg, 0, plan, mine, specs.default_roster_path())["specs"][
        "scene_dir"] == str(mine)


@pytest.mark.blender
@pytest.mark.filterwarnings("ignore:tostring.. is deprecated:DeprecationWarning")
def test_two_checkouts_render_byte_identical_datasets(tmp_path, monkeypatch):
    pytest.importorskip("pyrender", reason="optional: pip install pyrender")
    pytest.importorskip("anny", reason="needs the generator extra")
    from generator.pipeline import generate
    from generator.verify import verify_dataset

    trees = []
    for name in ("checkout_a", "checkout_b"):
        assets = tmp_path / name / "assets"
        shutil.copytree(REPO / "assets", assets)
        monkeypatch.setattr(specs, "ASSETS_DIR", assets)
        out = tmp_path / name / "ds"
        try:
            res = generate(micro_config(), 3, out, jobs=0, progress=False)
        except Exception as exc:  # noqa: BLE001 - no GL context on this machine
            pytest.skip(f"pyrender cannot render here: {exc}")
        assert res.complete
        text = (out / "dataset.json").read_text()
        assert str(tmp_path) not in text and str(REPO) not in text
        assert verify_dataset(out, check_hash=True).ok
        trees.append(file_hashes(out))
    a, b = trees
    assert a.keys() == b.keys() and [k for k in a if a[k] != b[k]] == []
    # a dataset of an older version (absolute paths of a checkout since moved) resumes,
    # and its dataset.json then has this version's bytes
    meta_p = tmp_path / "checkout_b" / "ds" / "dataset.json"
    meta = json.loads(meta_p.read_text())
    meta["specs"].update(scene_dir="/old/checkout/assets/scenes",
                         roster="/old/checkout/assets/persons.json")
    meta_p.write_text(json.dumps(meta, indent=2))
    assert verify_dataset(meta_p.parent).ok
    res = generate(micro_config(), 3, meta_p.parent, jobs=0, progress=False)
    assert res.complete and res.n_rendered == 0
    assert file_hashes(meta_p.parent) == a
