"""``viewadapt bench footage``: every method on a calibrated, annotated clip -- the
ground-plane filter, paired block-bootstrap differences, and the command on toy frames in
MOTChallenge layout (no Blender; the fixtures are built here)."""

import json
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from benchmark.frames.methods import ground_plane_filter
from viewadapt.camera.distortion import Undistortion, distort_points
from viewadapt.cli import main
from viewadapt.detect.evaluation import paired_block_bootstrap
from viewadapt.geometry import camera_from_pose
from tests.toy_frames import mot_toy_clip

N_FRAMES = 4
DIST = [-0.2, 0.0, 0.0, 0.0, 0.0]


@pytest.fixture(scope="module")
def camera():
    return camera_from_pose(focal=400.0, principal_point=(319.5, 239.5), height=6.0,
                            tilt=np.radians(20), image_size=(640, 480))


def _person_box(camera, ground, height, scale=1.0, lens=None):
    """The box of a person of ``height`` m standing at ``ground`` (its height times
    ``scale``), through the lens if given."""
    feet = camera.project(np.array([[*ground, 0.0]]))
    head = camera.project(np.array([[*ground, height]]))
    if lens is not None:
        feet, head = (distort_points(p, camera.K, lens) for p in (feet, head))
    h = (feet[0, 1] - head[0, 1]) * scale
    w = 0.41 * h
    return [feet[0, 0] - w / 2, feet[0, 1] - h, w, h, 1.0]


@pytest.mark.parametrize("lens", [None, DIST])
def test_ground_plane_filter_keeps_the_assumed_heights(camera, lens):
    und = None if lens is None else Undistortion(camera.K, lens, camera.image_size)
    at = [(12.0, 1.0), (20.0, -3.0), (9.0, 2.5)]
    boxes = np.array([_person_box(camera, g, 1.75, s, lens) for g in at
                      for s in (1.0, 0.85, 1.15, 1.4, 0.7)])
    kept = ground_plane_filter(boxes, camera, heights=[1.75], undistortion=und)
    want = np.array([s in (1.0, 0.85, 1.15) for g in at for s in (1.0, 0.85, 1.15, 1.4, 0.7)])
    np.testing.assert_array_equal(kept, boxes[want])
    # a second assumed height keeps the boxes of a person of that height
    tall = np.array([_person_box(camera, g, 2.3, 1.0, lens) for g in at])
    assert len(ground_plane_filter(tall, camera, heights=[1.75], undistortion=und)) == 0
    assert len(ground_plane_filter(tall, camera, heights=[1.75, 2.3], undistortion=und)) == 3


def test_ground_plane_filter_drops_feet_above_the_horizon(camera):
    sky = np.array([[300.0, -200.0, 20.0, 50.0, 1.0], [300.0, 5.0, 20.0, 50.0, 1.0]])
    assert len(ground_plane_filter(sky, camera, heights=[1.75])) == 0
    assert ground_plane_filter(np.zeros((0, 5)), camera, heights=[1.75]).shape == (0, 5)


def _clip(rng, n_frames, hit_rate):
    gts, dts = [], []
    for _ in range(n_frames):
        g = np.c_[rng.uniform(0, 300, (3, 2)), np.full((3, 2), [20.0, 50.0]), np.zeros((3, 1))]
        hit = g[rng.random(3) < hit_rate, :4]
        fp = np.c_[rng.uniform(400, 600, (2, 2)), np.full((2, 2), [20.0, 50.0])]
        d = np.r_[hit, fp]
        dts.append(np.c_[d, np.r_[np.full(len(hit), 0.9), rng.uniform(0, 1, 2)]])
        gts.append(g)
    return dts, gts


