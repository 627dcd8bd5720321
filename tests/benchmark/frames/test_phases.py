"""bench frames --phases: the methods on the candidate windows at several ground-grid phases."""

import json

import numpy as np
import pandas as pd
import pytest

from benchmark.data import load_dataset
from benchmark.frames.command import run_frames_benchmark
from benchmark.frames.methods import load_frames, train_source_detectors
from benchmark.frames.phases import grid_phases
from benchmark.frames.report import phase_gap_lines, phase_table, summary_table
from benchmark.frames.spec import FrameMethod
from tests.toy_frames import small_toy_frames


def _main(argv):
    from viewadapt.cli import main

    return main(argv)


@pytest.fixture(scope="module")
def toy(tmp_path_factory):
    root = tmp_path_factory.mktemp("phases")
    data = small_toy_frames(root / "data")
    model = train_source_detectors(load_dataset(data), quick=True, frame_view="none").save(
        root / "model.npz")
    return data, model


def _methods(*names):
    return [FrameMethod.parse(n) for n in names]


def test_which_methods_move_with_the_grid():
    assert all(m.on_window_grid for m in _methods("hog_adapted", "acf_warp",
                                                    "hog_adapted[body, paper eq.3]"))
    assert not any(m.on_window_grid for m in _methods("hog_pyramid", "acf_pyramid_fast",
                                                        "opencv", "opencv_native"))


def test_phase_runs_move_the_windows_and_average(toy, tmp_path):
    data, model_path = toy
    from viewadapt.io import SourceDetectors

    models = SourceDetectors.load(model_path)
    ad, wp, cv = _methods("hog_adapted", "hog_warp", "opencv_native")
    kw = dict(methods=[ad, wp, cv], models=models,
              cache_dir=tmp_path / "cache", progress=False, heights=(1.65, 1.85))
    one, *_, none = run_frames_benchmark(data, **kw)
    res, _, dets, frames, info, phase_dets = run_frames_benchmark(data, phases=2, **kw)
    assert none == {} and info["grid_phases"] == grid_phases(2)
    assert info["frame_shifts"] == [(0, 0), (0, 1), (1, 0), (1, 1)]
    assert set(phase_dets) == {ad, wp, cv}          # opencv on the frames moved 0-1 px
    for m in (ad, wp, cv):
        lamrs = res[m]["lamr_phases"]
        assert len(lamrs) == 4 and res[m]["lamr"] == pytest.approx(np.mean(lamrs))
        # the default grid is the one-phase run's, detection for detection
        assert lamrs[0] == one[m]["lamr"]
        assert all(np.array_equal(a, b) for a, b in zip(phase_dets[m][0], dets[m]))
    for m in (ad, wp):      # another phase scores other windows
        assert any(a.shape != b.shape or not np.allclose(a, b)
                   for a, b in zip(phase_dets[m][1], phase_dets[m][0]))
    # the tables
    md = "\n".join(summary_table(res, list(res), n_phases=4))
    assert "mean over 4 grid phases" in md and "| opencv_native |" in md
    csv = phase_table(res, info["grid_phases"], info["frame_shifts"]).splitlines()
    assert csv[0] == "method,phase_forward,phase_left,shift_x,shift_y,lamr" and len(csv) == 13
    assert csv[-1].startswith("opencv_native,,,1,1,") and csv[1].startswith("hog_adapted,0,0,,,")
    gap = phase_gap_lines(phase_dets, frames, n_boot=20)
    assert len(gap) == 4 and gap[-1].startswith("- hog_adapted - hog_warp: ")


def test_gap_verdicts(toy):
    data, _ = toy
    frames = load_frames(data)
    perfect = [np.c_[f.gt, np.ones(len(f.gt))] for f in frames]
    empty = [np.zeros((0, 5)) for _ in frames]
    ad, wp = _methods("hog_adapted", "hog_warp")
    # adapted perfect, warping finds nothing: the whole interval below +0.03
    assert phase_gap_lines({ad: [perfect] * 2, wp: [empty] * 2},
                           frames, n_boot=10)[-1].endswith(": met")
    assert phase_gap_lines({ad: [empty], wp: [perfect]},
                           frames, n_boot=10)[-1].endswith(": NOT met")
    assert phase_gap_lines({ad: [empty]}, frames) == []


