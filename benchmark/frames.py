"""Full-frame detection on calibrated surveillance frames: methods, evaluation, runtime.

Frame contract: see :mod:`benchmark.toyframes` (``frames_coco.json`` with the calibration
in every image entry). Calibration files for users' footage: :func:`read_calibration`.

Methods (Wang et al. 2017, Sec. 5.2 and Table 1), all on the same frames:

``hog_adapted`` / ``acf_adapted``
    the viewpoint-adapted detectors over world-space windows (:mod:`viewadapt.fullframe`);
``hog_warp`` / ``acf_warp``
    every candidate window warped into the canonical view, then featurised and classified
    (Li et al. 2008; Algorithm 1);
``hog_pyramid`` / ``acf_pyramid``
    the unadapted source detectors slid over an image pyramid of the 4x-upsampled frame
    (the paper's set-up for small people);
``opencv``
    ``cv2.HOGDescriptor.detectMultiScale`` with OpenCV's default people detector on the
    4x-upsampled frame (``opencv_native``: on the frame as it is).
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from viewadapt.boosting import cascade_step
from viewadapt.geometry import WINDOW_HEIGHT, WINDOW_WIDTH, Camera, camera_from_pose
from viewadapt.windows import PERSON_BOX_WINDOW

__all__ = ["OperatorCache", "FrameRecord", "load_frames", "read_calibration", "SourceDetectors",
           "train_source_detectors", "FRAME_VIEW_CHOICES", "DEFAULT_FRAME_VIEW", "METHODS",
           "FrameDetector",
           "standardize_boxes", "evaluate_method", "PAPER_FPS"]

#: Table 1 of the paper: frames per second on one Intel Core i7 core, CAVIAR 384x288.
PAPER_FPS = {"hog_pyramid": 0.439, "acf_pyramid": 3.54, "hog_warp": 0.0666,
             "acf_warp": 0.0419, "hog_adapted": 11.8, "acf_adapted": 10.7}
PAPER_WINDOWS = 31603
METHODS = ("hog_adapted", "hog_warp", "hog_pyramid", "opencv", "acf_adapted", "acf_warp",
           "acf_pyramid")


# ------------------------------------------------------------------------------- input


@dataclass
class FrameRecord:
    """One calibrated frame and its ground truth.

    ``gt`` is (G, 4) full boxes ``(x, y, w, h)``; ``occlusion`` (G,) hidden fractions.
    """

    path: Path
    image_id: int
    scene_id: str
    camera: Camera
    gt: np.ndarray
    occlusion: np.ndarray

    def image(self) -> np.ndarray:
        from .data import read_image

        return read_image(self.path)


def _camera_from_entry(entry, where):
    try:
        size = (int(entry["width"]), int(entry["height"]))
        return Camera(np.asarray(entry["K"], float), np.asarray(entry["R"], float),
                      np.asarray(entry["t"], float).reshape(3), size)
    except KeyError as exc:
        raise ValueError(f"{where}: image entry lacks {exc.args[0]!r} (frames need their "
                         "calibration K, R, t and width, height)") from None


def load_frames(root) -> list:
    """Read ``root/frames_coco.json`` into :class:`FrameRecord` s (files checked)."""
    root = Path(root)
    path = root / "frames_coco.json"
    if not path.is_file():
        raise FileNotFoundError(f"{root} has no frames_coco.json: it holds no surveillance "
                                "frames (generate a preset with frames, or the toy set)")
    from .data import read_json

    coco = read_json(path)
    by_image = {}
    for a in coco.get("annotations", []):
        if a.get("category_id", 1) != 1 or a.get("iscrowd", 0):
            continue
        by_image.setdefault(a["image_id"], []).append(a)
    frames = []
    for entry in coco.get("images", []):
        p = root / entry["file_name"]
        if not p.is_file():
            raise FileNotFoundError(f"{root}: frame {entry['file_name']} is listed in "
                                    "frames_coco.json but missing")
        cam = _camera_from_entry(entry, path)
        anns = by_image.get(entry["id"], [])
        gt = np.array([a["bbox"] for a in anns], float).reshape(-1, 4)
        occ = np.array([float(a.get("occlusion", 0.0)) for a in anns])
        frames.append(FrameRecord(p, int(entry["id"]), str(entry.get("scene_id", "")), cam,
                                  gt, occ))
    if not frames:
        raise ValueError(f"{path} lists no images")
    return frames


def read_calibration(path) -> Camera:
    """A camera from a YAML or JSON calibration file.

    Format (either form; lengths in metres, angles in degrees, pixels for focal and
    principal point)::

        image_size: [384, 288]        # width, height (required)
        K: [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]
        R: [[...], [...], [...]]      # world -> camera rotation, world Z up, ground Z = 0
        t: [tx, ty, tz]               # x_cam = R X + t (OpenCV convention)

    or::

        image_size: [384, 288]
        focal: 300                    # or [fx, fy]
        principal_point: [191.5, 143.5]   # optional, default the image centre
        height: 4.5                   # camera height above the ground
        tilt: 35                      # degrees below horizontal
        roll: 0                       # optional, degrees
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"calibration file {path} does not exist")
    text = path.read_text()
    try:
        if path.suffix.lower() == ".json":
            d = json.loads(text)
        else:
            try:
                import yaml
            except ImportError:
                raise ValueError(f"{path}: reading YAML needs PyYAML (pip install pyyaml); "
                                 "or write the calibration as JSON") from None
            d = yaml.safe_load(text)
    except ValueError as exc:
        if "PyYAML" in str(exc):
            raise
        raise ValueError(f"{path} cannot be parsed: {exc}") from None
    except Exception as exc:  # yaml raises its own error types
        raise ValueError(f"{path} cannot be parsed: {exc}") from None
    if not isinstance(d, dict):
        raise ValueError(f"{path}: expected a mapping with K, R, t or focal, height, tilt")
    if "image_size" not in d:
        raise ValueError(f"{path}: image_size [width, height] is missing")
    size = tuple(int(v) for v in d["image_size"])
    if all(k in d for k in ("K", "R", "t")):
        return Camera(np.asarray(d["K"], float), np.asarray(d["R"], float),
                      np.asarray(d["t"], float).reshape(-1), size)
    if all(k in d for k in ("focal", "height", "tilt")):
        pp = d.get("principal_point", ((size[0] - 1) / 2, (size[1] - 1) / 2))
        tilt = float(d["tilt"])
        if not 0 <= tilt < 90:              # reported in the degrees the file is written in
            raise ValueError(f"{path}: tilt must lie in [0, 90) degrees below the horizontal, "
                             f"got {tilt:g}")
        return camera_from_pose(focal=d["focal"], principal_point=pp, height=float(d["height"]),
                                tilt=np.radians(tilt),
                                roll=np.radians(float(d.get("roll", 0.0))), image_size=size)
    raise ValueError(f"{path}: give either K, R, t or focal, height, tilt")


