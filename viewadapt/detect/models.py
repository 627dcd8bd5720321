"""The source-view detectors the full-frame detector adapts, as one object to save and load."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..files import atomic_write_bytes
from .channels import HOG_WEIGHT_SHAPE

__all__ = ["SourceDetectors"]


@dataclass
class SourceDetectors:
    """Detectors trained on source-view (elevation 0) crops."""

    hog_weights: np.ndarray       # (16, 8, 13) over hog_window_features
    hog_bias: float
    acf: object                   # AdaBoostTrees
    #: how they were trained (seed, frame_view, ...); empty for models saved before it existed
    training: dict = field(default_factory=dict)

    def save(self, path):
        """Write the detectors to ``path`` (atomically)."""
        import pickle

        atomic_write_bytes(path, pickle.dumps(self))

    @staticmethod
    def load(path) -> "SourceDetectors":
        """Read detectors written by :meth:`save`; ``FileNotFoundError`` / ``ValueError``
        for a missing file or one that holds something else."""
        import pickle

        p = Path(path)
        if not p.is_file():
            raise FileNotFoundError(f"model file {p} does not exist")
        try:
            obj = pickle.loads(p.read_bytes())
        except Exception:  # noqa: BLE001 - truncated, foreign, or of an older layout
            raise ValueError(f"{p} cannot be read as source detectors: write it again with "
                             "this version's `viewadapt bench frames`") from None
        if not isinstance(obj, SourceDetectors):
            raise ValueError(f"{p} is not a model written by `viewadapt bench frames`")
        if np.shape(obj.hog_weights) != HOG_WEIGHT_SHAPE:
            raise ValueError(f"{p} holds HOG weights of shape {np.shape(obj.hog_weights)}, "
                             f"not {HOG_WEIGHT_SHAPE}: it was trained on an older "
                             "version's features; retrain it with `viewadapt bench frames`")
        if not hasattr(obj, "training"):
            obj.training = {}
        return obj

    def fingerprint(self) -> str:
        """A short hash of the models' parameters (keys the operator cache)."""
        import hashlib

        h = hashlib.sha256(np.asarray(self.hog_weights, np.float64).tobytes())
        h.update(np.float64(self.hog_bias).tobytes())
        for a in (self.acf.feature_, self.acf.threshold_, self.acf.value_):
            h.update(np.ascontiguousarray(a).tobytes())
        return h.hexdigest()[:16]