def test_paired_block_bootstrap_of_a_method_against_itself_and_a_better_one():
    rng = np.random.default_rng(0)
    dts, gts = _clip(rng, 60, 0.5)
    same = paired_block_bootstrap(dts, dts, gts, block=5, draws=200, seed=1)
    assert same["difference"] == 0 and same["ci"] == [0.0, 0.0] and same["draws_used"] == 200
    better = [np.r_[d, np.c_[g[:, :4], np.full(len(g), 0.95)]] for d, g in zip(dts, gts)]
    d = paired_block_bootstrap(better, dts, gts, block=5, draws=200, seed=1)
    assert d["difference"] < 0 and d["ci"][0] <= d["difference"] <= d["ci"][1] < 0
    assert d == paired_block_bootstrap(better, dts, gts, block=5, draws=200, seed=1)
    with pytest.raises(ValueError, match="detections on the 60 frames"):
        paired_block_bootstrap(dts[:-1], dts, gts)


@pytest.fixture(scope="module")
def toy(tmp_path_factory):
    """Toy frames as MOTChallenge's img1/000001.png..., their gt.txt, a calibration with a
    weak lens (the windows go through it), ignore regions and a quick model."""
    clip = mot_toy_clip(tmp_path_factory.mktemp("footage"), n_frames=N_FRAMES,
                        dist=[-0.02, 0.0, 0.0, 0.0, 0.0])
    root = clip.root
    regions = root / "ignore.json"
    regions.write_text(json.dumps({"polygons": [[[-1, -1], [20, -1], [20, 145], [-1, 145]]]}))
    return SimpleNamespace(**vars(clip), regions=regions)


METHODS = ["opencv_native", "opencv_native[ground]", "hog_adapted", "hog_warp",
           "opencv_adapted"]


def _footage(toy, out, *argv):
    return main(["bench", "footage", str(toy.img1), "--calibration", str(toy.calibration),
                 "--boxes", str(toy.gt), "--model", str(toy.model), "--cache", str(toy.cache),
                 "--quiet", "--out", str(out), *[str(a) for a in argv]])


def test_every_method_on_the_clip(toy, tmp_path, capsys):
    out = tmp_path / "run"
    assert _footage(toy, out, "--ignore", toy.regions, "--methods", *METHODS,
                    "--bootstrap-block", "2") == 0
    printed = capsys.readouterr().out
    table = pd.read_csv(out / "footage_summary.csv")
    assert list(table["method"]) == METHODS
    assert (table["n_frames"] == N_FRAMES).all() and (table["frames_per_second"] > 0).all()
    assert ((table["lamr"] >= 0) & (table["lamr"] <= 1)).all()
    n_gt = sum(len(f.gt) for f in toy.frames)
    assert (table["n_gt"] + table["n_gt_ignored"] <= n_gt).all()
    # every method against the best unadapted baseline, and adapted against warping
    pairs = json.loads((out / "paired_differences.json").read_text())
    ref = table[table["method"].str.startswith("opencv_native")].sort_values("lamr").iloc[0]
    assert {(p["method"], p["reference"]) for p in pairs} == {
        (m, ref["method"]) for m in METHODS if m != ref["method"]} | {
        ("hog_adapted", "hog_warp")}
    for p in pairs:
        lo, hi = p["ci"]
        assert lo is None or lo <= hi
    ev = json.loads((out / "evaluations.json").read_text())
    for m in METHODS:
        assert ev[m]["lamr"] == pytest.approx(float(table.set_index("method").loc[m, "lamr"]),
                                              abs=1e-5)
    dets = json.loads((out / "detections.json").read_text())
    assert set(dets) == set(METHODS)
    # the stored detections, evaluated again, give the run's numbers
    from benchmark.footage.run import open_clip
    from viewadapt.detect.evaluation import evaluation_summary
    from viewadapt.io import FrameBoxes

    clip = open_clip([str(toy.img1)], toy.calibration, toy.gt, toy.regions)
    keys = list(dets["hog_adapted"])
    truth = [clip.truth.get(k, FrameBoxes.empty()) for k in keys]
    for m in METHODS:
        again, _ = evaluation_summary([np.asarray(dets[m][k]).reshape(-1, 5) for k in keys],
                                      truth, clip.camera.image_size, regions=clip.regions,
                                      block=2)
        assert again["lamr"] == pytest.approx(ev[m]["lamr"], abs=1e-9)
        assert again["fppi"] == pytest.approx(ev[m]["fppi"], abs=1e-9)
    assert set(dets["hog_adapted"]) == {f"{k:06d}.png" for k in range(1, N_FRAMES + 1)}
    # the ground-filtered pyramid keeps a subset of the pyramid's boxes
    for k, boxes in dets["opencv_native[ground]"].items():
        assert all(b in dets["opencv_native"][k] for b in boxes)
    run = json.loads((out / "run.json").read_text())
    assert run["lens_correction"] == "windows" and run["methods"] == METHODS
    assert run["n_frames"] == N_FRAMES and set(run["seconds_per_method"]) == set(METHODS)
    assert (out / "det_footage.png").is_file() and "hog_adapted - hog_warp" in printed
    # the errors of every method at 0.1 and 1 FPPI, and their map
    errors = (out / "errors.md").read_text()
    assert all(f"| {m} | 0.1 |" in errors and f"| {m} | 1 |" in errors for m in METHODS)
    import cv2

    grid = cv2.imread(str(out / "error_map.jpg"))
    assert grid.shape[0] == len(METHODS) * 144 and grid.shape[1] == 192
    first = (out / "footage_summary.md").read_text().splitlines()[0]
    assert first.startswith("# ") and f"img1: {N_FRAMES} frames, {int(table['n_gt'][0])} " \
        "persons counted" in first


