"""`viewadapt detect` on a camera's footage: a video, a folder, a glob pattern or image
files; frame selection; every output format; --jobs; lens distortion; bad input.

One toy camera (benchmark.toyframes, no Blender) with six frames, a quickly trained source
model and one operator cache shared by every run (built once)."""

import json
from types import SimpleNamespace

import cv2
import numpy as np
import pandas as pd
import pytest

from benchmark.data import load_dataset
from benchmark.frames.methods import load_frames, train_source_detectors
from viewadapt.camera import distort_image
from viewadapt.cli import main
from viewadapt.detect import DetectorSpec, detect_stream
from viewadapt.nms import detections_from_scores
from viewadapt.io import (
    SourceDetectors, natural_sort_key, open_frames, prefetched, read_calibration, shipped_model_path,
)
from tests.toy_frames import TOY_FRAME_SIZE, small_toy_frames
from tests.box_iou import iou as box_iou

N_FRAMES = 6
SIZE = TOY_FRAME_SIZE
#: strong barrel distortion: a corner moves by about a quarter of its radius
DIST = [-0.35, 0.0, 0.0, 0.0, 0.0]
OUTPUTS = ("detections.csv", "detections_coco.json", "det.txt")


def _write_calibration(path, cam, **extra):
    path.write_text(json.dumps({"image_size": list(cam.image_size), "K": cam.K.tolist(),
                                "R": cam.R.tolist(), "t": cam.t.tolist(), **extra}))
    return path


def _write_video(path, images, size=SIZE):
    w = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), 10.0, size)
    assert w.isOpened(), "this OpenCV cannot write mp4v"
    for img in images:
        w.write(img)
    w.release()
    return path


def _best_iou(ref, other, floor=0.0):
    """For each detection of ``ref`` scoring above ``floor``, its best IoU in ``other`` (the
    same frame)."""
    out = []
    for f, a in ref[ref.score > floor].groupby("frame"):
        b = other[other.frame == f]
        m = box_iou(a[["x", "y", "w", "h"]], b[["x", "y", "w", "h"]]) if len(b) else \
            np.zeros((len(a), 1))
        out += list(m.max(axis=1))
    return np.array(out)


@pytest.fixture(scope="module")
def toy(tmp_path_factory):
    """Six frames of one toy camera as PNGs, an mp4, their calibration and a model."""
    root = tmp_path_factory.mktemp("footage")
    data = small_toy_frames(root / "data", frames_per_scene=N_FRAMES)
    frames = load_frames(data)
    assert len(frames) == N_FRAMES and len({f.path.parent for f in frames}) == 1
    # the paper's training: under the default recipe's wider margin (C = 0.001) a quick model
    # of these few windows stays nearly silent on the toy frames
    train_source_detectors(load_dataset(data), quick=True, frame_view="none",
                           recipe="elevation0").save(root / "model.npz")
    cam = frames[0].camera
    video = _write_video(root / "clip.mp4", [cv2.imread(str(f.path)) for f in frames])
    return SimpleNamespace(root=root, data=data, frames=frames, cam=cam, video=video,
                           folder=frames[0].path.parent, model=root / "model.npz",
                           calibration=_write_calibration(root / "cam.json", cam),
                           cache=root / "cache")


@pytest.fixture(scope="module")
def detect(toy):
    """``detect(name, *argv)`` -> OUT of a ``viewadapt detect`` run (each run once)."""
    done = {}

    def run(name, *argv, calibration=None):
        if name not in done:
            out = toy.root / "runs" / name
            rc = main(["detect", "--calibration", str(calibration or toy.calibration),
                       "--model", str(toy.model), "--cache", str(toy.cache),
                       "--threshold", "-0.5", "--quiet", "--out", str(out),
                       *[str(a) for a in argv]])
            assert rc == 0, name
            done[name] = out
        return done[name]

    return run


def _rows(out):
    return pd.read_csv(out / "detections.csv")


# ------------------------------------------------------------------ inputs and selection


