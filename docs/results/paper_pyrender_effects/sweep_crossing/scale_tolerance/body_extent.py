"""One-off: the mean body's and the plane's vertical extent in the crop window by elevation.

``python body_extent.py``: the shipped mean body (``SurfaceOfRevolution.mean_body()``, its
mesh's vertices projected by each elevation's crop camera, 10 m, 1.75 m) and the person
plane (rows 16 and 112 mapped by ``elevation_homography(0, e)``); each span as a share of
its elevation-0 span, and the elevation where the mean body's share reaches a given value
(linear between the grid's elevations). Output: body_extent.txt."""
import sys

import numpy as np

from viewadapt.geometry import apply_homography, crop_camera, elevation_homography
from viewadapt.objectmodel import SurfaceOfRevolution

V, _ = SurfaceOfRevolution.mean_body().mesh(1.75, segments=96)


def body_span(e):
    rows = crop_camera(e, distance=10.0, person_height=1.75).project(V)[:, 1]
    return rows.min(), rows.max()


def plane_share(e):
    q = apply_homography(elevation_homography(0.0, e), np.array([[32.0, 16.0], [32.0, 112.0]]))
    return (q[1, 1] - q[0, 1]) / 96.0


t0, b0 = body_span(0.0)
grid = np.round(np.arange(0.0, 1.2501, 0.025), 3)
share = []
print("elevation (rad) | mean body rows | body share | plane share")
for e in grid:
    t, b = body_span(e)
    share.append((b - t) / (b0 - t0))
    if np.isclose(e % 0.1, 0) or np.isclose(e % 0.1, 0.1) or np.isclose(e, np.pi / 4, atol=0.013):
        print(f"{e:.3f} | {t:.1f}-{b:.1f} | {share[-1]:.3f} | {plane_share(e):.3f}")
share = np.array(share)
print(f"pi/4: body share {(lambda s: (s[1] - s[0]) / (b0 - t0))(body_span(np.pi / 4)):.3f}, "
      f"plane {plane_share(np.pi / 4):.3f}")
for target in [float(v) for v in sys.argv[1:]] or [0.789 / 1.308]:
    e = np.interp(-target, -share, grid)           # share falls with the elevation
    print(f"body share {target:.3f} at {e:.3f} rad, {e - np.pi / 4:+.3f} above pi/4")
