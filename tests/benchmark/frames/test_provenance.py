"""What a trained model's record says about the rendered data it came from."""

from types import SimpleNamespace

from benchmark.frames.methods import dataset_provenance


def _ds(**extra):
    cfg = {"preset": "paper", "seed": 3, "renderer": {"name": "pyrender"},
           "elevations": [0.0, 0.785], "content_hash": {"sha256": "ab12"}, **extra}
    return SimpleNamespace(config=cfg, fingerprint="f00d")


def test_provenance_names_the_data():
    rec = dataset_provenance(_ds())
    assert rec == {"preset": "paper", "seed": 3, "renderer": {"name": "pyrender"},
                   "elevations": [0.0, 0.785], "content_hash": "ab12",
                   "fingerprint": "f00d"}


def test_provenance_records_camera_effects_only_when_rendered_through_them():
    rec = dataset_provenance(_ds(camera_effects={"name": "surveillance", "ranges": {}}))
    assert rec["camera_effects"] == "surveillance"
    assert "camera_effects" not in dataset_provenance(_ds(camera_effects=None))