def test_inputs_are_opened_and_sorted(toy, tmp_path):
    assert sorted(["f_10.png", "f_2.png", "F_1.png"], key=natural_sort_key) == \
        ["F_1.png", "f_2.png", "f_10.png"]
    s = open_frames(toy.folder, start=1, every=2)
    assert (s.kind, s.n_frames, s.n_total) == ("folder", 3, N_FRAMES)
    assert [f.index for f in s] == [1, 3, 5]
    s = open_frames(toy.video, every=2, max_frames=2)
    assert s.kind == "video" and s.fps == pytest.approx(5.0)
    frames = list(s)
    assert [(f.index, f.source) for f in frames] == [(0, "clip.mp4"), (2, "clip.mp4")]
    assert frames[0].image.shape == (SIZE[1], SIZE[0], 3) and frames[0].image.dtype == np.uint8
    assert open_frames(str(toy.folder / "*.png")).kind == "glob"
    assert open_frames([toy.frames[1].path, toy.frames[0].path]).paths == \
        [toy.frames[1].path, toy.frames[0].path]            # a list keeps its order


def test_prefetched_keeps_order_raises_in_place_and_stops_early():
    import threading
    import time

    assert list(prefetched(iter(range(100)), depth=3)) == list(range(100))
    assert list(prefetched([])) == []

    def failing():
        yield from range(5)
        raise ValueError("frame 5 is broken")

    got = []
    with pytest.raises(ValueError, match="frame 5 is broken"):
        for x in prefetched(failing(), depth=2):
            got.append(x)
    assert got == [0, 1, 2, 3, 4]                # every item before the error arrives

    produced, closed = [], []

    def endless():
        try:
            for i in range(10**9):
                produced.append(i)
                yield i
        finally:
            closed.append(True)

    it = prefetched(endless(), depth=2)
    assert [next(it) for _ in range(3)] == [0, 1, 2]
    time.sleep(0.2)
    assert len(produced) <= 3 + 2 + 1               # at most depth ahead (+ one in hand)
    it.close()                                      # the consumer stops early
    assert closed == [True]                         # ... and the source was closed
    assert not any(t.name == "viewadapt-prefetch" for t in threading.enumerate())
    with pytest.raises(ValueError, match="depth"):
        next(prefetched([1], depth=0))


def test_ground_positions_are_those_of_the_windows(toy):
    """FrameDetector.detect_on_ground gives the operator's thresholded, suppressed window
    scores (and detect the same boxes), each with the ground point of its window -- which
    is where the feet of that window's person project, and close to where the toy person
    whose box it found stands. Without box voting each box is its window's; with it (the
    default) the detections, scores and ground points are the same."""
    spec = DetectorSpec.create(toy.cam, toy.model, "hog", cache_dir=toy.cache,
                               thresholds={"hog": -0.5}, box_voting=0.0)
    det = spec.make()
    voting = DetectorSpec.create(toy.cam, toy.model, "hog", cache_dir=toy.cache,
                                 thresholds={"hog": -0.5}).make()
    coco = json.loads((toy.data / "frames_coco.json").read_text())
    errors = []
    for f in toy.frames:
        img = cv2.imread(str(f.path))[:, :, ::-1].copy()
        found = det.detect_on_ground(img, "hog")
        op = det.operator("hog")
        scored = detections_from_scores(op.boxes(), op.scores(op.frame_features(img)),
                                        threshold=-0.5, overlap=op.nms_overlap,
                                        nms_threshold=op.nms_threshold)
        assert np.array_equal(found.boxes, scored) and len(found.boxes) > 0
        assert np.array_equal(det.detect(img, "hog"), found.boxes)
        # each box is its window's (snapped) person box, each ground point its window's
        assert np.array_equal(det.operator("hog").boxes()[found.window], found.boxes[:, :4])
        assert np.array_equal(found.ground_xy, det.windows.ground_xy[found.window])
        voted = voting.detect_on_ground(img, "hog")
        assert np.array_equal(voted.window, found.window)
        assert np.array_equal(voted.ground_xy, found.ground_xy)
        assert np.array_equal(voted.boxes[:, 4], found.boxes[:, 4])
        feet = np.array([toy.cam.project(np.r_[g, 0.0]) for g in found.ground_xy])
        assert np.allclose(feet, det.windows.feet[found.window], atol=1e-6)
        anns = [a for a in coco["annotations"] if a["image_id"] == f.image_id]
        m = box_iou(found.boxes[:, :4], [a["bbox"] for a in anns])
        for i in np.flatnonzero((found.boxes[:, 4] > 0) & (m.max(axis=1) > 0.5)):
            truth = anns[int(m[i].argmax())]["ground_xy"]
            errors.append(np.hypot(*(found.ground_xy[i] - truth)))
    assert len(errors) >= 5
    assert max(errors) < 0.3 and np.median(errors) < 0.2     # metres; ground stride 0.146
    # the stream in worker processes is the same stream
    frames = list(open_frames(toy.folder, max_frames=2))
    one = [r.boxes for _, r in detect_stream(iter(frames), spec, detector=det)]
    two = [(f.index, r.boxes) for f, r in detect_stream(iter(frames), spec, jobs=2)]
    assert [i for i, _ in two] == [0, 1]
    assert all(np.array_equal(a, b) for a, (_, b) in zip(one, two))


