"""The detector a user calls: the viewpoint-adapted detectors of one calibrated camera.

:class:`FrameDetector` selects the camera's world-space candidate windows once
(:func:`~viewadapt.detect.windows.select_candidate_windows`), builds (or loads from the
operator cache) the adapted operator of each detector kind once -- the offline step of
Wang et al. (2017, Sec. 5.1) -- and then detects on any number of frames of that camera.
"""

from __future__ import annotations

import numbers
import time
from typing import NamedTuple

import numpy as np

from ..camera.distortion import check_distortion
from ..geometry import PERSON_HEIGHT_M, Camera
from ..io.cache import DEFAULT_CACHE_LIMIT_GB, OperatorCache
from ..io.models import SourceDetectors
from ..objectmodel import OBJECT_MODELS
from ..remap import ANGLE_RULES
from .channels import check_frame
from .kinds import DETECTOR_KINDS, HOG_DETECTOR, PRETRAINED_KINDS, detector_kind
from .layers import build_multiresolution_operator, check_upsample_below
from .templates import HOG_TOLERANCE
from .windows import (
    GROUND_STRIDE_M, MIN_PERSON_HEIGHT_PX, check_ground_stride, select_candidate_windows,
    windows_through_lens,
)

__all__ = ["DEFAULT_THRESHOLD", "DEFAULT_BOX_VOTING", "FrameDetections", "FrameDetector",
           "check_box_voting"]
#: Score threshold of the detections kept for non-maximum suppression: low, so that a DET
#: curve reaches high false-positive rates.
DEFAULT_THRESHOLD = -1.0
#: Box voting's temperature by default (:func:`viewadapt.nms.voted_boxes`, after Gidaris &
#: Komodakis 2015); 0 turns voting off.
DEFAULT_BOX_VOTING = 1.0


