"""What a detector's errors on a clip are, at an operating point (Caltech protocol).

At each operating point (a false-positive rate per image, its score threshold read from
the DET curve) the errors of :mod:`viewadapt.detect.evaluation`'s matching are sorted:

* misses -- the miss rate of persons with a neighbour (another annotated person whose box
  overlaps theirs by at least a fifth of its width and half its height: the people of a
  group, whom a window of one person also shows) against those alone, and by box height;
* false positives -- *localisation* errors (the best IoU with a ground-truth box between
  0.3 and 0.5: a person found, badly framed; counted apart when that person is missed, an
  error twice), *duplicates* (IoU at least 0.5 with a box another detection already
  matched) and *background* (the rest).

:func:`error_map` draws every counted person's foot point on a frame of the clip, found
or missed, and the false positives' foot points. ``viewadapt bench footage`` writes both
for its run (``errors.md``, ``error_map.jpg``);
:mod:`benchmark.studies.footage_errors` for detections a run stored.
"""

from __future__ import annotations

import numpy as np

from viewadapt.boxes import box_iou

__all__ = ["ERROR_FPPIS", "HEIGHT_BANDS", "neighbours", "frames_at_fppi", "error_breakdown",
           "error_map", "clip_errors", "error_lines", "map_grid"]

#: The operating points ``bench footage`` reports the errors at, false positives per image.
ERROR_FPPIS = (0.1, 1.0)
#: Box-height bands of the miss rates, pixels.
HEIGHT_BANDS = (0, 60, 80, 100, 130, np.inf)


def neighbours(boxes) -> np.ndarray:
    """(G,) bool: boxes ``(x, y, w, h)`` overlapped by another box by at least a fifth of
    their width and half their height."""
    b = np.asarray(boxes, float).reshape(-1, 4)
    x0, x1, y0, y1 = b[:, 0], b[:, 0] + b[:, 2], b[:, 1], b[:, 1] + b[:, 3]
    ox = np.clip(np.minimum(x1[:, None], x1[None]) - np.maximum(x0[:, None], x0[None]), 0, None)
    oy = np.clip(np.minimum(y1[:, None], y1[None]) - np.maximum(y0[:, None], y0[None]), 0, None)
    near = (ox >= 0.2 * b[:, 2:3]) & (oy >= 0.5 * b[:, 3:4])
    np.fill_diagonal(near, False)
    return near.any(axis=1)


def _error_rows(detections, truth, image_size, regions):
    """The protocol's rows and matches of every frame (once per method, whatever the
    operating points) and each frame's neighbour flags."""
    from viewadapt.detect.evaluation import evaluation_rows, frame_matches

    gt = [(t.boxes, t.occlusion, image_size, t.ignore) for t in truth]
    dts, gts = evaluation_rows(detections, gt, regions=regions)
    nbs = [neighbours(t.boxes) if len(t.boxes) else np.zeros(0, bool) for t in truth]
    return dts, gts, frame_matches(dts, gts), nbs


def _frames_at(rows, fppi):
    """Per frame at the threshold of ``fppi``: (standardised detections kept, their labels,
    the ground-truth rows, found flags, neighbour flags) and the threshold."""
    from viewadapt.detect.evaluation import frame_matches, matches_threshold_at_fppi

    dts, gts, matches, nbs = rows
    thr = matches_threshold_at_fppi(matches, fppi)
    frames = []
    for d, g, nb in zip(dts, gts, nbs):
        d = d[d[:, 4] >= thr]
        m = frame_matches([d], [g])[0]
        frames.append((d, np.asarray(m.dt_labels), g, np.asarray(m.gt_matched, bool), nb))
    return frames, thr


def frames_at_fppi(detections, truth, image_size, *, regions=None, fppi: float = 1.0):
    """Per frame at the threshold that gives ``fppi`` false positives per image (the
    protocol's rows, standardised): ``(detections kept, their labels (1 hit, 0 false
    positive, -1 ignored), ground-truth rows, found flags, neighbour flags)``, and the
    threshold. Parameters as :func:`error_breakdown`'s."""
    return _frames_at(_error_rows(detections, truth, image_size, regions), fppi)


