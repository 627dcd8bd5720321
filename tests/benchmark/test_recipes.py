"""benchmark.recipes: the source-training recipe, applied alike by every command that trains."""

import json

import numpy as np
import pandas as pd
import pytest

from benchmark.crops.features import WindowSet, rotation_about_centre
from benchmark.recipes import DEFAULT_RECIPE, RECIPES, Recipe, get_recipe, recipe_from_record
from benchmark.toydata import make_toy_dataset
from viewadapt.boosting import AdaBoostTrees
from viewadapt.cli import main
from viewadapt.geometry import elevation_homography
from viewadapt.warp import translation, warp_to_source_view


@pytest.fixture(scope="module")
def toy(tmp_path_factory):
    return make_toy_dataset(tmp_path_factory.mktemp("toy") / "data", n_persons=9, n_scenes=3,
                            n_backgrounds=2, seed=4)


CROSSVAL = ["--quick", "--detectors", "hog", "opencv", "--sources", "0,pi/4",
            "--object-models", "plane", "--no-upper-bound"]


@pytest.fixture(scope="module")
def runs(toy, tmp_path_factory):
    root = tmp_path_factory.mktemp("recipes")
    for name in ("elevation0", "rotated"):
        assert main(["bench", "crossval", "--data", str(toy), "--out", str(root / name),
                     "--recipe", name] + CROSSVAL) == 0
    return root


def test_recipes_are_checked_and_found_by_name():
    assert DEFAULT_RECIPE in RECIPES and get_recipe(RECIPES["rotated"]) is RECIPES["rotated"]
    assert RECIPES["elevation0"].negative_suffixes() == ()
    assert RECIPES["rotated"].negative_suffixes() == ("rot-60", "rot-30", "rot+30", "rot+60")
    for bad in ("mirrored", None, 3):
        with pytest.raises(ValueError, match="unknown recipe .*; choose one of elevation0, "
                                             "rotated"):
            get_recipe(bad)
    for rot in ((30.0, 30.0), (360.0,), (float("nan"),)):
        with pytest.raises(ValueError, match="distinct finite angles"):
            Recipe("x", "y", rotations_deg=rot)


def test_every_command_that_trains_defaults_to_the_shipped_detectors_recipe():
    from benchmark.pipelines import DEMO_RECIPE
    from benchmark.recipes import PAPER_RECIPE
    from viewadapt.cli import build_parser
    from viewadapt.io.models import SourceDetectors, shipped_model_path

    # the shipped models record the recipe every member was trained under
    members = SourceDetectors.load(shipped_model_path()).training["average_of"]
    assert {recipe_from_record(m["recipe"]).name for m in members} == {DEFAULT_RECIPE}
    parser = build_parser()
    for argv in (["bench", "crossval"], ["bench", "sweep"], ["bench", "frames"],
                 ["bench", "runtime"]):
        args = parser.parse_args(argv + ["--data", "D", "--out", "O"])
        assert args.recipe is RECIPES[DEFAULT_RECIPE], argv
    # the demo and the paper's reproduction keep their own, stated in their --help
    assert parser.parse_args(["demo", "--out", "O"]).recipe.name == DEMO_RECIPE == "rotated"
    assert parser.parse_args(["reproduce", "--out", "O"]).recipe.name == PAPER_RECIPE
    assert PAPER_RECIPE == "elevation0" != DEFAULT_RECIPE


def test_a_recipe_is_read_back_from_its_record_and_only_then():
    for r in RECIPES.values():
        assert recipe_from_record(json.loads(json.dumps(r.to_dict()))) is r
    changed = dict(RECIPES["rotated"].to_dict(), rotations_deg=[10.0])
    assert recipe_from_record(changed) is None                 # same name, other settings
    assert recipe_from_record(None) is None and recipe_from_record({"name": "new"}) is None


def test_a_rotated_window_can_be_cut_out_first_then_warped(toy):
    """The synthesised rows' rotated negatives: the window rotated (read from the whole
    image), then warped on its own with its borders replicated, as any crop-first warp."""
    from benchmark.data import read_image

    R = translation(24, 40) @ rotation_about_centre(30.0)
    H = np.linalg.inv(elevation_homography(0.0, np.pi / 4))
    path = next((toy / "background").rglob("*.png")).relative_to(toy)
    ws = WindowSet("b", [(str(path), R)], pd.DataFrame({"label": [0]}))
    (got,) = ws.warped(H, "synth").images(toy)
    img = read_image(toy / path)
    want = warp_to_source_view(warp_to_source_view(img, R), H)
    assert np.array_equal(got, want)
    # and not what the old crop (the translation alone, the rotation dropped) gave
    assert not np.array_equal(got, warp_to_source_view(img[40:168, 24:88], H))


