"""The approximated ACF pyramid baseline (Dollár et al. 2014, "Fast Feature Pyramids for
Object Detection", TPAMI): real levels equal the exact pyramid's, approximated levels are
the resampled real level times the power law, detections and the `bench frames` method."""

import argparse
import json

import cv2
import numpy as np
import pytest

from benchmark.data import load_dataset
from benchmark.frames.methods import FrameMethods, load_frames, train_source_detectors
from benchmark.frames.pyramids import (
    ACF_PYRAMID_LAMBDAS, acf_fast_pyramid_levels, acf_pyramid_fast_detect, acf_pyramid_levels,
    dense_cascade_scores, dense_cascade_scores_reference,
)
from benchmark.frames.spec import DEFAULT_METHODS, FrameMethod
from viewadapt.detect import ACF_GRADIENT_LAMBDA, ACF_SHRINK, acf_frame_features
from tests.toy_frames import small_toy_frames


@pytest.fixture(scope="module")
def toy(tmp_path_factory):
    return small_toy_frames(tmp_path_factory.mktemp("tf") / "data")


@pytest.fixture(scope="module")
def frame(toy):
    return load_frames(toy)[0]


@pytest.fixture(scope="module")
def models(toy):
    return train_source_detectors(load_dataset(toy), quick=True)


def _raw_level(image, scale_frame_px):
    """Unsmoothed 4-px block means of the frame resized to ``scale`` (the exact pyramid's
    level size), (h, w, 10)."""
    h, w = image.shape[:2]
    W = int(round(w * scale_frame_px)) // 4 * 4
    H = int(round(h * scale_frame_px)) // 4 * 4
    level = cv2.resize(image, (W, H), interpolation=cv2.INTER_LINEAR)
    return acf_frame_features(level, [ACF_SHRINK], pad=0, smooth_channels=0).maps[ACF_SHRINK]


def test_real_levels_equal_the_exact_pyramid(frame):
    img = frame.image()
    exact = acf_pyramid_levels(img)
    fast = acf_fast_pyramid_levels(img)
    assert [lv.scale for lv in fast] == [lv.scale for lv in exact]
    assert [lv.real for lv in fast] == [k % 4 == 0 for k in range(len(exact))]
    assert sum(lv.real for lv in fast) >= 2
    for e, f in zip(exact, fast):
        assert f.channels.shape == e.channels.shape
        if f.real:
            np.testing.assert_array_equal(f.channels, e.channels)
        else:                               # approximated: close, not equal
            assert not np.array_equal(f.channels, e.channels)
            np.testing.assert_allclose(f.channels[:3].mean(), e.channels[:3].mean(), rtol=0.02)


def test_lambda_zero_nearest_gives_the_resampled_real_level(frame):
    img = frame.image()
    levels = acf_fast_pyramid_levels(img, lambdas=(0, 0, 0),
                                     interpolation=cv2.INTER_NEAREST_EXACT, smooth_channels=0)
    real = [k for k, lv in enumerate(levels) if lv.real]
    upsample = 4.0
    for k, lv in enumerate(levels):
        r = min(real, key=lambda j: (abs(j - k), j))        # nearest, ties to the larger
        if k % 4 in (1, 2):
            assert r == k - k % 4                           # from the larger real level
        raw = _raw_level(img, upsample * 2 ** (-r / 4))
        h, w = lv.channels.shape[1:]
        # OpenCV's pixel-centre nearest neighbour, one channel at a time
        expected = np.stack([cv2.resize(np.ascontiguousarray(raw[..., c]), (w, h),
                                        interpolation=cv2.INTER_NEAREST_EXACT)
                             for c in range(raw.shape[2])])
        np.testing.assert_array_equal(lv.channels, expected)


def test_power_law_scales_gradient_channels_only(frame):
    img = frame.image()
    lam = 0.3
    plain = acf_fast_pyramid_levels(img, lambdas=(0, 0, 0))
    scaled = acf_fast_pyramid_levels(img, lambdas=(0, lam, 2 * lam))
    real = [k for k, lv in enumerate(plain) if lv.real]
    for k, (p, s) in enumerate(zip(plain, scaled)):
        r = min(real, key=lambda j: (abs(j - k), j))
        ratio = 2 ** ((r - k) / 4)                  # s / s_r, 4 levels per octave
        np.testing.assert_array_equal(s.channels[:3], p.channels[:3])
        np.testing.assert_allclose(s.channels[3], p.channels[3] * ratio ** -lam, rtol=1e-5,
                                   atol=1e-6)
        np.testing.assert_allclose(s.channels[4:], p.channels[4:] * ratio ** (-2 * lam),
                                   rtol=1e-5, atol=1e-6)