# -------------------------------------------------------------------------------- cache


def read_boxes(path, frame_paths) -> dict:
    """Ground-truth person boxes of a user's frames, from CSV or COCO JSON.

    CSV: a header with ``frame, x, y, w, h`` (pixels, top-left corner and size) and
    optionally ``occlusion`` (hidden fraction, 0..1); ``frame`` is the frame's file name or
    path. COCO: ``images`` with ``id`` and ``file_name``, ``annotations`` with ``image_id``
    and ``bbox`` ``[x, y, w, h]`` (and optionally ``occlusion``). Frames are matched by file
    name; a frame without boxes has no persons.

    Returns
    -------
    dict file name -> ((G, 4) boxes, (G,) occlusion)
    """
    import pandas as pd

    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"boxes file {path} does not exist")
    names = {Path(p).name for p in frame_paths}
    try:
        if path.suffix.lower() == ".json":
            d = json.loads(path.read_text())
            files = {im["id"]: Path(im["file_name"]).name for im in d["images"]}
            rows = [(files[a["image_id"]], *a["bbox"], float(a.get("occlusion", 0.0)))
                    for a in d["annotations"]]
            df = pd.DataFrame(rows, columns=["frame", "x", "y", "w", "h", "occlusion"])
        else:
            df = pd.read_csv(path)
            missing = {"frame", "x", "y", "w", "h"} - set(df.columns)
            if missing:
                raise ValueError(f"lacks the columns {sorted(missing)} (need frame, x, y, w, h"
                                 "[, occlusion])")
            if "occlusion" not in df.columns:
                df["occlusion"] = 0.0
            df["frame"] = [Path(str(f)).name for f in df["frame"]]
    except (KeyError, TypeError, json.JSONDecodeError, pd.errors.ParserError) as exc:
        raise ValueError(f"{path}: not a boxes CSV or COCO file ({exc})") from None
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None
    vals = df[["x", "y", "w", "h", "occlusion"]].to_numpy(np.float64)
    if not np.all(np.isfinite(vals)) or (vals[:, 2:4] <= 0).any():
        raise ValueError(f"{path}: boxes need finite x, y and positive w, h")
    if len(df) and not set(df["frame"]) & names:
        raise ValueError(f"{path}: none of its frames ({', '.join(sorted(set(df['frame']))[:3])}"
                         f" ...) is among the frames given")
    out = {}
    for n in names:
        d = df[df["frame"] == n]
        out[n] = (d[["x", "y", "w", "h"]].to_numpy(np.float64).reshape(-1, 4),
                  d["occlusion"].to_numpy(np.float64))
    return out


