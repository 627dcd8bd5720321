"""Full-frame detection on calibrated surveillance frames: methods, evaluation, runtime.

Frame contract: see :mod:`benchmark.toyframes` (``frames_coco.json`` with the calibration
in every image entry). Calibration files for users' footage:
:func:`viewadapt.io.read_calibration`.

Methods (Wang et al. 2017, Sec. 5.2 and Table 1), all on the same frames:

``hog_adapted`` / ``acf_adapted``
    the viewpoint-adapted detectors over world-space windows
    (:class:`viewadapt.detect.FrameDetector`); ``hog_adapted[body, paper eq.3]`` and the
    other adapted variants: the same with another angle rule or object model;
``hog_warp`` / ``acf_warp``
    every candidate window warped into the canonical view, then featurised and classified
    (Li et al. 2008; Algorithm 1);
``hog_pyramid`` / ``acf_pyramid``
    the unadapted source detectors slid over an image pyramid of the 4x-upsampled frame
    (the paper's set-up for small people), features computed at every level;
``acf_pyramid_fast``
    the ACF pyramid as Dollár's toolbox computes it: channels exact at one level per
    octave, power-law approximated in between (Dollár et al. 2014, "Fast Feature Pyramids
    for Object Detection"); :mod:`benchmark.frames.pyramids` holds the pyramid code;
``opencv``
    ``cv2.HOGDescriptor.detectMultiScale`` with OpenCV's default people detector on the
    4x-upsampled frame (``opencv_2x``: 2x; ``opencv_native``: on the frame as it is);
    ``opencv_adapted`` / ``opencv_warp``: the same detector adapted, or over warped windows;
``daimler``
    the same with OpenCV's 48x96 Daimler detector (``daimler_2x``, ``daimler_native``,
    ``daimler_adapted``, ``daimler_warp``);
``...[ground]``
    a pyramid whose boxes pass the ground-plane filter (:func:`ground_plane_filter`): the
    calibration used without adaptation.

Each method is a :class:`benchmark.frames.spec.FrameMethod`, its name parsed once where it
enters.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from benchmark.frames.pyramids import (
    ACF_PYRAMID_LAMBDAS, acf_pyramid_detect, acf_pyramid_fast_detect, hog_pyramid_detect,
    kind_nms, pyramid_scales,
)
from benchmark.frames.phases import shifted_frame, unshifted_boxes
from benchmark.frames.spec import frame_method
from benchmark.recipes import DEFAULT_RECIPE
from viewadapt.detect import (
    DEFAULT_FRAME_VIEW, FrameDetector, HOG_DETECTOR, PERSON_BOX_WINDOW, PRETRAINED_KINDS,
    check_frame, check_frame_view, detector_kind, person_boxes, train_on_windows,
)
from viewadapt.geometry import WINDOW_HEIGHT, Camera
from viewadapt.io import SourceDetectors

__all__ = ["FrameRecord", "load_frames", "train_source_detectors", "source_training_windows",
           "dataset_provenance",
           "FrameMethods",
           "evaluate_method", "PAPER_FPS", "warp_scores", "pyramid_scales", "hog_pyramid_detect",
           "acf_pyramid_detect", "acf_pyramid_fast_detect", "ACF_PYRAMID_LAMBDAS", "opencv_detect",
           "GROUND_FILTER_TOLERANCE", "ground_plane_filter"]

#: Table 1 of the paper: frames per second on one Intel Core i7 core, CAVIAR 384x288.
#: ``acf_pyramid_fast`` is what the paper timed as the ACF pyramid (Dollár's toolbox, fast
#: feature pyramids), so it carries the same reference.
PAPER_FPS = {"hog_pyramid": 0.439, "acf_pyramid": 3.54, "acf_pyramid_fast": 3.54,
             "hog_warp": 0.0666,
             "acf_warp": 0.0419, "hog_adapted": 11.8, "acf_adapted": 10.7}
PAPER_WINDOWS = 31603


# ------------------------------------------------------------------------------- input


@dataclass
class FrameRecord:
    """One calibrated frame and its ground truth.

    ``gt`` is (G, 4) full boxes ``(x, y, w, h)``; ``occlusion`` (G,) hidden fractions;
    ``ground`` (G, 3) the persons' ground positions in metres (None when the frames do not
    record them); ``dist`` the camera's OpenCV lens coefficients (None: a pinhole frame).
    """

    path: Path
    image_id: int
    scene_id: str
    camera: Camera
    gt: np.ndarray
    occlusion: np.ndarray
    ground: np.ndarray | None = None
    dist: np.ndarray | None = None

    def image(self) -> np.ndarray:
        from benchmark.data import read_image

        return read_image(self.path)


def _camera_from_entry(entry, where):
    try:
        size = (int(entry["width"]), int(entry["height"]))
        return Camera(np.asarray(entry["K"], float), np.asarray(entry["R"], float),
                      np.asarray(entry["t"], float).reshape(3), size)
    except KeyError as exc:
        raise ValueError(f"{where}: image entry lacks {exc.args[0]!r} (frames need their "
                         "calibration K, R, t and width, height)") from None


def _ground_positions(anns):
    """(G, 3) ground positions of a frame's annotations: the generator's
    ``ground_position`` or the toy frames' ``ground_xy``; None if any lacks both."""
    out = []
    for a in anns:
        g = a.get("ground_position", a.get("ground_xy"))
        if g is None:
            return None
        out.append((list(g) + [0.0])[:3])
    return np.array(out, float).reshape(-1, 3)


