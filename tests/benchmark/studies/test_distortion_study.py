"""`python -m benchmark.studies.distortion_study`: per-frame undistortion against the pinhole frames.

Zero distortion must leave the undistorted condition identical to the original frames, the
valid region must follow the lens (barrel: only the edge ring; pincushion: empty corners),
and the command must write its outputs or, for bad input, one line and nothing.
"""

import dataclasses
import json

import numpy as np
import pandas as pd
import pytest

from benchmark.data import load_dataset
from benchmark.studies.distortion_report import study_verdict, summarize_distortion_study
from benchmark.studies.distortion_study import (
    DEFAULT_DISTORTIONS, distortion_label, group_by_scene, invalid_box_fractions, main,
    parse_distortion, resample_half_pixel, run_distortion_study, valid_region,
)
from benchmark.frames.methods import load_frames, train_source_detectors
from tests.toy_frames import TOY_FRAME_SIZE, small_toy_frames

SIZE = TOY_FRAME_SIZE
K = np.array([[150.0, 0.0, 95.5], [0.0, 150.0, 71.5], [0.0, 0.0, 1.0]])
MODERATE = np.array(DEFAULT_DISTORTIONS[0])


@pytest.fixture(scope="module")
def toy(tmp_path_factory):
    return small_toy_frames(tmp_path_factory.mktemp("tf") / "data")


@pytest.fixture(scope="module")
def model(toy, tmp_path_factory):
    path = tmp_path_factory.mktemp("model") / "source_detectors.npz"
    train_source_detectors(load_dataset(toy), quick=True).save(path)
    return path


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("cache")


@pytest.fixture(scope="module")
def study(toy, model, cache):
    from viewadapt.io import SourceDetectors

    frames = load_frames(toy)
    return frames, run_distortion_study(frames, SourceDetectors.load(model),
                                        [np.zeros(5), MODERATE], cache_dir=cache,
                                        repeats=1, remap_repeats=2)


def test_zero_distortion_detects_exactly_as_the_original_frames(study):
    frames, s = study
    dets = s["detections"]
    assert list(dets) == ["(a) original", "(r1) resampled-once", "(r2) resampled-twice",
                          "(b) undistorted none", "(c) uncorrected none",
                          "(b') edge-restored none", "(w) lens-windows none",
                          "(b) undistorted k1=-0.25 k2=0.08",
                          "(c) uncorrected k1=-0.25 k2=0.08",
                          "(b') edge-restored k1=-0.25 k2=0.08",
                          "(w) lens-windows k1=-0.25 k2=0.08"]
    assert sum(len(d) for d in dets["(a) original"]) > 0
    for i in range(len(frames)):
        for m in ("(b) undistorted none", "(c) uncorrected none", "(b') edge-restored none"):
            np.testing.assert_array_equal(dets[m][i], dets["(a) original"][i])
        # no lens: the refitted windows are the pinhole ones (to the fit's rounding, which
        # moves float32 scores in their last digits)
        np.testing.assert_allclose(dets["(w) lens-windows none"][i], dets["(a) original"][i],
                                   rtol=1e-4, atol=1e-4)
    # a real lens changes what the uncorrected detector sees
    assert any(not np.array_equal(a, c) for a, c in
               zip(dets["(a) original"], dets["(c) uncorrected k1=-0.25 k2=0.08"]))
    summ = summarize_distortion_study(s, frames, n_boot=50, seed=0)
    zero = summ[summ["dist"] == "none"].iloc[3:6]         # (b), (c), (b') of the zero set
    assert list(zero["condition"]) == ["b undistorted", "c uncorrected", "b' edge-restored"]
    assert (zero[["diff", "diff_low", "diff_high"]].to_numpy() == 0).all()
    assert (zero["lamr"] == summ.iloc[0]["lamr"]).all()
    und = summ[summ["condition"] == "b undistorted"]
    assert (und["remap_ms"] > 0).all() and (und["detect_ms"] > 0).all()
    np.testing.assert_allclose(und["remap_fraction"], und["remap_ms"] / und["detect_ms"])
    # (b) - (r2) on the same draws: for the zero set it is (a) - (r2)
    r2 = summ[summ["condition"] == "r2 resampled-twice"].iloc[0]
    zb = und.set_index("dist").loc["none"]
    np.testing.assert_allclose(zb["diff_r2"], -r2["diff"], atol=1e-12)
    assert summ[summ["condition"] != "b undistorted"]["diff_r2"].isna().all()
    assert (und["gt_partly_invalid"].between(0, 1)).all()
    assert und.set_index("dist").loc["none", "gt_partly_invalid"] == 0
    assert und.set_index("dist").loc["k1=-0.25 k2=0.08", "max_shift_px"] > 5
    assert summ["n_gt"].iloc[0] == sum(len(f.gt) for f in frames)
    # the lens windows: no remap, their (w) - (b) paired on the same draws
    win = summ[summ["condition"] == "w lens-windows"].set_index("dist")
    assert win["remap_ms"].isna().all() and (win["frame_ms"] == win["detect_ms"]).all()
    assert win.loc["none", "diff_b"] == pytest.approx(
        win.loc["none", "diff"] - und.set_index("dist").loc["none", "diff"], abs=1e-12)
    np.testing.assert_allclose(und["frame_ms"], und["detect_ms"] + und["remap_ms"])
    assert summ[summ["condition"] != "w lens-windows"]["diff_b"].isna().all()


