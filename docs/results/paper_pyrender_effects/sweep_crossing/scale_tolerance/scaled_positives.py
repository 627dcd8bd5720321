"""One-off: the effects render with its pi/4 persons replaced by elevation-0 persons scaled.

``python scaled_positives.py SRC OUT K``: a dataset linked file by file to SRC (a rendered
dataset; :func:`benchmark.studies.derived_data.derive_dataset`), except that every person
crop at pi/4 is replaced by the elevation-0 crop of the same person, scene and instance
scaled vertically by ``K`` about the window's middle row (63.5;
:func:`~benchmark.studies.derived_data.scale_vertically`: bilinear, rows beyond the crop
replicated from its border, a vertical anti-aliasing blur for ``K < 1``). Nothing else
changes -- the elevation-0 crops the source detector trains on and every background are
SRC's -- so a cross-validation on OUT has SRC's fold models and negatives, and its
``unadapted`` row is the source detector's miss rate on its own view's persons made
``K`` times as tall (K < 1: compressed, as an elevated view compresses them; K > 1:
stretched, as an adapted detector whose elevation estimate is too high stretches them).

``python scaled_positives.py SRC OUT 1 --flat-rows B`` (the control of the replicated
border): the crops unscaled, their top and bottom ``B`` rows replaced by copies of the
nearest row kept -- the rows that ``K < 1`` fills from the border (B = 14 for K = 0.789).
"""
import sys
from pathlib import Path

from benchmark.studies.derived_data import derive_from_source_view, scale_vertically

src, out, k = Path(sys.argv[1]), Path(sys.argv[2]), float(sys.argv[3])
flat = int(sys.argv[5]) if len(sys.argv) == 6 and sys.argv[4] == "--flat-rows" else 0
assert len(sys.argv) in (4, 6) and (flat == 0 or k == 1.0)


def make(img, twin, row):
    if not flat:
        return scale_vertically(img, k)
    img[:flat] = img[flat]
    img[-flat:] = img[-flat - 1]
    return img


n = derive_from_source_view(src, out, f"pi/4 person crops replaced by the elevation-0 crops of "
                            f"the same person, scene and instance scaled vertically by {k}, "
                            f"{flat} flat rows at top and bottom (scaled_positives.py)", make)
print(n, f"pi/4 person crops replaced by elevation-0 crops scaled by {k}")
