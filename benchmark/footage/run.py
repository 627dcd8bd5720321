"""A user's clip and every method on it (``viewadapt bench footage``).

:func:`open_clip` reads what a user has -- frames (a folder, a video, files), a calibration
(the project's, PETS/Tsai XML, OpenCV FileStorage), ground truth (MOTChallenge, CAVIAR,
COCO, CSV) and ignore regions -- with the readers ``viewadapt detect`` uses, and decides how
the lens is handled as ``detect`` does (:func:`viewadapt.commands.detect.lens_correction`):
the candidate windows mapped through the lens, or every frame undistorted and the boxes
mapped back. :func:`run_footage` runs the methods of :mod:`benchmark.frames.spec` frame by
frame in one process and times each; every box it returns is in the input's pixels.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from benchmark.frames.methods import FrameMethods
from benchmark.frames.runtime import single_thread
from benchmark.frames.spec import FrameMethod
from viewadapt.camera.distortion import Undistortion
from viewadapt.commands.detect import boxes_in_input_pixels, lens_correction
from viewadapt.detect import DEFAULT_BOX_VOTING
from viewadapt.io import FrameBoxes, open_frames, read_boxes, read_ignore_regions
from viewadapt.io.calibration import read_calibration_file

__all__ = ["FOOTAGE_METHODS", "Clip", "open_clip", "add_clip_arguments", "FootageRun",
           "run_footage", "stored_detections"]

#: The methods ``bench footage`` runs by default, in its order: OpenCV's own
#: ``detectMultiScale`` at 1x, 2x and 4x without and with the ground-plane filter (the
#: baseline that isolates what adaptation adds to the calibration), for its INRIA and its
#: Daimler detector, our unadapted pyramids, the adapted detectors, and image warping of
#: each adapted model.
FOOTAGE_METHODS = tuple(FrameMethod.parse(n) for n in (
    "opencv_native", "opencv_2x", "opencv", "opencv_native[ground]", "opencv_2x[ground]",
    "opencv[ground]", "daimler_native", "daimler_2x", "daimler", "daimler_native[ground]",
    "daimler_2x[ground]", "daimler[ground]", "hog_pyramid", "acf_pyramid_fast", "hog_adapted",
    "acf_adapted", "opencv_adapted", "daimler_adapted", "hog_warp", "acf_warp", "opencv_warp",
    "daimler_warp"))


@dataclass
class Clip:
    """A calibrated, annotated clip as :func:`open_clip` read it.

    Attributes
    ----------
    camera : Camera
    dist : (D,) ndarray or None
        The lens (OpenCV coefficients of ``camera.K``).
    correction : {None, "windows", "undistort"}
        How the lens is handled (:func:`viewadapt.commands.detect.lens_correction`).
    stream : FrameStream
    truth : dict
        :func:`viewadapt.io.read_boxes`' ground truth, by image name or frame index.
    regions : list or None
        Ignore polygons.
    imported : ImportedCalibration or None
    """

    camera: object
    dist: object
    correction: str | None
    stream: object
    truth: dict
    regions: list | None
    imported: object = None

    def truth_of(self, frame) -> FrameBoxes:
        """The ground truth of one frame (empty for a frame the file does not list)."""
        key = frame.source if self.stream.paths is not None else frame.index
        return self.truth.get(key, FrameBoxes.empty())

    def stored_truth(self, keys) -> list:
        """The ground truth of the frames that the keys of a ``bench footage``
        ``detections.json`` name (a folder's frames by name, a video's by index), in the
        keys' order, without reading the frames."""
        video = self.stream.paths is None
        return [self.truth.get(int(k) if video else k, FrameBoxes.empty()) for k in keys]


def stored_detections(stored, keys) -> list:
    """One method's detections as ``detections.json`` holds them (frame key -> rows), as
    (D, 5) arrays in the order of ``keys`` (none for a key it does not list)."""
    return [np.asarray(stored.get(k, []), float).reshape(-1, 5) for k in keys]


def open_clip(inputs, calibration, boxes, ignore=None, *, lens: str = "auto",
              start: int = 0, every: int = 1,
              max_frames: int | None = None) -> Clip:
    """Read a clip: frames, calibration, ground truth and ignore regions.

    ``lens`` is ``detect``'s ``--lens`` (``auto``: windows through the lens; with
    ``undistort`` every method reads the same undistorted frames).
    """
    cal = read_calibration_file(calibration)
    correction = lens_correction(cal.dist, lens)
    stream = open_frames(inputs, start=start, every=every, max_frames=max_frames)
    truth = read_boxes(boxes, stream.paths,
                       n_frames=stream.n_total if stream.paths is None else None)
    regions = None if ignore is None else read_ignore_regions(ignore)
    return Clip(cal.camera, cal.dist, correction, stream, truth, regions, cal.imported)


def add_clip_arguments(parser) -> None:
    """The clip a study reads, as ``bench footage`` reads it (:func:`open_clip`): the frames
    (positional), ``--calibration``, ``--boxes`` and ``--ignore``."""
    parser.add_argument("inputs", nargs="+", help="the clip's frames, as bench footage reads "
                                                  "them")
    parser.add_argument("--calibration", type=Path, required=True)
    parser.add_argument("--boxes", type=Path, required=True)
    parser.add_argument("--ignore", type=Path, default=None)


