"""Frames of one camera, streamed from a video file, a folder, a glob pattern or image files.

:func:`open_frames` checks the input once (files exist, a folder or pattern holds images, a
video opens) and returns a :class:`FrameStream`; iterating over it decodes one frame at a
time, so a long clip runs in flat memory. Frames are selected as ``start, start + every,
start + 2 every, ...``, at most ``max_frames`` of them.
"""

from __future__ import annotations

import contextlib
import glob
import os
import queue
import re
import sys
import threading
from pathlib import Path
from typing import Iterator, NamedTuple

import numpy as np


__all__ = ["IMAGE_SUFFIXES", "Frame", "FrameStream", "open_frames", "natural_sort_key",
           "prefetched", "read_frame"]

#: File name suffixes read as still images (anything else is opened as a video).
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp", ".ppm", ".pgm",
                  ".pbm", ".pnm")
_GLOB_CHARS = re.compile(r"[*?[]")


class Frame(NamedTuple):
    """One frame of the input.

    Attributes
    ----------
    index : int
        0-based position in the input: the frame number of a video, or the position of the
        image in the (sorted) folder, pattern matches or list -- before ``start`` and
        ``every`` select frames, so a frame keeps its number whatever is selected.
    source : str
        The image's file name, or the video's.
    image : (height, width, 3) uint8 ndarray
        RGB.
    """

    index: int
    source: str
    image: np.ndarray


def natural_sort_key(name: str) -> tuple:
    """Sort key of a file name with its digit runs compared as numbers (``frame_2`` before
    ``frame_10``); case-insensitive, then the name itself breaks ties."""
    parts = re.split(r"(\d+)", name)
    return tuple(int(p) if i % 2 else p.lower() for i, p in enumerate(parts)), name


def _is_image(path: Path) -> bool:
    return path.suffix.lower() in IMAGE_SUFFIXES


def _check_selection(start, every, max_frames):
    for name, value, low in (("start", start, 0), ("every", every, 1)):
        if not isinstance(value, (int, np.integer)) or value < low:
            raise ValueError(f"{name} must be an integer >= {low}, got {value!r}")
    if max_frames is not None and (not isinstance(max_frames, (int, np.integer))
                                   or max_frames < 1):
        raise ValueError(f"max_frames must be an integer >= 1 or None, got {max_frames!r}")


class FrameStream:
    """The selected frames of one input, decoded one at a time (made by :func:`open_frames`).

    Attributes
    ----------
    kind : {"video", "folder", "glob", "files"}
    name : str
        The input as given (the video, folder or pattern; the first file of a list).
    fps : float
        Frame rate of the selected frames: a video's own rate over ``every``; 25 / ``every``
        for images, which carry none (the rate of an annotated video made of them;
        :meth:`describe` records None).
    n_frames : int or None
        How many frames iteration yields: exact for images; for a video from the frame
        count its container states (None when it states none).
    n_total : int or None
        Frames in the input (a video's as its container states, or None).
    paths : list of Path or None
        Every image of the input, in order (None for a video).
    video : Path or None
        The video file.
    start, every, max_frames
        The selection.
    """

    def __init__(self, kind, name, *, paths=None, video=None, fps=25.0, n_total=None,
                 start=0, every=1, max_frames=None):
        self.kind, self.name = kind, str(name)
        self.paths, self.video = paths, video
        self.start, self.every, self.max_frames = int(start), int(every), max_frames
        self.fps = float(fps) / self.every
        self.n_total = n_total
        n = None
        if n_total is not None and n_total > 0:
            n = len(range(self.start, int(n_total), self.every))
            if max_frames is not None:
                n = min(n, int(max_frames))
        self.n_frames = n

    def describe(self) -> dict:
        """The input and the selection, JSON-ready (for a run's metadata); ``fps`` is a
        video's rate of the selected frames, None for images (they carry none)."""
        return {"kind": self.kind, "input": self.name, "start": self.start,
                "every": self.every, "max_frames": self.max_frames,
                "frames_in_input": self.n_total,
                "fps": round(self.fps, 6) if self.video is not None else None}

    def __iter__(self) -> Iterator[Frame]:
        if self.video is not None:
            return self._video_frames()
        return self._image_frames()

    def _image_frames(self):
        idx = range(self.start, len(self.paths), self.every)
        if self.max_frames is not None:
            idx = idx[:self.max_frames]
        for i in idx:
            p = self.paths[i]
            yield Frame(i, p.name, read_frame(p))

    def _video_frames(self):
        import cv2

        cap = _open_video(self.video)
        try:
            i = n = 0
            while self.max_frames is None or n < self.max_frames:
                # grab() every frame: seeking (CAP_PROP_POS_FRAMES) is not exact for every
                # codec, and the frame numbers must be
                wanted = i >= self.start and (i - self.start) % self.every == 0
                if not cap.grab():
                    break
                if wanted:
                    ok, img = cap.retrieve()
                    if not ok or img is None:
                        raise ValueError(f"video {self.video}: frame {i} cannot be decoded")
                    if img.ndim == 2:
                        img = cv2.cvtColor(img, cv2.COLOR_GRAY2RGB)
                    else:
                        img = cv2.cvtColor(img, cv2.COLOR_BGR2RGB)
                    yield Frame(i, self.video.name, img)
                    n += 1
                i += 1
        finally:
            cap.release()


@contextlib.contextmanager
def _native_stderr_silenced():
    """File descriptor 2 sent to the null device meanwhile: OpenCV's and FFmpeg's own log
    lines (written by C code, past Python's ``sys.stderr``) on opening a file that is not
    a video would follow the one-line error."""
    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, ValueError):
        yield
        return
    null = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        os.close(null)