def check_box_voting(value, name: str = "box_voting") -> float:
    """Box voting's temperature as a float (0: none); a ValueError naming ``name`` when it
    is not a finite number >= 0."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = float("nan")
    if isinstance(value, bool) or not np.isfinite(v) or v < 0:
        raise ValueError(f"{name} must be a finite number >= 0 (0: no box voting), got "
                         f"{value!r}")
    return v


class FrameDetections(NamedTuple):
    """The detections of one frame.

    Attributes
    ----------
    boxes : (D, 5) ndarray
        ``(x, y, w, h, score)`` in frame pixels, by decreasing score (as
        :meth:`FrameDetector.detect`).
    window : (D,) int64 ndarray
        Index of each detection's candidate window in ``detector.windows``.
    ground_xy : (D, 2) ndarray
        Where each detected person stands: world ``(X, Y)`` on the ground plane ``Z = 0``,
        metres.
    """

    boxes: np.ndarray
    window: np.ndarray
    ground_xy: np.ndarray


class FrameDetector:
    """The viewpoint-adapted detectors of one camera: windows and operators built once.

    Parameters
    ----------
    camera : Camera
        Calibrated, with its ``image_size``.
    models : SourceDetectors
        Detectors trained on source-view (elevation-0) crops.
    person_heights : sequence of float
        Assumed person heights, metres: one set of candidate windows each.
    cache_dir : path or None
        Where :class:`~viewadapt.io.cache.OperatorCache` keeps the adapted operators.
    cache_limit_gb : float or None
        That directory's size limit (least recently used operators go first); None or 0:
        no limit.
    tolerance : float
        Shape tolerance of shared templates in HOG frame cells; every detector kind scales
        it by its own default (:attr:`DetectorKind.tolerance`) against HOG's, so that the
        tolerance in pixels is the same.
    cells_per_source_cell : float or None
        See :func:`~viewadapt.detect.templates.choose_cell_sizes`; None (default): each
        kind's own (:attr:`DetectorKind.cells_per_source_cell`).
    upsample_below : float or None
        Windows of a smaller scale read the frame upsampled
        (:func:`~viewadapt.detect.layers.build_multiresolution_operator`); None (default):
        each kind's own (:attr:`DetectorKind.upsample_below`: 0.5 for ``hog`` and ``acf``,
        0.75 for ``opencv`` and ``daimler``).
    thresholds : dict kind -> float
        Score threshold of each kind's detections (before non-maximum suppression;
        default :data:`DEFAULT_THRESHOLD`).
    rule : {"covariant", "paper", "none"}
        Angle rule of ``A`` (:func:`viewadapt.remap.map_angles`).
    object_model : {"plane", "body"}
        How a person's pixels move between the source view and the frame: the paper's
        plane, or the mean body of :mod:`viewadapt.objectmodel`
        (:func:`~viewadapt.detect.templates.window_mapping`).
    lens : (D,) array_like or None
        OpenCV distortion coefficients of the camera (relative to ``camera.K``): the
        candidate windows are mapped through the lens
        (:func:`~viewadapt.detect.windows.windows_through_lens`) and the detector reads the
        *distorted* frames as they come, its boxes in their pixels. None (default): the
        frames are pinhole frames (undistorted ones, if the camera has a lens).
    grid_phase : (2,) float
        Offset of the ground grid of candidate windows, in strides (forward, left), each in
        ``[0, 1)`` (:func:`~viewadapt.detect.windows.select_candidate_windows`).
    ground_stride : float or (2,) float or None
        The ground grid's stride, metres, one or (forward, lateral)
        (:func:`~viewadapt.detect.windows.select_candidate_windows`); None (default): the
        paper's :data:`~viewadapt.detect.windows.GROUND_STRIDE_M` both ways.
    min_person_height : float
        Persons shorter than this in the frame, px, get no candidate window (default
        :data:`~viewadapt.detect.windows.MIN_PERSON_HEIGHT_PX`).
    kinds : dict name -> DetectorKind, optional
        Detector kinds of this detector instead of the registry's of the same name, e.g.
        ``{"opencv": opencv_kind(w, b)}`` for another OpenCV HOG/SVM.
    stage : bool
        Whether the kinds that have a per-window normalisation stage (``hog``, ``opencv``,
        ``daimler``; :class:`~viewadapt.detect.renorm.RenormStage`) run it (default); False:
        their folded operators alone (:meth:`DetectorKind.fold`).
    box_voting : float
        Box voting's temperature after non-maximum suppression
        (:func:`viewadapt.nms.voted_boxes`): each detection's box becomes the mean of the
        candidate windows' boxes overlapping it, weighted by ``exp(score difference /
        box_voting)``; scores, windows and ground positions stay the kept window's.
        Default :data:`DEFAULT_BOX_VOTING`; 0: the kept window's box.
    """

    def __init__(self, camera: Camera, models: SourceDetectors, *,
                 person_heights=(PERSON_HEIGHT_M,), cache_dir=None,
                 cache_limit_gb: float | None = DEFAULT_CACHE_LIMIT_GB,
                 tolerance: float = HOG_TOLERANCE,
                 cells_per_source_cell: float | None = None,
                 upsample_below: float | None = None, thresholds=None,
                 rule: str = "covariant", object_model: str = "plane", lens=None,
                 grid_phase=(0.0, 0.0), min_person_height: float = MIN_PERSON_HEIGHT_PX,
                 kinds=None, stage: bool = True, ground_stride=None,
                 box_voting: float = DEFAULT_BOX_VOTING):
        if not isinstance(camera, Camera) or camera.image_size is None:
            raise ValueError("camera must be a Camera with its image_size (width, height)")
        self.camera = camera
        self.models = models
        self.size = tuple(camera.image_size)
        self.params = dict(person_heights=tuple(float(h) for h in person_heights),
                           tolerance=float(tolerance),
                           cells_per_source_cell=None if cells_per_source_cell is None
                           else float(cells_per_source_cell),
                           upsample_below=check_upsample_below(upsample_below),
                           rule=str(rule))
        if rule not in ANGLE_RULES:
            raise ValueError(f"rule must be one of {ANGLE_RULES}, got {rule!r}")
        if object_model not in OBJECT_MODELS:
            raise ValueError(f"object_model must be one of {OBJECT_MODELS}, got {object_model!r}")
        self.params["object_model"] = str(object_model)
        self.kinds = {}
        for name, k in dict(kinds or {}).items():
            if detector_kind(name).name != getattr(k, "name", None):
                raise ValueError(f"kinds[{name!r}] must be a detector kind called {name!r}")
            self.kinds[name] = k
        self.stage = bool(stage)
        self.box_voting = check_box_voting(box_voting)
        self.thresholds = {k: DEFAULT_THRESHOLD for k in DETECTOR_KINDS | PRETRAINED_KINDS} \
            | dict(thresholds or {})
        for k in self.thresholds:
            detector_kind(k)
        self.cache_dir = cache_dir
        self.cache_limit_gb = cache_limit_gb
        if not (isinstance(min_person_height, numbers.Real)
                and not isinstance(min_person_height, bool) and 0 <= min_person_height < 1e4):
            raise ValueError(f"min_person_height must be a number of pixels >= 0, got "
                             f"{min_person_height!r}")
        stride = GROUND_STRIDE_M if ground_stride is None else check_ground_stride(ground_stride)
        self.windows = select_candidate_windows(camera, self.size,
                                                person_heights=self.params["person_heights"],
                                                grid_phase=grid_phase, stride=stride,
                                                min_person_height_px=min_person_height)
        if ground_stride is not None:   # (only then: the cache keys of before stay valid)
            self.params["ground_stride"] = list(stride)
        self.params["grid_phase"] = [float(v) for v in grid_phase]
        self.params["min_person_height"] = float(min_person_height)
        if lens is not None:
            lens = check_distortion(lens)
            self.params["lens"] = [float(v) for v in lens]
            self.windows, _ = windows_through_lens(self.windows, camera.K, lens)
        self._ops = {}
        #: seconds each operator took to build or load, and whether it came from the cache
        self.build_seconds = {}
        self.cache_hit = {}

    def kind(self, name):
        """This detector's :class:`DetectorKind` called ``name`` (its own ``kinds``, else
        the registry's; without its normalisation stage unless :attr:`stage`)."""
        name = detector_kind(name).name
        kind = self.kinds.get(name) or detector_kind(name)
        return kind if self.stage or not kind.has_stage else kind.fold()

    def operator(self, kind: str):
        """The adapted operator of ``kind`` (built, or read from the cache, on first use)."""
        kind = detector_kind(kind).name
        if kind in self._ops:
            return self._ops[kind]
        t0 = time.perf_counter()
        key_parts = self.cache_key(kind)
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

    def cache_key(self, kind) -> dict:
        """What :class:`~viewadapt.io.cache.OperatorCache` keys ``kind``'s operator by: the
        camera, the kind, its model's fingerprint and this detector's parameters (the
        upsampling threshold and the cells per source cell the kind's operator uses)."""
        kind = detector_kind(kind).name
        return dict(camera=self.camera.to_dict(), kind=kind,
                    model=self.kind(kind).model_fingerprint(self.models),
                    **(self.params | dict(upsample_below=self.upsample_below(kind),
                                          cells_per_source_cell=self.cells_per_source_cell(kind))))

    def upsample_below(self, kind) -> float:
        """The upsampling threshold of ``kind``'s operator: the one this detector was given,
        else the kind's own."""
        given = self.params["upsample_below"]
        return float(self.kind(kind).upsample_below) if given is None else given

    def cells_per_source_cell(self, kind) -> float:
        """The frame cells per source cell ``kind``'s operator chooses its cell sizes by
        (:func:`~viewadapt.detect.templates.choose_cell_sizes`): the value this detector
        was given, else the kind's own."""
        given = self.params["cells_per_source_cell"]
        return float(self.kind(kind).cells_per_source_cell) if given is None else given

    def _build(self, name):
        kind = self.kind(name)
        # the same tolerance in pixels for every kind: its cells against HOG's
        tol = self.params["tolerance"] * kind.tolerance / HOG_DETECTOR.tolerance

        def build(w):
            return kind.build_operator(w, self.models, tolerance=tol, rule=self.params["rule"],
                                       cells_per_source_cell=self.cells_per_source_cell(name),
                                       object_model=self.params["object_model"])

        return build_multiresolution_operator(self.windows, build,
                                              upsample_below=self.upsample_below(name))

    def detect(self, image, kind: str = "hog") -> np.ndarray:
        """(D, 5) detections ``(x, y, w, h, score)`` of the adapted ``kind`` detector on one
        frame of this camera, by decreasing score (the boxes of :meth:`detect_on_ground`)."""
        return self.detect_on_ground(image, kind).boxes

    def detect_on_ground(self, image, kind: str = "hog") -> FrameDetections:
        """Detections of one frame with the candidate window and ground position of each.

        The operator's window scores, thresholded at ``thresholds[kind]`` and non-maximum
        suppressed by :func:`~viewadapt.nms.detections_from_scores` with the operator's
        settings; each kept box is a row of the operator's window boxes with that window's
        score, and non-maximum suppression names the window it kept.

        Parameters
        ----------
        image : (height, width[, 3]) ndarray
            A frame of this camera (undistorted if the camera has lens distortion and the
            windows were not mapped through the lens).
        kind : {"hog", "acf", "opencv"}

        Returns
        -------
        FrameDetections

        Notes
        -----
        The ground position of a detection is its candidate window's:
        ``windows.ground_xy``, the point on the ground below the feet of the person of
        assumed height the window was built for (the window's feet point
        :attr:`CandidateWindows.feet <viewadapt.detect.CandidateWindows.feet>` seen on the
        ground). It is exact for that window, not an approximation through the box: the box
        reported is the window's snapped to its shared template (a whole-cell shift of at
        most the template tolerance), so the box's bottom centre can lie a few pixels from
        the window's feet point.
        """
        kind = detector_kind(kind).name
        img = check_frame(image, self.size)
        dets, window = self.operator(kind).detect(img, threshold=self.thresholds[kind],
                                                  return_index=True, vote=self.box_voting)
        return FrameDetections(dets, window, self.windows.ground_xy[window].reshape(-1, 2))
