"""Evaluating detections on frames: the Caltech protocol and its DET figure.

Miss rate against false positives per image and the log-average miss rate over
``1e-2..1e0`` FPPI (Dollár et al. 2012, as Wang et al. 2017, Fig. 3), after standardising
every box to the pedestrian aspect 0.41 and ignoring ground truth that is too small, too
occluded or cut by the frame's border.

References
----------
.. [1] P. Dollár, C. Wojek, B. Schiele, P. Perona, "Pedestrian Detection: An Evaluation of
   the State of the Art", IEEE TPAMI 34(4), 2012.
"""

from __future__ import annotations

import numpy as np

from ..metrics import evaluate_frames

__all__ = ["standardize_boxes", "ground_truth_rows", "evaluate_detections"]


def standardize_boxes(boxes, aspect: float = 0.41) -> np.ndarray:
    """Boxes resized to ``width = aspect * height`` about their centre (Caltech ``dbEval``)."""
    b = np.asarray(boxes, float).reshape(-1, boxes.shape[-1] if np.ndim(boxes) == 2 else 4)
    out = b.copy()
    if len(b):
        cx = b[:, 0] + b[:, 2] / 2
        out[:, 2] = aspect * b[:, 3]
        out[:, 0] = cx - out[:, 2] / 2
    return out


def ground_truth_rows(boxes, occlusion, image_size, *, min_height: float = 24.0,
                      max_occlusion: float = 0.5) -> np.ndarray:
    """(G, 5) ``(x, y, w, h, ignore)`` of one frame's (G, 4) boxes: boxes too small, too
    occluded or cut by the border of the ``image_size`` (width, height) frame are ignored
    (Caltech protocol, Dollár et al. 2012); boxes standardised to the 0.41 aspect."""
    b = np.asarray(boxes, float).reshape(-1, 4)
    occ = np.asarray(occlusion, float).reshape(-1)
    gt = standardize_boxes(b) if len(b) else np.zeros((0, 4))
    w, h = image_size
    ign = np.zeros(len(gt), bool)
    if len(gt):
        ign |= b[:, 3] < min_height
        ign |= occ > max_occlusion
        ign |= (b[:, 0] < 1) | (b[:, 1] < 1) | (b[:, 0] + b[:, 2] > w - 1) | \
            (b[:, 1] + b[:, 3] > h - 1)
    return np.c_[gt, ign.astype(float)]


def evaluate_detections(detections, ground_truth, **kw) -> dict:
    """Miss rate vs FPPI and LAMR of detections on frames
    (:func:`viewadapt.metrics.evaluate_frames`).

    Parameters
    ----------
    detections : list of (D, 5) ndarray
        Per frame, ``(x, y, w, h, score)``.
    ground_truth : list of ((G, 4) boxes, (G,) occlusion, (width, height)) tuples
        Per frame: its ground-truth boxes, their hidden fractions and the frame's size.
    **kw
        ``min_height``, ``max_occlusion`` of :func:`ground_truth_rows`.
    """
    dts = [np.c_[standardize_boxes(d[:, :4]), d[:, 4]] if len(d) else np.zeros((0, 5))
           for d in detections]
    gts = [ground_truth_rows(b, o, size, **kw) for b, o, size in ground_truth]
    return evaluate_frames(dts, gts)


