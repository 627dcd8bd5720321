"""Detection on a stream of frames: each detection with its ground position, in one process
or split over worker processes with the same results.

The adapted detector scores world-space candidate windows (Wang et al. 2017, Sec. 5.1), so
every detection is a window whose person stands at a known ground position:
:func:`detect_on_ground` returns it with the boxes. :func:`detect_stream` runs a
:class:`~viewadapt.detect.FrameDetector` over frames (:mod:`viewadapt.io.video`) in
order, optionally in worker processes, each of which makes the same detector from a
:class:`DetectorSpec` and loads its adapted operator from the operator cache.
"""

from __future__ import annotations

import collections
import json
from dataclasses import dataclass
from typing import Iterator, NamedTuple

import numpy as np

from viewadapt.detect.channels import check_frame
from viewadapt.detect.detector import FrameDetector
from viewadapt.detect.kinds import detector_kind
from viewadapt.nms import detections_from_scores

__all__ = ["FrameDetections", "detect_on_ground", "DetectorSpec", "detect_stream"]


class FrameDetections(NamedTuple):
    """The detections of one frame.

    Attributes
    ----------
    boxes : (D, 5) ndarray
        ``(x, y, w, h, score)`` in frame pixels, by decreasing score (as
        :meth:`FrameDetector.detect <viewadapt.detect.FrameDetector.detect>`).
    window : (D,) int64 ndarray
        Index of each detection's candidate window in ``detector.windows``.
    ground_xy : (D, 2) ndarray
        Where each detected person stands: world ``(X, Y)`` on the ground plane ``Z = 0``,
        metres.
    """

    boxes: np.ndarray
    window: np.ndarray
    ground_xy: np.ndarray


def detect_on_ground(detector: FrameDetector, image, kind: str = "hog") -> FrameDetections:
    """Detections of one frame with the candidate window and ground position of each.

    The boxes are those of ``detector.detect(image, kind)``: the operator's window scores,
    thresholded and non-maximum suppressed by
    :func:`~viewadapt.nms.detections_from_scores` with the operator's settings. Each kept
    box is a row of the operator's window boxes with that window's score; non-maximum
    suppression names the window it kept.

    Parameters
    ----------
    detector : FrameDetector
    image : (height, width[, 3]) ndarray
        A frame of the detector's camera (undistorted if the camera has lens distortion).
    kind : {"hog", "acf"}

    Returns
    -------
    FrameDetections

    Notes
    -----
    The ground position of a detection is its candidate window's:
    ``detector.windows.ground_xy``, the point on the ground below the feet of the person of
    assumed height the window was built for (the window's feet point
    :attr:`CandidateWindows.feet <viewadapt.detect.CandidateWindows.feet>` seen on the
    ground). It is exact for that window, not an approximation through the box: the box
    reported is the window's snapped to its shared template (a whole-cell shift of at
    most the template tolerance), so the box's bottom centre can lie a few pixels from
    the window's feet point.
    """
    kind = detector_kind(kind).name
    img = check_frame(image, detector.size)
    op = detector.operator(kind)
    boxes = op.boxes()
    scores = op.scores(op.frame_features(img))
    dets, window = detections_from_scores(
        boxes, scores, threshold=detector.thresholds[kind], overlap=op.nms_overlap,
        nms_threshold=op.nms_threshold, return_index=True)
    return FrameDetections(dets, window, detector.windows.ground_xy[window].reshape(-1, 2))


@dataclass(frozen=True)
class DetectorSpec:
    """Everything that makes a :class:`FrameDetector`, in a form a worker process receives.

    Attributes
    ----------
    camera : str
        JSON of :meth:`Camera.to_dict <viewadapt.geometry.Camera.to_dict>`.
    model : str
        Path of the source detectors file (:meth:`SourceDetectors.load
        <viewadapt.detect.SourceDetectors.load>`).
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

        return FrameDetector(Camera.from_dict(json.loads(self.camera)),
                             SourceDetectors.load(self.model), **json.loads(self.options))


#: a worker process's detectors, made once per spec
_WORKER_DETECTORS: dict = {}


def _detect_in_worker(spec: DetectorSpec, image) -> FrameDetections:
    det = _WORKER_DETECTORS.get(spec)
    if det is None:
        _WORKER_DETECTORS.clear()           # one detector per worker: that of this run
        det = _WORKER_DETECTORS[spec] = spec.make()
    return detect_on_ground(det, image, spec.kind)


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
            yield frame, detect_on_ground(det, frame.image, spec.kind)
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