def test_the_body_model_through_the_lens_or_on_undistorted_frames(toy, tmp_path):
    out = tmp_path / "body"
    assert _footage(toy, out, "--methods", "opencv_native", "hog_adapted[body]",
                    "--max-frames", "2") == 0
    assert json.loads((out / "run.json").read_text())["lens_correction"] == "windows"
    # every method on undistorted frames, when asked for
    assert _footage(toy, tmp_path / "und", "--methods", "hog_adapted[body]", "--lens",
                    "undistort", "--max-frames", "2") == 0
    assert json.loads((tmp_path / "und" / "run.json").read_text())["lens_correction"] \
        == "undistort"


def test_a_denser_ground_grid(toy, tmp_path):
    """``--ground-stride F,L`` reaches the adapted detectors' windows and run.json."""
    runs = {}
    for name, argv in (("paper", ()), ("dense", ("--ground-stride", "0.1458,0.0729"))):
        out = tmp_path / name
        assert _footage(toy, out, "--methods", "hog_adapted", "--max-frames", "2", *argv) == 0
        runs[name] = json.loads((out / "run.json").read_text())
    assert runs["paper"]["ground_stride"] is None
    assert runs["dense"]["ground_stride"] == [0.1458, 0.0729]
    assert 1.5 * runs["paper"]["windows"] < runs["dense"]["windows"]


def test_the_upsampling_threshold_reaches_the_adapted_detector(toy, tmp_path, capfd):
    """``--upsample-below S`` (as detect and bench frames take it): 0 reads every window on
    the frame as it is, 10 every one on the 2x upsampled frame -- other scores; recorded in
    run.json (None: each detector's own); a bad value is a one-line error."""
    runs = {}
    for name, argv in (("own", ()), ("never", ("--upsample-below", "0")),
                       ("always", ("--upsample-below", "10"))):
        out = tmp_path / name
        assert _footage(toy, out, "--methods", "hog_adapted", "--max-frames", "2", *argv) == 0
        assert json.loads((out / "run.json").read_text())["upsample_below"] == (
            float(argv[1]) if argv else None)
        dets = json.loads((out / "detections.json").read_text())["hog_adapted"]
        runs[name] = np.concatenate([np.reshape(v, (-1, 5)) for v in dets.values()])
    assert len(runs["never"]) and len(runs["always"])
    assert not (runs["never"].shape == runs["always"].shape
                and np.allclose(runs["never"], runs["always"]))
    capfd.readouterr()
    with pytest.raises(SystemExit) as exc:
        _footage(toy, tmp_path / "bad", "--methods", "hog_adapted", "--upsample-below", "-1")
    err = capfd.readouterr().err.strip().splitlines()
    assert exc.value.code == 2 and "cannot read the upsampling threshold '-1' (a finite " \
        "number >= 0, 0 for never)" in err[-1]
    assert not (tmp_path / "bad").exists()