def load_frames(root) -> list:
    """Read ``root/frames_coco.json`` into :class:`FrameRecord` s (files checked)."""
    root = Path(root)
    path = root / "frames_coco.json"
    if not path.is_file():
        raise FileNotFoundError(f"{root} has no frames_coco.json: it holds no surveillance "
                                "frames (generate a preset with frames, or the toy set)")
    from benchmark.data import read_json

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
        ground = _ground_positions(anns)
        dist = None
        if entry.get("dist") is not None:           # the frame as the lens made it
            from viewadapt.camera.distortion import check_distortion
            try:
                dist = check_distortion(entry["dist"])
            except ValueError as exc:
                raise ValueError(f"{path}: image {entry['file_name']}: dist: {exc}") from None
            if not np.any(dist):
                dist = None
        frames.append(FrameRecord(p, int(entry["id"]), str(entry.get("scene_id", "")), cam,
                                  gt, occ, ground, dist))
    if not frames:
        raise ValueError(f"{path} lists no images")
    return frames


# ----------------------------------------------------------------------------- training


def train_source_detectors(ds, *, seed: int = 0, quick: bool = False, source_index: int = 0,
                           progress: bool = False,
                           frame_view: str = DEFAULT_FRAME_VIEW,
                           recipe=DEFAULT_RECIPE, extra_negatives=(),
                           svm_params=None, acf: bool = True) -> SourceDetectors:
    """Linear SVM on :func:`viewadapt.detect.hog_window_features` and ACF boosted trees
    (:func:`viewadapt.detect.train_on_windows`), trained on the dataset's crops of one
    elevation (default the first, 0) and its background windows.

    ``frame_view`` (``"hog"``, ``"acf"``, ``"both"`` or ``"none"``) says which detectors
    also see one frame-view copy of every crop (:func:`viewadapt.detect.frame_view_copies`):
    the crop as the adapted full-frame detector reads it from a frame, at a random person
    height of 24-144 px and a random offset against the frame's cell grid. Same crops, no
    target data (their measured effect: docs/findings.md). The default is ``"both"``
    (:data:`DEFAULT_FRAME_VIEW`).

    ``recipe`` (a :class:`benchmark.recipes.Recipe` or its name): the window sets the
    detectors train on (:meth:`~benchmark.recipes.Recipe.training_sets`: the crops, the
    background windows, the negatives the recipe adds, through its camera effects if any).
    The models' ``training`` records it.

    ``extra_negatives``: further :class:`~benchmark.crops.features.WindowSet` s of
    negatives (e.g. rectified windows of rendered frames), read from the dataset's root
    and added as they are (no recipe treatment); the training record counts them by key.

    ``svm_params``: the HOG/SVM's parameters instead of the defaults
    (:func:`viewadapt.detect.training.hog_svm`), e.g. ``{"C": 0.001}``.

    ``acf=False``: the HOG/SVM alone (the models' ``acf`` is None), as it would be trained
    beside the trees -- for studies that vary the HOG/SVM only.
    """
    from benchmark.recipes import get_recipe

    check_frame_view(frame_view)
    recipe = get_recipe(recipe)
    if recipe.svm_c is not None:
        svm_params = {"C": recipe.svm_c} | dict(svm_params or {})
    pos, neg = source_training_windows(ds, recipe, source_index)
    n_background = len(neg)
    extra = {}
    for ws in extra_negatives:
        neg.extend(ws.images(ds.root))
        extra[ws.key] = len(ws)
    models = train_on_windows(pos, neg, seed=seed, quick=quick, frame_view=frame_view,
                              svm_params=svm_params,
                              acf_members=recipe.acf_members if acf else 0)
    # train_on_windows' record (seed, SVM parameters, ACF members, ...), with what only
    # this function knows; the background windows counted without the extra negatives
    training = dict(models.training, source_index=source_index, recipe=recipe.to_dict(),
                    background_windows=n_background, dataset=dataset_provenance(ds))
    if extra:
        training["extra_negatives"] = extra
    return replace(models, training=training)