def error_breakdown(detections, truth, image_size, *, regions=None, fppi: float = 1.0) -> dict:
    """The errors of one method at ``fppi`` false positives per image.

    Parameters
    ----------
    detections : list of (D, 5) array_like
        Per frame ``(x, y, w, h, score)`` in the frame's pixels.
    truth : list of FrameBoxes
        Per frame, its ground truth.
    image_size : (width, height)
    regions : list of polygons, optional
        Ignore regions.
    fppi : float
        The operating point.

    Returns
    -------
    dict
        ``threshold``; ``counted`` and ``missed`` persons; ``with_neighbour`` and
        ``missed_with_neighbour``; ``height_bands`` ``[(low, high, counted, missed)]``;
        ``false_positives`` and of them ``localisation`` (of which
        ``localisation_on_missed``: on a person who is missed), ``duplicates`` and
        ``background``; ``log_height_ratio_mean`` and ``_sd`` of ``log(h_det / h_gt)``
        over the hits.
    """
    return _breakdown(*frames_at_fppi(detections, truth, image_size, regions=regions,
                                      fppi=fppi))


def _breakdown(frames, thr) -> dict:
    """:func:`error_breakdown` of :func:`_frames_at`'s frames."""
    out = dict(threshold=thr, counted=0, missed=0, with_neighbour=0, missed_with_neighbour=0,
               false_positives=0, localisation=0, localisation_on_missed=0, duplicates=0,
               background=0)
    bands = np.zeros((len(HEIGHT_BANDS) - 1, 2), int)
    ratios = []
    for d, labels, g, found, nb in frames:
        counted = g[:, 4] == 0
        missed = counted & ~found
        out["counted"] += int(counted.sum())
        out["missed"] += int(missed.sum())
        out["with_neighbour"] += int((counted & nb).sum())
        out["missed_with_neighbour"] += int((missed & nb).sum())
        k = np.digitize(g[:, 3], HEIGHT_BANDS[1:-1])
        np.add.at(bands[:, 0], k[counted], 1)
        np.add.at(bands[:, 1], k[missed], 1)
        hit = labels == 1
        if hit.any():            # each hit against the counted box it overlaps most
            iou = box_iou(d[hit, :4], g[:, :4]) * counted[None, :]
            ratios += (d[hit, 3] / g[iou.argmax(axis=1), 3]).tolist()
        fp = labels == 0
        if fp.any():
            iou = box_iou(d[fp, :4], g[:, :4])
            best = iou.max(axis=1) if len(g) else np.zeros(fp.sum())
            loc = (best >= 0.3) & (best < 0.5)
            out["false_positives"] += int(fp.sum())
            out["duplicates"] += int((best >= 0.5).sum())
            out["localisation"] += int(loc.sum())
            if loc.any():        # the person it frames badly, missed: an error twice
                out["localisation_on_missed"] += int(missed[iou[loc].argmax(axis=1)].sum())
            out["background"] += int((best < 0.3).sum())
    r = np.log(ratios) if ratios else np.zeros(0)
    out["log_height_ratio_mean"] = float(r.mean()) if len(r) else float("nan")
    out["log_height_ratio_sd"] = float(r.std()) if len(r) else float("nan")
    out["height_bands"] = [(float(lo), float(hi), int(c), int(m)) for (lo, hi), (c, m)
                           in zip(zip(HEIGHT_BANDS[:-1], HEIGHT_BANDS[1:]), bands)]
    return out


def error_map(image, detections, truth, image_size, *, regions=None, fppi: float = 1.0,
              title: str = "") -> np.ndarray:
    """``image`` (an RGB frame of the clip) dimmed, with every counted person's foot point
    over all frames (green found, red missed at ``fppi``) and the false positives' foot
    points (cyan crosses): a (H, W, 3) uint8 image."""
    frames, _ = frames_at_fppi(detections, truth, image_size, regions=regions, fppi=fppi)
    return _draw(image, frames, truth, title)


