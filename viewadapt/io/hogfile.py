"""A linear HOG/SVM detector saved by OpenCV (``cv2.HOGDescriptor.save``, YAML or XML).

:func:`read_opencv_hog_detector` reads one within bounds (size, nesting, no aliases or
document types: :func:`~viewadapt.io.imports.check_filestorage_text`, before OpenCV parses
it) and accepts only the layout the adapted OpenCV detector reads
(:mod:`viewadapt.detect.opencv_cells`): a 64x128 window of 8-px cells in 16-px blocks at an
8-px stride, 9 unsigned bins, L2-Hys at 0.2, gamma correction on -- or, for the Daimler
detector's kind, the same in a 48x96 window without gamma correction
(:data:`DAIMLER_FILE_LAYOUT`). Anything else is a one-line error naming the file and the
field.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from viewadapt.io.bounded import MAX_CALIBRATION_BYTES, read_limited_text
from viewadapt.io.imports import check_filestorage_text

__all__ = ["HOG_FILE_LAYOUT", "DAIMLER_FILE_LAYOUT", "PRETRAINED_FILE_LAYOUTS",
           "read_opencv_hog_detector"]

#: The HOGDescriptor fields the adapted detector needs, and their values.
HOG_FILE_LAYOUT = {"winSize": (64, 128), "blockSize": (16, 16), "blockStride": (8, 8),
                   "cellSize": (8, 8), "nbins": 9, "histogramNormType": 0,
                   "L2HysThreshold": 0.2, "gammaCorrection": True, "signedGradient": False}
#: The same for a 48x96 detector read as OpenCV's Daimler detector is
#: (``HOGDescriptor((48, 96), (16, 16), (8, 8), (8, 8), 9)``: no gamma correction).
DAIMLER_FILE_LAYOUT = HOG_FILE_LAYOUT | {"winSize": (48, 96), "gammaCorrection": False}
#: The file layout of each pretrained detector kind's ``--model``.
PRETRAINED_FILE_LAYOUTS = {"opencv": HOG_FILE_LAYOUT, "daimler": DAIMLER_FILE_LAYOUT}


def read_opencv_hog_detector(path, layout=HOG_FILE_LAYOUT) -> tuple[np.ndarray, float]:
    """``(w, b)`` of the HOG/SVM detector in an OpenCV ``HOGDescriptor`` file: ``w`` the
    3780 weights in OpenCV's descriptor layout (1980 in :data:`DAIMLER_FILE_LAYOUT`), ``b``
    the bias (0 when the file stores no bias). ``ValueError`` naming the file and field for
    a file of another ``layout``."""
    import cv2

    path = Path(path)
    text = read_limited_text(path, "HOG detector file", 4 * MAX_CALIBRATION_BYTES)
    check_filestorage_text(text, path)
    missing = [k for k in ("winSize", "SVMDetector") if k not in text]
    if missing:
        raise ValueError(f"{path}: not an OpenCV HOGDescriptor file (no {' or '.join(missing)}; "
                         "write one with cv2.HOGDescriptor.save)")
    hog = cv2.HOGDescriptor()
    try:
        ok = hog.load(str(path))
    except cv2.error as exc:
        why = str(exc).split("error:")[-1].strip()
        raise ValueError(f"{path}: OpenCV cannot read it as a HOGDescriptor file "
                         f"({' '.join(why.split())[:100]})") from None
    if not ok:
        raise ValueError(f"{path}: not an OpenCV HOGDescriptor file (cv2.HOGDescriptor.load "
                         "failed; write one with HOGDescriptor.save)")
    w, h = layout["winSize"]
    for field, want in layout.items():
        got = getattr(hog, field)
        got = tuple(int(v) for v in got) if isinstance(want, tuple) else got
        same = abs(float(got) - want) < 1e-6 if isinstance(want, float) else got == want
        if not same:
            raise ValueError(f"{path}: {field} is {got!r}; the adapted detector reads "
                             f"{want!r} (Dalal-Triggs' layout in a {w}x{h} window)")
    n = (w // 8 - 1) * (h // 8 - 1) * 36
    v = np.asarray(hog.svmDetector, np.float64).ravel()
    if v.size not in (n, n + 1) or not np.all(np.isfinite(v)):
        raise ValueError(f"{path}: SVMDetector holds {v.size} values"
                         f"{'' if np.all(np.isfinite(v)) else ', not all finite'}; a {w}x{h} "
                         f"detector has {n} weights and a bias")
    return v[:n].copy(), float(v[n]) if v.size == n + 1 else 0.0