def source_training_windows(ds, recipe=DEFAULT_RECIPE,
                            source_index: int = 0) -> tuple[list, list]:
    """``(positives, negatives)``: the 64x128 windows :func:`train_source_detectors` trains
    on -- the dataset's crops of elevation ``source_index`` and its background windows
    (stride 16), as the recipe (:class:`benchmark.recipes.Recipe` or its name) gives them."""
    from benchmark.crops.features import background_windows, person_windows
    from benchmark.recipes import get_recipe

    pos, neg = [], []
    for kind, _, ws in get_recipe(recipe).training_sets(
            person_windows(ds, source_index), background_windows(ds, source_index, stride=16)):
        (pos if kind == "person" else neg).extend(ws.images(ds.root))
    return pos, neg


def dataset_provenance(ds) -> dict:
    """What a model was trained on: the dataset's preset, seed, renderer, elevations and
    content hash (from its ``dataset.json``), its fingerprint, and the generator's camera
    effects setting (``camera_effects``, only for a dataset rendered through one)."""
    cfg = ds.config
    out = {"preset": cfg.get("preset"), "seed": cfg.get("seed"),
           "renderer": cfg.get("renderer"), "elevations": cfg.get("elevations"),
           "content_hash": (cfg.get("content_hash") or {}).get("sha256"),
           "fingerprint": ds.fingerprint}
    effects = cfg.get("camera_effects")
    if isinstance(effects, dict) and effects.get("name"):
        out["camera_effects"] = effects["name"]
    return out


# ------------------------------------------------------------------------------ methods


