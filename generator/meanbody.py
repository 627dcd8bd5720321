"""The mean-body object model's profile, measured on a neutral anny body.

``python -m generator.meanbody`` builds anny's neutral adult (every phenotype parameter at
the middle of its range, adult age, 1.75 m, T-shirt and trousers, short hair, standing) --
none of the roster's persons, so the model holds no test data -- and writes
``viewadapt/data/mean_body.json``: the radius ``r(z)`` of a surface of revolution about the
body's vertical axis. At each height ``r`` is the mean half-width of the body's horizontal
slice over viewing directions (half the mean caliper width, i.e. the perimeter of the slice's
convex hull over ``2 pi``), so the model has the body's mean apparent width from any
azimuth; the top closes at the crown. :class:`viewadapt.objectmodel.SurfaceOfRevolution`
reads it.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from .specs import GarmentSpec, HairSpec, PersonSpec, PhenotypeSpec, PoseSpec

__all__ = ["neutral_person", "radius_profile", "main"]

OUT = Path(__file__).resolve().parents[1] / "viewadapt" / "data" / "mean_body.json"


def neutral_person(stature: float = 1.75) -> PersonSpec:
    """anny's neutral adult as a :class:`PersonSpec` (not in the roster)."""
    grey = (0.3, 0.3, 0.3)
    return PersonSpec(
        id="neutral", stature=stature,
        phenotype=PhenotypeSpec(gender=0.5, age=0.8335, muscle=0.5, weight=0.5, height=0.5,
                                proportions=0.5),
        skin=(0.6, 0.45, 0.35), top=GarmentSpec("tshirt", grey),
        bottom=GarmentSpec("trousers", grey), shoes=grey, hair=HairSpec("short", grey),
        pose=PoseSpec("standing"))


def radius_profile(points, n_levels: int = 36, n_directions: int = 36):
    """``(z, r)`` of the mean half-width of horizontal slices of a point cloud.

    Parameters
    ----------
    points : (N, 3) array_like
        Surface points, feet at ``z = 0``.
    n_levels : int
        Slices from the feet to the crown (each ``height / n_levels`` thick).
    n_directions : int
        Viewing directions over 180 degrees for the mean caliper width.

    Returns
    -------
    z : (n_levels + 1,) heights as fractions of the body height (the last is the crown,
        radius 0); r : (n_levels + 1,) radii as fractions of the body height.
    """
    P = np.asarray(points, dtype=np.float64)
    top = P[:, 2].max()
    edges = np.linspace(0.0, top, n_levels + 1)
    phi = np.arange(n_directions) * np.pi / n_directions
    dirs = np.stack([np.cos(phi), np.sin(phi)], -1)
    centre = np.median(P[:, :2], axis=0)
    zs, rs = [], []
    for lo, hi in zip(edges[:-1], edges[1:]):
        s = P[(P[:, 2] >= lo) & (P[:, 2] < hi), :2] - centre
        if len(s) < 3:
            continue
        proj = s @ dirs.T
        rs.append(0.5 * float((proj.max(0) - proj.min(0)).mean()))
        zs.append(0.5 * (lo + hi))
    return np.r_[zs, top] / top, np.r_[rs, 0.0] / top


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m generator.meanbody", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=OUT, help=f"JSON file (default {OUT})")
    ap.add_argument("--levels", type=int, default=36, help="height slices (default 36)")
    args = ap.parse_args(argv)
    from .body import BodyModel

    person = neutral_person()
    mesh = BodyModel().build(person, "standing")
    z, r = radius_profile(mesh.all_points(), n_levels=args.levels)
    doc = {"name": "mean body (surface of revolution)",
           "source": "python -m generator.meanbody: anny's neutral adult, standing, 1.75 m; "
                     "radius = mean half-width of each horizontal slice over 36 directions",
           "height_fraction": [round(float(v), 5) for v in z],
           "radius_fraction": [round(float(v), 5) for v in r]}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(doc, indent=1) + "\n")
    print(f"wrote {args.out}: {len(z)} levels, max radius {max(r) * person.stature:.3f} m")
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
