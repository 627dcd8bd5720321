"""Nothing is ever unpickled from disk: the source detectors and the operator cache are
array files (npz + JSON metadata, read with allow_pickle=False), rebuilt only from the
project's own classes; a crafted pickle at either path runs nothing. Also the checks of a
calibration's K, R, t."""

import json
import pickle
import zipfile

import cv2
import numpy as np
import pytest

from viewadapt.boosting import AdaBoostTrees
from viewadapt.detect import FrameDetector
from viewadapt.geometry import camera_from_pose
from viewadapt.io import OperatorCache, SourceDetectors, read_calibration
from viewadapt.io.arrayfile import read_array_file, write_array_file
from viewadapt.version import __version__

SIZE = (192, 144)


class _Payload:
    """Unpickling it creates ``marker`` (what a crafted pickle could do with any code)."""

    def __init__(self, marker):
        self.marker = str(marker)

    def __reduce__(self):
        return (open, (self.marker, "w"))


def _write_payload(path, marker):
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(pickle.dumps(_Payload(marker)))
    assert not marker.exists()


def _main(argv, capsys):
    """``viewadapt`` with ``argv``: (exit code, stderr)."""
    from viewadapt.cli import main

    capsys.readouterr()
    rc = main(argv)
    return rc, capsys.readouterr().err


@pytest.fixture(scope="module")
def camera():
    return camera_from_pose(focal=200.0, principal_point=(95.5, 71.5), height=4.0,
                            tilt=np.radians(35), image_size=SIZE)


@pytest.fixture(scope="module")
def models():
    rng = np.random.default_rng(0)
    X = rng.normal(size=(300, 5120))
    y = (X[:, :40].sum(1) > 0).astype(int)
    acf = AdaBoostTrees(n_estimators=12, stages=None, max_bins=16, max_features=0.05,
                        random_state=0).fit(X, y)
    return SourceDetectors(rng.normal(size=(16, 8, 13)), 0.25, acf,
                           training={"seed": 0, "frame_view": "both", "quick": True})


@pytest.fixture(scope="module")
def files(camera, models, tmp_path_factory):
    """A saved model, a calibration file of ``camera`` and one frame of it."""
    d = tmp_path_factory.mktemp("safe")
    models.save(d / "source_detectors.npz")
    (d / "cam.json").write_text(json.dumps({"image_size": list(SIZE), "K": camera.K.tolist(),
                                            "R": camera.R.tolist(), "t": camera.t.tolist()}))
    rng = np.random.default_rng(3)
    img = cv2.GaussianBlur(rng.integers(0, 256, (SIZE[1], SIZE[0], 3), dtype=np.uint8),
                           (5, 5), 1.5)
    cv2.imwrite(str(d / "frame.png"), img)
    return d


@pytest.fixture(scope="module")
def frame(files):
    return cv2.imread(str(files / "frame.png"))[:, :, ::-1].copy()


def _one_line(msg):
    return "\n" not in str(msg).strip()


# ------------------------------------------------------------------ source detectors


def test_source_detectors_round_trip(models, files):
    path = files / "source_detectors.npz"
    assert path.read_bytes()[:4] == b"PK\x03\x04"         # a zip archive, not a pickle
    with np.load(path, allow_pickle=False) as z:          # every entry a plain array
        assert all(z[k].dtype != object for k in z.files)
    meta, _ = read_array_file(path, "viewadapt.source_detectors", 1, remedy="")
    assert meta["viewadapt"] == __version__ and meta["training"] == models.training
    back = SourceDetectors.load(path)
    assert np.array_equal(back.hog_weights, models.hog_weights)
    assert back.hog_weights.dtype == np.float64 and back.hog_bias == models.hog_bias
    assert back.training == models.training
    X = np.random.default_rng(1).normal(size=(500, 5120))
    assert np.array_equal(back.acf.decision_function(X), models.acf.decision_function(X))
    assert np.array_equal(back.acf.predict(X), models.acf.predict(X))
    assert back.acf.get_params() == models.acf.get_params()
    assert np.array_equal(back.acf.used_features_, models.acf.used_features_)
    assert back.fingerprint() == models.fingerprint()