def test_bench_frames_phases_end_to_end(toy, tmp_path):
    data, model = toy
    out = tmp_path / "out"
    assert _main(["bench", "frames", "--data", str(data), "--out", str(out), "--model",
                  str(model), "--phases", "2", "--heights", "1.65,1.85", "--methods",
                  "hog_adapted", "hog_warp", "opencv_native"]) == 0
    summary = pd.read_csv(out / "frames_summary.csv").set_index("method")
    phases = pd.read_csv(out / "phases.csv")
    assert sorted(set(phases["method"])) == ["hog_adapted", "hog_warp", "opencv_native"]
    for m in ("hog_adapted", "hog_warp"):
        rows = phases[phases["method"] == m]
        assert len(rows) == 4 and summary.loc[m, "grid_phases"] == 4
        assert summary.loc[m, "lamr"] == pytest.approx(rows["lamr"].mean(), abs=1e-4)
        default = rows[(rows["phase_forward"] == 0) & (rows["phase_left"] == 0)]["lamr"]
        assert summary.loc[m, "lamr_default_grid"] == pytest.approx(default.item(), abs=1e-4)
        # the curve is the default grid's, with its own LAMR
        curve = json.loads((out / "det_curves.json").read_text())[m]
        assert curve["lamr"] == pytest.approx(default.item(), abs=1e-4)
    # OpenCV on the frames moved by 0..1 px: its LAMR the mean over the four
    shifted = phases[phases["method"] == "opencv_native"]
    assert shifted["phase_forward"].isna().all() and len(shifted) == 4
    assert sorted(zip(shifted["shift_x"], shifted["shift_y"])) == [(0, 0), (0, 1), (1, 0),
                                                                   (1, 1)]
    assert summary.loc["opencv_native", "grid_phases"] == 4
    assert summary.loc["opencv_native", "lamr"] == pytest.approx(shifted["lamr"].mean(),
                                                                 abs=1e-4)
    md = (out / "frames_summary.md").read_text()
    assert "mean over 4 grid phases" in md and "hog_adapted - hog_warp: " in md
    assert (out / "phases.png").stat().st_size > 0
    run = json.loads((out / "run.json").read_text())
    assert run["grid_phases"] == [[0, 0], [0, 0.5], [0.5, 0], [0.5, 0.5]]
    assert run["frame_shifts"] == [[0, 0], [0, 1], [1, 0], [1, 1]]


@pytest.mark.parametrize("extra", [["--phases", "0"], ["--phases", "2",
                                                        "--keep-other-methods"]])
def test_bench_frames_phases_bad_input(toy, tmp_path, capsys, extra):
    data, model = toy
    out = tmp_path / "bad"
    assert _main(["bench", "frames", "--data", str(data), "--out", str(out), "--model",
                  str(model), "--methods", "hog_adapted", *extra]) == 2
    assert "--phases" in capsys.readouterr().err and not out.exists()