def _table(b, b_r2, r1, fraction=0.03, w=None, w_ms=None):
    """A summary with one coefficient set: the (low, high) intervals of (b) - (a),
    (b) - (r2) and (r1) - (a), and optionally (w) - (a) with (w)'s ms per frame (against
    10 ms for undistortion plus detection)."""
    nan = (np.nan, np.nan)
    rows = []
    conds = [("a original", (0.0, 0.0), nan), ("r1 resampled-once", r1, nan),
             ("r2 resampled-twice", (-0.05, 0.09), nan), ("b undistorted", b, b_r2),
             ("c uncorrected", (0.1, 0.3), nan)] + ([("w lens-windows", w, nan)] if w else [])
    for cond, d, d2 in conds:
        rows.append(dict(condition=cond, dist="k1=-0.25" if cond[0] in "bcw" else "none",
                         diff_low=d[0], diff_high=d[1], diff_r2_low=d2[0],
                         diff_r2_high=d2[1],
                         remap_fraction=fraction if cond == "b undistorted" else np.nan,
                         frame_ms={"b undistorted": 10.0, "w lens-windows": w_ms}.get(
                             cond, 9.0)))
    return pd.DataFrame(rows)


@pytest.mark.parametrize("b, b_r2, r1, fraction, verdict", [
    ((-0.01, 0.05), (-0.1, 0.1), (-0.05, 0.03), 0.03, "keep undistortion"),
    ((0.001, 0.07), (-0.02, 0.04), (-0.05, 0.03), 0.03,
     "keep undistortion (synthetic resampling)"),
    ((0.001, 0.07), (0.001, 0.05), (-0.05, 0.03), 0.03, "undecided"),  # beyond resampling
    ((0.001, 0.07), (-0.02, 0.04), (0.002, 0.03), 0.03, "undecided"),  # one resample hurts
    ((-0.01, 0.05), (-0.02, 0.04), (-0.05, 0.03), 0.2, "undecided"),   # the remap is dear
])
def test_verdict_follows_the_rule(b, b_r2, r1, fraction, verdict):
    assert study_verdict(_table(b, b_r2, r1, fraction)) == verdict


@pytest.mark.parametrize("b, fraction, w, w_ms, verdict", [
    ((-0.01, 0.05), 0.03, (-0.02, 0.04), 9.5, "map the windows through the lens"),  # cheaper
    ((-0.01, 0.05), 0.03, (-0.05, -0.01), 9.5, "map the windows through the lens"),  # better
    ((-0.01, 0.05), 0.03, (-0.02, 0.04), 10.5, "keep undistortion"),   # dearer, both as good
    ((-0.01, 0.05), 0.03, (0.01, 0.06), 9.5, "keep undistortion"),     # resolvably worse
    ((0.001, 0.07), 0.03, (-0.02, 0.04), 10.5, "map the windows through the lens"),  # (b) fails
    ((0.001, 0.07), 0.03, (0.01, 0.04), 9.5, "undecided"),             # neither qualifies
])
def test_verdict_weighs_the_lens_windows(b, fraction, w, w_ms, verdict):
    # (b) - (r2) resolvably worse, so undistortion qualifies only on (b) - (a)
    assert study_verdict(_table(b, (0.001, 0.05), (-0.05, 0.03), fraction, w, w_ms)) == verdict


def test_resample_half_pixel_is_a_box_then_a_binomial_blur():
    rng = np.random.default_rng(0)
    img = rng.uniform(0, 1, (12, 16)).astype(np.float32)
    once = resample_half_pixel(img, 1)
    box = (img[:-1, :-1] + img[1:, :-1] + img[:-1, 1:] + img[1:, 1:]) / 4
    np.testing.assert_allclose(once[:-1, :-1], box, atol=1e-5)   # bilinear weights: 5 bits
    twice = resample_half_pixel(img, 2)
    k = np.array([1, 2, 1]) / 4
    blur = sum(k[i] * k[j] * img[i:i + 10, j:j + 14] for i in range(3) for j in range(3))
    np.testing.assert_allclose(twice[1:-1, 1:-1], blur, atol=1e-4)
    frame = rng.integers(0, 256, (12, 16, 3), dtype=np.uint8)
    assert resample_half_pixel(frame, 2).dtype == np.uint8
    with pytest.raises(ValueError, match="times must be 1 or 2"):
        resample_half_pixel(img, 3)


def test_parse_distortion_and_labels():
    np.testing.assert_array_equal(parse_distortion("-0.25, 0.08,0,0,0"), MODERATE)
    assert distortion_label(MODERATE) == "k1=-0.25 k2=0.08"
    assert distortion_label([0, 0, 0.001, 0]) == "p1=0.001"
    assert distortion_label(np.zeros(5)) == "none"
    for bad, match in [("0.1,0.2,0.3", "got 3"), ("nan,0,0,0,0", "non-finite"),
                       ("a,b", "not comma-separated numbers"), ("", "not comma-separated")]:
        with pytest.raises(ValueError, match=match) as err:
            parse_distortion(bad)
        assert "\n" not in str(err.value) and str(err.value).startswith("--dist")


