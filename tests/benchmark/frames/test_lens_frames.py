"""bench frames on frames with a lens: frames_coco.json's optional ``dist`` per image is
read and checked, frames of one camera with another lens are another camera, and the
candidate windows of a camera with a lens are mapped through it, as ``viewadapt detect``
maps them."""

import json
import shutil

import numpy as np
import pytest

from benchmark.frames.command import _detect_camera, _group_by_camera
from benchmark.frames.methods import load_frames, train_source_detectors
from benchmark.data import load_dataset
from viewadapt.detect import select_candidate_windows, windows_through_lens
from tests.toy_frames import small_toy_frames

DIST = [-0.2, 0.0, 0.0, 0.0, 0.0]


@pytest.fixture(scope="module")
def toy(tmp_path_factory):
    return small_toy_frames(tmp_path_factory.mktemp("lens_frames"), frames_per_scene=2)


def _with_dist(toy, tmp_path, dists):
    root = tmp_path / "data"
    shutil.copytree(toy, root)
    coco = json.loads((root / "frames_coco.json").read_text())
    for entry, d in zip(coco["images"], dists):
        if d is not None:
            entry["dist"] = d
    (root / "frames_coco.json").write_text(json.dumps(coco))
    return root


def test_dist_is_read_checked_and_separates_cameras(toy, tmp_path):
    plain = load_frames(toy)
    assert all(f.dist is None for f in plain)
    root = _with_dist(toy, tmp_path, [DIST, None])
    frames = load_frames(root)
    np.testing.assert_array_equal(frames[0].dist, DIST)
    assert frames[1].dist is None
    assert len(_group_by_camera(frames)) == len(_group_by_camera(plain)) + 1
    bad = _with_dist(toy, tmp_path / "bad", [[0.1, 0.2, 0.3]])
    with pytest.raises(ValueError, match=r"frames_coco.json: image .*: dist: dist must be 4, 5"):
        load_frames(bad)


def test_the_windows_of_a_camera_with_a_lens_go_through_it(toy, tmp_path, monkeypatch):
    import benchmark.frames.methods as methods

    models = train_source_detectors(load_dataset(toy), quick=True, frame_view="none")
    frames = load_frames(_with_dist(toy, tmp_path, [DIST] * 99))
    group = _group_by_camera(frames)[0]
    made = []

    class Spy(methods.FrameMethods):
        def __init__(self, camera, models, **kw):
            made.append(kw)
            super().__init__(camera, models, **kw)

    monkeypatch.setattr(methods, "FrameMethods", Spy)
    _, _, n = _detect_camera(group, models=models, methods=[], heights=(1.75,),
                             cache_dir=None, cache_limit_gb=None, tolerance=0.5,
                             cells_per_source_cell=0.7, upsample_below=0.5)
    assert made[0]["lens"] == DIST
    cam = group[0].camera
    want, _ = windows_through_lens(select_candidate_windows(cam, cam.image_size), cam.K, DIST)
    assert n == len(want)
    np.testing.assert_allclose(Spy(cam, models, lens=DIST).windows.homographies,
                               want.homographies)
    assert not np.allclose(Spy(cam, models).windows.homographies, want.homographies)