#: default size limit of an operator cache directory, GiB (one paper camera's ACF operator
#: is about 45 MB, so a 13-camera run with both detectors holds about 0.8 GB per model)
DEFAULT_CACHE_LIMIT_GB = 2.0


def check_cache_limit(limit_gb):
    """``limit_gb`` if it is None or a finite number >= 0, else ValueError."""
    if limit_gb is not None and not (np.isfinite(limit_gb) and limit_gb >= 0):
        raise ValueError(f"the cache limit must be >= 0 GB, got {limit_gb}")
    return limit_gb


class OperatorCache:
    """Adapted operators on disk, keyed by (calibration, model, parameters).

    The key is a hash of the camera's ``K, R, t`` and image size, the model's fingerprint,
    the window and operator parameters and the library version, so a changed calibration
    or model never reuses a stale operator. Files are written atomically.

    ``limit_gb`` caps the directory's operators: after each save the least recently used
    ones (by modification time; a load refreshes it) are deleted until the rest fit, never
    the one just written. ``None`` or 0: no limit.
    """

    #: bump whenever what an operator holds or computes changes (2: ACF gradient rows
    #: scaled by s ** lambda, gather tables, G without explicit zeros; 3: block-normalised
    #: HOG cells with texture channels; 4: the "runs" tables, no CSR matrix stored; 5: one
    #: copy of the HOG templates, in the run tables)
    VERSION = 5

    def __init__(self, directory, limit_gb: float | None = DEFAULT_CACHE_LIMIT_GB):
        self.dir = Path(directory)
        self.limit = int(check_cache_limit(limit_gb) * 2**30) if limit_gb else None

    def key(self, parts: dict) -> str:
        import hashlib

        from viewadapt import __version__

        blob = json.dumps({"v": self.VERSION, "viewadapt": __version__, **parts},
                          sort_keys=True, default=lambda o: np.asarray(o).tolist())
        return hashlib.sha256(blob.encode()).hexdigest()[:24]

    def path(self, parts: dict) -> Path:
        return self.dir / f"operator-{self.key(parts)}.pkl"

    def load(self, parts: dict):
        import pickle

        p = self.path(parts)
        try:
            op = pickle.loads(p.read_bytes())
        except Exception:       # missing (or evicted by another process), truncated, foreign
            return None
        try:
            p.touch()           # recently used: evicted last
        except OSError:
            pass
        return op

    def save(self, parts: dict, operator) -> Path:
        import os
        import pickle
        import tempfile

        self.dir.mkdir(parents=True, exist_ok=True)
        p = self.path(parts)
        fd, tmp = tempfile.mkstemp(dir=self.dir, prefix=".tmp-", suffix=".pkl")
        try:
            with os.fdopen(fd, "wb") as fh:
                pickle.dump(operator, fh, protocol=pickle.HIGHEST_PROTOCOL)
            os.replace(tmp, p)
        except BaseException:   # a full disk: no half-written file left behind
            Path(tmp).unlink(missing_ok=True)
            raise
        self.evict(keep=p)
        return p

    def evict(self, keep=None) -> list:
        """Delete the least recently used operators until the directory's fit the limit
        (never ``keep``); return the deleted paths."""
        if self.limit is None:
            return []
        files = []
        for f in self.dir.glob("operator-*.pkl"):
            try:
                st = f.stat()
            except FileNotFoundError:               # evicted meanwhile by another process
                continue
            files.append((st.st_mtime, st.st_size, f))
        total = sum(size for _, size, _ in files)
        gone = []
        for _, size, f in sorted(files, key=lambda t: t[0]):
            if total <= self.limit:
                break
            if keep is not None and f == Path(keep):
                continue
            f.unlink(missing_ok=True)
            total -= size
            gone.append(f)
        return gone