def test_valid_region_follows_the_lens():
    assert valid_region(K, np.zeros(5), SIZE).all()
    barrel = valid_region(K, MODERATE, SIZE)
    assert barrel.shape == (SIZE[1], SIZE[0])
    assert barrel[3:-3, 3:-3].all() and not barrel.all()      # only the render's edge ring
    pincushion = valid_region(K, [0.3, 0, 0, 0, 0], SIZE)
    assert not pincushion[:10, :10].any() and pincushion[60:80, 85:105].all()


def test_invalid_box_fractions_by_hand():
    valid = np.ones((10, 20), bool)
    valid[:, :5] = False                                      # left quarter invalid
    boxes = [[0, 0, 10, 10], [10, 2, 4, 4], [-10, 0, 20, 10], [30, 0, 5, 5], [2.5, 0, 5, 2]]
    np.testing.assert_allclose(invalid_box_fractions(boxes, valid),
                               [0.5, 0.0, 0.5, 0.0, 3 / 6])    # last: pixels 2..7, 3 invalid
    assert invalid_box_fractions(np.zeros((0, 4)), valid).shape == (0,)


def test_group_by_scene_refuses_two_cameras_in_one_scene(toy):
    frames = load_frames(toy)
    assert list(group_by_scene(frames).values()) == [list(range(len(frames)))]
    moved = dataclasses.replace(frames[1].camera, t=frames[1].camera.t + 0.1)
    with pytest.raises(ValueError, match="different cameras"):
        group_by_scene([frames[0], dataclasses.replace(frames[1], camera=moved)])


def test_cli_writes_all_outputs(toy, model, cache, tmp_path, capsys):
    out = tmp_path / "out"
    rc = main(["--data", str(toy), "--out", str(out), "--model", str(model), "--dist",
               "-0.25,0.08,0,0,0", "-0.4,0.15,0,0,0", "--repeats", "1", "--boot", "20",
               "--cache", str(cache), "--seed", "3"])
    assert rc == 0, capsys.readouterr()
    assert {p.name for p in out.iterdir()} >= {"distortion_study.csv", "distortion_study.md",
                                              "run.json", ".viewadapt-output"}
    assert not (out / "cache").exists()                       # --cache elsewhere
    tab = pd.read_csv(out / "distortion_study.csv")
    assert list(tab["condition"]) == ["a original", "r1 resampled-once",
                                      "r2 resampled-twice"] + ["b undistorted", "c uncorrected",
                                                       "b' edge-restored", "w lens-windows"] * 2
    assert list(tab["dist"])[3:] == ["k1=-0.25 k2=0.08"] * 4 + ["k1=-0.4 k2=0.15"] * 4
    assert tab[["lamr", "ci_low", "ci_high", "detect_ms"]].notna().all().all()
    run = json.loads((out / "run.json").read_text())
    assert run["seed"] == 3 and run["n_boot"] == 20 and run["model"] == str(model)
    assert run["verdict"] in ("keep undistortion", "keep undistortion (synthetic resampling)",
                              "map the windows through the lens", "undecided")
    assert all(set(op["lens_windows"]) == {"k1=-0.25 k2=0.08", "k1=-0.4 k2=0.15"}
               for op in run["operators"].values())                 # the lens windows' builds
    assert run["distortions"]["k1=-0.4 k2=0.15"] == [-0.4, 0.15, 0, 0, 0]
    md = (out / "distortion_study.md").read_text()
    assert "## Conclusion" in md and "k1=-0.4 k2=0.15" in md


@pytest.mark.parametrize("extra, match", [
    (["--dist", "0.1,0.2,0.3"], "got 3"),
    (["--dist", "-0.25,nan,0,0,0"], "non-finite"),
    (["--dist", "-0.25,0.08,0,0,0", "-0.25,0.08,0,0,0"], "given twice"),
    (["--dist"], "not comma-separated numbers"),
    (["--model", "missing.npz"], "does not exist"),
    (["--repeats", "0"], "at least 1"),
])
def test_bad_input_is_one_line_and_writes_nothing(extra, match, toy, tmp_path, capsys):
    out = tmp_path / "out"
    rc = main(["--data", str(toy), "--out", str(out), *extra])
    printed = capsys.readouterr().err
    assert rc == 2 and printed.count("\n") == 1, printed
    assert printed.startswith("python -m benchmark.studies.distortion_study: error: "), printed
    assert match in printed
    assert not out.exists()


def test_dataset_without_frames_is_refused(tmp_path, capsys):
    data = tmp_path / "crops_only"
    data.mkdir()
    (data / "dataset.json").write_text("{}")
    out = tmp_path / "out"
    assert main(["--data", str(data), "--out", str(out)]) == 2
    printed = capsys.readouterr().err
    assert printed.count("\n") == 1 and "no frames_coco.json" in printed
    assert not out.exists()
