"""`bench runtime`'s judging on hand-made measurements (no timing) and its temporary folder,
gone after a run that succeeds and after one that raises (the timing stubbed out)."""

import tempfile

import numpy as np
import pytest

import benchmark.data
import benchmark.frames.methods
from benchmark.frames import runtime
from benchmark.frames.runtime import RUNTIME_TARGETS, format_table, judge_runtime, run_runtime


def _row(method, fps, nms_ms=None):
    row = {"method": method, "seconds_per_frame": 1.0 / fps, "fps_1core": fps}
    if nms_ms is not None:
        row["stages"] = [{"stage": "features", "ms": 5.0}, {"stage": "nms", "ms": nms_ms}]
    return row


#: fps (one core) of every method; NMS of the adapted detectors in ms
FPS = {"hog_adapted": 250.0, "acf_adapted": 40.0, "hog_warp": 2.0, "acf_warp": 0.5,
       "hog_pyramid": 1.0, "acf_pyramid": 4.0, "acf_pyramid_fast": 8.0, "opencv": 30.0,
       "opencv_native": 100.0, "opencv_2x": 60.0, "opencv_adapted": 20.0, "opencv_warp": 0.1}
NMS_MS = {"hog_adapted": 0.4, "acf_adapted": 1.5}
INFO = {"hog_precompute_s": 12.0, "hog_cache_hit_s": 0.2, "acf_precompute_s": 50.0,
        "acf_cache_hit_s": 3.0}


def _rows(leave_out=()):
    return [_row(m, f, NMS_MS.get(m)) for m, f in FPS.items() if m not in leave_out]


def _verdicts(rows, info):
    return {v["target"]: v for v in judge_runtime(rows, info)}


def test_the_table_holds_each_target_once_in_words():
    whats = [t.what for t in RUNTIME_TARGETS]
    assert len(set(whats)) == len(whats) == 11
    assert {(t.quantity, t.baseline, t.bound) for t in RUNTIME_TARGETS if t.baseline} == {
        ("hog_adapted", "hog_warp", 100.0), ("hog_adapted", "opencv", 10.0),
        ("opencv_adapted", "opencv_2x", 1.0)}


def test_targets_met_and_missed():
    v = _verdicts(_rows(), INFO)
    assert list(v) == [t.what for t in RUNTIME_TARGETS]
    met = {k: x["met"] for k, x in v.items()}
    assert met == {
        "hog_adapted >= 30 fps (1 core)": True,          # 250 fps
        "hog_adapted >= 100x hog_warp": True,            # 250 / 2 = 125x
        "hog_adapted >= 10x opencv (4x)": False,         # 250 / 30 = 8.3x
        "acf_adapted >= 15 fps (1 core)": True,          # 40 fps
        "hog_adapted >= 100 fps (1 core)": True,
        "acf_adapted >= 60 fps (1 core)": False,
        "NMS <= 1 ms (both detectors)": False,           # ACF's 1.5 ms, the slower
        "precompute <= 30 s (hog)": True,                # 12 s (ACF's 50 s not judged)
        "cache hit <= 1 s (hog)": True,                  # 0.2 s
        "opencv_adapted >= opencv (2x)": False,          # 20 / 60
        "opencv_adapted >= 25 fps (1 core)": False,      # 20 fps
    }
    assert v["hog_adapted >= 100x hog_warp"]["value"] == pytest.approx(125.0)
    assert v["hog_adapted >= 10x opencv (4x)"]["value"] == pytest.approx(250 / 30)
    assert v["NMS <= 1 ms (both detectors)"]["value"] == 1.5
    assert all(x["missing"] is None for x in v.values())


def test_a_bound_is_met_on_the_bound_itself():
    v = _verdicts([_row("hog_adapted", 30.0)], {"hog_cache_hit_s": 1.0})
    assert v["hog_adapted >= 30 fps (1 core)"]["met"] is True
    assert v["cache hit <= 1 s (hog)"]["met"] is True


def test_a_missing_baseline_is_not_judged():
    v = _verdicts(_rows(leave_out=("hog_warp",)), INFO)
    assert v["hog_adapted >= 100x hog_warp"] == {
        "target": "hog_adapted >= 100x hog_warp", "value": None, "bound": 100.0, "met": None,
        "missing": "hog_warp"}
    assert v["hog_adapted >= 10x opencv (4x)"]["met"] is False    # the others still judged
    # nor a missing quantity: no stages, no NMS target; no precompute time, no target
    v = _verdicts([_row("hog_adapted", 250.0)], {})
    assert v["NMS <= 1 ms (both detectors)"]["met"] is None
    assert v["precompute <= 30 s (hog)"]["missing"] == "hog_precompute_s"
    assert v["hog_adapted >= 30 fps (1 core)"]["met"] is True