def _draw(image, frames, truth, title) -> np.ndarray:
    """:func:`error_map` of :func:`_frames_at`'s frames."""
    import cv2

    img = (np.asarray(image, np.uint8) // 2 + 60).astype(np.uint8)
    img = np.ascontiguousarray(img)
    for (d, labels, g, found, _), t in zip(frames, truth):
        for j, b in enumerate(np.asarray(t.boxes, float).reshape(-1, 4)):
            if g[j, 4] == 0:
                colour = (0, 200, 0) if found[j] else (230, 0, 0)
                cv2.circle(img, (int(b[0] + b[2] / 2), int(b[1] + b[3])), 3, colour, -1)
        for b in d[labels == 0]:
            cv2.drawMarker(img, (int(b[0] + b[2] / 2), int(b[1] + b[3])), (0, 230, 230),
                           cv2.MARKER_TILTED_CROSS, 7, 1)
    if title:
        cv2.putText(img, title, (10, 25), cv2.FONT_HERSHEY_SIMPLEX, 0.7, (255, 255, 255), 2)
    return img


def clip_errors(image, detections, truth, image_size, *, regions=None, fppis=ERROR_FPPIS,
                title: str = "") -> tuple[dict, np.ndarray]:
    """``({fppi: error_breakdown(...)}, error_map(...) at the last fppi)`` of one method,
    the protocol's rows and matches computed once for all the operating points."""
    rows = _error_rows(detections, truth, image_size, regions)
    at = {f: _frames_at(rows, f) for f in fppis}
    return ({f: _breakdown(*at[f]) for f in fppis},
            _draw(image, at[fppis[-1]][0], truth, title))


def _rate(missed, counted) -> str:
    return f"{missed / counted:.3f} ({missed}/{counted})" if counted else "-"


def error_lines(results, fppis) -> list[str]:
    """Markdown tables of ``{method: {fppi: error_breakdown(...)}}``: the errors at each
    operating point, then the miss rate by box height at the last."""
    out = ["| method | FPPI | threshold | miss rate | with a neighbour | alone | "
           "false positives | localisation (on a missed person) | duplicates | background | "
           "hits' log(h / h_gt): mean, sd |",
           "|---|---|---|---|---|---|---|---|---|---|---|"]
    for m, per in results.items():
        for f in fppis:
            r = per[f]
            alone = (r["missed"] - r["missed_with_neighbour"],
                     r["counted"] - r["with_neighbour"])
            out.append(f"| {m} | {f:g} | {r['threshold']:.3f} | "
                       f"{_rate(r['missed'], r['counted'])} | "
                       f"{_rate(r['missed_with_neighbour'], r['with_neighbour'])} | "
                       f"{_rate(*alone)} | {r['false_positives']} | {r['localisation']} "
                       f"({r['localisation_on_missed']}) | "
                       f"{r['duplicates']} | {r['background']} | "
                       f"{r['log_height_ratio_mean']:+.3f}, {r['log_height_ratio_sd']:.3f} |")
    bands = next(iter(next(iter(results.values())).values()))["height_bands"]
    out += ["", f"Miss rate by box height (px) at {fppis[-1]:g} FPPI:", "",
            "| method | " + " | ".join(f"{lo:g}-{hi:g}" for lo, hi, _, _ in bands) + " |",
            "|---|" + "---|" * len(bands)]
    for m, per in results.items():
        out.append(f"| {m} | " + " | ".join(_rate(mi, c) for _, _, c, mi
                                            in per[fppis[-1]]["height_bands"]) + " |")
    return out


def map_grid(maps, width: int = 640) -> np.ndarray:
    """:func:`error_map` images stacked, scaled down to at most ``width`` px wide (RGB)."""
    import cv2

    grid = np.vstack(maps)
    if grid.shape[1] > width:
        s = width / grid.shape[1]
        grid = cv2.resize(grid, None, fx=s, fy=s, interpolation=cv2.INTER_AREA)
    return grid