def _open_video(path: Path):
    import cv2

    with _native_stderr_silenced():
        cap = cv2.VideoCapture(str(path))
    if not cap.isOpened():
        cap.release()
        raise ValueError(f"video {path} cannot be read: OpenCV cannot open it (not a video, "
                         "truncated, or a format this OpenCV build does not decode)")
    return cap


def _image_list(paths, what) -> list:
    images = sorted((p for p in paths if p.is_file() and _is_image(p)),
                    key=lambda p: natural_sort_key(p.name))
    if not images:
        raise ValueError(f"{what} holds no images ({', '.join(s[1:] for s in IMAGE_SUFFIXES)})")
    return images


def open_frames(inputs, *, start: int = 0, every: int = 1,
                max_frames: int | None = None) -> FrameStream:
    """Open the frames of one camera for streaming.

    Parameters
    ----------
    inputs : path or sequence of paths
        One video file (anything ``cv2.VideoCapture`` reads: mp4, avi, ...), one folder
        (its images, not those of subfolders), one glob pattern (``"frames/*.png"``; ``**``
        reaches subfolders), or one or more image files. A file is an image when its
        suffix is one of :data:`IMAGE_SUFFIXES`, else a video.
    start : int
        Index of the first frame read (0-based).
    every : int
        Read every ``every``-th frame from ``start`` on.
    max_frames : int or None
        Read at most this many frames.

    Returns
    -------
    FrameStream
        Folder and pattern matches in natural order (:func:`natural_sort_key`); files in
        the order given.

    Raises
    ------
    FileNotFoundError
        A file or folder that does not exist (and is not a pattern).
    ValueError
        One line: a video OpenCV cannot open, a folder or pattern without images, a video
        given with other inputs, ``start`` past the last image, or a bad selection. An
        empty video (or ``start`` past its end) opens; its stream yields nothing.
    """
    _check_selection(start, every, max_frames)
    items = [inputs] if isinstance(inputs, (str, Path)) else list(inputs)
    if not items:
        raise ValueError("no input given (a video, a folder, a glob pattern or image files)")
    sel = dict(start=start, every=every, max_frames=max_frames)
    paths = [Path(p) for p in items]
    if len(paths) == 1 and not paths[0].exists() and _GLOB_CHARS.search(str(items[0])):
        matches = [Path(p) for p in glob.glob(str(items[0]), recursive=True)]
        images = _image_list(matches, f"the pattern {items[0]!r}")
        return _image_stream("glob", items[0], images, sel)
    for p in paths:
        if not p.exists():
            raise FileNotFoundError(f"input {p} does not exist")
    if len(paths) == 1 and paths[0].is_dir():
        return _image_stream("folder", paths[0], _image_list(paths[0].iterdir(),
                                                             f"the folder {paths[0]}"), sel)
    for p in paths:
        if p.is_dir():
            raise ValueError(f"input {p} is a folder: give one folder on its own, or image "
                             "files")
    videos = [p for p in paths if not _is_image(p)]
    if videos and len(paths) > 1:
        raise ValueError(f"{videos[0]} is not an image ({', '.join(IMAGE_SUFFIXES)}): give "
                         "one video on its own, or image files")
    if videos:
        return _video_stream(paths[0], sel)
    return _image_stream("files", paths[0], paths, sel)


def _image_stream(kind, name, images, sel) -> FrameStream:
    if sel["start"] >= len(images):
        raise ValueError(f"start {sel['start']} is past the last frame: {name} holds "
                         f"{len(images)} image(s), numbered from 0")
    return FrameStream(kind, name, paths=images, n_total=len(images), **sel)


def _video_stream(path: Path, sel) -> FrameStream:
    import cv2

    cap = _open_video(path)
    try:
        fps = cap.get(cv2.CAP_PROP_FPS)
        count = int(cap.get(cv2.CAP_PROP_FRAME_COUNT))
    finally:
        cap.release()
    if not np.isfinite(fps) or fps <= 0:
        fps = 25.0
    return FrameStream("video", path, video=path, fps=fps, n_total=count if count > 0 else None,
                       **sel)


def prefetched(items, depth: int = 4) -> Iterator:
    """``items`` in order, produced by a background thread at most ``depth`` ahead.

    Reading the next frames (decoding, undistortion: OpenCV calls that release the GIL)
    then overlaps with detecting on this one. An exception raised while producing an item
    is raised here, in its place; when the consumer stops early (an error, ``close()``),
    the thread stops and closes ``items``.

    Parameters
    ----------
    items : iterable
    depth : int
        Items produced ahead of the consumer (memory: ``depth`` items).
    """
    if depth < 1:
        raise ValueError(f"depth must be at least 1, got {depth}")
    q: queue.Queue = queue.Queue(maxsize=depth)
    stop = threading.Event()
    end = object()

    def put(item) -> bool:
        while not stop.is_set():
            try:
                q.put(item, timeout=0.05)
                return True
            except queue.Full:
                continue
        return False

    def produce():
        it = iter(items)
        try:
            for x in it:
                if not put((x, None)):
                    return
            put((end, None))
        except BaseException as exc:            # raised in the consumer, in order
            put((end, exc))
        finally:
            close = getattr(it, "close", None)
            if close is not None:
                close()

    worker = threading.Thread(target=produce, name="viewadapt-prefetch", daemon=True)
    worker.start()
    try:
        while True:
            x, exc = q.get()
            if x is end:
                if exc is not None:
                    raise exc
                return
            yield x
    finally:
        stop.set()
        worker.join()


def read_frame(path) -> np.ndarray:
    """A frame as uint8 RGB (M, N, 3); a missing or undecodable file is a ``ValueError``."""
    import cv2

    img = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if img is None:
        raise ValueError(f"frame {path} is missing or cannot be decoded as an image")
    return np.ascontiguousarray(img[:, :, ::-1])
