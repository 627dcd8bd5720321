"""The frames benchmark's methods as frozen specs: every name parses to its fields and back,
bad names and combinations are refused in one line, the predicates, the command line's
parsing and expansion, and the variant labels the cross-validation shares."""

import argparse
import dataclasses
import pickle

import pytest

from benchmark.frames.spec import (
    DEFAULT_METHODS, FRAME_METHODS, OBJECT_MODEL_TAGS, RULE_TAGS, FrameMethod, frame_method,
    variant_label,
)

#: every method name of ``bench frames`` -> (kind, how, rule, object model, upsample,
#: ground-plane filter, fold alone), as the benchmark documents them (adapted: each rule and
#: object model; the pyramids and OpenCV's detector on the 4x-upsampled frame, ``opencv_2x``
#: on the 2x one, ``opencv_native`` on the frame as it is; each pyramid also with the
#: filter; the adapted detectors with a normalisation stage also without it, on the plane)
EXPECTED = {
    "hog_adapted": ("hog", "adapted", "covariant", "plane", None, False, False),
    "hog_adapted[S only]": ("hog", "adapted", "none", "plane", None, False, False),
    "hog_adapted[paper eq.3]": ("hog", "adapted", "paper", "plane", None, False, False),
    "hog_adapted[body]": ("hog", "adapted", "covariant", "body", None, False, False),
    "hog_adapted[body, S only]": ("hog", "adapted", "none", "body", None, False, False),
    "hog_adapted[body, paper eq.3]": ("hog", "adapted", "paper", "body", None, False, False),
    "hog_warp": ("hog", "warp", None, None, None, False, False),
    "hog_pyramid": ("hog", "pyramid", None, None, 4, False, False),
    "acf_adapted": ("acf", "adapted", "covariant", "plane", None, False, False),
    "acf_adapted[S only]": ("acf", "adapted", "none", "plane", None, False, False),
    "acf_adapted[paper eq.3]": ("acf", "adapted", "paper", "plane", None, False, False),
    "acf_adapted[body]": ("acf", "adapted", "covariant", "body", None, False, False),
    "acf_adapted[body, S only]": ("acf", "adapted", "none", "body", None, False, False),
    "acf_adapted[body, paper eq.3]": ("acf", "adapted", "paper", "body", None, False, False),
    "acf_warp": ("acf", "warp", None, None, None, False, False),
    "acf_pyramid": ("acf", "pyramid", None, None, 4, False, False),
    "acf_pyramid_fast": ("acf", "pyramid_fast", None, None, 4, False, False),
    "opencv_adapted": ("opencv", "adapted", "covariant", "plane", None, False, False),
    "opencv_adapted[S only]": ("opencv", "adapted", "none", "plane", None, False, False),
    "opencv_adapted[paper eq.3]": ("opencv", "adapted", "paper", "plane", None, False, False),
    "opencv_adapted[body]": ("opencv", "adapted", "covariant", "body", None, False, False),
    "opencv_adapted[body, S only]": ("opencv", "adapted", "none", "body", None, False, False),
    "opencv_adapted[body, paper eq.3]": ("opencv", "adapted", "paper", "body", None, False, False),
    "opencv_warp": ("opencv", "warp", None, None, None, False, False),
    "daimler_adapted": ("daimler", "adapted", "covariant", "plane", None, False, False),
    "daimler_adapted[S only]": ("daimler", "adapted", "none", "plane", None, False, False),
    "daimler_adapted[paper eq.3]": ("daimler", "adapted", "paper", "plane", None, False, False),
    "daimler_adapted[body]": ("daimler", "adapted", "covariant", "body", None, False, False),
    "daimler_adapted[body, S only]": ("daimler", "adapted", "none", "body", None, False, False),
    "daimler_adapted[body, paper eq.3]":
        ("daimler", "adapted", "paper", "body", None, False, False),
    "daimler_warp": ("daimler", "warp", None, None, None, False, False),
    "opencv": ("opencv", "pyramid", None, None, 4, False, False),
    "opencv_2x": ("opencv", "pyramid", None, None, 2, False, False),
    "opencv_native": ("opencv", "pyramid", None, None, 1, False, False),
    "daimler": ("daimler", "pyramid", None, None, 4, False, False),
    "daimler_2x": ("daimler", "pyramid", None, None, 2, False, False),
    "daimler_native": ("daimler", "pyramid", None, None, 1, False, False),
    "hog_pyramid[ground]": ("hog", "pyramid", None, None, 4, True, False),
    "acf_pyramid[ground]": ("acf", "pyramid", None, None, 4, True, False),
    "acf_pyramid_fast[ground]": ("acf", "pyramid_fast", None, None, 4, True, False),
    "opencv[ground]": ("opencv", "pyramid", None, None, 4, True, False),
    "opencv_2x[ground]": ("opencv", "pyramid", None, None, 2, True, False),
    "opencv_native[ground]": ("opencv", "pyramid", None, None, 1, True, False),
    "daimler[ground]": ("daimler", "pyramid", None, None, 4, True, False),
    "daimler_2x[ground]": ("daimler", "pyramid", None, None, 2, True, False),
    "daimler_native[ground]": ("daimler", "pyramid", None, None, 1, True, False),
    "hog_adapted[fold]": ("hog", "adapted", "covariant", "plane", None, False, True),
    "hog_adapted[S only, fold]": ("hog", "adapted", "none", "plane", None, False, True),
    "hog_adapted[paper eq.3, fold]": ("hog", "adapted", "paper", "plane", None, False, True),
    "hog_adapted[body, fold]": ("hog", "adapted", "covariant", "body", None, False, True),
    "hog_adapted[body, S only, fold]": ("hog", "adapted", "none", "body", None, False, True),
    "hog_adapted[body, paper eq.3, fold]": ("hog", "adapted", "paper", "body", None, False, True),
    "opencv_adapted[fold]": ("opencv", "adapted", "covariant", "plane", None, False, True),
    "opencv_adapted[S only, fold]": ("opencv", "adapted", "none", "plane", None, False, True),
    "opencv_adapted[paper eq.3, fold]": ("opencv", "adapted", "paper", "plane", None, False, True),
    "daimler_adapted[fold]": ("daimler", "adapted", "covariant", "plane", None, False, True),
    "daimler_adapted[S only, fold]": ("daimler", "adapted", "none", "plane", None, False, True),
    "daimler_adapted[paper eq.3, fold]":
        ("daimler", "adapted", "paper", "plane", None, False, True),
}
#: the methods that score the candidate windows (and so move with their ground grid)
ON_GRID = {n for n in EXPECTED if "_adapted" in n or n.endswith("_warp")}
#: the methods that read no trained source detector
UNTRAINED = {n for n in EXPECTED if n.startswith(("opencv", "daimler"))}
FIELDS = ("kind", "how", "rule", "object_model", "upsample", "ground", "fold")