def test_crossval_records_the_recipe_and_trains_every_method_with_it(runs):
    scores = {n: pd.read_parquet(runs / n / "scores.parquet") for n in ("elevation0", "rotated")}
    for name in scores:
        run = json.loads((runs / name / "run.json").read_text())
        assert run["recipe"]["name"] == name and run["crossval"]["recipe"]["name"] == name
        assert f"recipe `{name}`" in (runs / name / "report.md").read_text()

    def method_scores(df, det, method):
        d = df[(df["detector"] == det) & (df["method"] == method)]
        return d.sort_values(["fold", "path", "x", "y"], na_position="first")["score"].to_numpy()

    a, b = scores["elevation0"], scores["rotated"]
    # every HOG row that trains changes with the recipe; OpenCV's pretrained one cannot
    for method in ("unadapted", "adapted", "image warping", "synthesised", "oracle"):
        assert not np.allclose(method_scores(a, "hog", method), method_scores(b, "hog", method))
    for method in ("unadapted", "adapted"):
        assert np.array_equal(method_scores(a, "opencv", method),
                              method_scores(b, "opencv", method))


def test_results_of_two_recipes_are_not_mixed(runs, toy, capsys):
    before = (runs / "rotated" / "run.json").read_bytes()
    assert main(["bench", "sweep", "--data", str(toy), "--out", str(runs / "rotated"),
                 "--recipe", "elevation0", "--quick"]) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "trained with recipe 'rotated', not 'elevation0'" in err[0]
    assert (runs / "rotated" / "run.json").read_bytes() == before
    assert not (runs / "rotated" / "sweep_summary.csv").exists()


def test_an_unknown_recipe_is_a_usage_error(toy, tmp_path, capsys):
    for argv in (["bench", "crossval", "--data", str(toy)], ["bench", "frames", "--data", str(toy)],
                 ["demo"]):
        with pytest.raises(SystemExit) as exc:
            main(argv + ["--out", str(tmp_path / "o"), "--recipe", "mirrored"])
        assert exc.value.code == 2
        assert "unknown recipe 'mirrored'" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_the_sweep_trains_the_crossval_models_under_the_recipe(runs, toy, tmp_path):
    """The sweep assembles the recipe's negatives itself; its unadapted rows must be the
    cross-validation's, trained the same way."""
    out = tmp_path / "sw"
    assert main(["bench", "sweep", "--data", str(toy), "--out", str(out), "--quick",
                 "--recipe", "rotated", "--object-models", "plane", "--step",
                 str(np.pi / 36), "--sigma", "0"]) == 0
    sw = pd.read_parquet(out / "sweep_scores.parquet")
    cv = pd.read_parquet(runs / "rotated" / "scores.parquet")
    cv = cv[(cv["detector"] == "hog") & (cv["method"] == "unadapted")]
    un = sw[sw["method"] == "unadapted"]
    key = lambda d: np.sort(d["score"].to_numpy())                  # noqa: E731
    assert len(un) == len(cv) and np.allclose(key(un), key(cv), atol=1e-5)


def test_camera_effects_are_drawn_per_window_reproducibly_and_come_last(toy):
    from benchmark.crops.features import person_windows
    from benchmark.data import load_dataset
    from benchmark.recipes import SURVEILLANCE_CAMERA

    ds = load_dataset(toy)
    plain = person_windows(ds, 0)
    cam = plain.through_camera(SURVEILLANCE_CAMERA)
    a, b = list(cam.images(toy))[:6], list(cam.images(toy))[:6]
    clean = list(plain.images(toy))[:6]
    assert all(np.array_equal(x, y) for x, y in zip(a, b))            # the same every run
    assert all(not np.array_equal(x, c) for x, c in zip(a, clean))
    # each window its own draw: the residuals of two windows are not one pattern
    r = [x.astype(float) - c for x, c in zip(a, clean)]
    assert not np.allclose(r[0], r[1])
    assert cam.key != plain.key and cam.key != plain.through_camera(SURVEILLANCE_CAMERA,
                                                                     seed=1).key
    with pytest.raises(ValueError, match="camera effects, which come last; warp first"):
        cam.warped(np.eye(3), "w")
    with pytest.raises(ValueError, match="warp first"):
        cam.through_camera(SURVEILLANCE_CAMERA)


def test_the_camera_recipe_trains_on_every_window_through_the_camera(toy):
    from benchmark.data import load_dataset
    from benchmark.frames.methods import train_source_detectors

    ds = load_dataset(toy)
    r = RECIPES["camera"]
    assert [k for k, _ in r.training_suffixes()] == ["person"] + ["background"] * 5
    assert all(a.endswith("cam") for _, a in r.training_suffixes())
    rotated = train_source_detectors(ds, quick=True, frame_view="none", recipe="rotated")
    camera = train_source_detectors(ds, quick=True, frame_view="none", recipe="camera")
    assert camera.training["recipe"]["camera"]["jpeg_quality"] == [30, 90]
    assert recipe_from_record(camera.training["recipe"]) is r
    assert camera.training["background_windows"] == rotated.training["background_windows"]
    assert not np.allclose(camera.hog_weights, rotated.hog_weights)


