"""The full-frame detector kinds: one spec each for the adapted HOG/SVM and ACF detectors.

A :class:`DetectorKind` holds everything the full-frame code needs to know about one
detector: its features (:class:`~viewadapt.detect.templates.FeatureKind`: layout, frame
cell maps, frame ``G``), its model within :class:`~viewadapt.io.models.SourceDetectors`,
how its adapted operator is built, its template tolerance and its non-maximum suppression.
:class:`~viewadapt.detect.FrameDetector`, the frames benchmark, its runtime table and the
training of the source detectors all read these specs instead of switching on names.
"""

from __future__ import annotations

import copy
import hashlib
from functools import cache

import numpy as np

from ..geometry import WINDOW_HEIGHT, WINDOW_WIDTH
from .features import ACF_FEATURES, DAIMLER_FEATURES, HOG_FEATURES, OPENCV_FEATURES
from .layers import UPSAMPLE_BELOW
from .linear import (
    OPENCV_FOLD_CELL_SIZES, AdaptedLinearOperator, build_adapted_linear_operator,
    build_adapted_opencv_operator,
)
from .opencv_cells import (
    DAIMLER_WINDOW, opencv_cell_weights, opencv_daimler_people_detector,
    opencv_default_people_detector,
)
from .renorm import (
    HOG_VERIFY_THRESHOLD, OPENCV_STAGE_CELL_SIZES, RENORM_CELLS_PER_SOURCE_CELL,
    STAGE_CELL_TOLERANCE, VERIFY_THRESHOLD,
)
from .templates import ACF_TOLERANCE, CELLS_PER_SOURCE_CELL, HOG_TOLERANCE
from .trees import AdaptedTreesOperator, build_adapted_trees_operator

__all__ = ["PRETRAINED_UPSAMPLE_BELOW", "OPENCV_FOLD_CELLS_PER_SOURCE_CELL", "DetectorKind",
           "HOG_DETECTOR", "ACF_DETECTOR", "OPENCV_DETECTOR", "DAIMLER_DETECTOR", "DETECTOR_KINDS",
           "PRETRAINED_KINDS", "hog_kind", "opencv_kind", "detector_kind"]


#: The scale below which OpenCV's detectors, trained on their windows alone, read persons
#: from the 2x-upsampled frame: persons under 96 px, Daimler's 48x96 window's own size. For
#: the 64x128 INRIA detector, persons of 96-128 px read at the frame's own resolution gave
#: the same LAMR as read upsampled on the 104 rendered frames and the PETS 2009 clip, about
#: 1.3 times as fast (a smaller upsampled band; docs/real_footage.md).
PRETRAINED_UPSAMPLE_BELOW = 0.75
#: ``rho`` of the cell sizes the fold of OpenCV's INRIA detector reads when its stage
#: rescores what the fold keeps (:data:`~viewadapt.detect.linear.OPENCV_FOLD_CELL_SIZES`,
#: an octave apart): each window reads the coarser size whenever it is at most twice its
#: source cells' image, so the fold is a coarse first stage of the cascade and its templates
#: small. Measured on the 104 rendered frames and the PETS 2009 clip: the same LAMR as
#: :data:`~viewadapt.detect.templates.CELLS_PER_SOURCE_CELL`, the fold about half the time
#: (docs/real_footage.md). Daimler's detector keeps the default: its stage, not its fold,
#: is its cost, and a coarser fold passes it more windows.
OPENCV_FOLD_CELLS_PER_SOURCE_CELL = 0.5