def test_a_hog_only_model_file_detects_with_hog(camera, models, frame, tmp_path):
    # train_on_windows(acf_members=0) writes files without an ACF model; the HOG detector
    # must still run from them (its operator cache keys the models by their fingerprint)
    hog_only = SourceDetectors(models.hog_weights, models.hog_bias, None, {"acf_members": 0})
    hog_only.save(tmp_path / "hog_only.npz")
    back = SourceDetectors.load(tmp_path / "hog_only.npz")
    assert back.acf is None and back.fingerprint() == hog_only.fingerprint()
    assert back.fingerprint() != models.fingerprint()
    with_acf = FrameDetector(camera, models, cache_dir=tmp_path / "a").operator("hog")
    alone = FrameDetector(camera, back, cache_dir=tmp_path / "b").operator("hog")
    assert np.array_equal(alone.detect(frame, threshold=-1.0),
                          with_acf.detect(frame, threshold=-1.0))


def test_adaboost_arrays_are_checked(models):
    params, arrays = models.acf.to_arrays()
    json.dumps(params)                                    # JSON-ready
    again = AdaBoostTrees.from_arrays(params, arrays)
    assert np.array_equal(again.feature_, models.acf.feature_)
    with pytest.raises(ValueError, match="threshold_"):
        AdaBoostTrees.from_arrays(params, {k: v for k, v in arrays.items()
                                           if k != "threshold_"})
    bad = dict(arrays, feature_=np.where(arrays["feature_"] >= 0, 6000, -1))
    with pytest.raises(ValueError, match="outside"):
        AdaBoostTrees.from_arrays(params, bad)
    with pytest.raises(ValueError, match="unknown"):
        AdaBoostTrees.from_arrays(dict(params, evil="os.system"), arrays)


def test_a_pickled_model_file_is_never_loaded(files, tmp_path, capsys):
    marker = tmp_path / "pwned"
    for name in ("source_detectors.pkl", "source_detectors.npz"):
        evil = tmp_path / name
        _write_payload(evil, marker)
        with pytest.raises(ValueError, match="pickle") as err:
            SourceDetectors.load(evil)
        assert str(evil) in str(err.value) and _one_line(err.value)
        assert "viewadapt bench frames" in str(err.value)
        assert not marker.exists()
        out = tmp_path / f"out_{name}"
        rc, stderr = _main(["detect", "--calibration", str(files / "cam.json"), "--model",
                            str(evil), "--out", str(out), str(files / "frame.png")], capsys)
        assert rc == 2 and "pickle" in stderr and len(stderr.strip().splitlines()) == 1
        assert not marker.exists() and not out.exists()


def _model_entries(files):
    return read_array_file(files / "source_detectors.npz", "viewadapt.source_detectors", 1,
                           remedy="")


