"""The source-view detectors the full-frame detector adapts, as one object to save and load.

On disk they are an array file (:mod:`viewadapt.io.arrayfile`) of format
``"viewadapt.source_detectors"``: nothing in it is executed when it is read.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from viewadapt.arrays import stored_array, under_prefix, with_prefix
from viewadapt.boosting import AdaBoostTrees
from viewadapt.detect.channels import HOG_WEIGHT_SHAPE
from viewadapt.io.arrayfile import read_array_file, write_array_file
from viewadapt.io.packaged import packaged_path

__all__ = ["SOURCE_DETECTORS_FORMAT", "SOURCE_DETECTORS_VERSION", "SourceDetectors",
           "shipped_model_path"]

#: format name and version of a saved :class:`SourceDetectors` (``models/*.npz``)
SOURCE_DETECTORS_FORMAT = "viewadapt.source_detectors"
SOURCE_DETECTORS_VERSION = 1
_REMEDY = "write it again with this version's `viewadapt bench frames`"
#: file name of the source detectors shipped in ``viewadapt/data``
_SHIPPED = "source_detectors.npz"


def shipped_model_path() -> Path:
    """Path of the source detectors shipped with the package.

    They are the average (:func:`viewadapt.ensembles.average_source_detectors`) of
    ``bench frames``' models of two renders (seeds 0 and 1) of the ``paper`` preset through
    the generator's ``surveillance`` camera effects: HOG/SVM and ACF boosted trees on the
    elevation-0 crops and their frame-view copies, seed 0, recipe ``averaged`` (the ACF
    model the average of nine seeds' trees); the 18 boosted models are stored with the
    first gating the others (:func:`viewadapt.ensembles.average_trees`' ``gate``). The
    file's training record keeps each
    member's record (recipe, dataset: preset, seed, renderer, camera effects, content
    hash) under ``average_of``. ``viewadapt detect`` uses them when no ``--model`` is given.
    """
    return packaged_path(_SHIPPED)


@dataclass
class SourceDetectors:
    """Detectors trained on source-view (elevation 0) crops.

    Saved as an ``.npz`` array file: ``hog_weights`` (16, 8, 13) float64, the ACF model's
    arrays under ``acf/`` (:meth:`viewadapt.boosting.AdaBoostTrees.to_arrays`), and JSON
    metadata ``{"format": "viewadapt.source_detectors", "format_version": 1, "viewadapt":
    version, "hog_bias": b, "acf": {"class": "AdaBoostTrees", "params": {...}} or null,
    "training": {...}}``.
    """

    hog_weights: np.ndarray       # (16, 8, 13) over hog_window_features
    hog_bias: float
    acf: object                   # AdaBoostTrees
    #: how they were trained (seed, frame_view, ...); empty for models saved before it existed
    training: dict = field(default_factory=dict)

    def save(self, path) -> Path:
        """Write the detectors to ``path`` (an ``.npz`` array file, atomically)."""
        arrays = {"hog_weights": np.asarray(self.hog_weights, dtype=np.float64)}
        acf = None
        if self.acf is not None:
            if not isinstance(self.acf, AdaBoostTrees):
                raise ValueError(f"the ACF model must be an AdaBoostTrees to be saved, got "
                                 f"{type(self.acf).__name__}")
            params, acf_arrays = self.acf.to_arrays()
            acf = {"class": "AdaBoostTrees", "params": params}
            arrays.update(with_prefix("acf/", acf_arrays))
        meta = {"hog_bias": float(self.hog_bias), "acf": acf, "training": dict(self.training)}
        return write_array_file(path, SOURCE_DETECTORS_FORMAT, SOURCE_DETECTORS_VERSION,
                                meta, arrays)

    @staticmethod
    def load(path) -> "SourceDetectors":
        """Read detectors written by :meth:`save`.

        ``FileNotFoundError`` for a missing file; a one-line ``ValueError`` for anything
        else than such a file: a pickle (never loaded), a truncated or corrupt file, an
        array file of another format or format version, or one with missing or mis-shaped
        entries.
        """
        p = Path(path)
        if not p.is_file():
            raise FileNotFoundError(f"model file {p} does not exist")
        meta, arrays = read_array_file(p, SOURCE_DETECTORS_FORMAT, SOURCE_DETECTORS_VERSION,
                                       remedy=_REMEDY)
        try:
            w = stored_array(arrays, "hog_weights", "f")
            bias = meta.get("hog_bias")
            if isinstance(bias, bool) or not isinstance(bias, (int, float)) \
                    or not np.isfinite(bias):
                raise ValueError(f"its hog_bias is {bias!r}, not a finite number")
            acf = meta.get("acf")
            if acf is not None:
                if not isinstance(acf, dict) or acf.get("class") != "AdaBoostTrees" \
                        or not isinstance(acf.get("params"), dict):
                    raise ValueError("its ACF model is not a stored AdaBoostTrees")
                acf = AdaBoostTrees.from_arrays(acf["params"], under_prefix("acf/", arrays))
            training = meta.get("training", {})
            if not isinstance(training, dict):
                raise ValueError("its training record is not a mapping")
        except ValueError as exc:
            raise ValueError(f"{p} is not a readable model ({exc}): {_REMEDY}") from None
        if w.shape != HOG_WEIGHT_SHAPE:
            raise ValueError(f"{p} holds HOG weights of shape {w.shape}, "
                             f"not {HOG_WEIGHT_SHAPE}: it was trained on an older "
                             "version's features; retrain it with `viewadapt bench frames`")
        return SourceDetectors(np.ascontiguousarray(w, dtype=np.float64), float(bias), acf,
                               training)

    def fingerprint(self) -> str:
        """A short hash of the models' parameters (keys the operator cache)."""
        import hashlib

        h = hashlib.sha256(np.asarray(self.hog_weights, np.float64).tobytes())
        h.update(np.float64(self.hog_bias).tobytes())
        if self.acf is None:                # a file of the HOG/SVM alone
            h.update(b"no ACF model")
        else:
            for a in (self.acf.feature_, self.acf.threshold_, self.acf.value_):
                h.update(np.ascontiguousarray(a).tobytes())
        return h.hexdigest()[:16]