def test_box_voting_reaches_every_method(toy, tmp_path):
    """Box voting (the default; ``--box-voting 0`` none): every method's boxes are voted
    (the adapted detector's and the pyramid's alike), their scores are not; recorded in
    run.json."""
    runs = {}
    for name, argv in (("plain", ("--box-voting", "0")), ("voted", ())):
        out = tmp_path / name
        assert _footage(toy, out, "--methods", "hog_pyramid", "hog_adapted",
                        "--max-frames", "3", *argv) == 0
        runs[name] = json.loads((out / "detections.json").read_text())
        assert json.loads((out / "run.json").read_text())["box_voting"] == (
            0.0 if argv else 1.0)
    for m in ("hog_pyramid", "hog_adapted"):
        a = np.concatenate([np.reshape(v, (-1, 5)) for v in runs["plain"][m].values()])
        b = np.concatenate([np.reshape(v, (-1, 5)) for v in runs["voted"][m].values()])
        assert len(a) == len(b) > 0
        np.testing.assert_array_equal(a[:, 4], b[:, 4])
        assert not np.allclose(a[:, :4], b[:, :4]), m


def test_the_daimler_detector_against_its_own_pyramids(toy, tmp_path, capsys):
    """OpenCV's Daimler detector runs as OpenCV's INRIA one does; each adapted detector is
    paired with the best unadapted baseline and with its own detector's best pyramid."""
    out = tmp_path / "daimler"
    methods = ["opencv_native", "daimler_native", "daimler_native[ground]", "daimler_adapted"]
    assert _footage(toy, out, "--methods", *methods, "--max-frames", "4",
                    "--bootstrap-block", "2") == 0
    printed = capsys.readouterr().out
    table = pd.read_csv(out / "footage_summary.csv").set_index("method")
    assert list(table.index) == methods
    best = table[~table.index.str.contains("adapted")]["lamr"].idxmin()
    own = table.loc[["daimler_native", "daimler_native[ground]"], "lamr"].idxmin()
    pairs = {(p["method"], p["reference"])
             for p in json.loads((out / "paired_differences.json").read_text())}
    assert {(m, best) for m in methods if m != best} <= pairs
    assert own != best                  # on this clip: the adapted detector gets both pairs
    assert ("daimler_adapted", own) in pairs and f"daimler_adapted - {own}" in printed


