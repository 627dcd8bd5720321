"""The feature families the full-frame operators read (HOG cells, ACF channels), and how an
operator file records which frame features it was built for."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import partial
from typing import Callable

from ..arrays import is_int, is_json_scalar
from .acf_channels import acf_frame_features, acf_window_features
from .channels import (
    ACF_GRADIENT_LAMBDA, ACF_SHRINK, ACF_WEIGHT_SHAPE, HOG_CELL, HOG_CHANNELS, HOG_WEIGHT_SHAPE,
    N_ACF_CHANNELS, hog_frame_features, hog_window_features,
)
from .frame_remap import acf_frame_remap, acf_gradient_rows, hog_frame_remap, opencv_frame_remap
from .opencv_cells import (
    DAIMLER_WINDOW, OPENCV_CHANNELS, OPENCV_WEIGHT_SHAPE, daimler_window_features,
    opencv_frame_features, opencv_window_features,
)

__all__ = ["FeatureKind", "HOG_FEATURES", "OPENCV_FEATURES", "DAIMLER_FEATURES", "ACF_FEATURES",
           "FEATURE_MAKERS",
           "FEATURE_CHANNELS",
           "feature_maker_to_dict", "feature_maker_from_dict"]


@dataclass(frozen=True, eq=False)
class FeatureKind:
    """One feature family as the full-frame detectors read it: its layout on the canonical
    window, its frame cell maps and its frame ``G``.

    Attributes
    ----------
    name : str
    source_cell : int
        The canonical window's cell (or block) size, px: what frame cell sizes are chosen on.
    shape : tuple
        Layout of the canonical window's features (and of a source model's weights).
    window_features : callable
        ``window_features(window) -> ndarray`` of ``shape`` (what source models train on).
    frame_features : callable
        ``frame_features(image, cell_sizes, *, pad, image_size) -> FrameFeatures``.
    frame_remap : callable
        ``frame_remap(H, group, rule) -> G`` from a frame patch to the window's features.
    gradient_lambda : float
        Power-law exponent of the rows in ``gradient_rows`` across scales (0: none).
    gradient_rows : (n,) bool ndarray or None
        Rows of ``G`` scaled by ``s ** gradient_lambda``.
    """

    name: str
    source_cell: int
    shape: tuple
    window_features: Callable
    frame_features: Callable
    frame_remap: Callable
    gradient_lambda: float = 0.0
    gradient_rows: object = field(default=None, repr=False)


#: block-normalised HOG cells (:func:`~viewadapt.detect.channels.hog_window_features`)
HOG_FEATURES = FeatureKind("hog", HOG_CELL, HOG_WEIGHT_SHAPE, hog_window_features,
                           hog_frame_features, hog_frame_remap)


#: OpenCV's block-normalised HOG cells
#: (:func:`~viewadapt.detect.opencv_cells.opencv_window_features`)
OPENCV_FEATURES = FeatureKind("opencv", HOG_CELL, OPENCV_WEIGHT_SHAPE, opencv_window_features,
                              opencv_frame_features, opencv_frame_remap)


#: OpenCV's block-normalised HOG cells of the Daimler detector's 48x96 window, no gamma
#: (:func:`~viewadapt.detect.opencv_cells.daimler_window_features`)
DAIMLER_FEATURES = FeatureKind("daimler", HOG_CELL,
                               (DAIMLER_WINDOW[1] // HOG_CELL, DAIMLER_WINDOW[0] // HOG_CELL,
                                OPENCV_CHANNELS),
                               daimler_window_features,
                               partial(opencv_frame_features, gamma=False),
                               partial(opencv_frame_remap, window=DAIMLER_WINDOW))


#: ACF channels (:func:`~viewadapt.detect.acf_channels.acf_window_features`)
ACF_FEATURES = FeatureKind("acf", ACF_SHRINK, ACF_WEIGHT_SHAPE, acf_window_features,
                           acf_frame_features, acf_frame_remap, ACF_GRADIENT_LAMBDA,
                           acf_gradient_rows())


#: The functions an operator's stored feature maker may name
#: (:func:`feature_maker_from_dict`): nothing else is ever called from a stored operator.
FEATURE_MAKERS = {f.__name__: f for f in (hog_frame_features, opencv_frame_features,
                                           acf_frame_features)}
#: Channels per frame cell of each feature maker's maps.
FEATURE_CHANNELS = {"hog_frame_features": HOG_CHANNELS, "opencv_frame_features": OPENCV_CHANNELS,
                    "acf_frame_features": N_ACF_CHANNELS}


def feature_maker_to_dict(maker) -> dict:
    """An operator's feature maker -- a ``functools.partial`` of a function in
    :data:`FEATURE_MAKERS` with keyword arguments only -- as ``{"function": name,
    "keywords": {...}}`` (JSON-ready); ``ValueError`` for any other callable."""
    func = getattr(maker, "func", None)
    name = getattr(func, "__name__", None)
    if not isinstance(maker, partial) or maker.args or FEATURE_MAKERS.get(name) is not func:
        raise ValueError(f"only a feature maker partial(f, **keywords) with f one of "
                         f"{sorted(FEATURE_MAKERS)} can be stored, got {maker!r}")
    kw = {}
    for k, v in maker.keywords.items():
        v = [int(c) if is_int(c) else c for c in v] if isinstance(v, (list, tuple)) else v
        v = int(v) if is_int(v) else v
        if not (is_json_scalar(v) or isinstance(v, list) and all(is_json_scalar(c) for c in v)):
            raise ValueError(f"the feature maker's keyword {k}={v!r} cannot be stored")
        kw[k] = v
    return {"function": name, "keywords": kw}


def feature_maker_from_dict(d) -> partial:
    """The feature maker :func:`feature_maker_to_dict` described: a function of
    :data:`FEATURE_MAKERS` by name with its (JSON scalar or list) keywords; ``ValueError``
    for any other name or keyword value."""
    if not isinstance(d, dict) or d.get("function") not in FEATURE_MAKERS \
            or not isinstance(d.get("keywords"), dict):
        name = d.get("function") if isinstance(d, dict) else d
        raise ValueError(f"its feature maker {name!r} is not one of {sorted(FEATURE_MAKERS)}")
    kw = dict(d["keywords"])
    for k, v in kw.items():
        if not (is_json_scalar(v) or isinstance(v, list) and all(is_json_scalar(c) for c in v)):
            raise ValueError(f"its feature maker's keyword {k}={v!r} is not a plain value")
    if "image_size" in kw and kw["image_size"] is not None:
        kw["image_size"] = tuple(kw["image_size"])
    return partial(FEATURE_MAKERS[d["function"]], **kw)