def test_damaged_or_foreign_model_files_give_one_line_errors(files, tmp_path, capsys):
    good = (files / "source_detectors.npz").read_bytes()
    meta, arrays = _model_entries(files)
    body = {k: v for k, v in meta.items() if k not in ("format", "format_version",
                                                        "viewadapt")}
    cases = {}
    cases["truncated"] = (good[:len(good) // 2], "cannot be read")
    cases["text"] = (b"hello", "not an .npz archive")
    np.save(tmp_path / "plain.npy", np.zeros(3))
    cases["npy"] = ((tmp_path / "plain.npy").read_bytes(), "not an .npz archive")
    write_array_file(tmp_path / "k.npz", "viewadapt.operator", 7, {}, {"x": np.zeros(2)})
    cases["kind"] = ((tmp_path / "k.npz").read_bytes(), "'viewadapt.operator'")
    write_array_file(tmp_path / "v.npz", "viewadapt.source_detectors", 2, body, arrays)
    cases["version"] = ((tmp_path / "v.npz").read_bytes(), "format version 2")
    write_array_file(tmp_path / "m.npz", "viewadapt.source_detectors", 1, body,
                     {k: v for k, v in arrays.items() if k != "hog_weights"})
    cases["missing"] = ((tmp_path / "m.npz").read_bytes(), "lacks the array 'hog_weights'")
    write_array_file(tmp_path / "a.npz", "viewadapt.source_detectors", 1, body,
                     {k: v for k, v in arrays.items() if k != "acf/value_"})
    cases["missing acf"] = ((tmp_path / "a.npz").read_bytes(), "value_")
    with zipfile.ZipFile(tmp_path / "z.npz", "w") as z:
        z.writestr("readme.txt", "not arrays")
    cases["zip"] = ((tmp_path / "z.npz").read_bytes(), "cannot be read|metadata")
    for name, (blob, match) in cases.items():
        p = tmp_path / "model.npz"
        p.write_bytes(blob)
        with pytest.raises(ValueError, match=match) as err:
            SourceDetectors.load(p)
        msg = str(err.value)
        assert _one_line(msg) and str(p) in msg and "viewadapt bench frames" in msg, name
    rc, stderr = _main(["detect", "--calibration", str(files / "cam.json"), "--model",
                        str(p), "--out", str(tmp_path / "o"), str(files / "frame.png")], capsys)
    assert rc == 2 and len(stderr.strip().splitlines()) == 1
    assert not (tmp_path / "o").exists()


# ------------------------------------------------------------------ the operator cache


@pytest.mark.parametrize("kind", ["hog", "acf"])
def test_a_cached_operator_scores_as_the_built_one(camera, models, frame, kind, tmp_path):
    d1 = FrameDetector(camera, models, cache_dir=tmp_path)
    built = d1.operator(kind)
    assert d1.cache_hit[kind] is False
    entries = list(tmp_path.iterdir())
    assert len(entries) == 1 and entries[0].name.startswith("operator-")
    assert entries[0].suffix == ".npz" and entries[0].read_bytes()[:4] == b"PK\x03\x04"
    d2 = FrameDetector(camera, models, cache_dir=tmp_path)
    loaded = d2.operator(kind)
    assert d2.cache_hit[kind] is True and type(loaded) is type(built)
    assert len(loaded.layers) == len(built.layers) == 2      # native and upsampled
    feats = built.frame_features(frame)
    assert np.array_equal(loaded.scores(loaded.frame_features(frame)), built.scores(feats))
    assert np.array_equal(loaded.detect(frame, threshold=-1.0),
                          built.detect(frame, threshold=-1.0))
    assert np.array_equal(loaded.snapped_homographies, built.snapped_homographies)
    for a, b in zip(loaded.layers, built.layers):
        assert a.factor == b.factor and a.rows == b.rows and np.array_equal(a.index, b.index)
        assert a.operator.features.func is b.operator.features.func
        assert a.operator.features.keywords == b.operator.features.keywords
        assert len(a.operator.groups) == len(b.operator.groups)
        for ga, gb in zip(a.operator.groups, b.operator.groups):
            assert (ga.cell_size, ga.prototype, ga.origin, ga.shape) == \
                (gb.cell_size, gb.prototype, gb.origin, gb.shape)
            assert np.array_equal(ga.members, gb.members)
            assert np.array_equal(ga.shifts, gb.shifts)
            if kind == "hog":
                assert np.array_equal(ga.template, gb.template)
            else:
                assert (ga.template != gb.template).nnz == 0
        if kind == "acf":
            assert np.array_equal(a.operator.gradient_factor, b.operator.gradient_factor)


def _key_parts(camera, models, kind, tmp_path):
    return FrameDetector(camera, models, cache_dir=tmp_path).cache_key(kind)


def test_a_pickled_cache_entry_is_a_miss_and_runs_nothing(files, models, tmp_path, capsys):
    cache_dir = tmp_path / "cache"
    cam = read_calibration(files / "cam.json")
    parts = _key_parts(cam, models, "hog", cache_dir)
    entry = OperatorCache(cache_dir).path(parts)         # exactly where detect will look
    marker = tmp_path / "pwned"
    _write_payload(entry, marker)
    out = tmp_path / "out"
    rc, stderr = _main(["detect", "--calibration", str(files / "cam.json"), "--model",
                        str(files / "source_detectors.npz"), "--cache", str(cache_dir),
                        "--out", str(out), str(files / "frame.png")], capsys)
    assert rc == 0, stderr
    assert not marker.exists()
    assert (out / "detections.csv").is_file()
    # the entry was rebuilt and overwritten (so the pickle sat at the key's own path)
    assert entry.read_bytes()[:4] == b"PK\x03\x04"
    assert OperatorCache(cache_dir).load(parts) is not None


def test_bad_or_old_cache_entries_are_misses(camera, models, frame, tmp_path):
    parts = _key_parts(camera, models, "hog", tmp_path)
    cache = OperatorCache(tmp_path)
    det = FrameDetector(camera, models, cache_dir=tmp_path)
    ref = det.operator("hog").scores(det.operator("hog").frame_features(frame))
    entry = cache.path(parts)
    good = entry.read_bytes()
    meta, arrays = read_array_file(entry, "viewadapt.operator", OperatorCache.VERSION,
                                   remedy="")
    body = {k: v for k, v in meta.items() if k not in ("format", "format_version",
                                                        "viewadapt")}
    bad = {"truncated": good[:len(good) // 3], "empty": b"",
           "pickle": pickle.dumps(np.zeros(3))}
    write_array_file(tmp_path / "x", "viewadapt.source_detectors", 1, body, arrays)
    bad["kind"] = (tmp_path / "x").read_bytes()
    write_array_file(tmp_path / "x", "viewadapt.operator", OperatorCache.VERSION + 1, body,
                     arrays)
    bad["future version"] = (tmp_path / "x").read_bytes()
    write_array_file(tmp_path / "x", "viewadapt.operator", OperatorCache.VERSION,
                     dict(body, key="0" * 24), arrays)
    bad["other key"] = (tmp_path / "x").read_bytes()
    write_array_file(tmp_path / "x", "viewadapt.operator", OperatorCache.VERSION, body,
                     {k: v for k, v in arrays.items() if not k.endswith("runs_starts")})
    bad["missing table"] = (tmp_path / "x").read_bytes()
    oob = dict(arrays)
    key = next(k for k in arrays if k.endswith("runs_starts"))
    oob[key] = arrays[key] + 10**9                        # would read outside the frame
    write_array_file(tmp_path / "x", "viewadapt.operator", OperatorCache.VERSION, body, oob)
    bad["out of range"] = (tmp_path / "x").read_bytes()
    klass = json.loads(json.dumps(body))
    klass["operator"]["class"] = "builtins.eval"
    write_array_file(tmp_path / "x", "viewadapt.operator", OperatorCache.VERSION, klass,
                     arrays)
    bad["foreign class"] = (tmp_path / "x").read_bytes()
    maker = json.loads(json.dumps(body))
    maker["operator"]["layers"][0]["operator"]["features"]["function"] = "system"
    write_array_file(tmp_path / "x", "viewadapt.operator", OperatorCache.VERSION, maker,
                     arrays)
    bad["foreign function"] = (tmp_path / "x").read_bytes()
    for name, blob in bad.items():
        entry.write_bytes(blob)
        assert cache.load(parts) is None, name
        again = FrameDetector(camera, models, cache_dir=tmp_path)
        op = again.operator("hog")                         # rebuilt, the entry overwritten
        assert again.cache_hit["hog"] is False, name
        assert np.array_equal(op.scores(op.frame_features(frame)), ref), name
        assert cache.load(parts) is not None, name


def test_only_operators_are_stored(tmp_path):
    with pytest.raises(ValueError, match="only the operators"):
        OperatorCache(tmp_path).save({"camera": 0}, np.zeros(3))
    assert not list(tmp_path.glob("operator-*"))


# ------------------------------------------------------------------ calibration K, R, t


def _calibration(camera, **change):
    d = {"image_size": list(SIZE), "K": camera.K.tolist(), "R": camera.R.tolist(),
         "t": camera.t.tolist()}
    d.update(change)
    return d


def _bad_calibrations(camera):
    K, R, t = camera.K, camera.R, camera.t

    def k(**entries):
        out = K.copy()
        for name, v in entries.items():
            out[int(name[1]), int(name[2])] = v
        return out.tolist()

    flip = np.diag([1.0, 1.0, -1.0])
    return {
        "negative focal lengths": (dict(K=k(k00=-274, k11=-274)),
                                   r"K has a negative focal length \(fx = -274\)"),
        "zero fy": (dict(K=k(k11=0)), r"zero focal length \(fy = 0\)"),
        "NaN in K": (dict(K=k(k02=float("nan"))), "K has non-finite"),
        "K not upper-triangular": (dict(K=k(k10=3)), r"K must be upper-triangular.*K\[1,0\]"),
        "K[2,2] zero": (dict(K=k(k22=0)), r"K\[2,2\] must be positive"),
        "principal point outside": (dict(K=k(k02=500)), "principal point.*outside"),
        "K of the wrong shape": (dict(K=[[200, 0, 95.5], [0, 200, 71.5]]), "K must be a 3x3"),
        "K not numbers": (dict(K="identity"), "K must be a 3x3"),
        "R not a rotation": (dict(R=(R * 1.01).tolist()), "R is not a rotation"),
        "R a reflection": (dict(R=(flip @ R).tolist()), "R has determinant -1"),
        "R infinite": (dict(R=np.where(np.eye(3) > 0, np.inf, R).tolist()), "R has non-finite"),
        "t of 2 values": (dict(t=[0.0, 1.0]), "t must be 3 numbers"),
        "t NaN": (dict(t=[0.0, float("nan"), 1.0]), "t has non-finite"),
        "centre below the ground": (dict(t=(-t).tolist()), "camera centre.*below the ground"),
        "image_size not numbers": (dict(image_size=["wide", 144]), "image_size"),
    }


@pytest.mark.parametrize("case", list(_bad_calibrations(
    camera_from_pose(focal=200.0, principal_point=(95.5, 71.5), height=4.0,
                     tilt=np.radians(35), image_size=SIZE))))
def test_bad_calibrations_are_refused_by_detect(case, camera, files, tmp_path, capsys):
    change, match = _bad_calibrations(camera)[case]
    calib = tmp_path / "cam.json"
    calib.write_text(json.dumps(_calibration(camera, **change)))
    with pytest.raises(ValueError, match=match) as err:
        read_calibration(calib)
    assert _one_line(err.value) and str(err.value).startswith(f"calibration {calib}:")
    out = tmp_path / "out"
    rc, stderr = _main(["detect", "--calibration", str(calib), "--model",
                        str(files / "source_detectors.npz"), "--out", str(out),
                        str(files / "frame.png")], capsys)
    assert rc == 2 and len(stderr.strip().splitlines()) == 1, stderr
    assert not out.exists()


def test_good_calibrations_keep_their_camera(camera, tmp_path):
    calib = tmp_path / "cam.json"
    calib.write_text(json.dumps(_calibration(camera)))
    cam = read_calibration(calib)
    assert np.array_equal(cam.K, camera.K) and np.array_equal(cam.R, camera.R)
    assert np.array_equal(cam.t, camera.t) and cam.image_size == SIZE
    # a homogeneous scale of K is divided out; R a hair off a rotation is made one
    noisy = camera.R + 1e-8 * np.random.default_rng(0).normal(size=(3, 3))
    calib.write_text(json.dumps(_calibration(camera, K=(2 * camera.K).tolist(),
                                             R=noisy.tolist())))
    cam = read_calibration(calib)
    assert np.allclose(cam.K, camera.K, rtol=0, atol=1e-12)
    assert np.allclose(cam.R @ cam.R.T, np.eye(3), rtol=0, atol=1e-12)
    assert np.allclose(cam.R, camera.R, rtol=0, atol=1e-7)
    # a skew is accepted (it is part of K like any other entry)
    K = camera.K.copy()
    K[0, 1] = 0.5
    calib.write_text(json.dumps(_calibration(camera, K=K.tolist())))
    assert read_calibration(calib).K[0, 1] == 0.5


@pytest.mark.parametrize("field, value, match", [
    ("tilt", "steep", r"tilt must be a number \(degrees below the horizontal\), got 'steep'"),
    ("height", None, r"height must be a number \(metres above the ground\)"),
    ("roll", "nan", r"roll must be finite \(degrees\)"),
    ("focal", ["wide", 300], r"focal must be a number \(pixels\), got 'wide'"),
])
def test_pose_form_fields_are_named_in_errors(field, value, match, tmp_path):
    d = {"image_size": [384, 288], "focal": 300, "height": 4.5, "tilt": 35}
    d[field] = value
    calib = tmp_path / "cam.json"
    calib.write_text(json.dumps(d))
    with pytest.raises(ValueError, match=match) as err:
        read_calibration(calib)
    assert _one_line(err.value) and str(err.value).startswith(f"calibration {calib}:")
