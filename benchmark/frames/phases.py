"""Grid phases of the candidate windows, and LAMR differences averaged over them.

Where the ground grid of candidate windows falls is arbitrary (``grid_phase`` of
:func:`viewadapt.detect.select_candidate_windows`), yet a frame LAMR moves with it: every
window moves by a fraction of a pixel, and which windows land on a person changes. A
comparison of detectors on the candidate windows is therefore made on the mean over
several phases, with a paired bootstrap over frames that resamples every phase of both
sides together. Used by ``bench frames --phases`` (:mod:`benchmark.frames.command`) and the
calibration round trip's detector check (:mod:`benchmark.studies.calibration_lamr`).
"""

from __future__ import annotations

import numpy as np

from viewadapt.detect import ground_truth_rows, standardize_boxes
from viewadapt.metrics import accumulate_frames, log_average_miss_rate, match_detections

__all__ = ["grid_phases", "frame_shifts", "phase_columns", "shifted_frame", "unshifted_boxes",
           "frame_matches", "matches_lamr", "paired_lamr_difference", "phase_mean_difference"]


def grid_phases(n: int) -> list:
    """The ``n x n`` ground-grid phases ``(i / n, j / n)`` of the candidate windows
    (:func:`viewadapt.detect.select_candidate_windows`' ``grid_phase``), the default grid's
    ``(0, 0)`` first."""
    if n < 1:
        raise ValueError(f"the number of grid phases per axis must be at least 1, got {n}")
    return [(i / n, j / n) for i in range(n) for j in range(n)]


def frame_shifts(n: int) -> list:
    """The ``n x n`` whole-pixel shifts ``(dx, dy)`` (0 to ``n - 1`` each way) of the frame
    under a sliding-window pyramid (:func:`shifted_frame`), in the order of
    :func:`grid_phases` (no shift first): where a pyramid's own window grid falls, as the
    grid phases are where the candidate windows' ground grid falls. At OpenCV's 2x
    upsampling one pixel is a quarter of ``detectMultiScale``'s finest 8-px stride."""
    if n < 1:
        raise ValueError(f"the number of frame shifts per axis must be at least 1, got {n}")
    return [(i, j) for i in range(n) for j in range(n)]


def phase_columns(method, phase, shift) -> dict:
    """Where ``method`` (a :class:`~benchmark.frames.spec.FrameMethod`) ran at one phase, as
    the columns of ``phases.csv``: ``phase_forward, phase_left`` (the grid phase, fractions of
    the ground grid's stride) for a method on the candidate windows, ``shift_x, shift_y``
    (the frame shift, px) for a pyramid; None in the other pair."""
    a, b = phase if method.on_window_grid else (None, None)
    x, y = (None, None) if method.on_window_grid else shift
    return dict(phase_forward=a, phase_left=b, shift_x=x, shift_y=y)


def shifted_frame(image, shift) -> np.ndarray:
    """``image`` on a canvas ``dx`` px wider and ``dy`` px taller, the frame at its bottom
    right and its first columns and rows replicated to the left and above: every pixel of the
    frame is kept, ``dx, dy`` px further from the origin (boxes found on it map back by
    :func:`unshifted_boxes`)."""
    import cv2

    dx, dy = (int(v) for v in shift)
    if dx < 0 or dy < 0:
        raise ValueError(f"a frame shift is whole pixels >= 0, got {tuple(shift)}")
    if dx == dy == 0:
        return image
    return cv2.copyMakeBorder(np.ascontiguousarray(image), dy, 0, dx, 0, cv2.BORDER_REPLICATE)


def unshifted_boxes(detections, shift) -> np.ndarray:
    """(D, 5) boxes ``(x, y, w, h, score)`` found on :func:`shifted_frame`'s canvas, in the
    frame's own pixels."""
    d = np.array(detections, np.float64).reshape(-1, 5)
    d[:, 0] -= shift[0]
    d[:, 1] -= shift[1]
    return d


def frame_matches(detections, frames) -> list:
    """Per-frame matches of detections to ground truth, the first stage of
    :func:`benchmark.frames.methods.evaluate_method` (the same ground-truth rows, ignore flags and
    box standardisation), so that resampled frames need only be accumulated.

    Parameters
    ----------
    detections : list of (D, 5) ndarray
        Per frame of ``frames``, ``(x, y, w, h, score)``.
    frames : list of FrameRecord

    Returns
    -------
    list of viewadapt.metrics.FrameMatch
    """
    out = []
    for d, f in zip(detections, frames, strict=True):
        gt = ground_truth_rows(f.gt, f.occlusion, f.camera.image_size)
        d = np.asarray(d, dtype=np.float64).reshape(-1, 5)
        out.append(match_detections(standardize_boxes(d[:, :4]), d[:, 4], gt[:, :4],
                                    gt[:, 4].astype(bool)))
    return out


def matches_lamr(matches) -> float:
    """The log-average miss rate of per-frame matches (accumulate, summarise)."""
    fppi, miss_rate, _ = accumulate_frames(matches)
    return float(log_average_miss_rate(fppi, miss_rate))


def paired_lamr_difference(dets, reference, frames, *, n_boot: int, rng) -> tuple:
    """``LAMR(dets) - LAMR(reference)``, each a list of per-frame ``(D, 5)`` detections of
    ``frames``, with its 95 % paired bootstrap interval over frames: the one-phase case of
    :func:`phase_mean_difference` (same parameters and result)."""
    return phase_mean_difference([dets], [reference], frames, n_boot=n_boot, rng=rng)


def phase_mean_difference(dets, reference, frames, *, n_boot: int, rng) -> tuple:
    """The difference of two mean LAMRs over grid phases and its 95 % paired bootstrap
    interval over frames (each replicate resamples the frames once, for every phase of
    both).

    Parameters
    ----------
    dets, reference : list of lists of (D, 5) ndarray
        Per grid phase (any number, not necessarily the same for both), per frame of
        ``frames``.
    frames : list of FrameRecord
    n_boot : int
        Bootstrap replicates (0: no interval, NaN bounds).
    rng : numpy.random.Generator

    Returns
    -------
    (difference, ci_low, ci_high) : floats
    """
    a = [frame_matches(d, frames) for d in dets]
    b = [frame_matches(d, frames) for d in reference]

    def mean_diff(idx):
        return (np.mean([matches_lamr([m[i] for i in idx]) for m in a])
                - np.mean([matches_lamr([m[i] for i in idx]) for m in b]))

    diff = mean_diff(range(len(frames)))
    if n_boot <= 0:
        return float(diff), np.nan, np.nan
    boot = [mean_diff(rng.integers(len(frames), size=len(frames))) for _ in range(n_boot)]
    return float(diff), float(np.quantile(boot, 0.025)), float(np.quantile(boot, 0.975))