@pytest.fixture
def stubbed(monkeypatch, tmp_path):
    """``run_runtime`` with the training and the one-core timing stubbed out, the temporary
    folders made under ``tmp_path / "tmp"``; returns that folder and the cache folders the
    stubbed timing was given (each with a file written into it)."""
    root = tmp_path / "tmp"
    root.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(root))

    class Models:
        training = {"frame_view": "both"}

        def save(self, path):
            path.write_bytes(b"models")

    seen = []

    def time_one_core(frames, models, cache_dir, **_):
        cache_dir.mkdir(parents=True)
        (cache_dir / "operator.npz").write_bytes(b"op")
        seen.append(cache_dir)
        info = {"window_selection_s": 0.1, "candidate_windows": 30000, **INFO,
                "hog_templates": 10, "acf_templates": 10, "hog_cell_sizes": (4.0,),
                "acf_cell_sizes": (4.0,), "hog_scored_positions": 5000,
                "hog_weights_per_window": 100.0}
        rows = [{**r, "windows": None, "feature_pixels": 1e6, "how": "stub", "detail": "-"}
                for r in _rows()]
        for st in (st for r in rows for st in r.get("stages", ())):
            st.update(bytes=1000, floor_ms=0.01)
        return rows, info

    monkeypatch.setattr(benchmark.data, "load_dataset", lambda data: None)
    monkeypatch.setattr(benchmark.frames.methods, "train_source_detectors",
                        lambda ds, **_: Models())
    monkeypatch.setattr(runtime, "timing_frames",
                        lambda data, n, size: [np.zeros((288, 384, 3), np.uint8)])
    monkeypatch.setattr(runtime, "time_one_core", time_one_core)
    return root, seen


def test_the_temporary_folder_is_gone_after_a_run(stubbed):
    root, seen = stubbed
    rows, info = run_runtime("data", jobs=1)
    assert len(seen) == 1 and root in seen[0].parents      # the cache was in the folder
    assert list(root.iterdir()) == []
    assert info["targets"] == {k: x["met"] for k, x in _verdicts(rows, info).items()}
    assert info["faster_acf_pyramid"] == "acf_pyramid_fast"            # 8 fps against 4
    assert info["ratios"]["acf_adapted / faster ACF pyramid"] == pytest.approx(40 / 8)
    table = format_table(rows, info)
    assert "- hog_adapted >= 10x opencv (4x): NOT met\n" in table
    assert "- hog_adapted >= 100x hog_warp: met\n" in table


def test_the_temporary_folder_is_gone_after_a_run_that_raises(stubbed, monkeypatch):
    root, seen = stubbed
    stub = runtime.time_one_core

    def fails(*args, **kwargs):
        stub(*args, **kwargs)
        raise RuntimeError("timing failed")

    monkeypatch.setattr(runtime, "time_one_core", fails)
    with pytest.raises(RuntimeError, match="timing failed"):
        run_runtime("data", jobs=1)
    assert len(seen) == 1 and root in seen[0].parents
    assert list(root.iterdir()) == []


def test_models_given_are_timed_without_training(stubbed, monkeypatch):
    root, seen = stubbed

    class Given:
        training = {"seed": 7, "quick": False}

        def save(self, path):
            path.write_bytes(b"given")

    def no_training(ds, **_):
        raise AssertionError("trained although models were given")

    monkeypatch.setattr(benchmark.frames.methods, "train_source_detectors", no_training)
    rows, info = run_runtime("data", jobs=1, models=Given())
    assert info["training"] == {"seed": 7, "quick": False} and len(seen) == 1


def test_a_model_file_that_is_not_there_is_one_line(tmp_path, capsys):
    from viewadapt.cli import main

    (tmp_path / "data").mkdir()
    rc = main(["bench", "runtime", "--data", str(tmp_path / "data"), "--out",
               str(tmp_path / "o"), "--model", str(tmp_path / "missing.npz")])
    err = capsys.readouterr().err
    assert rc != 0 and "missing.npz" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "o").exists()


def test_a_cache_folder_given_is_kept(stubbed, tmp_path):
    root, seen = stubbed
    run_runtime("data", jobs=1, cache_dir=tmp_path / "cache")
    assert seen == [tmp_path / "cache"] and (tmp_path / "cache" / "operator.npz").exists()
    assert list(root.iterdir()) == []


@pytest.mark.parametrize("size", ["768", "768x", "32x128", "768x99999"])
def test_a_bad_size_is_a_usage_error(size, tmp_path, capsys):
    from viewadapt.cli import main

    with pytest.raises(SystemExit) as exc:
        main(["bench", "runtime", "--data", str(tmp_path), "--out", str(tmp_path / "o"),
              "--size", size])
    assert exc.value.code == 2 and "--size" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()