def test_video_folder_glob_and_list_give_the_same_detections(toy, detect):
    paths = sorted((f.path for f in toy.frames), key=lambda p: natural_sort_key(p.name))
    runs = {"list": detect("list", *paths), "folder": detect("folder", toy.folder),
            "glob": detect("glob", toy.folder / "frame_*.png")}
    for name, out in runs.items():
        for f in OUTPUTS:
            assert (out / f).read_bytes() == (runs["list"] / f).read_bytes(), (name, f)
        assert len(list((out / "annotated").glob("*.png"))) == N_FRAMES   # auto: frames
        assert json.loads((out / "metadata.json").read_text())["input"]["kind"] == name \
            .replace("list", "files")
    rows = _rows(runs["list"])
    assert len(rows) > 0 and set(rows["frame"]) == set(range(N_FRAMES))
    assert list(rows["source"].unique()) == [p.name for p in paths]
    # the video: boxes found, every output, the annotated video by default
    out = detect("video", toy.video)
    video = _rows(out)
    assert len(video) > 0 and set(video["frame"]) == set(range(N_FRAMES))
    assert set(video["source"]) == {"clip.mp4"}
    for f in (*OUTPUTS, "annotated.mp4", "metadata.json"):
        assert (out / f).is_file(), f
    assert not (out / "annotated").exists()
    # the same persons, up to the video's compression
    assert np.mean(_best_iou(rows, video) > 0.5) >= 0.8


def test_every_start_and_max_frames_select_frames(toy, detect):
    full = _rows(detect("folder", toy.folder))
    out = detect("folder_sel", "--start", 1, "--every", 2, "--max-frames", 2, toy.folder)
    assert sorted(p.name for p in (out / "annotated").glob("*.png")) == \
        ["00001_frame_1.png", "00003_frame_3.png"]
    sel = _rows(out)
    want = full[full["frame"].isin([1, 3])].reset_index(drop=True)
    pd.testing.assert_frame_equal(sel, want)
    meta = json.loads((out / "metadata.json").read_text())
    assert meta["frames"] == 2 and meta["input"]["start"] == 1 and meta["input"]["every"] == 2
    assert meta["cpu_seconds"] > 0 and meta["frames_per_second"] > 0
    # a video: frame numbers are the video's
    vfull = _rows(detect("video", toy.video))
    out = detect("video_sel", "--start", 2, "--every", 3, "--annotate", "frames", toy.video)
    assert sorted(p.name for p in (out / "annotated").glob("*.png")) == \
        ["00002_clip.png", "00005_clip.png"]
    pd.testing.assert_frame_equal(
        _rows(out), vfull[vfull["frame"].isin([2, 5])].reset_index(drop=True))
    out = detect("video_one", "--max-frames", 1, "--annotate", "none", toy.video)
    assert set(_rows(out)["frame"]) == {0} and not (out / "annotated").exists()
    assert not (out / "annotated.mp4").exists()


# ------------------------------------------------------------------ outputs


