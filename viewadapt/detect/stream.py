"""Detection on a stream of frames: each detection with its ground position, in one process
or split over worker processes with the same results.

The adapted detector scores world-space candidate windows (Wang et al. 2017, Sec. 5.1), so
every detection is a window whose person stands at a known ground position:
:meth:`FrameDetector.detect_on_ground <viewadapt.detect.FrameDetector.detect_on_ground>`
returns it with the boxes. :func:`detect_stream` runs a
:class:`~viewadapt.detect.FrameDetector` over frames (:mod:`viewadapt.io.video`) in
order, optionally in worker processes, each of which makes the same detector from a
:class:`DetectorSpec` and loads its adapted operator from the operator cache.
"""

from __future__ import annotations

import collections
import json
from dataclasses import dataclass
from typing import Iterator

import numpy as np

from .detector import FrameDetections, FrameDetector
from .kinds import PRETRAINED_KINDS, detector_kind, opencv_kind

__all__ = ["DetectorSpec", "pretrained_kinds", "detect_stream"]


def pretrained_kinds(kind: str, model) -> dict:
    """``FrameDetector``'s ``kinds`` for the pretrained detector ``kind`` (``"opencv"``,
    ``"daimler"``) with the weights of ``model``, an OpenCV HOGDescriptor file read in the
    kind's own layout (:data:`viewadapt.io.hogfile.PRETRAINED_FILE_LAYOUTS`; Daimler's
    48x96); ``{}`` (its own weights) when ``model`` is None or empty."""
    from viewadapt.io.hogfile import PRETRAINED_FILE_LAYOUTS, read_opencv_hog_detector

    if not model:
        return {}
    w, b = read_opencv_hog_detector(model, PRETRAINED_FILE_LAYOUTS[kind])
    return {kind: opencv_kind(w, b, detector=kind)}


@dataclass(frozen=True)
class DetectorSpec:
    """Everything that makes a :class:`FrameDetector`, in a form a worker process receives.

    Attributes
    ----------
    camera : str
        JSON of :meth:`Camera.to_dict <viewadapt.geometry.Camera.to_dict>`.
    model : str
        Path of the source detectors file (:meth:`SourceDetectors.load
        <viewadapt.io.SourceDetectors.load>`); for a pretrained kind an OpenCV HOGDescriptor
        file (:func:`viewadapt.io.read_opencv_hog_detector`), or "" for its own weights.
    kind : str
        The detector kind run on the frames.
    options : str
        JSON of the :class:`FrameDetector` keyword arguments (paths as strings).
    """

    camera: str
    model: str
    kind: str
    options: str

    @classmethod
    def create(cls, camera, model, kind: str, **options) -> "DetectorSpec":
        """The spec of ``FrameDetector(camera, SourceDetectors.load(model), **options)``
        running ``kind``."""
        opts = {k: (str(v) if k == "cache_dir" and v is not None else v)
                for k, v in options.items()}
        return cls(json.dumps(camera.to_dict()), str(model), detector_kind(kind).name,
                   json.dumps(opts, sort_keys=True))

    def make(self) -> FrameDetector:
        """A new :class:`FrameDetector` of this spec (its operators built on first use, or
        read from the operator cache)."""
        from viewadapt.geometry import Camera
        from viewadapt.io.models import SourceDetectors

        cam = Camera.from_dict(json.loads(self.camera))
        if self.kind in PRETRAINED_KINDS:
            return FrameDetector(cam, None, kinds=pretrained_kinds(self.kind, self.model),
                                 **json.loads(self.options))
        return FrameDetector(cam, SourceDetectors.load(self.model), **json.loads(self.options))


#: a worker process's detectors, made once per spec
_WORKER_DETECTORS: dict = {}


def _detect_in_worker(spec: DetectorSpec, image) -> FrameDetections:
    det = _WORKER_DETECTORS.get(spec)
    if det is None:
        _WORKER_DETECTORS.clear()           # one detector per worker: that of this run
        det = _WORKER_DETECTORS[spec] = spec.make()
    return det.detect_on_ground(image, spec.kind)


def detect_stream(frames, spec: DetectorSpec, *, jobs: int = 1,
                  detector: FrameDetector | None = None) -> Iterator[tuple]:
    """Detect on every frame, in order: ``(frame, FrameDetections)`` per frame.

    Parameters
    ----------
    frames : iterable of Frame
        E.g. a :class:`~viewadapt.io.video.FrameStream`; consumed lazily.
    spec : DetectorSpec
    jobs : int
        1: in this process, with ``detector`` (or ``spec.make()``). More (or -1, all
        cores): worker processes (joblib), each making the detector of ``spec`` once;
        at most ``2 * jobs`` frames are in flight, so memory stays flat.
    detector : FrameDetector, optional
        The detector of ``spec`` in this process (``jobs == 1``).

    Yields
    ------
    (Frame, FrameDetections)
        In the order of ``frames``; the same detections whatever ``jobs`` is (each frame is
        scored by the same operator, read from the cache by a worker).
    """
    if jobs is None or jobs == 1:
        det = detector if detector is not None else spec.make()
        for frame in frames:
            yield frame, det.detect_on_ground(frame.image, spec.kind)
        return
    if not isinstance(jobs, (int, np.integer)) or jobs < -1 or jobs == 0:
        raise ValueError(f"jobs must be >= 1 or -1 (all cores), got {jobs!r}")
    from joblib import Parallel, delayed

    pending = collections.deque()

    def tasks():
        for frame in frames:
            pending.append(frame)
            yield delayed(_detect_in_worker)(spec, frame.image)

    par = Parallel(n_jobs=int(jobs), return_as="generator", batch_size=1,
                   pre_dispatch="2*n_jobs")
    for result in par(tasks()):
        yield pending.popleft(), result
