"""How far a wrong elevation estimate misaligns the person, by the plane's geometry alone:
``python -m benchmark.studies.sweep_geometry [--source S] [--truths T ...]``.

A detector trained at elevation ``s`` and adapted to an estimate ``e`` reads a window of the
true elevation ``t`` as if the person plane had been seen from ``e``: the window is brought
into the training view by ``H(s -> e)^-1`` where ``H(s -> t)^-1`` would be right, so the
person it sees is the training view's person moved by ``M(e) = H(s -> e)^-1 H(s -> t)``. The
unadapted detector reads the window as it is: its person is moved by ``H(s -> t)``. Both are
pure geometry (:func:`viewadapt.geometry.elevation_homography`), known before any detector
is trained.

:func:`misalignment` measures such a map over the person's region of the training window
(the person 96 px tall, feet and head at :data:`~viewadapt.geometry.WINDOW_FEET` and
:data:`~viewadapt.geometry.WINDOW_HEAD`, 24 px wide): the mean displacement of its points
(``"displacement"``, px), or the mean ``|log|`` of its local vertical scale (``"scale"``: a
person stretched or squashed by a factor ``k`` scores ``|log k|`` either way).
:func:`misalignment_crossing` gives the estimate above the truth at which the adapted
detector's person is misaligned as much as the unadapted detector's: where a detector whose
miss rate grew with that misalignment alone, whatever its direction, would cross the
unadapted detector in the robustness sweep (Wang et al. 2017, Fig. 6). A sweep that crosses
later shows a detector that tolerates a stretched person better than a squashed one.
"""

from __future__ import annotations

import argparse

import numpy as np

from viewadapt.geometry import (
    WINDOW_CENTRE, WINDOW_FEET, WINDOW_HEAD, apply_homography, elevation_homography,
)

__all__ = ["MEASURES", "person_points", "misalignment", "misalignment_crossing", "main"]

#: the misalignment measures of :func:`misalignment`
MEASURES = ("displacement", "scale")
#: the person region's half width in the training window, px (a quarter of its height)
_HALF_WIDTH = 12.0
#: the vertical step of the local scale, px
_DY = 0.5


def person_points(step: float = 2.0) -> np.ndarray:
    """``(N, 2)`` points on a grid of ``step`` px over the person's region of the training
    window: 24 px wide about the window's centre line, from the head to the feet."""
    if not step > 0:
        raise ValueError(f"step must be positive, got {step!r}")
    xs = np.arange(WINDOW_CENTRE[0] - _HALF_WIDTH, WINDOW_CENTRE[0] + _HALF_WIDTH + 1e-9, step)
    ys = np.arange(WINDOW_HEAD[1], WINDOW_FEET[1] + 1e-9, step)
    yy, xx = np.meshgrid(ys, xs, indexing="ij")
    return np.stack([xx.ravel(), yy.ravel()], 1)


def misalignment(M, measure: str = "scale", points=None) -> float:
    """How far the map ``M`` (3x3 homography of training-window pixels) moves the person:
    the mean displacement of ``points`` (default :func:`person_points`) in px
    (``"displacement"``), or the mean ``|log|`` of the local vertical scale there
    (``"scale"``). 0 for the identity."""
    if measure not in MEASURES:
        raise ValueError(f"unknown measure {measure!r}; choose one of {', '.join(MEASURES)}")
    P = person_points() if points is None else np.asarray(points, float)
    Q = apply_homography(M, P)
    if measure == "displacement":
        return float(np.linalg.norm(Q - P, axis=1).mean())
    dQ = apply_homography(M, P + [0.0, _DY]) - Q
    return float(np.abs(np.log(np.linalg.norm(dQ, axis=1) / _DY)).mean())


def misalignment_crossing(truth: float, *, source: float = 0.0, measure: str = "scale",
                          step: float = 1e-3, distance: float = 10.0,
                          framing: str = "plane") -> float:
    """The smallest estimate ``e >= truth`` at which adapting to ``e`` misaligns the person as
    much as not adapting at all (:func:`misalignment` of ``M(e)`` reaches that of
    ``H(source -> truth)``), on a grid of ``step`` rad below pi/2; NaN if it never does."""
    if not 0 <= source < truth < np.pi / 2:
        raise ValueError(f"need 0 <= source < truth < pi/2, got source {source!r}, truth "
                         f"{truth!r}")
    kw = dict(distance=distance, framing=framing)
    H_true = elevation_homography(source, truth, **kw)
    points = person_points()
    unadapted = misalignment(H_true, measure, points)
    for e in np.arange(truth, np.pi / 2 - 1e-3, step):
        M = np.linalg.inv(elevation_homography(source, float(e), **kw)) @ H_true
        if misalignment(M, measure, points) >= unadapted:
            return float(e)
    return float("nan")


def main(argv=None) -> int:
    """Print, per true elevation, the unadapted misalignment and the estimate above the truth
    at which adapting misaligns as much, by each measure (a markdown table)."""
    ap = argparse.ArgumentParser(prog="python -m benchmark.studies.sweep_geometry",
                                 description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--source", type=float, default=0.0, help="training elevation, rad")
    ap.add_argument("--truths", type=float, nargs="+",
                    default=[np.pi / 8, np.pi / 6, np.pi / 4, np.pi / 3],
                    help="true target elevations, rad (default pi/8, pi/6, pi/4, pi/3)")
    ap.add_argument("--distance", type=float, default=10.0,
                    help="the crop camera's distance, m (the dataset's; default 10)")
    args = ap.parse_args(argv)
    lines = ["| truth (rad) | unadapted: scale, px | equal misalignment above the truth: "
             "scale | displacement |", "|---|---|---|---|"]
    try:
        for t in args.truths:
            H = elevation_homography(args.source, t, distance=args.distance)
            cross = [misalignment_crossing(t, source=args.source, measure=m,
                                           distance=args.distance) - t
                     for m in ("scale", "displacement")]
            lines.append(f"| {t:.3f} | {misalignment(H, 'scale'):.3f}, "
                         f"{misalignment(H, 'displacement'):.2f} | +{cross[0]:.3f} | "
                         f"+{cross[1]:.3f} |")
    except ValueError as exc:
        ap.exit(2, f"{ap.prog}: error: {exc}\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