def test_default_lambdas_are_the_measured_ones():
    assert ACF_PYRAMID_LAMBDAS == (0.0, ACF_GRADIENT_LAMBDA, ACF_GRADIENT_LAMBDA)


@pytest.mark.parametrize("kw, match", [(dict(lambdas=(0, 1)), "lambdas"),
                                       (dict(lambdas=(0, np.nan, 0)), "lambdas"),
                                       (dict(per_octave=0), "per_octave")])
def test_bad_parameters(frame, kw, match):
    with pytest.raises(ValueError, match=match):
        acf_fast_pyramid_levels(frame.image(), **kw)


def test_detections_by_decreasing_score(frame, models):
    det = acf_pyramid_fast_detect(frame.image(), models, threshold=-1e9)
    assert det.ndim == 2 and det.shape[1] == 5 and len(det) > 0
    assert np.all(np.diff(det[:, 4]) <= 0)
    assert np.all(det[:, 2:4] > 0)


def test_method_is_known_and_dispatched(frame, models):
    names = [m.name for m in DEFAULT_METHODS]
    assert names.index("acf_pyramid_fast") == names.index("acf_pyramid") + 1
    m = FrameMethod.parse("acf_pyramid_fast")
    assert (m.kind, m.how, m.rule, m.object_model, m.name) == (
        "acf", "pyramid_fast", None, None, "acf_pyramid_fast")
    with pytest.raises(ValueError, match="unknown method"):
        FrameMethod.parse("hog_pyramid_fast")
    fm = FrameMethods(frame.camera, models, thresholds={"hog": 0.0, "acf": -1e9})
    got = fm.detect(m, frame.image())
    np.testing.assert_array_equal(got, acf_pyramid_fast_detect(frame.image(), models,
                                                               threshold=-1e9,
                                                               vote=fm.adapted.box_voting))


def test_bench_frames_accepts_the_method(toy, models, tmp_path):
    import viewadapt.cli as cli

    parser = cli.build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    if "detect" not in sub.choices:
        from benchmark.frames.command import register

        register(sub, cli.common_parser())
    model = tmp_path / "models.npz"
    models.save(model)
    out = tmp_path / "out"
    args = parser.parse_args(["bench", "frames", "--data", str(toy), "--out", str(out),
                              "--quick", "--model", str(model), "--methods", "acf_pyramid",
                              "acf_pyramid_fast"])
    assert int(args.func(args) or 0) == 0
    curves = json.loads((out / "det_curves.json").read_text())
    assert "acf_pyramid_fast" in json.dumps(curves)
    summary = (out / "frames_summary.csv").read_text()
    assert "acf_pyramid_fast" in summary


def test_compiled_cascade_equals_the_numpy_reference(frame, models):
    C = acf_pyramid_levels(frame.image())[0].channels
    yy, xx = np.mgrid[0:C.shape[1] - 31, 0:C.shape[2] - 15]
    pos = np.stack([yy.ravel(), xx.ravel()], 1)
    got = dense_cascade_scores(models.acf, C, pos)
    np.testing.assert_array_equal(got, dense_cascade_scores_reference(models.acf, C, pos))
    assert dense_cascade_scores(models.acf, C, pos[:0]).shape == (0,)


def test_a_fold_method_is_the_adapted_detector_without_its_stage(frame, models):
    """``hog_adapted[fold]`` runs the registry's HOG without its per-window normalisation
    stage, on the same windows; ``hog_adapted`` keeps the stage."""
    from viewadapt.detect import FrameDetector, hog_kind

    fm = FrameMethods(frame.camera, models, thresholds={"hog": -1.0})
    staged, fold = FrameMethod.parse("hog_adapted"), FrameMethod.parse("hog_adapted[fold]")
    fm.prepare(fold)
    assert all(L.operator.stage is None
               for L in fm.detector("covariant", "plane", fold=True).operator("hog").layers)
    assert all(L.operator.stage is not None for L in fm.adapted.operator("hog").layers)
    img = frame.image()
    want = FrameDetector(frame.camera, models, thresholds={"hog": -1.0},
                         kinds={"hog": hog_kind(renorm=False)}).detect(img, "hog")
    np.testing.assert_array_equal(fm.detect(fold, img), want)
    np.testing.assert_array_equal(fm.detect(staged, img), fm.adapted.detect(img, "hog"))
    assert not np.array_equal(fm.detect(staged, img), want)