class DetectorKind:
    """One adapted full-frame detector (see the module notes).

    Attributes
    ----------
    name : str
    features : FeatureKind
    tolerance : float
        Default shape tolerance of shared templates, in this detector's frame cells.
    operator_class : type
        Its operator; gives the NMS setting (``nms_overlap``, ``nms_threshold``).
    window : (width, height)
        The detector's window, px: the canonical 64x128, or that window scaled
        (:func:`~viewadapt.detect.windows.detector_window_homography`; Daimler's 48x96).
    cells_per_source_cell : float
        ``rho`` of the frame cell sizes its operator chooses
        (:func:`~viewadapt.detect.templates.choose_cell_sizes`), unless the detector is given
        another: :data:`~viewadapt.detect.templates.CELLS_PER_SOURCE_CELL`, or for OpenCV's
        INRIA detector with its stage :data:`OPENCV_FOLD_CELLS_PER_SOURCE_CELL`.
    upsample_below : float
        Windows of a smaller scale (frame px per canonical px) read the frame upsampled
        (:func:`~viewadapt.detect.layers.build_multiresolution_operator`), unless the
        detector is given another threshold: the project's detectors, trained with
        frame-view copies of small persons, from :data:`UPSAMPLE_BELOW`; a pretrained
        detector, trained on its window alone, from :data:`PRETRAINED_UPSAMPLE_BELOW`.
    """

    name: str
    features: object
    tolerance: float
    operator_class: type
    window: tuple = (WINDOW_WIDTH, WINDOW_HEIGHT)
    cells_per_source_cell: float = CELLS_PER_SOURCE_CELL
    upsample_below: float = UPSAMPLE_BELOW

    @property
    def nms_overlap(self) -> str:
        return self.operator_class.nms_overlap

    @property
    def nms_threshold(self) -> float:
        return self.operator_class.nms_threshold

    def model(self, models):
        """This detector's model within ``models`` (:class:`SourceDetectors`)."""
        raise NotImplementedError

    def build_operator(self, windows, models, **kw):
        """The adapted operator of ``windows`` (keywords of the operator's builder)."""
        raise NotImplementedError

    def model_fingerprint(self, models) -> str:
        """Hex digest of the model this kind reads (a key of the operator cache)."""
        return models.fingerprint()

    def window_scores(self, models, X) -> np.ndarray:
        """(n,) source-model scores of (n, d) canonical-window features (image warping)."""
        raise NotImplementedError

    #: whether the windows the folded operator keeps are rescored by a per-window
    #: normalisation stage (:class:`~viewadapt.detect.renorm.RenormStage`)
    renorm = False
    #: the object models whose operators the stage rescores (the others: the fold alone)
    stage_object_models = ("plane",)

    @property
    def has_stage(self) -> bool:
        """Whether the kind's operator has a normalisation stage that :meth:`fold` can
        leave out."""
        return self.renorm

    def stages(self, object_model: str) -> bool:
        """Whether the kind's operator under ``object_model`` has a normalisation stage."""
        return self.renorm and object_model in self.stage_object_models

    def fold(self) -> DetectorKind:
        """The same detector without its per-window normalisation stage (the folded
        operator alone, eq. (7)); ValueError for a kind without one."""
        if not self.renorm:
            raise ValueError(f"the {self.name} detector has no normalisation stage to "
                             "leave out")
        fold = copy.copy(self)          # the same model (weights shared, read-only)
        fold.renorm = False
        return fold

    def __repr__(self):
        return f"DetectorKind({self.name!r})"