def test_every_output_parses(toy, detect):
    out = detect("folder", toy.folder)
    rows = _rows(out)
    assert list(rows.columns) == ["frame", "source", "x", "y", "w", "h", "score", "ground_x",
                                  "ground_y"]
    assert rows["frame"].dtype.kind == "i" and (rows[["w", "h"]] > 0).all().all()
    assert np.isfinite(rows[["x", "y", "score", "ground_x", "ground_y"]].to_numpy()).all()
    assert (rows["score"] > -0.5).all()
    for _, g in rows.groupby("frame", sort=False):          # by decreasing score
        assert g["score"].is_monotonic_decreasing
    coco = json.loads((out / "detections_coco.json").read_text())
    assert isinstance(coco, list) and len(coco) == len(rows)
    assert {k for c in coco for k in c} == {"image_id", "category_id", "bbox", "score"}
    assert [c["image_id"] for c in coco] == list(rows["frame"] + 1)
    assert np.allclose([c["bbox"] for c in coco], rows[["x", "y", "w", "h"]], atol=0.006)
    assert np.allclose([c["score"] for c in coco], rows["score"], atol=1e-6)
    mot = np.loadtxt(out / "det.txt", delimiter=",", ndmin=2)
    assert mot.shape == (len(rows), 10)
    assert np.array_equal(mot[:, 0], rows["frame"] + 1) and (mot[:, 1] == -1).all()
    assert np.allclose(mot[:, 2:6], rows[["x", "y", "w", "h"]]) and (mot[:, 7:] == -1).all()
    assert np.allclose(mot[:, 6], rows["score"])
    img = cv2.imread(str(out / "annotated" / "00000_frame_0.png"))
    assert img.shape == (SIZE[1], SIZE[0], 3)
    assert (img != cv2.imread(str(toy.frames[0].path))).any()          # boxes drawn
    # the annotated video holds every frame
    cap = cv2.VideoCapture(str(detect("video", toy.video) / "annotated.mp4"))
    assert cap.isOpened()
    n = 0
    while cap.grab():
        n += 1
    cap.release()
    assert n == N_FRAMES


def test_jobs_2_writes_the_same_bytes_as_one_process(toy, detect):
    one = detect("jobs1", "--annotate", "video", toy.folder)
    two = detect("jobs2", "--jobs", 2, "--annotate", "video", toy.folder)
    names = sorted(p.name for p in one.iterdir() if p.name != "metadata.json")
    assert names == sorted(p.name for p in two.iterdir() if p.name != "metadata.json")
    assert {*OUTPUTS, "annotated.mp4"} <= set(names)
    for name in names:
        assert (one / name).read_bytes() == (two / name).read_bytes(), name
    assert json.loads((two / "metadata.json").read_text())["jobs"] == 2
    assert (one / "detections.csv").read_bytes() == \
        (detect("folder", toy.folder) / "detections.csv").read_bytes()
    cap = cv2.VideoCapture(str(two / "annotated.mp4"))
    assert int(cap.get(cv2.CAP_PROP_FRAME_COUNT)) == N_FRAMES
    cap.release()


# ------------------------------------------------------------------ lens distortion


def test_distorted_frames_are_undistorted(toy, detect):
    """Frames through a strong barrel lens, with its coefficients in the calibration, give
    the detections of the undistorted frames, written in the input's (distorted) pixels;
    without them the boxes are off. (The adapted operator alone, ``--stage off``: the toy
    model's few boxes above 0 are too few to compare; the stage reads the frames' cells as
    the operator does.)"""
    from viewadapt.commands.detect import boxes_in_input_pixels

    folder = toy.root / "distorted"
    folder.mkdir(exist_ok=True)
    for f in toy.frames:
        cv2.imwrite(str(folder / f.path.name),
                    distort_image(cv2.imread(str(f.path)), toy.cam.K, DIST))
    calib = _write_calibration(toy.root / "cam_dist.json", toy.cam, dist=DIST)
    ref = _rows(detect("folder_fold", "--stage", "off", toy.folder))
    fixed = detect("distorted", "--stage", "off", "--annotate", "none", "--lens", "undistort",
                   folder, calibration=calib)
    raw = detect("distorted_raw", "--stage", "off", "--annotate", "none", folder)
    ref = ref.copy()            # the pinhole frames' boxes, through the lens
    ref[["x", "y", "w", "h"]] = boxes_in_input_pixels(
        ref[["x", "y", "w", "h", "score"]].to_numpy(), toy.cam.K, DIST)[:, :4]
    fixed_iou, raw_iou = _best_iou(ref, _rows(fixed)), _best_iou(ref, _rows(raw))
    assert len(fixed_iou) >= 10 and (fixed_iou > 0.5).all()
    assert fixed_iou.mean() > 0.88 and fixed_iou.mean() > raw_iou.mean() + 0.03
    meta = json.loads((fixed / "metadata.json").read_text())
    assert meta["undistortion"]["dist"] == DIST
    assert json.loads((raw / "metadata.json").read_text())["undistortion"] is None
    assert meta["lens_windows"] is None