def test_the_regularised_recipe_sets_the_c_of_every_svm(toy):
    from benchmark.crops.crossval import CrossvalConfig
    from benchmark.crops.detectors import HogDescriptorDetector
    from benchmark.frames.methods import train_source_detectors
    from benchmark.data import load_dataset

    reg = RECIPES["regularised"]
    assert reg.svm_C(0.01) == 0.001 and RECIPES["elevation0"].svm_C(0.01) == 0.01
    # recipes without a C keep the records they wrote before
    assert "svm_c" not in RECIPES["elevation0"].to_dict() and reg.to_dict()["svm_c"] == 0.001
    for bad in (0, -1.0, float("inf"), "0.1"):
        with pytest.raises(ValueError, match="svm_c"):
            Recipe("x", "y", svm_c=bad)
    # the crops' SVMs (crossval, sweep)
    rng = np.random.default_rng(0)
    X_pos, X_neg = rng.random((20, 16 * 8 * 9)) + 0.5, rng.random((40, 16 * 8 * 9))
    for recipe, C in ((reg, 0.001), (RECIPES["elevation0"], 0.01)):
        cfg = CrossvalConfig(recipe=recipe)
        model = HogDescriptorDetector().fit(X_pos, X_neg, seed=0, config=cfg)
        assert model.C == C
    # the frames' source detectors: the same SVM as asking for its C
    ds = load_dataset(toy)
    a = train_source_detectors(ds, quick=True, recipe="regularised")
    b = train_source_detectors(ds, quick=True, svm_params={"C": 0.001})
    assert np.array_equal(a.hog_weights, b.hog_weights)
    assert a.training["recipe"]["svm_c"] == 0.001 and a.training["svm_params"] == {"C": 0.001}
    assert not np.array_equal(a.hog_weights, train_source_detectors(
        ds, quick=True, recipe="elevation0").hog_weights)


def test_acf_members_average_that_many_seeds_of_every_acf_model(toy):
    from benchmark.crops.crossval import CrossvalConfig
    from benchmark.crops.detectors import AcfTreesDetector
    from benchmark.data import load_dataset
    from benchmark.frames.methods import train_source_detectors

    two = Recipe("two", "two ACF members", svm_c=0.001, acf_members=2)
    assert two.to_dict()["acf_members"] == 2
    assert "acf_members" not in RECIPES["elevation0"].to_dict()
    for bad in (0, True, 1.5, "2"):
        with pytest.raises(ValueError, match="acf_members"):
            Recipe("x", "y", acf_members=bad)
    # the frames' source detectors: member k is the single model of seed k; the SVM as before
    ds = load_dataset(toy)
    avg = train_source_detectors(ds, quick=True, recipe=two, seed=3)
    one = [train_source_detectors(ds, quick=True, recipe="regularised", seed=s) for s in (3, 4)]
    assert np.array_equal(avg.hog_weights, one[0].hog_weights)
    n = one[0].acf.n_estimators_
    assert avg.acf.n_estimators_ == n + one[1].acf.n_estimators_
    # member 0 gates: its trees first, read as its own score, then member 1's
    assert np.array_equal(avg.acf.feature_[:n], one[0].acf.feature_)
    assert np.array_equal(avg.acf.feature_[n:], one[1].acf.feature_)
    assert np.allclose(avg.acf.value_[:n], one[0].acf.value_ / 2)
    assert np.array_equal(avg.acf.cascade_scale_,
                          np.repeat([2.0, 1.0], [n, avg.acf.n_estimators_ - n]))
    assert avg.training["acf_members"] == 2 and avg.training["recipe"]["acf_members"] == 2
    assert "acf_members" not in one[0].training
    # the crops' ACF models (crossval, sweep)
    rng = np.random.default_rng(0)
    X_pos, X_neg = rng.random((30, 40)) + 0.3, rng.random((60, 40))
    single = [AcfTreesDetector().fit(X_pos, X_neg, seed=s, config=CrossvalConfig(
        recipe=RECIPES["elevation0"], acf_estimators=8, acf_stages=(8,))) for s in (5, 6)]
    both = AcfTreesDetector().fit(X_pos, X_neg, seed=5, config=CrossvalConfig(
        recipe=two, acf_estimators=8, acf_stages=(8,)))
    X = rng.random((25, 40))
    free = [AdaBoostTrees.from_arrays(*m.to_arrays()) for m in (*single, both)]
    for m in free:
        m.cascade_threshold = None
    np.testing.assert_allclose(free[2].decision_function(X),
                               (free[0].decision_function(X) + free[1].decision_function(X)) / 2,
                               rtol=1e-10, atol=1e-10)