class _HogDetector(DetectorKind):
    """Linear SVM on block-normalised HOG cells: one adapted template per group, ``G^T w``
    (the fold); with ``renorm`` (the default, :func:`hog_kind`) the windows it scores a
    person are rescored with their cells remapped by their own ``G`` and block-normalised in
    the window (:class:`~viewadapt.detect.renorm.RenormStage`), the others keep their
    folded score."""

    name, features, tolerance = "hog", HOG_FEATURES, HOG_TOLERANCE
    operator_class = AdaptedLinearOperator
    stage_object_models = ("plane", "body")

    def __init__(self, renorm: bool = True, verify_threshold: float = HOG_VERIFY_THRESHOLD):
        #: whether the windows the fold keeps are rescored with their own block
        #: normalisation (:class:`~viewadapt.detect.renorm.RenormStage`, ``model="hog"``),
        #: from folded score ``verify_threshold``
        self.renorm = bool(renorm)
        self.verify_threshold = float(verify_threshold)

    def model(self, models):
        return models.hog_weights, models.hog_bias

    def model_fingerprint(self, models) -> str:
        key = models.fingerprint()         # (the fold alone)
        return key if not self.renorm else hashlib.sha256(
            f"{key} renorm {self.verify_threshold} cells +{STAGE_CELL_TOLERANCE}"
            " any object model".encode()     # (before: the stage of the plane alone)
        ).hexdigest()

    def build_operator(self, windows, models, **kw):
        w, b = self.model(models)
        if self.renorm:
            kw.update(renorm=True, verify_threshold=self.verify_threshold)
        return build_adapted_linear_operator(windows, w, b, **kw)

    def window_scores(self, models, X):
        w, b = self.model(models)
        return np.asarray(X, np.float64) @ np.ravel(w) + b


class _AcfDetector(DetectorKind):
    """Boosted trees on ACF channels: the used rows of ``G`` per group, a soft cascade."""

    name, features, tolerance = "acf", ACF_FEATURES, ACF_TOLERANCE
    operator_class = AdaptedTreesOperator

    def model(self, models):
        return models.acf

    def build_operator(self, windows, models, **kw):
        return build_adapted_trees_operator(windows, self.model(models), **kw)

    def window_scores(self, models, X):
        return self.model(models).decision_function(np.asarray(X, np.float64))


@cache
def _opencv_people():
    W, b = opencv_default_people_detector()
    W.setflags(write=False)
    return W, b


@cache
def _daimler_people():
    W, b = opencv_daimler_people_detector()
    W.setflags(write=False)
    return W, b


class _OpenCVDetector(DetectorKind):
    """OpenCV's INRIA-trained HOG/SVM people detector (``getDefaultPeopleDetector``; Dalal &
    Triggs 2005) -- or another 64x128 HOG/SVM in OpenCV's layout (:func:`opencv_kind`) --
    over its block-normalised cells, adapted like the HOG/SVM, the windows it keeps
    rescored with their own block normalisation
    (:class:`~viewadapt.detect.renorm.RenormStage`): its weights come with it, not from
    :class:`SourceDetectors`."""

    name, features, tolerance = "opencv", OPENCV_FEATURES, HOG_TOLERANCE
    operator_class = AdaptedLinearOperator

    #: OpenCV's square-root gamma correction in the features
    gamma = True
    _default = staticmethod(_opencv_people)

    #: trained on windows alone, it reads small persons from the upsampled frame, as
    #: ``detectMultiScale`` users upsample frames (:data:`PRETRAINED_UPSAMPLE_BELOW`)
    upsample_below = PRETRAINED_UPSAMPLE_BELOW
    #: its fold's ``rho`` when the stage runs
    fold_cells_per_source_cell = OPENCV_FOLD_CELLS_PER_SOURCE_CELL

    @property
    def cells_per_source_cell(self) -> float:
        """``rho`` of its fold's cell sizes: :attr:`fold_cells_per_source_cell` with the
        stage, :data:`~viewadapt.detect.templates.CELLS_PER_SOURCE_CELL` for the fold alone."""
        return self.fold_cells_per_source_cell if self.renorm else CELLS_PER_SOURCE_CELL

    def __init__(self, weights=None, bias: float = 0.0, *, renorm: bool = True):
        self._own = None
        #: whether the windows the fold keeps are rescored (the stage)
        self.renorm = bool(renorm)
        if weights is not None:
            W = opencv_cell_weights(weights, window=self.window)
            W.setflags(write=False)
            self._own = (W, float(bias))

    def model(self, models=None):
        return self._own if self._own is not None else self._default()

    def model_fingerprint(self, models=None) -> str:
        W, b = self.model()
        h = hashlib.sha256(np.ascontiguousarray(W, np.float64).tobytes())
        h.update(np.float64(b).tobytes())
        h.update(f"renorm {RENORM_CELLS_PER_SOURCE_CELL} {VERIFY_THRESHOLD} binned "
                 f"+{STAGE_CELL_TOLERANCE}".encode())
        if self.window != (WINDOW_WIDTH, WINDOW_HEIGHT) or not self.gamma:
            h.update(f"window {self.window} gamma {self.gamma}".encode())
        if not self.renorm:
            h.update(b"fold alone")
        else:
            h.update(f"fold cells {OPENCV_FOLD_CELL_SIZES} stage cells "
                     f"{OPENCV_STAGE_CELL_SIZES}".encode())
        return h.hexdigest()

    def build_operator(self, windows, models, **kw):
        W, b = self.model()
        return build_adapted_opencv_operator(windows, W, b, window=self.window,
                                             gamma=self.gamma, renorm=self.renorm, **kw)

    def window_scores(self, models, X):
        W, b = self.model()
        return np.asarray(X, np.float64) @ np.ravel(W) + b


