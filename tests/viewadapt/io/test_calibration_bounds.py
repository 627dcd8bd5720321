"""Calibration files are read with bounds: a misspelled key is named with the closest known
one, a file over 1 MB is refused before it is read, YAML anchors and aliases (an alias bomb)
and nesting deeper than 16 levels are refused, in the project's YAML/JSON and in OpenCV
FileStorage and Tsai files alike; every refusal is one line naming the file."""

import json
import subprocess
import sys
import time

import cv2
import numpy as np
import pytest

from viewadapt.geometry import camera_from_pose
from viewadapt.io import read_calibration, read_distortion

SIZE = (384, 288)
POSE = "image_size: [384, 288]\nfocal: 300\nheight: 4.5\ntilt: 35\n"


@pytest.fixture(scope="module")
def camera():
    return camera_from_pose(focal=300.0, principal_point=(191.5, 143.5), height=4.5,
                            tilt=np.radians(35), image_size=SIZE)


def _error(path) -> str:
    """The one-line ValueError ``read_calibration(path)`` raises."""
    with pytest.raises(ValueError) as exc:
        read_calibration(path)
    msg = str(exc.value)
    assert len(msg.splitlines()) == 1 and str(path) in msg, msg
    assert len(msg) < 400, msg[:400]
    return msg


def _main(argv, capsys):
    from viewadapt.cli import main

    capsys.readouterr()
    rc = main(argv)
    return rc, capsys.readouterr().err


def _opencv_yaml(camera, extra=""):
    return ("%YAML:1.0\n---\nimage_width: 384\nimage_height: 288\n"
            "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ "
            + ", ".join(repr(float(v)) for v in camera.K.ravel()) + " ]\n"
            f"rvec: {cv2.Rodrigues(camera.R)[0].ravel().tolist()}\n"
            f"tvec: {camera.t.tolist()}\n" + extra)


# ------------------------------------------------------------------------------- keys


@pytest.mark.parametrize("text, wrong, right", [
    (POSE + "rol: 45\n", "rol", "roll"),
    (POSE.replace("focal:", "focall:"), "focall", "focal"),
    (POSE.replace("image_size:", "image_sise:"), "image_sise", "image_size"),
    (POSE + "principle_point: [191.5, 143.5]\n", "principle_point", "principal_point"),
    (POSE + "dsit: [0.1, 0, 0, 0]\n", "dsit", "dist"),
])
def test_a_misspelled_key_is_named_with_the_closest_known_one(text, wrong, right, tmp_path):
    path = tmp_path / "cam.yaml"
    path.write_text(text)
    assert _error(path) == (f"calibration {path}: unknown key {wrong!r} "
                            f"(did you mean {right!r}?)")
    with pytest.raises(ValueError, match="unknown key"):
        read_distortion(path)


def test_misspelled_matrix_keys_and_keys_without_a_match(camera, tmp_path):
    d = {"image_size": list(SIZE), "k": camera.K.tolist(), "R": camera.R.tolist(),
         "t": camera.t.tolist()}
    path = tmp_path / "cam.json"
    path.write_text(json.dumps(d))
    assert _error(path) == f"calibration {path}: unknown key 'k' (did you mean 'K'?)"
    d["K"] = d.pop("k")
    d["colour"] = "red"
    path.write_text(json.dumps(d))
    msg = _error(path)
    assert msg.startswith(f"calibration {path}: unknown key 'colour' (the keys read are ")
    for key in ("image_size", "K", "R", "t", "focal", "height", "tilt", "roll",
                "principal_point", "dist"):
        assert repr(key) in msg
    d["rol"] = 2
    path.write_text(json.dumps(d))
    assert "unknown keys 'colour', 'rol' (did you mean 'roll'?)" in _error(path)


def test_every_key_read_or_written_is_still_accepted(camera, tmp_path):
    full = {"image_size": list(SIZE), "K": camera.K.tolist(), "R": camera.R.tolist(),
            "t": camera.t.tolist(), "dist": [-0.1, 0.01, 0, 0, 0],
            "reprojection_error_px": 0.1, "camera_height_m": 4.5, "tilt_deg": 35.0,
            "focal": "estimated", "correspondences": 6}
    path = tmp_path / "cam.json"
    path.write_text(json.dumps(full))
    assert np.allclose(read_calibration(path).K, camera.K)
    assert read_distortion(path).tolist() == [-0.1, 0.01, 0, 0, 0]
    pose = {"image_size": list(SIZE), "focal": [300, 300], "principal_point": [191.5, 143.5],
            "height": 4.5, "tilt": 35, "roll": 0, "dist": None}
    path.write_text(json.dumps(pose))
    assert np.allclose(read_calibration(path).P, camera.P)