# ----------------------------------------------------------------------------- training


@dataclass
class SourceDetectors:
    """Detectors trained on source-view (elevation 0) crops."""

    hog_weights: np.ndarray       # (16, 8, 13): viewadapt.fullframe.hog_window_features
    hog_bias: float
    acf: object                   # AdaBoostTrees
    #: how they were trained (seed, frame_view, ...); empty for models saved before it existed
    training: dict = field(default_factory=dict)

    def save(self, path):
        import pickle

        Path(path).write_bytes(pickle.dumps(self))

    @staticmethod
    def load(path) -> "SourceDetectors":
        import pickle

        p = Path(path)
        if not p.is_file():
            raise FileNotFoundError(f"model file {p} does not exist")
        obj = pickle.loads(p.read_bytes())
        if not isinstance(obj, SourceDetectors):
            raise ValueError(f"{p} is not a model written by `viewadapt bench frames`")
        from viewadapt.fullframe import HOG_WEIGHT_SHAPE

        if np.shape(obj.hog_weights) != HOG_WEIGHT_SHAPE:
            raise ValueError(f"{p} holds HOG weights of shape {np.shape(obj.hog_weights)}, "
                             f"not {HOG_WEIGHT_SHAPE}: it was trained on an older "
                             "version's features; retrain it with `viewadapt bench frames`")
        if not hasattr(obj, "training"):
            obj.training = {}
        return obj

    def fingerprint(self) -> str:
        import hashlib

        h = hashlib.sha256(np.asarray(self.hog_weights, np.float64).tobytes())
        h.update(np.float64(self.hog_bias).tobytes())
        for a in (self.acf.feature_, self.acf.threshold_, self.acf.value_):
            h.update(np.ascontiguousarray(a).tobytes())
        return h.hexdigest()[:16]


#: ``frame_view`` choices of :func:`train_source_detectors`: which detectors also train on
#: frame-view copies of the crops.
FRAME_VIEW_CHOICES = ("hog", "acf", "both", "none")
#: Both detectors train on the copies: over four training seeds adapted ACF was better with
#: them on 7 of 8 seed-and-set runs (README, "Accuracy").
DEFAULT_FRAME_VIEW = "both"