def test_bench_frames_box_voting(toy, tmp_path, capsys):
    """Box voting (the default; ``--box-voting 0`` none): the same detections and scores,
    boxes voted, recorded in run.json; an earlier run with other voting is not mixed in by
    --keep-other-methods."""
    data, model = toy
    dets = {}
    for name, argv in (("plain", ["--box-voting", "0"]), ("voted", [])):
        out = tmp_path / name
        assert _main(["bench", "frames", "--data", str(data), "--out", str(out), "--model",
                      str(model), "--methods", "hog_adapted", *argv]) == 0
        dets[name] = json.loads((out / "detections.json").read_text())["hog_adapted"]
        assert json.loads((out / "run.json").read_text())["box_voting"] == (0 if argv else 1.0)
    a = np.concatenate([np.reshape(v, (-1, 5)) for v in dets["plain"].values()])
    b = np.concatenate([np.reshape(v, (-1, 5)) for v in dets["voted"].values()])
    assert len(a) == len(b) > 0
    np.testing.assert_array_equal(a[:, 4], b[:, 4])
    assert not np.allclose(a[:, :4], b[:, :4])
    capsys.readouterr()
    assert _main(["bench", "frames", "--data", str(data), "--out", str(tmp_path / "plain"),
                  "--model", str(model), "--methods", "hog_warp", "--keep-other-methods",
                  "--box-voting", "1", "--overwrite"]) == 2
    assert "--box-voting 0, not 1" in capsys.readouterr().err


def test_frame_shifts_keep_every_pixel_and_map_boxes_back():
    """The pyramids' phases: the frame on a larger canvas, its first columns and rows
    replicated, nothing cut; boxes found there map back by the shift."""
    from benchmark.frames.phases import frame_shifts, shifted_frame, unshifted_boxes

    assert frame_shifts(2) == [(0, 0), (0, 1), (1, 0), (1, 1)]
    assert len(frame_shifts(4)) == len(grid_phases(4)) and frame_shifts(4)[0] == (0, 0)
    img = np.arange(5 * 7 * 3, dtype=np.uint8).reshape(5, 7, 3)
    assert shifted_frame(img, (0, 0)) is img
    canvas = shifted_frame(img, (3, 2))
    assert canvas.shape == (7, 10, 3)
    np.testing.assert_array_equal(canvas[2:, 3:], img)
    np.testing.assert_array_equal(canvas[:2, 3:], np.broadcast_to(img[:1], (2, 7, 3)))
    np.testing.assert_array_equal(canvas[2:, :3], np.repeat(img[:, :1], 3, axis=1))
    boxes = np.array([[10.0, 20.0, 30.0, 60.0, 0.5]])
    np.testing.assert_array_equal(unshifted_boxes(boxes, (3, 2)),
                                  [[7.0, 18.0, 30.0, 60.0, 0.5]])
    with pytest.raises(ValueError, match="whole pixels >= 0"):
        shifted_frame(img, (-1, 0))
    with pytest.raises(ValueError, match="at least 1"):
        frame_shifts(0)


def test_a_frame_shift_moves_the_pyramids_only(toy):
    """FrameMethods(frame_shift=...): a pyramid's boxes on the moved frame, mapped back (so
    they differ from the unmoved frame's, in the frame's own pixels); the methods on the
    candidate windows do not see it (their grid moves with grid_phase)."""
    from benchmark.frames.methods import FrameMethods
    from viewadapt.io import SourceDetectors

    data, model = toy
    frame = load_frames(data)[0]
    models = SourceDetectors.load(model)
    fm = FrameMethods(frame.camera, models, person_heights=(1.75,))
    shifted = FrameMethods(frame.camera, models, person_heights=(1.75,), frame_shift=(16, 24))
    assert fm.frame_shift == (0, 0) and shifted.frame_shift == (16, 24)
    image = frame.image()
    plain = fm.detect("hog_pyramid", image)
    moved = shifted.detect("hog_pyramid", image)
    assert len(plain) and len(moved) and not np.array_equal(plain, moved)
    # boxes stay on the frame's persons: the best box of each run overlaps the other's
    from viewadapt.boxes import box_iou

    best = plain[np.argmax(plain[:, 4]), :4]
    assert box_iou(best[None], moved[:, :4]).max() > 0.5
    adapted = fm.detect("hog_adapted", image)
    assert len(adapted) and np.array_equal(shifted.detect("hog_adapted", image), adapted)
    for bad in ((-1, 0), (1, 2, 3)):
        with pytest.raises(ValueError, match="frame shift"):
            FrameMethods(frame.camera, models, person_heights=(1.75,), frame_shift=bad)