def test_every_method_over_grid_phases(toy, tmp_path, capsys):
    """``--phases 2``: the adapted and warping methods also run at the grid's three other
    phases and the pyramids on the frame moved by (0, 1), (1, 0), (1, 1) px; the report's
    means and paired differences are over the phases, the default grid's (unshifted
    frame's) run being the table's."""
    out = tmp_path / "phases"
    assert _footage(toy, out, "--methods", *METHODS, "--phases", "2", "--max-frames", "4",
                    "--bootstrap-block", "2") == 0
    printed = capsys.readouterr().out
    ph = json.loads((out / "phases.json").read_text())
    assert ph["grid_phases"] == [[0, 0], [0, 0.5], [0.5, 0], [0.5, 0.5]]
    assert ph["frame_shifts"] == [[0, 0], [0, 1], [1, 0], [1, 1]]
    assert list(ph["lamr"]) == METHODS
    table = pd.read_csv(out / "footage_summary.csv").set_index("method")
    for m in METHODS:
        assert len(ph["lamr"][m]) == 4
        assert ph["lamr"][m][0] == pytest.approx(table.loc[m, "lamr"], abs=1e-5)
    ref = table.loc[["opencv_native", "opencv_native[ground]"], "lamr"].idxmin()
    diffs = {(d["method"], d["reference"]): d for d in ph["differences"]}
    assert {(m, ref) for m in METHODS if m != ref} | {("hog_adapted", "hog_warp")} \
        == set(diffs)
    for m in METHODS:                  # both sides averaged over their phases
        if m != ref:
            assert diffs[m, ref]["difference"] == pytest.approx(
                np.mean(ph["lamr"][m]) - np.mean(ph["lamr"][ref]), abs=1e-5)
    rows = pd.read_csv(out / "phases.csv")
    assert len(rows) == 4 * len(METHODS) and set(rows["method"]) == set(METHODS)
    pyr = rows[rows["method"].str.startswith("opencv_native")]
    assert pyr["phase_forward"].isna().all() and set(pyr["shift_x"]) == {0, 1}
    grid = rows[~rows["method"].str.startswith("opencv_native")]
    assert grid["shift_x"].isna().all() and set(grid["phase_left"]) == {0, 0.5}
    assert "## Over 4 grid phases" in printed and "(phase mean)" in printed
    assert "moved by 0-1 whole pixels" in printed
    run = json.loads((out / "run.json").read_text())
    assert run["grid_phases"] == ph["grid_phases"] and run["frame_shifts"] == ph["frame_shifts"]


def test_the_targets_on_phase_means_take_the_baselines_means_too():
    """target_items with ``lamr`` (phase means): the best ground-filtered pyramid is chosen,
    and stated, by its phase mean, not by its default grid's LAMR."""
    from benchmark.footage.report import target_items
    from benchmark.frames.spec import FrameMethod

    ad, one, two = (FrameMethod.parse(n) for n in ("opencv_adapted", "opencv_native[ground]",
                                                    "opencv_2x[ground]"))
    evaluations = {ad: [{"lamr": 0.20}], one: [{"lamr": 0.175}], two: [{"lamr": 0.18}]}
    plain = target_items(evaluations, [])
    assert plain == ["- opencv_adapted LAMR 0.200 below opencv_native[ground]'s 0.175: NOT met"]
    means = {ad: 0.16, one: 0.19, two: 0.17}
    assert target_items(evaluations, [], lamr=means, note=" (phase mean)") == [
        "- opencv_adapted LAMR 0.160 (phase mean) below opencv_2x[ground]'s 0.170: met"]


def test_each_phase_runs_at_its_own_grid(toy):
    """run_phases gives each phase's detections as the runner at that grid phase (the
    window-grid methods) or frame shift (the pyramids) gives them."""
    from benchmark.footage.phases import run_phases
    from benchmark.footage.run import open_clip, run_footage
    from benchmark.frames.spec import FrameMethod
    from viewadapt.io import SourceDetectors

    clip = open_clip([str(toy.img1)], toy.calibration, toy.gt, max_frames=1)
    models = SourceDetectors.load(toy.model)
    methods = [FrameMethod.parse(m) for m in ("hog_pyramid", "hog_adapted")]
    phases, shifts = [(0.0, 0.0), (0.5, 0.5)], [(0, 0), (3, 2)]
    got = run_phases(clip, methods, models, phases, shifts, heights=(1.75,),
                     cache_dir=toy.cache)
    assert list(got) == methods and all(len(v) == 1 for v in got.values())
    kw = dict(heights=(1.75,), cache_dir=toy.cache)
    want = run_footage(clip, methods, models, grid_phase=phases[1], frame_shift=shifts[1],
                       **kw).detections
    default = run_footage(clip, methods, models, **kw).detections
    for m in methods:
        np.testing.assert_array_equal(got[m][0][0], want[m][0])
        assert not np.array_equal(want[m][0], default[m][0]), m
    with pytest.raises(ValueError, match="2 grid phases but 1 frame shifts"):
        run_phases(clip, methods, models, phases, shifts[:1], **kw)