def test_windows_through_the_lens_find_the_same_persons(toy, detect):
    """--lens windows reads the distorted frames as they are: its boxes, undistorted, are
    those of the pinhole frames' detections."""
    from benchmark.studies.distortion_study import undistorted_boxes
    from viewadapt.camera import Undistortion

    folder = toy.root / "distorted"           # written by the test above
    calib = _write_calibration(toy.root / "cam_dist.json", toy.cam, dist=DIST)
    ref = _rows(detect("folder", toy.folder))
    out = detect("lens_windows", "--annotate", "none", "--lens", "windows", folder,
                 calibration=calib)
    rows = _rows(out)
    und = Undistortion(toy.cam.K, DIST, toy.cam.image_size)
    back = undistorted_boxes(rows[["x", "y", "w", "h", "score"]].to_numpy(), und)
    rows[["x", "y", "w", "h"]] = back[:, :4]
    iou = _best_iou(ref, rows, floor=-0.25)     # (the toy model has few boxes above 0)
    assert len(iou) >= 10 and (iou > 0.5).all() and np.median(iou) > 0.7, iou
    meta = json.loads((out / "metadata.json").read_text())
    assert meta["lens_windows"]["dist"] == DIST and meta["undistortion"] is None
    # the default (auto) is the lens windows: the same bytes
    auto = detect("lens_auto", "--annotate", "none", folder, calibration=calib)
    assert (auto / "detections.csv").read_bytes() == (out / "detections.csv").read_bytes()
    assert json.loads((auto / "metadata.json").read_text())["lens_windows"]["dist"] == DIST


def test_auto_lens_maps_the_windows_through_it():
    from viewadapt.commands.detect import DEFAULT_LENS, lens_correction

    assert DEFAULT_LENS == "auto"
    assert lens_correction(None, "auto") is None
    assert lens_correction(np.array(DIST), "auto") == "windows"
    for lens in ("windows", "undistort"):
        assert lens_correction(np.array(DIST), lens) == lens


# ------------------------------------------------------------------ bad input


def _bad_inputs(toy, d):
    d.mkdir()
    (d / "junk.mp4").write_bytes(b"not a video" * 40)
    (d / "empty.avi").write_bytes(b"")
    _write_video(d / "no_frames.mp4", [])
    _write_video(d / "small.mp4", [np.zeros((120, 160, 3), np.uint8)] * 3, size=(160, 120))
    cv2.imwrite(str(d / "small.png"), np.zeros((120, 160, 3), np.uint8))
    (d / "no_images").mkdir()
    (d / "no_images" / "notes.txt").write_text("no frames here")
    return {
        "unreadable video": ([d / "junk.mp4"], "cannot be read"),
        "empty file": ([d / "empty.avi"], "cannot be read"),
        "video without frames": ([d / "no_frames.mp4"], "cannot be read|no frames"),
        "start past a video's end": (["--start", 50, toy.video], "no frames from --start 50"),
        "start past the last image": (["--start", 6, toy.folder], "past the last frame"),
        "folder without images": ([d / "no_images"], "holds no images"),
        "pattern matching nothing": ([d / "nothing_*.png"], "holds no images"),
        "missing file": ([d / "nope.mp4"], "does not exist"),
        "video among images": ([toy.frames[0].path, toy.video], "one video on its own"),
        "frame of another size": ([d / "small.png"], "small.png is 160x120 px, the "
                                                     "calibration is for 192x144"),
        "video of another size": ([d / "small.mp4"], "frame 0 of .*small.mp4 is 160x120"),
        "--every 0": (["--every", 0, toy.folder], "--every must be at least 1"),
        "--max-frames 0": (["--max-frames", 0, toy.folder], "--max-frames must be at least 1"),
        "--start -1": (["--start", -1, toy.folder], "--start must be at least 0"),
        "--jobs 0": (["--jobs", 0, toy.folder], "--jobs must be at least 1"),
        "--boxes not a text file": (["--boxes", d / "small.png", toy.video],
                                    "not a UTF-8 text"),
    }