@pytest.mark.parametrize("name", list(EXPECTED))
def test_every_name_parses_to_its_fields_and_back(name):
    m = FrameMethod.parse(name)
    assert tuple(getattr(m, f) for f in FIELDS) == EXPECTED[name]
    assert m.name == name
    assert FrameMethod(*EXPECTED[name]) == m and hash(FrameMethod(*EXPECTED[name])) == hash(m)
    assert m.on_window_grid == (name in ON_GRID)
    assert m.needs_training == (name not in UNTRAINED)
    assert frame_method(name) == m and frame_method(m) is m
    assert pickle.loads(pickle.dumps(m)) == m          # joblib's workers get them pickled


def test_the_table_holds_every_method_once_and_the_defaults_in_order():
    assert [m.name for m in FRAME_METHODS] == list(EXPECTED)
    assert [m.name for m in DEFAULT_METHODS] == [
        "hog_adapted", "hog_warp", "hog_pyramid", "opencv", "acf_adapted", "acf_warp",
        "acf_pyramid", "acf_pyramid_fast"]


def test_defaults_fill_in_and_specs_are_frozen():
    assert FrameMethod("hog", "adapted") == FrameMethod.parse("hog_adapted")
    assert FrameMethod("acf", "adapted", object_model="body").name == "acf_adapted[body]"
    assert FrameMethod("hog", "pyramid").upsample == 4
    assert FrameMethod("opencv", "pyramid", upsample=1).name == "opencv_native"
    m = FrameMethod.parse("hog_adapted")
    with pytest.raises(dataclasses.FrozenInstanceError):
        m.rule = "paper"
    assert dataclasses.replace(m, rule="paper").name == "hog_adapted[paper eq.3]"
    assert FrameMethod.parse("acf_warp").detector.name == "acf"
    # OpenCV's detectMultiScale and its adapted detector read the same weights
    assert FrameMethod.parse("opencv").detector is FrameMethod.parse("opencv_warp").detector
    assert FrameMethod.parse("opencv").detector.name == "opencv"
    # a fold method's detector is its kind without the normalisation stage
    for k in ("hog", "opencv", "daimler"):
        staged, fold = FrameMethod.parse(f"{k}_adapted"), FrameMethod.parse(f"{k}_adapted[fold]")
        assert staged.detector.has_stage and not fold.detector.has_stage
        assert fold.detector.name == k and dataclasses.replace(staged, fold=True) == fold


@pytest.mark.parametrize("name", ["nonsense", "hog_pyramid_fast", "hog_adapted[cube]",
                                  "hog_adapted[single A]", "hog_warp[body]", "opencv_pyramid",
                                  "opencv_warp[body]", "acf_adapted[paper eq.3, body]", "hog", "",
                                  "acf_adapted[fold]", "opencv_adapted[body, fold]", "opencv_2x[fold]",
                                  "HOG_ADAPTED", None])
def test_a_bad_name_is_one_line_naming_the_choices(name):
    with pytest.raises(ValueError, match="unknown method") as err:
        FrameMethod.parse(name)
    msg = str(err.value)
    assert "\n" not in msg and repr(name) in msg
    assert all(n in msg for n in EXPECTED)