class _DaimlerDetector(_OpenCVDetector):
    """OpenCV's Daimler-trained 48x96 HOG/SVM people detector (``getDaimlerPeopleDetector``),
    without gamma correction as OpenCV's own example runs it, adapted like ``opencv``: its
    window is the canonical one scaled by 3/4, so the candidate windows are the same and
    each window's homography is read through
    :func:`~viewadapt.detect.windows.detector_window_homography`."""

    name, features, window, gamma = "daimler", DAIMLER_FEATURES, DAIMLER_WINDOW, False
    fold_cells_per_source_cell = CELLS_PER_SOURCE_CELL
    _default = staticmethod(_daimler_people)


def hog_kind(*, renorm: bool = True,
             verify_threshold: float = HOG_VERIFY_THRESHOLD) -> DetectorKind:
    """The ``hog`` detector kind, with (``renorm``, the default, the registry's
    :data:`HOG_DETECTOR`) or without (the fold alone) the per-window normalisation stage,
    from folded score ``verify_threshold``: windows the fold scores below it keep their
    folded score."""
    return _HogDetector(renorm, verify_threshold)


def opencv_kind(weights, bias: float = 0.0, *, detector: str = "opencv") -> DetectorKind:
    """The ``opencv`` detector kind with another 64x128 HOG/SVM in OpenCV's descriptor
    layout (``weights`` (3780,), ``bias``), e.g. one of
    :func:`viewadapt.io.read_opencv_hog_detector`; ``detector="daimler"``: the ``daimler``
    kind with another 48x96 one (1980 weights, read without gamma correction)."""
    kinds = {"opencv": _OpenCVDetector, "daimler": _DaimlerDetector}
    if detector not in kinds:
        raise ValueError(f"detector must be one of {tuple(kinds)}, got {detector!r}")
    return kinds[detector](weights, bias)


HOG_DETECTOR = _HogDetector()
ACF_DETECTOR = _AcfDetector()
OPENCV_DETECTOR = _OpenCVDetector()
DAIMLER_DETECTOR = _DaimlerDetector()
#: the adapted full-frame detectors trained on the source view (:class:`SourceDetectors`)
DETECTOR_KINDS = {k.name: k for k in (HOG_DETECTOR, ACF_DETECTOR)}
#: the adapted full-frame detectors that come trained (on real photographs)
PRETRAINED_KINDS = {k.name: k for k in (OPENCV_DETECTOR, DAIMLER_DETECTOR)}


def detector_kind(name) -> DetectorKind:
    """The :class:`DetectorKind` called ``name`` (or ``name`` itself if it is one)."""
    if isinstance(name, DetectorKind):
        return name
    try:
        return (DETECTOR_KINDS | PRETRAINED_KINDS)[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown detector {name!r}; choose from "
                         f"{tuple(DETECTOR_KINDS | PRETRAINED_KINDS)}") from None