def test_bad_input_is_one_line_and_writes_nothing(toy, tmp_path, capfd):
    import re

    for case, (argv, match) in _bad_inputs(toy, tmp_path / "in").items():
        out = tmp_path / "out"
        capfd.readouterr()
        rc = main(["detect", "--calibration", str(toy.calibration), "--model",
                   str(toy.model), "--out", str(out), *[str(a) for a in argv]])
        err = capfd.readouterr().err.strip()
        assert rc == 2 and len(err.splitlines()) == 1, (case, err)
        assert err.startswith("viewadapt detect: error: ") and re.search(match, err), \
            (case, err)
        assert not out.exists(), case
    # --annotate takes a value, so it never swallows INPUT
    with pytest.raises(SystemExit) as exc:
        main(["detect", "--calibration", str(toy.calibration), "--model", str(toy.model),
              "--out", str(tmp_path / "o"), "--annotate", str(toy.video)])
    assert exc.value.code == 2 and not (tmp_path / "o").exists()


def test_a_later_frame_of_another_size_fails_after_frames_were_detected(toy, tmp_path, capfd):
    """Found by the reading thread after three frames were detected: one line, exit 2, no
    outputs (the operator cache, kept apart here, is all that stays)."""
    small = tmp_path / "small.png"
    cv2.imwrite(str(small), np.zeros((120, 160, 3), np.uint8))
    out = tmp_path / "out"
    capfd.readouterr()
    rc = main(["detect", "--calibration", str(toy.calibration), "--model", str(toy.model),
               "--out", str(out), "--cache", str(tmp_path / "cache"), "--quiet",
               *[str(f.path) for f in toy.frames[:3]], str(small)])
    err = capfd.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1, err
    assert "small.png is 160x120 px" in err and not out.exists()


def test_a_model_and_calibration_load_as_the_command_does(toy):
    """The spec a worker receives makes the detector the command makes."""
    spec = DetectorSpec.create(read_calibration(toy.calibration), toy.model, "hog",
                               person_heights=(1.65, 1.85), cache_dir=None)
    det = spec.make()
    assert det.params["person_heights"] == (1.65, 1.85)
    assert det.models.fingerprint() == SourceDetectors.load(toy.model).fingerprint()
    assert det.camera.to_dict() == toy.cam.to_dict()
    assert DetectorSpec.create(toy.cam, toy.model, "hog", person_heights=(1.65, 1.85),
                               cache_dir=None) == spec      # hashable, equal: one per worker


def test_the_shipped_model_runs_with_no_model_option(toy, tmp_path):
    """`viewadapt detect --calibration cam INPUT` uses the models shipped in the package:
    the average of bench frames' models of two renders of the paper preset (seeds 0 and 1)
    through the surveillance camera effects, each under the averaged recipe (ACF the
    average of nine seeds, the first of the 18 gating the rest), every member's record kept
    in the file."""
    path = shipped_model_path()
    assert path.is_file() and path.stat().st_size < 1_000_000
    shipped = SourceDetectors.load(path)
    members = shipped.training["average_of"]
    assert [m["dataset"]["seed"] for m in members] == [0, 1]
    assert len({m["dataset"]["content_hash"] for m in members}) == 2
    for m in members:
        data = m["dataset"]
        assert data["preset"] == "paper" and data["camera_effects"] == "surveillance"
        assert data["elevations"][m["source_index"]] == 0.0
        assert m["recipe"]["name"] == "averaged" and m["acf_members"] == 9
        assert m["frame_view"] == "both" and not m["quick"] and m["seed"] == 0
    assert shipped.acf.n_estimators_ == 2 * 9 * 256 and np.abs(shipped.hog_weights).sum() > 0
    # one of the 18 boosted models gates the others (viewadapt.ensembles.average_trees)
    assert shipped.training["acf_gate"] is True
    np.testing.assert_array_equal(shipped.acf.cascade_scale_,
                                  np.repeat([18.0, 1.0], [256, 17 * 256]))
    out = tmp_path / "out"
    rc = main(["detect", "--calibration", str(toy.calibration), "--threshold", "-1",
               "--quiet", "--out", str(out), "--jobs", "2", str(toy.video)])
    assert rc == 0
    meta = json.loads((out / "metadata.json").read_text())
    assert meta["model"] == str(path) and meta["model_training"] == shipped.training
    rows = pd.read_csv(out / "detections.csv")
    assert len(rows) > 0 and set(rows.frame) <= set(range(N_FRAMES))
    assert (out / "det.txt").is_file() and (out / "detections_coco.json").is_file()
    cap = cv2.VideoCapture(str(out / "annotated.mp4"))
    assert int(cap.get(cv2.CAP_PROP_FRAME_COUNT)) == N_FRAMES
    cap.release()