class FootageRun:
    """What :func:`run_footage` measured.

    Attributes
    ----------
    detections : dict FrameMethod -> list of (D, 5) ndarray
        Per frame, ``(x, y, w, h, score)`` in the input's pixels.
    seconds : dict FrameMethod -> float
        Seconds detecting (summed over frames, one process, after each method's untimed
        run on the first frame; a ground-filtered pyramid's include its unfiltered
        pyramid's).
    prepare_seconds : dict FrameMethod -> float
        The offline step (building or loading the adapted operators).
    truth : list of FrameBoxes
    keys : list
        Each frame's image name (images) or index (a video).
    n_windows : int
    undistort_seconds : float
        Undistorting the frames (``correction == "undistort"``), not in ``seconds``.
    """

    def __init__(self, methods):
        self.detections = {m: [] for m in methods}
        self.seconds = {m: 0.0 for m in methods}
        self.prepare_seconds = {m: 0.0 for m in methods}
        self.truth = []
        self.keys = []
        self.n_windows = 0
        self.undistort_seconds = 0.0

    @property
    def n_frames(self) -> int:
        return len(self.truth)


def run_footage(clip: Clip, methods, models, *, heights, cache_dir=None, cache_limit_gb=None,
                tolerance=None, ground_stride=None, grid_phase=(0.0, 0.0), frame_shift=(0, 0),
                box_voting=DEFAULT_BOX_VOTING, upsample_below=None,
                progress=None) -> FootageRun:
    """Every method on every frame of the clip, in one process, each timed on one core
    (OpenCV and BLAS limited to one thread, :func:`benchmark.frames.runtime.single_thread`).

    A ground-filtered pyramid reuses its unfiltered pyramid's boxes of the same frame when
    that runs too (its seconds are the pyramid's plus the filter's).

    Parameters
    ----------
    clip : Clip
    methods : sequence of FrameMethod
    models : SourceDetectors or None
        Our source detectors (None when no method needs them).
    heights : sequence of float
        Assumed person heights, metres.
    cache_dir, cache_limit_gb, tolerance, ground_stride, grid_phase, box_voting, upsample_below
        :class:`viewadapt.detect.FrameDetector`'s (tolerance, ground_stride None: its
        defaults; grid_phase: where the candidate windows' ground grid stands;
        box_voting: applied to every method's boxes, the pyramids' too; upsample_below
        None: each detector's own).
    frame_shift : (int, int)
        Whole pixels the frame is moved under the pyramids
        (:class:`benchmark.frames.methods.FrameMethods`); the window-grid methods move with
        ``grid_phase`` instead.
    progress : callable or None
        Called once per frame.
    """
    cam = clip.camera
    kw = dict(person_heights=heights, cache_dir=cache_dir, cache_limit_gb=cache_limit_gb,
              grid_phase=tuple(grid_phase), box_voting=box_voting,
              upsample_below=upsample_below)
    if tolerance is not None:
        kw["tolerance"] = tolerance
    if ground_stride is not None:
        kw["ground_stride"] = list(ground_stride)
    if clip.correction == "windows":
        kw["lens"] = np.asarray(clip.dist).tolist()
    undistort = Undistortion(cam.K, clip.dist, cam.image_size) \
        if clip.correction == "undistort" else None
    fm = FrameMethods(cam, models, frame_shift=frame_shift, **kw)
    out = FootageRun(methods)
    out.n_windows = len(fm.windows)
    for m in methods:
        t = time.perf_counter()
        fm.prepare(m)
        out.prepare_seconds[m] = time.perf_counter() - t
    with single_thread():
        for i, frame in enumerate(clip.stream):
            _run_frame(frame, clip, fm, methods, undistort, out, warm_up=i == 0)
            if progress is not None:
                progress()
    return out


def _run_frame(frame, clip, fm, methods, undistort, out, *, warm_up: bool = False) -> None:
    """Every method on one frame of the clip, each timed, into ``out``; ``warm_up``: each
    method first runs once on the frame untimed (the first call of a compiled kernel loads
    it, which is not the per-frame cost)."""
    cam = clip.camera
    if (frame.image.shape[1], frame.image.shape[0]) != tuple(cam.image_size):
        raise ValueError(f"frame {frame.source} is {frame.image.shape[1]}x"
                         f"{frame.image.shape[0]} px, the calibration is for "
                         f"{cam.image_size[0]}x{cam.image_size[1]}")
    image = frame.image
    if undistort is not None:
        t = time.perf_counter()
        image = undistort(image)
        out.undistort_seconds += time.perf_counter() - t
    raw = {}
    for m in methods:
        if warm_up:
            fm.detect(m, image)
        t = time.perf_counter()
        base = replace(m, ground=False) if m.ground else None
        if base in raw:
            dets = fm.on_ground(raw[base][0])
            extra = raw[base][1]
        else:
            dets = fm.detect(m, image)
            extra = 0.0
        seconds = time.perf_counter() - t
        raw[m] = (dets, seconds)
        out.seconds[m] += seconds + extra
        if undistort is not None:
            dets = boxes_in_input_pixels(dets, cam.K, clip.dist)
        out.detections[m].append(np.asarray(dets, np.float64).reshape(-1, 5))
    out.truth.append(clip.truth_of(frame))
    out.keys.append(frame.source if clip.stream.paths is not None else frame.index)