class FrameMethods:
    """Every method of the frames benchmark on one camera: the adapted detectors of
    :class:`viewadapt.detect.FrameDetector` (one per angle rule and object model asked
    for) and the baselines, on the same windows.

    Parameters are those of :class:`~viewadapt.detect.FrameDetector` (without ``rule``,
    ``object_model`` and ``stage``: each adapted method names its own), and ``frame_shift``
    (``(dx, dy)``, whole pixels >= 0): the pyramids (ours and OpenCV's) slide their windows
    over the frame moved that far (:func:`benchmark.frames.phases.shifted_frame`), their
    boxes mapped back before the ground-plane filter -- where their own window grid falls,
    as ``grid_phase`` says where the candidate windows' ground grid does (the methods on the
    candidate windows do not see the shift). One instance is one phase of both grids.
    """

    def __init__(self, camera, models, *, frame_shift=(0, 0), **kw):
        shift = tuple(int(v) for v in frame_shift)
        if len(shift) != 2 or min(shift) < 0:
            raise ValueError(f"a frame shift is two whole pixels >= 0, got {frame_shift!r}")
        self.frame_shift = shift
        self.adapted = FrameDetector(camera, models, **kw)
        self.models = models
        self._camera, self._kw = camera, kw
        self._variants = {("covariant", "plane", not self.adapted.stage): self.adapted}
        self._undistortion = None

    @property
    def windows(self):
        """The candidate windows every method scores (the adapted detector's)."""
        return self.adapted.windows

    @property
    def thr(self) -> dict:
        """Score threshold per detector kind (the adapted detector's)."""
        return self.adapted.thresholds

    def detector(self, rule: str = "covariant", object_model: str = "plane",
                 fold: bool = False) -> FrameDetector:
        """The :class:`FrameDetector` of one angle rule and object model (made on first use,
        on the same windows); ``fold``: without the normalisation stages (``stage=False``)."""
        key = (rule, object_model, bool(fold))
        if key not in self._variants:
            self._variants[key] = FrameDetector(self._camera, self.models, rule=rule,
                                                object_model=object_model,
                                                **dict(self._kw, stage=not fold))
        return self._variants[key]

    def prepare(self, method) -> None:
        """Build (or load) the adapted operator of ``method`` (a
        :class:`~benchmark.frames.spec.FrameMethod` or its name) now: the offline step, not
        timed per frame; nothing for the other methods."""
        m = frame_method(method)
        if m.how == "adapted":
            self.detector(m.rule, m.object_model, m.fold).operator(m.kind)

    def detect(self, method, image) -> np.ndarray:
        """(D, 5) detections ``(x, y, w, h, score)`` of ``method`` (a
        :class:`~benchmark.frames.spec.FrameMethod` or its name) on ``image``; a pyramid's
        on the frame moved by :attr:`frame_shift`, in the frame's own pixels."""
        check_frame(image, self.adapted.size)
        m = frame_method(method)
        kind = m.detector
        vote = self.adapted.box_voting          # every method's boxes alike
        shift = self.frame_shift
        if m.how == "adapted":
            return self.detector(m.rule, m.object_model, m.fold).detect(image, kind.name)
        if m.how == "warp":
            s = warp_scores(image, self.windows.homographies, self.models, kind)
            return kind_nms(person_boxes(self.windows.homographies), s, self.thr[kind.name],
                            kind, vote)
        canvas = shifted_frame(image, shift)
        if m.kind in PRETRAINED_KINDS:
            dets = opencv_detect(canvas, upsample=m.upsample, detector=m.kind, vote=vote)
        else:
            detect = {"pyramid": hog_pyramid_detect if kind is HOG_DETECTOR
                      else acf_pyramid_detect, "pyramid_fast": acf_pyramid_fast_detect}[m.how]
            dets = detect(canvas, self.models, upsample=m.upsample,
                          threshold=self.thr[kind.name], vote=vote)
        if shift != (0, 0):
            dets = unshifted_boxes(dets, shift)
        return self.on_ground(dets) if m.ground else dets

    def on_ground(self, detections) -> np.ndarray:
        """The detections that pass :func:`ground_plane_filter` on this camera (through
        its lens, if the windows are) for the assumed person heights."""
        lens = self.adapted.params.get("lens")
        if lens is not None and self._undistortion is None:
            from viewadapt.camera.distortion import Undistortion
            self._undistortion = Undistortion(self._camera.K, lens, self.adapted.size)
        return ground_plane_filter(detections, self._camera,
                                   heights=self.adapted.params["person_heights"],
                                   undistortion=self._undistortion)


def warp_scores(image, homographies, models, kind, *, chunk: int = 512) -> np.ndarray:
    """Image warping (Li et al. 2008): every window warped to the detector's window (64x128;
    Daimler's 48x96), featurised and scored by the source model of ``kind`` (a
    :class:`~viewadapt.detect.DetectorKind` or its name)."""
    from viewadapt.detect import detector_window_homography
    from viewadapt.warp import warp_to_source_view

    kind = detector_kind(kind)
    T = detector_window_homography(kind.window)
    out = np.empty(len(homographies))
    for a in range(0, len(homographies), chunk):
        Hs = homographies[a:a + chunk] @ T
        X = np.stack([kind.features.window_features(
            warp_to_source_view(image, H, size=kind.window)).ravel() for H in Hs])
        out[a:a + len(Hs)] = kind.window_scores(models, X)
    return out


