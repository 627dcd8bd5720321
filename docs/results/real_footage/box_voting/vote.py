"""One-off: box voting after non-maximum suppression (Gidaris & Komodakis 2015, "Object
detection via a multi-region & semantic segmentation-aware CNN model", Sec. 4: each kept
box replaced by the score-weighted mean of the candidate boxes overlapping it). Here each
kept box becomes the mean of the thresholded candidates whose overlap with it exceeds the
NMS threshold (its own overlap kind), weighted by exp((s_j - s_kept) / tau); scores and
window indices unchanged. Patched into every caller of viewadapt.nms.detections_from_scores
(adapted detectors, image warping, pyramids, OpenCV's detectMultiScale through _nms), then
the CLI runs (the product has the same since: viewadapt.nms.voted_boxes, --box-voting).
Usage: VOTE=tau python vote.py <viewadapt CLI args...>  (VOTE unset or 0:
plain NMS); or imported (patch(tau)) by other one-offs."""
import os
import sys

import numpy as np

import viewadapt.nms as nms

_plain = nms.detections_from_scores


def _overlaps(a, b, over_min):
    """(D, C) overlap of boxes a (D, 4) with b (C, 4), as the NMS kernel computes it."""
    ix = np.minimum(a[:, None, 0] + a[:, None, 2], b[None, :, 0] + b[None, :, 2]) - \
        np.maximum(a[:, None, 0], b[None, :, 0])
    iy = np.minimum(a[:, None, 1] + a[:, None, 3], b[None, :, 1] + b[None, :, 3]) - \
        np.maximum(a[:, None, 1], b[None, :, 1])
    inter = np.maximum(ix, 0) * np.maximum(iy, 0)
    aa, ab = a[:, 2] * a[:, 3], b[:, 2] * b[:, 3]
    den = np.minimum(aa[:, None], ab[None]) if over_min else aa[:, None] + ab[None] - inter
    return np.where(den > 0, inter / np.where(den > 0, den, 1), 0.0)


def voted(tau):
    def detections_from_scores(boxes, scores, *, threshold=0.0, nms_threshold=0.5,
                               overlap="union", max_candidates=2000, return_index=False,
                               vote=0.0):      # (the product's own voting, off: this one)
        dets, sel = _plain(boxes, scores, threshold=threshold, nms_threshold=nms_threshold,
                           overlap=overlap, max_candidates=max_candidates, return_index=True,
                           vote=0.0)
        if tau > 0 and len(sel):
            b = np.asarray(boxes, np.float64)
            s = np.asarray(scores, np.float64)
            cand = np.flatnonzero(s > threshold)
            if cand.size > max_candidates:
                cand = cand[np.argpartition(-s[cand], max_candidates - 1)[:max_candidates]]
            ov = _overlaps(b[sel], b[cand], overlap == "min")
            w = np.where(ov > nms_threshold, np.exp((s[cand][None] - s[sel][:, None]) / tau), 0)
            # the kept box itself always counts with weight 1
            w = np.where(cand[None] == sel[:, None], 1.0, w)
            dets = dets.copy()
            dets[:, :4] = (w @ b[cand]) / w.sum(1, keepdims=True)
        return (dets, sel) if return_index else dets
    return detections_from_scores


def patch(tau):
    import benchmark.frames.pyramids as py   # (its kind_nms serves the methods module too)
    import viewadapt.detect.templates as tp
    f = voted(float(tau))
    for mod in (nms, py, tp):
        mod.detections_from_scores = f


if __name__ == "__main__":
    patch(float(os.environ.get("VOTE", "0")))
    from viewadapt.cli import main
    sys.exit(main(sys.argv[1:]))