@pytest.mark.parametrize("fields", [
    ("opencv", "pyramid_fast"), ("opencv", "adapted", None, None, 2), ("hog", "pyramid_fast"), ("hog", "slide"), ("sift", "warp"),
    ("hog", "warp", "paper"), ("hog", "warp", None, "body"), ("hog", "adapted", "literal"),
    ("hog", "adapted", None, "cube"), ("hog", "adapted", None, None, 4),
    ("hog", "warp", None, None, 4), ("hog", "pyramid", "paper"),
    ("hog", "pyramid", None, None, 1), ("opencv", "pyramid", None, None, 3),
    ("hog", "adapted", None, None, None, True), ("opencv", "warp", None, None, None, True),
    ("opencv", "pyramid", None, None, 2, "yes"),
    ("acf", "adapted", None, None, None, False, True),
    ("opencv", "adapted", None, "body", None, False, True),
    ("hog", "warp", None, None, None, False, True),
    ("opencv", "pyramid", None, None, 2, False, True)])
def test_combinations_no_method_has_are_refused(fields):
    with pytest.raises(ValueError) as err:
        FrameMethod(*fields)
    assert "\n" not in str(err.value)


def test_the_tags_cover_the_rules_and_object_models():
    from viewadapt.objectmodel import OBJECT_MODELS
    from viewadapt.remap import ANGLE_RULES

    assert set(RULE_TAGS) == set(ANGLE_RULES) and set(OBJECT_MODEL_TAGS) == set(OBJECT_MODELS)
    assert variant_label("adapted") == variant_label("adapted", "covariant", "plane") == "adapted"
    assert variant_label("adapted", "paper", "body") == "adapted[body, paper eq.3]"
    assert variant_label("image warping", object_model="body") == "image warping[body]"
    assert variant_label("adapted", extra="single A") == "adapted[single A]"


def test_the_crops_variants_share_the_labels():
    from benchmark.crops.crossval import ADAPT_VARIANTS, EXACT_VARIANTS

    # the cross-validation's rows, in their order (its outputs list them so)
    assert list(ADAPT_VARIANTS.items()) == [
        ("adapted", ("covariant", True, "plane")),
        ("adapted[S only]", ("none", True, "plane")),
        ("adapted[paper eq.3]", ("paper", True, "plane")),
        ("adapted[single A]", ("covariant", False, "plane")),
        ("adapted[body]", ("covariant", True, "body")),
        ("adapted[body, S only]", ("none", True, "body")),
        ("adapted[body, paper eq.3]", ("paper", True, "body"))]
    assert EXACT_VARIANTS == {"exact geometry": ("covariant", "adapted"),
                              "exact geometry[paper eq.3]": ("paper", "adapted[paper eq.3]")}
    # each per-cell variant is a frames method of either detector, under the same label
    for label, (rule, per_cell, model) in ADAPT_VARIANTS.items():
        if per_cell:
            for kind in ("hog", "acf"):
                assert FrameMethod(kind, "adapted", rule, model).name == f"{kind}_{label}"


def _frames_parser():
    from viewadapt.cli import common_parser

    from benchmark.frames.command import register

    parser = argparse.ArgumentParser(prog="viewadapt")
    register(parser.add_subparsers(dest="command"), common_parser())
    return parser


def test_the_command_line_parses_methods_once(tmp_path, capsys):
    parser = _frames_parser()
    base = ["bench", "frames", "--data", str(tmp_path), "--out", str(tmp_path / "out")]
    args = parser.parse_args(base + ["--methods", "hog_adapted[body]", "opencv_native"])
    assert args.methods == [FrameMethod("hog", "adapted", object_model="body"),
                            FrameMethod("opencv", "pyramid", upsample=1)]
    with pytest.raises(SystemExit):
        parser.parse_args(base + ["--methods", "hog_adapted[cube]"])
    err = capsys.readouterr().err
    assert "unknown method 'hog_adapted[cube]'" in err and "hog_adapted[body]" in err


def test_expand_adapted():
    from benchmark.frames.spec import expand_adapted

    ms = [FrameMethod.parse(n) for n in ("hog_adapted", "hog_warp")]
    got = expand_adapted(ms, ["covariant", "paper"], ["plane", "body"])
    assert [m.name for m in got] == ["hog_adapted", "hog_adapted[paper eq.3]",
                                     "hog_adapted[body]", "hog_adapted[body, paper eq.3]",
                                     "hog_warp"]
    body = FrameMethod.parse("acf_adapted[body]")
    assert expand_adapted([body]) == [body]
    assert [m.name for m in expand_adapted([body], rules=["none"])] == ["acf_adapted[body, S only]"]
    assert [m.name for m in expand_adapted([body, body], object_models=["plane"])] == [
        "acf_adapted"]
    fold = FrameMethod.parse("hog_adapted[fold]")
    assert [m.name for m in expand_adapted([fold], ["paper"], ["plane", "body"])] == [
        "hog_adapted[paper eq.3, fold]", "hog_adapted[body, paper eq.3]"]