def test_the_stage_can_be_left_out(toy, detect):
    """``--stage off`` runs the adapted operator alone (its own cache entry); with ``--jobs``
    the workers leave it out too."""
    on, off = detect("folder", toy.folder), detect("folder_fold", "--stage", "off", toy.folder)
    assert json.loads((on / "metadata.json").read_text())["stage"] is True
    assert json.loads((off / "metadata.json").read_text())["stage"] is False
    assert (on / "detections.csv").read_bytes() != (off / "detections.csv").read_bytes()
    two = detect("fold_jobs2", "--stage", "off", "--jobs", 2, toy.folder)
    assert (two / "detections.csv").read_bytes() == (off / "detections.csv").read_bytes()


def test_a_denser_ground_grid_across_the_view(toy, detect, tmp_path, capfd):
    """``--ground-stride F,L``: more windows (a cache entry of their own), recorded in
    metadata.json; one number is both strides; a bad value is argparse's one-line error."""
    from viewadapt.detect import GROUND_STRIDE_M as S

    meta = json.loads((detect("folder", toy.folder) / "metadata.json").read_text())
    assert meta["ground_stride"] == [S, S]
    dense = json.loads((detect("dense", toy.folder, "--ground-stride", f"{S},{S / 2}")
                        / "metadata.json").read_text())
    assert dense["ground_stride"] == [S, S / 2]
    assert 1.5 * meta["windows"] < dense["windows"] < 2.5 * meta["windows"]
    _refused(toy, tmp_path, capfd, "--ground-stride", ("0", "0.1,-1", "0.1,0.1,0.1", "wide"),
             "cannot read the ground stride")


def test_box_voting_moves_boxes_not_scores(toy, detect, tmp_path, capfd):
    """``--box-voting TAU`` (default 1, 0 none): the same detections and scores, boxes
    moved towards the candidates overlapping them, recorded in metadata.json; with --jobs
    the workers vote too; a bad value is argparse's one-line error."""
    plain = detect("plain", toy.folder, "--box-voting", "0")
    voted = detect("folder", toy.folder)
    assert json.loads((plain / "metadata.json").read_text())["box_voting"] == 0
    assert json.loads((voted / "metadata.json").read_text())["box_voting"] == 1
    a, b = pd.read_csv(plain / "detections.csv"), pd.read_csv(voted / "detections.csv")
    assert len(a) == len(b) > 0
    np.testing.assert_array_equal(a["score"], b["score"])
    assert not np.allclose(a[["x", "y"]], b[["x", "y"]])
    two = detect("voted_jobs2", "--jobs", 2, toy.folder)
    assert (two / "detections.csv").read_bytes() == (voted / "detections.csv").read_bytes()
    _refused(toy, tmp_path, capfd, "--box-voting", ("-1", "nan", "inf", "hot"),
             "cannot read the box voting temperature")


def test_min_height_drops_windows_of_shorter_persons(toy, detect, tmp_path, capfd):
    meta = json.loads((detect("folder", toy.folder) / "metadata.json").read_text())
    from viewadapt.detect import FrameDetector

    tall = np.median(96 * FrameDetector(toy.cam, None).windows.scale)  # a person's px
    fewer = json.loads((detect("min_height", toy.folder, "--min-height", f"{tall:.0f}")
                        / "metadata.json").read_text())
    assert fewer["min_person_height"] == float(f"{tall:.0f}")
    assert 0 < fewer["windows"] < meta["windows"]
    _refused(toy, tmp_path, capfd, "--min-height", ("-3", "nan", "tall"),
             "minimum person height must be >= 0 px")


def _refused(toy, tmp_path, capfd, option, values, message):
    """Each of ``values`` given to ``option`` is argparse's one-line error (exit 2) saying
    ``message``, and nothing is written."""
    for bad in values:
        capfd.readouterr()
        with pytest.raises(SystemExit) as exc:
            main(["detect", "--calibration", str(toy.calibration), "--model", str(toy.model),
                  "--out", str(tmp_path / "o"), option, bad, str(toy.folder)])
        err = capfd.readouterr().err.strip().splitlines()[-1]
        assert exc.value.code == 2 and message in err, err
        assert not (tmp_path / "o").exists()
