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

__all__ = ["standardize_boxes", "ground_truth_rows", "evaluate_detections", "plot_det_figure",
           "FAMILY_COLORS"]


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


#: figure colour of each detector family (the method name's first part)
FAMILY_COLORS = {"hog": "tab:blue", "acf": "tab:red", "opencv": "tab:gray"}


def plot_det_figure(results, path_stem, title=""):
    """Miss rate against FPPI, log-log, the legend with each method's LAMR (Fig. 3)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    dash = {"pyramid": "-", "warp": "--", "adapted": ":", "opencv": "-.", "native": "-."}
    fig, ax = plt.subplots(figsize=(5.5, 4.5))
    variants = sorted({m.partition("[")[2] for m in results if "[" in m})
    for m, r in sorted(results.items(), key=lambda kv: kv[1]["lamr"]):
        fam = m.split("_")[0]
        ls = dash.get(m.split("_")[-1], "-")
        if "[" in m:          # an adapted variant (rule, object model): its own dash pattern
            ls = (0, (4, 1 + variants.index(m.partition("[")[2]), 1, 1))
        fppi = np.r_[1e-3, r["fppi"]] if len(r["fppi"]) else np.array([1e-3, 10])
        mr = np.r_[1.0, r["miss_rate"]] if len(r["miss_rate"]) else np.array([1.0, 1.0])
        ax.step(np.maximum(fppi, 1e-3), mr, where="post", ls=ls, lw=2,
                color=FAMILY_COLORS.get(fam, "k"), label=f"{100 * r['lamr']:.1f}% {m}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(1e-2, 1e1)
    ax.set_ylim(5e-2, 1.0)
    ax.set_xlabel("false positives per image")
    ax.set_ylabel("miss rate")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="lower left", title="log-average miss rate")
    if title:
        ax.set_title(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(f"{path_stem}.png", dpi=150)
    fig.savefig(f"{path_stem}.pdf")
    plt.close(fig)