@pytest.mark.parametrize("argv, message", [
    (["--methods", "opencv_native", "--jobs", "2"], "--jobs must be 1"),
    (["--methods", "opencv_native", "--bootstrap-block", "0"],
     "--bootstrap-block must be at least 1"),
    (["--methods", "opencv_native", "--every", "0"], "--every must be at least 1"),
    (["--methods", "hog_adapted", "--phases", "0"], "--phases must be at least 1"),
])
def test_bad_input_is_one_line(toy, tmp_path, capfd, argv, message):
    assert _footage(toy, tmp_path / "bad", *argv) == 2
    err = capfd.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1
    assert not (tmp_path / "bad").exists()


def test_an_unknown_method_is_refused_by_the_parser(toy, tmp_path, capfd):
    with pytest.raises(SystemExit) as exc:
        _footage(toy, tmp_path / "bad", "--methods", "sift_adapted")
    assert exc.value.code == 2 and "unknown method 'sift_adapted'" in capfd.readouterr().err


def test_each_method_runs_once_untimed_before_the_timed_frames(toy, monkeypatch):
    """The first call of a compiled kernel loads it: each method first runs on the first
    frame untimed, so its seconds are those of the clip's frames alone."""
    from benchmark.footage.run import open_clip, run_footage
    from benchmark.frames.methods import FrameMethods
    from benchmark.frames.spec import FrameMethod
    from viewadapt.io import SourceDetectors

    calls = []
    detect = FrameMethods.detect

    def counted(self, method, image, **kw):
        calls.append(method.name)
        return detect(self, method, image, **kw)

    monkeypatch.setattr(FrameMethods, "detect", counted)
    methods = [FrameMethod.parse(m) for m in ("opencv_native", "opencv_native[ground]",
                                              "hog_adapted")]
    clip = open_clip([str(toy.img1)], toy.calibration, toy.gt, max_frames=2)
    run = run_footage(clip, methods, SourceDetectors.load(toy.model), heights=(1.75,),
                      cache_dir=toy.cache)
    assert run.n_frames == 2 and all(len(run.detections[m]) == 2 for m in methods)
    # once untimed and once per frame; the ground-filtered pyramid reuses the timed boxes
    assert calls.count("opencv_native") == 3 and calls.count("hog_adapted") == 3
    assert calls.count("opencv_native[ground]") == 1


def test_the_runner_places_the_windows_at_a_grid_phase(toy):
    """``run_footage(grid_phase=)`` moves the candidate windows' ground grid (the adapted
    detectors' windows), as FrameDetector's ``grid_phase`` does."""
    from benchmark.footage.run import open_clip, run_footage
    from benchmark.frames.spec import FrameMethod
    from viewadapt.detect import FrameDetector
    from viewadapt.io import SourceDetectors

    clip = open_clip([str(toy.img1)], toy.calibration, toy.gt, max_frames=1)
    models = SourceDetectors.load(toy.model)
    m = FrameMethod.parse("hog_adapted")
    runs = [run_footage(clip, [m], models, heights=(1.75,), cache_dir=toy.cache, grid_phase=ph)
            for ph in ((0.0, 0.0), (0.5, 0.5))]
    want = len(FrameDetector(clip.camera, None, grid_phase=(0.5, 0.5),
                             lens=np.asarray(clip.dist).tolist() if clip.dist is not None
                             and clip.correction == "windows" else None).windows)
    assert runs[1].n_windows == want
    assert not np.array_equal(runs[0].detections[m][0], runs[1].detections[m][0])