def test_scaled_positives_are_the_crops_magnified_about_their_centres(toy):
    from benchmark.crops.features import person_windows, scale_about_centre, scaled_windows
    from benchmark.data import load_dataset
    from viewadapt.geometry import apply_homography

    # the window's centre stays, a point 40 rows below it lands 40 * 1.1 rows below
    H = scale_about_centre(1.0, 1.1)
    centre = np.array([[31.5, 63.5]])
    assert np.allclose(apply_homography(H, centre), centre)
    assert np.allclose(apply_homography(np.linalg.inv(H), centre + [0, 40]),
                       centre + [0, 44])
    ds = load_dataset(toy)
    plain = person_windows(ds, 0)
    taller = scaled_windows(plain, 1.0, 1.1)
    a, b = next(iter(plain.images(toy))), next(iter(taller.images(toy)))
    assert a.shape == b.shape and not np.array_equal(a, b)
    # row 107 of the taller window reads row 63.5 + 43.5 / 1.1 = 103.045 of the crop
    want = 0.955 * a[103].astype(float) + 0.045 * a[104].astype(float)
    assert np.abs(b[107].astype(float) - want).max() <= 2.0   # OpenCV's weights are 1/32ths
    assert np.abs(b[107].astype(float) - a[107]).max() > 20
    assert taller.key != plain.key and taller.key != scaled_windows(plain, 1.0, 0.9).key


def test_the_scaled_recipe_trains_on_three_versions_of_every_positive(toy):
    from benchmark.data import load_dataset
    from benchmark.frames.methods import source_training_windows, train_source_detectors

    r = RECIPES["scaled"]
    assert r.training_suffixes() == [("person", ""), ("person", "scale1x0.9"),
                                     ("person", "scale1x1.1"), ("background", "")]
    assert r.to_dict()["positive_scales"] == [[1.0, 0.9], [1.0, 1.1]]
    assert "positive_scales" not in RECIPES["averaged"].to_dict()  # older records unchanged
    assert recipe_from_record(r.to_dict()) is r
    ds = load_dataset(toy)
    pos, neg = source_training_windows(ds, "scaled")
    pos0, neg0 = source_training_windows(ds, "averaged")
    assert len(pos) == 3 * len(pos0) and len(neg) == len(neg0)
    assert all(np.array_equal(x, y) for x, y in zip(pos[:len(pos0)], pos0))
    scaled = train_source_detectors(ds, quick=True, frame_view="none", recipe="scaled")
    plain = train_source_detectors(ds, quick=True, frame_view="none", recipe="averaged")
    assert scaled.training["recipe"]["positive_scales"] == [[1.0, 0.9], [1.0, 1.1]]
    assert not np.allclose(scaled.hog_weights, plain.hog_weights)
    for bad in (((1.0, 1.0),), ((1.0, 0.0),), ((1.0, 1.1), (1.0, 1.1)), (1.0, 2.0)):
        with pytest.raises(ValueError, match="positive_scales"):
            Recipe("bad", "x", positive_scales=bad)


def test_a_scaled_window_warped_again_is_one_warp_through_both(toy):
    """The synthesised rows warp every training set into the target view, the scaled
    positives too: two warps of a cut-out window compose into one."""
    from benchmark.crops.features import person_windows, scale_about_centre, scaled_windows
    from benchmark.data import load_dataset
    from viewadapt.geometry import elevation_homography

    ds = load_dataset(toy)
    plain = person_windows(ds, 0)
    H = np.linalg.inv(elevation_homography(0.0, np.pi / 4))
    twice = scaled_windows(plain, 1.0, 1.1).warped(H, "synth")
    once = plain.warped(scale_about_centre(1.0, 1.1) @ H, "both")
    a, b = next(iter(twice.images(toy))), next(iter(once.images(toy)))
    assert np.array_equal(a, b) and twice.key != once.key
    with pytest.raises(ValueError, match="cut out first"):
        scaled_windows(plain, 1.0, 1.1).warped(H, "whole", crop_first=False)


def test_every_recipe_summary_reaches_the_help_as_written(capsys):
    """argparse %-formats help texts; a summary's own "%" must not be read as a format."""
    for argv in (["bench", "crossval", "--help"], ["bench", "sweep", "--help"]):
        with pytest.raises(SystemExit):
            main(argv)
        text = " ".join(capsys.readouterr().out.split())
        for r in RECIPES.values():
            assert f"{r.name}: {' '.join(r.summary.split())}" in text, r.name
        assert "option_strings" not in text