def test_detect_refuses_a_misspelled_key_in_one_line(tmp_path, capsys):
    path = tmp_path / "cam.yaml"
    path.write_text(POSE + "rol: 45\n")
    (tmp_path / "frame.png").write_bytes(b"")
    rc, err = _main(["detect", "--calibration", str(path), "--out", str(tmp_path / "out"),
                     str(tmp_path / "frame.png")], capsys)
    assert rc == 2 and err == (f"viewadapt detect: error: calibration {path}: unknown key "
                               "'rol' (did you mean 'roll'?)\n")
    assert not (tmp_path / "out").exists()


# ------------------------------------------------------------------------------ bounds


def test_a_file_over_1_mb_is_refused_before_it_is_read(tmp_path, monkeypatch):
    path = tmp_path / "cam.yaml"
    path.write_text(POSE + "# " + "x" * 2 ** 21 + "\n")          # valid, but 2 MB
    assert "is over the 1 MB a calibration file may have" in _error(path)
    huge = tmp_path / "huge.json"
    with open(huge, "wb") as fh:                                   # sparse: nothing written
        fh.write(b'{"image_size": "')
        fh.truncate(300 * 2 ** 20)
    import pathlib

    def never(*a, **k):
        raise AssertionError("the file was read")

    monkeypatch.setattr(pathlib.Path, "read_bytes", never)
    monkeypatch.setattr(pathlib.Path, "read_text", never)
    assert "300 MB is over the 1 MB" in _error(huge)


def _alias_bomb(levels: int) -> str:
    lines = ['a0: &a0 ["x", "x", "x", "x", "x", "x", "x", "x", "x"]']
    lines += [f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 9) + "]" for i in range(1, levels)]
    return "\n".join(lines) + "\n" + POSE.replace("[384, 288]", f"*a{levels - 1}")


def test_yaml_anchors_and_aliases_are_refused(tmp_path):
    bomb = tmp_path / "bomb.yaml"
    bomb.write_text(_alias_bomb(6))                  # 9^6 strings once the aliases expand
    t0 = time.perf_counter()
    msg = _error(bomb)
    assert time.perf_counter() - t0 < 2
    assert "YAML anchors and aliases" in msg and "are not read" in msg
    plain = tmp_path / "alias.yaml"
    plain.write_text("size: &s [384, 288]\n" + POSE.replace("[384, 288]", "*s"))
    assert "anchors and aliases (&s, line 1)" in _error(plain)
    with pytest.raises(ValueError, match="anchors and aliases"):
        read_distortion(plain)


@pytest.mark.parametrize("suffix", [".json", ".yaml"])
def test_deep_nesting_is_refused_in_one_line(suffix, tmp_path):
    path = tmp_path / f"cam{suffix}"
    for depth in (17, 100_000):
        nest = "[" * depth + "]" * depth
        text = (json.dumps({"image_size": [384, 288], "focal": 300, "height": 4.5, "tilt": 35})
                [:-1] + f', "dist": {nest}}}' if suffix == ".json" else POSE + f"dist: {nest}\n")
        path.write_text(text)
        msg = _error(path)
        assert "nested" in msg and "more than the 16" in msg, msg
        assert "recursion" not in msg
    deepest = "[" * 14 + "[384, 288]" + "]" * 14        # in the mapping: 16 levels, read
    path.write_text(POSE.replace("[384, 288]", deepest) if suffix == ".yaml" else
                    json.dumps({"image_size": json.loads(deepest), "focal": 300}))
    assert "image_size must be [width, height]" in _error(path)


def test_unparsable_yaml_is_one_line(tmp_path):
    path = tmp_path / "cam.yaml"
    path.write_text("image_size: [384, 288\nfocal: 300\n")
    msg = _error(path)
    assert "cannot be parsed" in msg and "line" in msg


# ------------------------------------------------------------ OpenCV FileStorage, Tsai