def opencv_detect(image, *, upsample: int = 4, hit_threshold: float = -0.5,
                  detector: str = "opencv", vote: float = 0.0) -> np.ndarray:
    """``cv2.HOGDescriptor.detectMultiScale`` with the default people detector (``detector
    = "daimler"``: the 48x96 Daimler detector, set up as OpenCV's own example sets it up).

    Grouping off (``groupThreshold=0``) so that every window's score feeds our NMS and the
    DET curve; boxes mapped back to the frame and shrunk to the person (OpenCV's windows
    have the INRIA 16-px margins; Daimler's window is the same window scaled by 3/4).
    ``vote``: box voting's temperature after our NMS (:func:`viewadapt.nms.voted_boxes`).
    """
    import cv2

    if detector == "daimler":
        hog = cv2.HOGDescriptor((48, 96), (16, 16), (8, 8), (8, 8), 9)
        hog.setSVMDetector(cv2.HOGDescriptor_getDaimlerPeopleDetector())
    elif detector == "opencv":
        hog = cv2.HOGDescriptor()
        hog.setSVMDetector(cv2.HOGDescriptor_getDefaultPeopleDetector())
    else:
        raise ValueError(f"detector must be 'opencv' or 'daimler', got {detector!r}")
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
    return kind_nms(boxes, np.asarray(weights, float).ravel(), hit_threshold, HOG_DETECTOR,
                    vote)


#: Relative height mismatch beyond which :func:`ground_plane_filter` drops a box.
GROUND_FILTER_TOLERANCE = 0.2


def ground_plane_filter(detections, camera, *, heights, undistortion=None,
                        tolerance: float = GROUND_FILTER_TOLERANCE) -> np.ndarray:
    """The detections whose box height agrees with a person standing at their foot point.

    Each box's bottom centre is taken as the feet on the ground plane ``Z = 0``
    (undistorted first when ``undistortion`` -- a
    :class:`viewadapt.camera.distortion.Undistortion` -- is given); a person of each
    assumed height standing there is projected (and distorted back); a box is kept when
    its height is within ``tolerance`` (relative) of one of those persons' heights in
    pixels. Boxes whose feet lie above the horizon are dropped. This uses the calibration
    without adapting the detector: the baseline that isolates what adaptation adds.

    Parameters
    ----------
    detections : (D, 5) array_like ``(x, y, w, h, score)``
    camera : Camera
    heights : sequence of float, metres
    undistortion : Undistortion or None
    tolerance : float

    Returns
    -------
    (D', 5) ndarray, the kept rows in their order.
    """
    from viewadapt.camera.distortion import distort_points

    d = np.asarray(detections, np.float64).reshape(-1, 5)
    if not len(d):
        return d
    feet = np.c_[d[:, 0] + d[:, 2] / 2, d[:, 1] + d[:, 3]]
    pin = feet if undistortion is None else undistortion.undistort_points(feet)
    Hg = camera.K @ np.c_[camera.R[:, :2], camera.t]          # ground (X, Y, 1) -> pixels
    g = np.linalg.solve(Hg, np.c_[pin, np.ones(len(pin))].T).T
    ok = np.abs(g[:, 2]) > 1e-12
    ground = g[:, :2] / np.where(ok, g[:, 2], 1.0)[:, None]
    # the ground point must lie in front of the camera
    cam_z = (camera.R @ np.c_[ground, np.zeros(len(ground))].T).T[:, 2] + camera.t[2]
    ok &= cam_z > 0
    keep = np.zeros(len(d), bool)
    at = np.flatnonzero(ok)
    for h in heights:
        head = camera.project(np.c_[ground[at], np.full(len(at), float(h))])
        if undistortion is not None:
            head = distort_points(head, undistortion.K, undistortion.dist)
        want = feet[at, 1] - head[:, 1]
        fits = (want > 0) & (np.abs(d[at, 3] / np.where(want > 0, want, 1.0) - 1) <= tolerance)
        keep[at[fits]] = True
    return d[keep]


# --------------------------------------------------------------------------- evaluation


def evaluate_method(detections, frames, **kw) -> dict:
    """Miss rate vs FPPI and LAMR of per-frame detections on :class:`FrameRecord` s
    (:func:`viewadapt.detect.evaluate_detections`)."""
    from viewadapt.detect import evaluate_detections

    return evaluate_detections(detections, [(f.gt, f.occlusion, f.camera.image_size)
                                            for f in frames], **kw)