def train_source_detectors(ds, *, seed: int = 0, quick: bool = False, source_index: int = 0,
                           progress: bool = False,
                           frame_view: str = DEFAULT_FRAME_VIEW) -> SourceDetectors:
    """Linear SVM on :func:`viewadapt.fullframe.hog_window_features` and ACF boosted trees,
    trained on the dataset's crops of one elevation (default the first, 0).

    ``frame_view`` (``"hog"``, ``"acf"``, ``"both"`` or ``"none"``) says which detectors
    also see one frame-view copy of every crop (:func:`viewadapt.frameview.frame_view_copies`):
    the crop as the adapted full-frame detector reads it from a frame, at a random person
    height of 24-144 px and a random offset against the frame's cell grid. Same crops, no
    target data. On the 104 paper-preset frames the copies lowered adapted HOG's LAMR from
    0.656 to 0.620 (seed 0); over seeds 0-3 they lowered adapted ACF's mean LAMR from 0.597
    to 0.508 there and from 0.492 to 0.360 on the 9 small-preset frames (README,
    "Accuracy", finding 5). The default is ``"both"`` (:data:`DEFAULT_FRAME_VIEW`).
    """
    from viewadapt.boosting import AdaBoostTrees
    from viewadapt.classifiers import LinearSVMDetector
    from viewadapt.fullframe import HOG_WEIGHT_SHAPE, acf_window_features, hog_window_features

    from .features import background_windows, person_windows

    if frame_view not in FRAME_VIEW_CHOICES:
        raise ValueError(f"frame_view must be one of {FRAME_VIEW_CHOICES}, got {frame_view!r}")
    pos = list(person_windows(ds, source_index).images(ds.root))
    neg = list(background_windows(ds, source_index, stride=16).images(ds.root))
    # left-right mirrored crops double the positives (Dalal & Triggs)
    pos = pos + [np.ascontiguousarray(w[:, ::-1]) for w in pos]

    def training_set(features, kind, copy_seed):
        Xp = np.stack([features(w).ravel() for w in pos])
        Xn = np.stack([features(w).ravel() for w in neg])
        if frame_view in (kind, "both"):
            from viewadapt.frameview import frame_view_copies

            kw = dict(kind=kind, upsample_below=UPSAMPLE_BELOW)
            Xp = np.vstack([Xp, frame_view_copies(pos, seed=copy_seed, **kw)])
            Xn = np.vstack([Xn, frame_view_copies(neg, seed=copy_seed + 1, **kw)])
        return np.vstack([Xp, Xn]), np.r_[np.ones(len(Xp), int), np.zeros(len(Xn), int)]

    X, y = training_set(hog_window_features, "hog", seed)
    # C = 0.01 as Dalal & Triggs (block-normalised, clipped cells as their descriptor)
    svm = LinearSVMDetector(C=0.01, initial_negatives=2000 if quick else 5000,
                            mining_rounds=1, random_state=seed).fit(X, y)
    # the channels the full-frame operator reads (float32 OpenCV path)
    X, y = training_set(acf_window_features, "acf", seed + 2)
    n_trees = 64 if quick else 256
    trees = AdaBoostTrees(n_estimators=n_trees, stages=None, max_bins=32 if quick else 64,
                          max_features=0.25 if quick else 0.125, random_state=seed)
    trees.fit(X, y)
    return SourceDetectors(svm.coef_[0].reshape(HOG_WEIGHT_SHAPE).astype(np.float64),
                           float(svm.intercept_[0]), trees,
                           training=dict(seed=seed, frame_view=frame_view, quick=quick,
                                         source_index=source_index,
                                         crops=len(pos) // 2, background_windows=len(neg)))


# ------------------------------------------------------------------------------ methods


def _window_person_boxes(H):
    from viewadapt.windows import person_boxes

    return person_boxes(H)


#: Windows of persons smaller than ``96 * UPSAMPLE_BELOW`` px (48 px) read the frame
#: upsampled 2x (:func:`viewadapt.fullframe.build_multiresolution_operator`). Chosen on the
#: 26 paper-preset frames (templates grouped over all windows in that experiment), adapted
#: LAMR with the frame upsampled below s = 0 (never) / 0.35 / 0.5 / 0.7 / everywhere:
#: HOG/SVM 0.683 / 0.649 / 0.617 / 0.630 / 0.643, ACF 0.691 / 0.669 / 0.646 / 0.648 /
#: 0.633; checked on the 78 frames rendered after them (README, "Accuracy").
UPSAMPLE_BELOW = 0.5


class FrameDetector:
    """All methods for one camera: windows and adapted operators built once.

    Parameters
    ----------
    camera : Camera
    models : SourceDetectors
    person_heights : sequence of float
    cache_dir : path or None
        Where :class:`OperatorCache` keeps the adapted operators.
    cache_limit_gb : float or None
        That directory's size limit (least recently used operators go first); None or 0:
        no limit.
    """

    def __init__(self, camera, models, *, person_heights=(1.75,), cache_dir=None,
                 cache_limit_gb: float | None = DEFAULT_CACHE_LIMIT_GB,
                 tolerance: float = 0.5, cells_per_source_cell: float = 0.7,
                 upsample_below: float = UPSAMPLE_BELOW,
                 threshold_hog: float = -1.0, threshold_acf: float = -1.0):
        from viewadapt.windows import select_candidate_windows

        self.camera = camera
        self.models = models
        self.size = tuple(camera.image_size)
        self.params = dict(person_heights=tuple(float(h) for h in person_heights),
                           tolerance=float(tolerance),
                           cells_per_source_cell=float(cells_per_source_cell),
                           upsample_below=float(upsample_below))
        self.thr = {"hog": threshold_hog, "acf": threshold_acf}
        self.cache_dir = cache_dir
        self.cache_limit_gb = cache_limit_gb
        self.windows = select_candidate_windows(camera, self.size,
                                                person_heights=self.params["person_heights"])
        self._ops = {}
        self.build_seconds = {}
        self.cache_hit = {}

    # adapted operators, cached on disk
    def operator(self, kind: str):
        if kind in self._ops:
            return self._ops[kind]
        t0 = time.perf_counter()
        key_parts = dict(camera=self.camera.to_dict(), kind=kind,
                         model=self.models.fingerprint(), **self.params)
        cache = OperatorCache(self.cache_dir, self.cache_limit_gb) if self.cache_dir else None
        op = cache.load(key_parts) if cache else None
        self.cache_hit[kind] = op is not None
        if op is None:
            op = self._build(kind)
            if cache:
                cache.save(key_parts, op)
        self.build_seconds[kind] = time.perf_counter() - t0
        self._ops[kind] = op
        return op

    def _build(self, kind):
        from viewadapt.fullframe import (
            build_adapted_linear_operator, build_adapted_trees_operator,
            build_multiresolution_operator,
        )

        kw = dict(tolerance=self.params["tolerance"],
                  cells_per_source_cell=self.params["cells_per_source_cell"])
        if kind == "hog":
            def build(w):
                return build_adapted_linear_operator(w, self.models.hog_weights,
                                                     self.models.hog_bias, **kw)
        elif kind == "acf":
            # ACF cells are sized on 4-px blocks, HOG's on 8-px cells: the same pixel
            # tolerance is twice as many ACF cells
            kw["tolerance"] = 2 * kw["tolerance"]

            def build(w):
                return build_adapted_trees_operator(w, self.models.acf, **kw)
        else:
            raise ValueError(f"unknown operator kind {kind!r}")
        return build_multiresolution_operator(self.windows, build,
                                              upsample_below=self.params["upsample_below"])

    def detect(self, method: str, image) -> np.ndarray:
        """(D, 5) detections ``(x, y, w, h, score)`` of ``method`` on ``image``."""
        from viewadapt.fullframe import _check_frame

        _check_frame(image, self.size)
        if method == "hog_adapted":
            return self.operator("hog").detect(image, threshold=self.thr["hog"])
        if method == "acf_adapted":
            return self.operator("acf").detect(image, threshold=self.thr["acf"])
        if method in ("hog_warp", "acf_warp"):
            s = warp_scores(image, self.windows.homographies, self.models, method[:3])
            return _nms(_window_person_boxes(self.windows.homographies), s,
                        self.thr[method[:3]], method[:3])
        if method == "hog_pyramid":
            return hog_pyramid_detect(image, self.models, threshold=self.thr["hog"])
        if method == "acf_pyramid":
            return acf_pyramid_detect(image, self.models, threshold=self.thr["acf"])
        if method == "opencv":
            return opencv_detect(image, upsample=4)
        if method == "opencv_native":
            return opencv_detect(image, upsample=1)
        raise ValueError(f"unknown method {method!r}; choose from {METHODS}")


def _nms(boxes, scores, thr, kind):
    from viewadapt.fullframe import detections_from_scores

    if kind == "acf":
        return detections_from_scores(boxes, scores, threshold=thr, nms_threshold=0.65,
                                      overlap="min")
    return detections_from_scores(boxes, scores, threshold=thr, nms_threshold=0.5)


def warp_scores(image, homographies, models, kind, *, chunk: int = 512) -> np.ndarray:
    """Image warping (Li et al. 2008): every window warped to 64x128, featurised, scored."""
    from viewadapt.fullframe import acf_window_features, hog_window_features
    from viewadapt.warp import warp_to_source_view

    out = np.empty(len(homographies))
    for a in range(0, len(homographies), chunk):
        Hs = homographies[a:a + chunk]
        wins = [warp_to_source_view(image, H) for H in Hs]
        if kind == "hog":
            X = np.stack([hog_window_features(w).ravel() for w in wins]).astype(np.float64)
            out[a:a + len(Hs)] = X @ models.hog_weights.ravel() + models.hog_bias
        else:
            X = np.stack([acf_window_features(w).ravel() for w in wins]).astype(np.float64)
            out[a:a + len(Hs)] = models.acf.decision_function(X)
    return out


def _pyramid_scales(size, upsample, step, min_height=WINDOW_HEIGHT):
    w, h = size
    scales = []
    s = float(upsample)
    while h * s >= min_height and w * s >= WINDOW_WIDTH:
        scales.append(s)
        s /= step
    return scales


def _level_boxes(cy, cx, cell, scale):
    """Person boxes of windows whose top-left cell is (cy, cx) at a pyramid level."""
    x0, y0, x1, y1 = PERSON_BOX_WINDOW
    left = cx * cell + x0                  # level pixel coordinates
    top = cy * cell + y0
    # level pixel (u) -> frame pixel: (u + 0.5) / scale - 0.5
    bx = (left + 0.5) / scale - 0.5
    by = (top + 0.5) / scale - 0.5
    return np.stack([bx, by, np.full_like(bx, (x1 - x0) / scale),
                     np.full_like(by, (y1 - y0) / scale)], 1)


def hog_pyramid_detect(image, models, *, upsample: int = 4, step: float = 1.05,
                       threshold: float = 0.0) -> np.ndarray:
    """The unadapted HOG/SVM slid over an image pyramid of the upsampled frame.

    Every level's block-normalised 8-px cells (:func:`viewadapt.fullframe.hog_frame_features`)
    are cross-correlated with the (16, 8, 13) weights; windows at a one-cell stride.
    """
    import cv2

    from viewadapt.fullframe import channel_slices3, correlate_slices, hog_frame_features

    h, w = image.shape[:2]
    T = np.asarray(models.hog_weights, np.float32)
    T3 = channel_slices3(T)
    boxes, scores = [], []
    for s in _pyramid_scales((w, h), upsample, step):
        level = cv2.resize(image, (int(round(w * s)), int(round(h * s))),
                           interpolation=cv2.INTER_LINEAR)
        F = hog_frame_features(level, [8], pad=0).maps[8]
        if F.shape[0] < 16 or F.shape[1] < 8:
            continue
        res = correlate_slices(channel_slices3(F), T3) + models.hog_bias
        cy, cx = np.nonzero(res > threshold)
        if cy.size:
            boxes.append(_level_boxes(cy, cx, 8, level.shape[1] / w))
            scores.append(res[cy, cx])
    if not boxes:
        return np.zeros((0, 5))
    return _nms(np.concatenate(boxes), np.concatenate(scores).astype(float), threshold, "hog")


def _trees_dense(model, C, positions, block=32):
    """Soft-cascade scores of windows read straight from an ACF channel map.

    ``C`` (10, h, w) channels, ``positions`` (n, 2) top-left blocks ``(y, x)``; feature
    ``f`` of the (10, 32, 16) layout is ``C[ch, y + i, x + j]``.
    """
    ch, ii, jj = np.unravel_index(np.arange(10 * 32 * 16), (10, 32, 16))
    feat, thr_, val = model.feature_, model.threshold_, model.value_
    depth = (feat.shape[1] + 1).bit_length() - 2
    n = positions.shape[0]
    score = np.zeros(n)
    alive = np.arange(n)
    casc = model.cascade_threshold
    for t0 in range(0, feat.shape[0], block):
        if alive.size == 0:
            break
        t1 = min(feat.shape[0], t0 + block)
        trees = np.arange(t1 - t0)[None, :]
        node = np.zeros((alive.size, t1 - t0), np.intp)
        py, px = positions[alive, 0][:, None], positions[alive, 1][:, None]
        for _ in range(depth):
            f = feat[t0:t1][trees, node]
            fi = np.maximum(f, 0)
            v = C[ch[fi], py + ii[fi], px + jj[fi]]
            go = v >= thr_[t0:t1][trees, node]
            node = np.where(f >= 0, 2 * node + 1 + go, node)
        score[alive], stopped = cascade_step(score[alive], val[t0:t1][trees, node], casc)
        alive = alive[~stopped]
    return score


def acf_pyramid_detect(image, models, *, upsample: int = 4, per_octave: int = 4,
                       threshold: float = 0.0) -> np.ndarray:
    """The unadapted ACF detector over an image pyramid of the upsampled frame.

    Channels computed at every level (``per_octave`` levels per octave; the toolbox uses 8
    with power-law approximations between real levels), windows at a one-block (4 px)
    stride, the soft cascade reading features straight from the channel maps.
    """
    import cv2

    from viewadapt.fullframe import ACF_SHRINK, acf_frame_features

    h, w = image.shape[:2]
    boxes, scores = [], []
    for s in _pyramid_scales((w, h), upsample, 2 ** (1 / per_octave)):
        W, H = int(round(w * s)) // 4 * 4, int(round(h * s)) // 4 * 4
        level = cv2.resize(image, (W, H), interpolation=cv2.INTER_LINEAR)
        # the channels the detector was trained on (acf_window_features), whole level
        C = np.moveaxis(acf_frame_features(level, [ACF_SHRINK], pad=0).maps[ACF_SHRINK], -1, 0)
        ny, nx = C.shape[1] - 32 + 1, C.shape[2] - 16 + 1
        if ny < 1 or nx < 1:
            continue
        yy, xx = np.mgrid[0:ny, 0:nx]
        pos = np.stack([yy.ravel(), xx.ravel()], 1)
        sc = _trees_dense(models.acf, C, pos)
        keep = sc > threshold
        if keep.any():
            boxes.append(_level_boxes(pos[keep, 0], pos[keep, 1], 4, W / w))
            scores.append(sc[keep])
    if not boxes:
        return np.zeros((0, 5))
    return _nms(np.concatenate(boxes), np.concatenate(scores), threshold, "acf")


def opencv_detect(image, *, upsample: int = 4, hit_threshold: float = -0.5) -> np.ndarray:
    """``cv2.HOGDescriptor.detectMultiScale`` with the default people detector.

    Grouping off (``groupThreshold=0``) so that every window's score feeds our NMS and the
    DET curve; boxes mapped back to the frame and shrunk to the person (OpenCV's windows
    have the INRIA 16-px margins).
    """
    import cv2

    hog = cv2.HOGDescriptor()
    hog.setSVMDetector(cv2.HOGDescriptor_getDefaultPeopleDetector())
    img = image if upsample == 1 else cv2.resize(
        image, (image.shape[1] * upsample, image.shape[0] * upsample),
        interpolation=cv2.INTER_LINEAR)
    rects, weights = hog.detectMultiScale(np.ascontiguousarray(img[:, :, ::-1]),
                                          hitThreshold=hit_threshold, winStride=(8, 8),
                                          padding=(0, 0), scale=1.05, groupThreshold=0)
    if len(rects) == 0:
        return np.zeros((0, 5))
    r = np.asarray(rects, float) / upsample
    s = r[:, 3] / WINDOW_HEIGHT
    x0, y0, x1, y1 = PERSON_BOX_WINDOW
    boxes = np.stack([r[:, 0] + (x0 + 0.5) * s, r[:, 1] + (y0 + 0.5) * s, (x1 - x0) * s,
                      (y1 - y0) * s], 1)
    return _nms(boxes, np.asarray(weights, float).ravel(), hit_threshold, "hog")


# --------------------------------------------------------------------------- evaluation


def standardize_boxes(boxes, aspect: float = 0.41) -> np.ndarray:
    """Boxes resized to ``width = aspect * height`` about their centre (Caltech ``dbEval``)."""
    b = np.asarray(boxes, float).reshape(-1, boxes.shape[-1] if np.ndim(boxes) == 2 else 4)
    out = b.copy()
    if len(b):
        cx = b[:, 0] + b[:, 2] / 2
        out[:, 2] = aspect * b[:, 3]
        out[:, 0] = cx - out[:, 2] / 2
    return out


def ground_truth_rows(frame: FrameRecord, *, min_height: float = 24.0,
                      max_occlusion: float = 0.5) -> np.ndarray:
    """(G, 5) ``(x, y, w, h, ignore)``: too small, too occluded or cut by the border ->
    ignore."""
    gt = standardize_boxes(frame.gt) if len(frame.gt) else np.zeros((0, 4))
    w, h = frame.camera.image_size
    ign = np.zeros(len(gt), bool)
    if len(gt):
        ign |= frame.gt[:, 3] < min_height
        ign |= frame.occlusion > max_occlusion
        ign |= (frame.gt[:, 0] < 1) | (frame.gt[:, 1] < 1) | \
            (frame.gt[:, 0] + frame.gt[:, 2] > w - 1) | (frame.gt[:, 1] + frame.gt[:, 3] > h - 1)
    return np.c_[gt, ign.astype(float)]


def evaluate_method(detections, frames, **kw) -> dict:
    """Miss rate vs FPPI and LAMR (:func:`viewadapt.metrics.evaluate_frames`)."""
    from viewadapt.metrics import evaluate_frames

    dts = [np.c_[standardize_boxes(d[:, :4]), d[:, 4]] if len(d) else np.zeros((0, 5))
           for d in detections]
    gts = [ground_truth_rows(f, **kw) for f in frames]
    return evaluate_frames(dts, gts)
