"""benchmark.studies.frame_negatives: person-free windows of rendered frames as negatives."""

import json

import numpy as np
import pytest

from benchmark.frames.methods import load_frames
from benchmark.studies.frame_negatives import frame_negative_windows, main, misframed_windows
from tests.toy_frames import small_toy_frames
from viewadapt.boxes import box_iou
from viewadapt.detect import person_boxes
from viewadapt.io import SourceDetectors


@pytest.fixture(scope="module")
def toy(tmp_path_factory):
    return small_toy_frames(tmp_path_factory.mktemp("fneg") / "data")


def test_drawn_windows_are_person_free_inside_and_seeded(toy):
    from viewadapt.detect import select_candidate_windows

    frames = load_frames(toy)
    ws, report = frame_negative_windows(frames, per_frame=30, max_iou=0.1, seed=3)
    assert [r["drawn"] for r in report] == [min(30, r["person_free"]) for r in report]
    assert len(ws) == sum(r["drawn"] for r in report) > 0
    by_path = {str(f.path): f for f in frames}
    for (path, H), (_, row) in zip(ws.items, ws.meta.iterrows()):
        f = by_path[str(path)]
        cw = select_candidate_windows(f.camera, f.camera.image_size)
        j = int(np.flatnonzero(np.all(np.isclose(cw.homographies, H), axis=(1, 2)))[0])
        box = cw.person_boxes()[j]
        if len(f.gt):
            assert box_iou(box, f.gt).max() < 0.1
        w, h = f.camera.image_size
        c = cw.window_corners()[j]
        assert (c >= 0).all() and (c[:, 0] <= w - 1).all() and (c[:, 1] <= h - 1).all()
        assert row["label"] == 0
    again, _ = frame_negative_windows(frames, per_frame=30, max_iou=0.1, seed=3)
    other, _ = frame_negative_windows(frames, per_frame=30, max_iou=0.1, seed=4)
    assert all(np.array_equal(a[1], b[1]) for a, b in zip(ws.items, again.items))
    assert any(not np.array_equal(a[1], b[1]) for a, b in zip(ws.items, other.items))
    tall, rep = frame_negative_windows(frames, per_frame=10 ** 6, min_height=60, seed=3)
    assert 0 < len(tall) == sum(r["person_free"] for r in rep)
    assert all(r["person_free"] <= r["tall_enough"] < r["inside"] for r in rep)
    assert (person_boxes(np.stack([H for _, H in tall.items]))[:, 3] >= 60).all()
    wins = list(ws.images(toy))
    assert wins[0].shape == (128, 64, 3) and wins[0].dtype == np.uint8


def test_misframed_windows_frame_a_person_badly(toy):
    from viewadapt.detect import select_candidate_windows

    frames = load_frames(toy)
    ws, report = misframed_windows(frames, iou=(0.15, 0.4), per_person=5, min_height=0,
                                   seed=2)
    assert 0 < len(ws) == sum(r["drawn"] for r in report)
    assert all(r["drawn"] <= 5 * r["persons"] for r in report)
    by_path = {str(f.path): f for f in frames}
    for path, H in ws.items:
        f = by_path[str(path)]
        cw = select_candidate_windows(f.camera, f.camera.image_size)
        j = int(np.flatnonzero(np.all(np.isclose(cw.homographies, H), axis=(1, 2)))[0])
        overlap = box_iou(cw.person_boxes()[j], f.gt)
        assert 0.15 <= overlap.max() <= 0.4
    again, _ = misframed_windows(frames, iou=(0.15, 0.4), per_person=5, min_height=0, seed=2)
    assert all(np.array_equal(a[1], b[1]) for a, b in zip(ws.items, again.items))
    with pytest.raises(ValueError, match="low < high < 0.5"):
        misframed_windows(frames, iou=(0.3, 0.6))


def test_main_trains_with_the_added_negatives(toy, tmp_path):
    out = tmp_path / "out"
    assert main(["--data", str(toy), "--out", str(out), "--per-frame", "20", "--quick"]) == 0
    rec = json.loads((out / "frame_negatives.json").read_text())
    models = SourceDetectors.load(out / "source_detectors.npz")
    extra = models.training["extra_negatives"]
    assert list(extra.values()) == [rec["negatives"]] and rec["negatives"] > 0
    assert models.training["background_windows"] > 0
    with pytest.raises(SystemExit):
        main(["--data", str(toy), "--out", str(tmp_path / "o2"), "--per-frame", "0"])
    mis = tmp_path / "mis"
    assert main(["--data", str(toy), "--out", str(mis), "--misframed", "--per-person", "5",
                 "--min-height", "0", "--quick"]) == 0
    rec = json.loads((mis / "frame_negatives.json").read_text())
    assert rec["misframed"] and rec["iou"] == [0.15, 0.4] and rec["negatives"] > 0
    with pytest.raises(SystemExit):
        main(["--data", str(toy), "--out", str(tmp_path / "o3"), "--misframed", "--iou",
              "0.4", "0.2"])


def test_hard_negatives_are_the_highest_scored_person_free_windows(toy, tmp_path):
    from benchmark.frames.methods import train_source_detectors
    from benchmark.data import load_dataset
    from benchmark.studies.frame_negatives import hard_negative_windows
    from viewadapt.detect import FrameDetector

    frames = load_frames(toy)
    models = train_source_detectors(load_dataset(toy), quick=True)
    ws, report = hard_negative_windows(frames, models, kind="acf", per_frame=15)
    assert len(ws) == sum(r["drawn"] for r in report) > 0
    by_path = {str(f.path): f for f in frames}
    for path in {str(p) for p, _ in ws.items}:
        f = by_path[path]
        det = FrameDetector(f.camera, models)
        op = det.operator("acf")
        s = np.asarray(op.scores(op.frame_features(f.image())), float)
        kept = [H for p, H in ws.items if str(p) == path]
        j = [int(np.flatnonzero(np.all(np.isclose(det.windows.homographies, H),
                                       axis=(1, 2)))[0]) for H in kept]
        boxes = det.windows.person_boxes()
        free = np.ones(len(s), bool)
        if len(f.gt):
            free = box_iou(boxes, f.gt).max(axis=1) < 0.1
            assert free[j].all()
        # no person-free window inside the frame outscores the lowest one kept
        w, h = f.camera.image_size
        c = det.windows.window_corners()
        inside = ((c[..., 0] >= 0) & (c[..., 0] <= w - 1) & (c[..., 1] >= 0)
                  & (c[..., 1] <= h - 1)).all(axis=1)
        others = np.setdiff1d(np.flatnonzero(free & inside), j)
        assert len(j) == 15 and (s[others] <= s[j].min()).all()
    out = tmp_path / "hard"
    models.save(tmp_path / "m.npz")
    assert main(["--data", str(toy), "--out", str(out), "--hard-from", str(tmp_path / "m.npz"),
                 "--per-frame", "10", "--quick"]) == 0
    rec = json.loads((out / "frame_negatives.json").read_text())
    assert rec["hard_kind"] == "acf" and rec["negatives"] > 0
    with pytest.raises(SystemExit):
        main(["--data", str(toy), "--out", str(tmp_path / "o4"), "--hard-from",
              str(tmp_path / "m.npz"), "--misframed"])
    tall, rep = hard_negative_windows(frames, models, kind="acf", per_frame=15,
                                      min_height=60)
    assert 0 < len(tall) <= len(ws)
    assert (person_boxes(np.stack([H for _, H in tall.items]))[:, 3] >= 60).all()