def test_opencv_filestorage_bounds(camera, tmp_path):
    """Aliases, deep nesting (YAML, JSON, XML: cv2.FileStorage crashes on it) and size.
    Run in a child process: before these bounds a deep file killed it."""
    good = tmp_path / "cam.yml"
    good.write_text(_opencv_yaml(camera))
    assert np.allclose(read_calibration(good).K, camera.K)
    d = 100_000
    cases = {
        "alias.yml": _opencv_yaml(camera, "a: &x [1, 2]\nb: *x\n"),
        "deep.yml": _opencv_yaml(camera, "deep: " + "[" * d + "]" * d + "\n"),
        "deep17.yml": _opencv_yaml(camera, "deep: " + "[" * 17 + "]" * 17 + "\n"),
        "deep.json": '{"image_width": 384, "x": ' + "[" * d + "]" * d + "}",
        "deep.xml": ('<?xml version="1.0"?>\n<opencv_storage>' + "<a>" * d + "</a>" * d
                     + "</opencv_storage>\n"),
        "big.yml": _opencv_yaml(camera, "# " + "x" * 2 ** 21 + "\n"),
    }
    for name, text in cases.items():
        (tmp_path / name).write_text(text)
    code = ("import sys\nfrom viewadapt.io import read_calibration\n"
            "for p in sys.argv[1:]:\n"
            "    try:\n        read_calibration(p)\n        print('READ', p)\n"
            "    except ValueError as e:\n        print(str(e).replace('\\n', ' | '))\n")
    r = subprocess.run([sys.executable, "-c", code] + [str(tmp_path / n) for n in cases],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, (r.returncode, r.stderr[-2000:])
    lines = r.stdout.splitlines()
    assert len(lines) == len(cases), r.stdout
    want = ["anchors and aliases", "nested", "nested", "nested 100001 levels", "nested",
            "is over the 1 MB"]
    for line, name, w in zip(lines, cases, want):
        assert str(tmp_path / name) in line and w in line and " | " not in line, (name, line)


def test_tsai_bounds(tmp_path):
    big = tmp_path / "View_001.xml"
    big.write_text('<?xml version="1.0"?>\n<Camera name="x">\n<!-- ' + "x" * 2 ** 21
                   + " -->\n</Camera>\n")
    assert "is over the 1 MB a calibration file may have" in _error(big)
    deep = tmp_path / "View_002.xml"
    deep.write_text('<?xml version="1.0"?>\n<Camera>' + "<a>" * 40 + "</a>" * 40 + "</Camera>")
    assert "XML nested" in _error(deep)


def test_one_bounded_reader_for_every_input():
    """Boxes, calibrations and imports share the guarded readers of viewadapt.io.bounded."""
    from viewadapt.io import boxes, bounded, calibration, imports

    for name in ("read_limited_text", "parse_json", "parse_xml", "json_depth"):
        assert getattr(imports, name) is getattr(bounded, name)
    assert boxes.parse_json is bounded.parse_json
    assert boxes.read_limited_text is bounded.read_limited_text
    assert calibration.parse_yaml is bounded.parse_yaml


def test_bounded_yaml_and_json_helpers(tmp_path):
    from viewadapt.io.bounded import check_yaml, parse_json, parse_yaml

    assert parse_yaml("a: [1, {b: 2}]\n", "x.yaml", max_depth=3) == {"a": [1, {"b": 2}]}
    with pytest.raises(ValueError, match=r"x.yaml: YAML nested more than the 2 levels read"):
        parse_yaml("a: [1, {b: 2}]\n", "x.yaml", max_depth=2)
    with pytest.raises(ValueError, match=r"x.yaml: YAML anchors and aliases \(\*a, line 2\)"):
        parse_yaml("- 1\n- *a\n", "x.yaml")
    with pytest.raises(ValueError, match="x.json: JSON nested 3 levels deep, more than the 2"):
        parse_json("[[[1]]]", "x.json", max_depth=2)
    assert check_yaml("%YAML:1.0\n---\nm: !!opencv-matrix\n  rows: 1\n", "x.yml", 16)
    assert not check_yaml("%YAML:1.0\n---\nm: [\n", "x.yml", 16)        # PyYAML cannot read
    with pytest.raises(ValueError, match="anchors and aliases"):
        check_yaml("%YAML:1.0\n---\na: &x 1\nb: *x\n", "x.yml", 16)
