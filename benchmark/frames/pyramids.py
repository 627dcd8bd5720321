"""Image-pyramid baselines of the frames benchmark: the unadapted detectors slid over a
pyramid of the upsampled frame (Wang et al. 2017, Sec. 5.2 and Table 1).

``hog_pyramid_detect``
    HOG/SVM, block-normalised cells recomputed at every level (scale step 1.05);
``acf_pyramid_detect``
    ACF soft cascade, channels computed exactly at every level (``per_octave`` levels
    per octave);
``acf_pyramid_fast_detect``
    the same detector over Dollár's *fast feature pyramid*: channels computed exactly at
    one level per octave, the levels in between approximated from the nearest such level
    with the power law ``f(I_s) ~ f(I) s ** -lambda`` (Dollár et al. 2014), as the
    toolbox's ``chnsPyramid`` does. The reference the paper's Table 1 timed (3.54 fps).

Both ACF pyramids score every window of every level with the same compiled soft cascade
(:func:`dense_cascade_scores`, the toolbox's ``acfDetect1`` loop), so they differ only in
how the channels are obtained.

Re-exported by :mod:`benchmark.frames.methods`.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from viewadapt.boosting import cascade_step
from viewadapt.detect import (
    ACF_DETECTOR, ACF_GRADIENT_LAMBDA, ACF_SHRINK, HOG_DETECTOR, PERSON_BOX_WINDOW,
    acf_frame_features,
)
from viewadapt.geometry import WINDOW_HEIGHT, WINDOW_WIDTH
from viewadapt.nms import detections_from_scores

__all__ = ["pyramid_scales", "level_boxes", "kind_nms", "hog_pyramid_detect",
           "dense_cascade_scores", "dense_cascade_scores_reference",
           "PyramidLevel", "ACF_PYRAMID_LAMBDAS", "acf_pyramid_levels",
           "acf_fast_pyramid_levels", "smooth_channel_maps", "acf_pyramid_detect",
           "acf_pyramid_fast_detect"]

#: Power-law exponents ``lambda`` of the ACF channel types across scales (Dollár et al.
#: 2014, eq. (4)): colour (LUV) 0 -- intensive, scale-invariant --, normalised gradient
#: magnitude and orientation channels :data:`viewadapt.detect.ACF_GRADIENT_LAMBDA`, the
#: exponent the project measured on rendered frames (``python -m
#: benchmark.studies.acf_scaling``: one fit over the magnitude and orientation channels
#: together, so both types share it).
ACF_PYRAMID_LAMBDAS = (0.0, ACF_GRADIENT_LAMBDA, ACF_GRADIENT_LAMBDA)
#: channel slices of the ACF layout per channel type (LUV, magnitude, orientations)
_TYPE_SLICES = (slice(0, 3), slice(3, 4), slice(4, 10))


def pyramid_scales(size, upsample, step, min_height=WINDOW_HEIGHT) -> list:
    """Scales of an image pyramid of the frame ``size`` upsampled ``upsample`` times,
    divided by ``step`` per level while a canonical window still fits."""
    w, h = size
    scales = []
    s = float(upsample)
    while h * s >= min_height and w * s >= WINDOW_WIDTH:
        scales.append(s)
        s /= step
    return scales


def level_boxes(cy, cx, cell, scale):
    """(n, 4) frame person boxes ``(x, y, w, h)`` of the windows whose top-left cell is
    ``(cy, cx)`` on a pyramid level of ``scale`` level pixels per frame pixel, cells of
    ``cell`` level pixels."""
    x0, y0, x1, y1 = PERSON_BOX_WINDOW
    left = cx * cell + x0                  # level pixel coordinates
    top = cy * cell + y0
    # level pixel (u) -> frame pixel: (u + 0.5) / scale - 0.5
    bx = (left + 0.5) / scale - 0.5
    by = (top + 0.5) / scale - 0.5
    return np.stack([bx, by, np.full_like(bx, (x1 - x0) / scale),
                     np.full_like(by, (y1 - y0) / scale)], 1)


def kind_nms(boxes, scores, threshold, kind, vote=0.0):
    """Threshold and NMS with the setting of the adapted detector ``kind`` (``vote``: box
    voting's temperature, :func:`viewadapt.nms.voted_boxes`; 0 none)."""
    return detections_from_scores(boxes, scores, threshold=threshold, overlap=kind.nms_overlap,
                                  nms_threshold=kind.nms_threshold, vote=vote)


def hog_pyramid_detect(image, models, *, upsample: int = 4, step: float = 1.05,
                       threshold: float = 0.0, vote: float = 0.0) -> np.ndarray:
    """The unadapted HOG/SVM slid over an image pyramid of the upsampled frame.

    Every level's block-normalised 8-px cells (:func:`viewadapt.detect.hog_frame_features`)
    are cross-correlated with the (16, 8, 13) weights; windows at a one-cell stride.
    """
    import cv2

    from viewadapt.detect import channel_slices3, correlate_slices, hog_frame_features

    h, w = image.shape[:2]
    T = np.asarray(models.hog_weights, np.float32)
    T3 = channel_slices3(T)
    boxes, scores = [], []
    for s in pyramid_scales((w, h), upsample, step):
        level = cv2.resize(image, (int(round(w * s)), int(round(h * s))),
                           interpolation=cv2.INTER_LINEAR)
        F = hog_frame_features(level, [8], pad=0).maps[8]
        if F.shape[0] < 16 or F.shape[1] < 8:
            continue
        res = correlate_slices(channel_slices3(F), T3) + models.hog_bias
        cy, cx = np.nonzero(res > threshold)
        if cy.size:
            boxes.append(level_boxes(cy, cx, 8, level.shape[1] / w))
            scores.append(res[cy, cx])
    if not boxes:
        return np.zeros((0, 5))
    return kind_nms(np.concatenate(boxes), np.concatenate(scores).astype(float), threshold,
                    HOG_DETECTOR, vote)


def dense_cascade_scores(model, C, positions):
    """Soft-cascade scores of windows read straight from an ACF channel map.

    ``C`` (10, h, w) channels, ``positions`` (n, 2) top-left blocks ``(y, x)``; feature
    ``f`` of the (10, 32, 16) layout is ``C[ch, y + i, x + j]``. A compiled loop
    (:meth:`viewadapt.boosting.AdaBoostTrees.gathered_scores`), one window at a time, each
    stopping at the soft cascade's rejection threshold
    (``acfDetect1``; :func:`viewadapt.boosting.cascade_step`): the same scores as
    :func:`dense_cascade_scores_reference`, bit for bit.

    Returns
    -------
    (n,) float64 ndarray
    """
    C = np.ascontiguousarray(C, np.float32)
    _, h, w = C.shape
    ch, ii, jj = np.unravel_index(np.arange(10 * 32 * 16), (10, 32, 16))
    offset = (ch * h * w + ii * w + jj).astype(np.int64)
    positions = np.asarray(positions, np.int64).reshape(-1, 2)
    origin = positions[:, 0] * w + positions[:, 1]
    if len(origin) == 0:
        return np.empty(0)
    return model.gathered_scores(C.ravel(), origin, offset)


def dense_cascade_scores_reference(model, C, positions, block=32):
    """:func:`dense_cascade_scores` in numpy: trees evaluated in blocks of ``block`` over
    the windows still above the cascade's rejection threshold (the slow reference)."""
    ch, ii, jj = np.unravel_index(np.arange(10 * 32 * 16), (10, 32, 16))
    feat, thr_, val = model.feature_, model.threshold_, model.value_
    depth = (feat.shape[1] + 1).bit_length() - 2
    n = positions.shape[0]
    score = np.zeros(n)
    alive = np.arange(n)
    casc = model.cascade_threshold
    for t0 in range(0, feat.shape[0], block):
        if alive.size == 0:
            break
        t1 = min(feat.shape[0], t0 + block)
        trees = np.arange(t1 - t0)[None, :]
        node = np.zeros((alive.size, t1 - t0), np.intp)
        py, px = positions[alive, 0][:, None], positions[alive, 1][:, None]
        for _ in range(depth):
            f = feat[t0:t1][trees, node]
            fi = np.maximum(f, 0)
            v = C[ch[fi], py + ii[fi], px + jj[fi]]
            go = v >= thr_[t0:t1][trees, node]
            node = np.where(f >= 0, 2 * node + 1 + go, node)
        score[alive], stopped = cascade_step(score[alive], val[t0:t1][trees, node], casc,
                                             model.cascade_scale_[t0:t1])
        alive = alive[~stopped]
    return score


class PyramidLevel(NamedTuple):
    """One level of an ACF channel pyramid.

    ``scale`` level pixels per frame pixel (the level image's width over the frame's);
    ``channels`` (10, H // 4, W // 4) float32, the layout of
    :func:`viewadapt.detect.acf_window_features`; ``real`` True where the channels were
    computed from the resampled image, False where approximated from another level.
    """

    scale: float
    channels: np.ndarray
    real: bool


def _level_size(size, s):
    """(W, H) of the pyramid level of scale ``s``: multiples of the 4-px block."""
    w, h = size
    return int(round(w * s)) // ACF_SHRINK * ACF_SHRINK, \
        int(round(h * s)) // ACF_SHRINK * ACF_SHRINK


def _level_image(image, W, H):
    import cv2

    return cv2.resize(image, (W, H), interpolation=cv2.INTER_LINEAR)


def acf_pyramid_levels(image, *, upsample: int = 4, per_octave: int = 4) -> list:
    """ACF channels computed exactly at every level of the upsampled frame's pyramid.

    Each level is the frame resized (bilinear) to ``upsample * 2 ** (-k / per_octave)``
    times its size, rounded down to whole 4-px blocks, then
    :func:`viewadapt.detect.acf_frame_features` at :data:`~viewadapt.detect.ACF_SHRINK` --
    the channels the detector was trained on.

    Parameters
    ----------
    image : (M, N[, 3]) ndarray
    upsample : int
        Scale of the first (largest) level.
    per_octave : int
        Levels per octave.

    Returns
    -------
    list of :class:`PyramidLevel`, largest first, all ``real``.
    """
    h, w = image.shape[:2]
    out = []
    for s in pyramid_scales((w, h), upsample, 2 ** (1 / per_octave)):
        W, H = _level_size((w, h), s)
        F = acf_frame_features(_level_image(image, W, H), [ACF_SHRINK], pad=0).maps[ACF_SHRINK]
        out.append(PyramidLevel(W / w, np.moveaxis(F, -1, 0), True))
    return out


def smooth_channel_maps(A, radius: float = 1) -> np.ndarray:
    """``convTri(A, radius)`` of (h, w, C) float32 channel maps, border reflected: the
    post-aggregation smoothing of :func:`viewadapt.detect.acf_frame_features`
    (``smooth_channels``), the same arithmetic."""
    import cv2

    from viewadapt.acf import convolve_triangle, triangle_kernel

    tri = triangle_kernel(radius)
    if tri is None:
        return A
    if min(A.shape[:2]) > 1:
        k = tri.astype(np.float32)
        return cv2.sepFilter2D(A, -1, k, k, borderType=cv2.BORDER_REFLECT)
    return np.moveaxis(convolve_triangle(np.moveaxis(A, -1, 0), radius), 0, -1) \
        .astype(np.float32)


def _resize_channels(A, size, interpolation):
    """(h, w, C) maps resized to ``size`` (width, height), four channels per OpenCV call
    (OpenCV's area resampling takes at most four)."""
    import cv2

    out = np.empty((size[1], size[0], A.shape[2]), np.float32)
    for c in range(0, A.shape[2], 4):
        r = cv2.resize(np.ascontiguousarray(A[..., c:c + 4]), size, interpolation=interpolation)
        out[..., c:c + 4] = r.reshape(size[1], size[0], -1)
    return out


def acf_fast_pyramid_levels(image, *, upsample: int = 4, per_octave: int = 4,
                            lambdas=ACF_PYRAMID_LAMBDAS, interpolation=None,
                            smooth_channels: float = 1) -> list:
    """Dollár's fast feature pyramid of the upsampled frame: ACF channels computed exactly
    once per octave, approximated in between.

    The levels and their sizes are those of :func:`acf_pyramid_levels`. Levels ``k`` with
    ``k % per_octave == 0`` are *real*: the unsmoothed block means of
    :func:`viewadapt.detect.acf_frame_features` of the resized frame. Every other level is
    approximated from the nearest real level ``r`` (ties to the larger level, as
    ``chnsPyramid``): its unsmoothed channels resampled to the level's size and each
    channel type ``Omega`` multiplied by the power law

    .. math:: C_\\Omega(I_{s}) \\approx R(C_\\Omega(I_{s_r}), s / s_r)
              \\, (s / s_r)^{-\\lambda_\\Omega}

    (Dollár et al. 2014, eq. (4)). Then every level is smoothed (``convTri``,
    ``smooth_channels``) as the exact pyramid is, so the real levels equal
    :func:`acf_pyramid_levels`' levels.

    Parameters
    ----------
    image : (M, N[, 3]) ndarray
    upsample, per_octave : int
        As :func:`acf_pyramid_levels`.
    lambdas : (3,) sequence of float
        ``lambda`` of the LUV, gradient magnitude and orientation channels
        (:data:`ACF_PYRAMID_LAMBDAS`).
    interpolation : int, optional
        OpenCV interpolation flag for the resampling; default ``INTER_AREA`` when a level
        is smaller than its real level, ``INTER_LINEAR`` when larger.
    smooth_channels : float
        ``convTri`` radius applied to every level after resampling.

    Returns
    -------
    list of :class:`PyramidLevel`, largest first.

    Notes
    -----
    The toolbox (``chnsPyramid``) computes real levels at ``nOctUp``-based scales and
    ``nPerOct = 8`` by default; here the scales are those of the exact pyramid, so the two
    baselines differ only by the approximation. ``lambda`` is not re-estimated per image:
    the project's value measured on rendered frames (Dollár's method: least squares of
    the log channel ratio against the log scale).

    References
    ----------
    P. Dollár, R. Appel, S. Belongie and P. Perona, "Fast Feature Pyramids for Object
    Detection", IEEE TPAMI 36(8), 2014.
    """
    import cv2

    lambdas = np.asarray(lambdas, float)
    if lambdas.shape != (3,) or not np.all(np.isfinite(lambdas)):
        raise ValueError(f"lambdas must be 3 finite numbers (LUV, magnitude, orientations), "
                         f"got {lambdas!r}")
    if int(per_octave) != per_octave or per_octave < 1:
        raise ValueError(f"per_octave must be a positive integer, got {per_octave!r}")
    per_octave = int(per_octave)
    h, w = image.shape[:2]
    scales = pyramid_scales((w, h), upsample, 2 ** (1 / per_octave))
    real = [k for k in range(len(scales)) if k % per_octave == 0]
    raw = {}
    for k in real:
        W, H = _level_size((w, h), scales[k])
        raw[k] = acf_frame_features(_level_image(image, W, H), [ACF_SHRINK], pad=0,
                                    smooth_channels=0).maps[ACF_SHRINK]
    out = []
    for k, s in enumerate(scales):
        W, H = _level_size((w, h), s)
        # nearest real level, ties to the larger (finer) one
        r = min(real, key=lambda j: (abs(j - k), j))
        A = raw[r]
        if r != k:
            up = W // ACF_SHRINK > A.shape[1]
            flag = interpolation if interpolation is not None else (
                cv2.INTER_LINEAR if up else cv2.INTER_AREA)
            A = _resize_channels(A, (W // ACF_SHRINK, H // ACF_SHRINK), flag)
            ratio = s / scales[r]
            for sl, lam in zip(_TYPE_SLICES, lambdas):
                if lam:
                    # Dollár et al. 2014, eq. (4): f(I_s) = f(I_{s_r}) (s / s_r) ** -lambda
                    A[..., sl] *= np.float32(ratio ** -lam)
        A = smooth_channel_maps(np.ascontiguousarray(A, np.float32), smooth_channels)
        out.append(PyramidLevel(W / w, np.moveaxis(A, -1, 0), r == k))
    return out


def _detect_levels(levels, model, threshold, vote=0.0):
    """Soft cascade at every block of every level; thresholded, NMS'd detections."""
    boxes, scores = [], []
    for lv in levels:
        C = lv.channels
        ny, nx = C.shape[1] - 32 + 1, C.shape[2] - 16 + 1
        if ny < 1 or nx < 1:
            continue
        yy, xx = np.mgrid[0:ny, 0:nx]
        pos = np.stack([yy.ravel(), xx.ravel()], 1)
        sc = dense_cascade_scores(model, C, pos)
        keep = sc > threshold
        if keep.any():
            boxes.append(level_boxes(pos[keep, 0], pos[keep, 1], ACF_SHRINK, lv.scale))
            scores.append(sc[keep])
    if not boxes:
        return np.zeros((0, 5))
    return kind_nms(np.concatenate(boxes), np.concatenate(scores), threshold, ACF_DETECTOR,
                    vote)


def acf_pyramid_detect(image, models, *, upsample: int = 4, per_octave: int = 4,
                       threshold: float = 0.0, vote: float = 0.0) -> np.ndarray:
    """The unadapted ACF detector over an image pyramid of the upsampled frame.

    Channels computed at every level (:func:`acf_pyramid_levels`, ``per_octave`` levels
    per octave), windows at a one-block (4 px) stride, the soft cascade reading features
    straight from the channel maps (:func:`dense_cascade_scores`).

    Returns
    -------
    (D, 5) ndarray ``(x, y, w, h, score)``, by decreasing score.
    """
    levels = acf_pyramid_levels(image, upsample=upsample, per_octave=per_octave)
    return _detect_levels(levels, models.acf, threshold, vote)


def acf_pyramid_fast_detect(image, models, *, upsample: int = 4, per_octave: int = 4,
                            lambdas=ACF_PYRAMID_LAMBDAS, threshold: float = 0.0,
                            vote: float = 0.0) -> np.ndarray:
    """The unadapted ACF detector over Dollár's fast feature pyramid of the upsampled frame.

    :func:`acf_pyramid_detect` with the channels of :func:`acf_fast_pyramid_levels`:
    computed exactly at one level per octave, power-law approximated at the
    ``per_octave - 1`` levels in between (Dollár et al. 2014); the same windows, soft
    cascade and NMS.

    Returns
    -------
    (D, 5) ndarray ``(x, y, w, h, score)``, by decreasing score.

    References
    ----------
    P. Dollár, R. Appel, S. Belongie and P. Perona, "Fast Feature Pyramids for Object
    Detection", IEEE TPAMI 36(8), 2014.
    """
    levels = acf_fast_pyramid_levels(image, upsample=upsample, per_octave=per_octave,
                                     lambdas=lambdas)
    return _detect_levels(levels, models.acf, threshold, vote)
