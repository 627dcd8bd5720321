"""One-off probe (docs/training.md point 52): source training that has seen the adaptation operator.

Besides the source view's windows (recipe ``regularised``: C = 0.001), for each d in DELTAS
  negatives  the background windows' 4-px cells remapped by the covariant plane G(0 -> d), i.e. the
             source backgrounds as the adapted detector would read them in view d;
  roundtrip  the crops and the background windows warped into view d by the plane (image, crop
             first, as synthesised training warps them) and their 4-px cells remapped back by the
             same G: both classes carry what the remapping does to a window.
then ``benchmark.studies.sweep_decomposition``'s run on them.

Usage: adaptation_aware.py negatives|roundtrip DATA OUT CACHE
"""
import sys

import numpy as np

import benchmark.crops.sweep as sw
from benchmark.crops.crossval import variant_remap, view_maps
from benchmark.crops.detectors import detector_spec, feature_key
from benchmark.crops.features import background_windows, person_windows
from benchmark.recipes import Recipe
from viewadapt.adapt import remap_features
from viewadapt.geometry import elevation_homography

DELTAS = (np.pi / 8, np.pi / 4, 3 * np.pi / 8)
MODE = sys.argv[1] if __name__ == "__main__" else "negatives"
KINDS = ("person", "background") if MODE == "roundtrip" else ("background",)


def _suffix(d):
    return f"{'rt' if MODE == 'roundtrip' else 'remap'}{d:.4f}"


class AdaptationAware(Recipe):
    def training_suffixes(self):
        return super().training_suffixes() + [(k, _suffix(d)) for d in DELTAS for k in KINDS]


_prepare = sw.prepare


def prepare(ds, cfg, cache, elevations=None):
    data = _prepare(ds, cfg, cache, elevations)
    spec = detector_spec("hog")
    src = feature_key(spec.source_features)
    es = data["index"][0.0]
    sets = {"person": person_windows(ds, es),
            "background": background_windows(ds, es, stride=cfg.bg_stride)}
    for d in DELTAS:
        G = variant_remap("hog", view_maps(0.0, float(d), cfg)["plane"], "adapted", cfg)
        H = elevation_homography(0.0, float(d), distance=cfg.distance, framing=cfg.framing)
        for k in KINDS:
            ws = sets[k].warped(np.linalg.inv(H), _suffix(d)) if MODE == "roundtrip" else sets[k]
            X = remap_features(G, cache.get(ws, spec.target_features))
            data["feat"][(src, k, es, _suffix(d))] = X.astype(data["feat"][(src, k, es, "")].dtype)
    return data


sw.prepare = prepare

if __name__ == "__main__":
    import benchmark.recipes as rc
    from benchmark.studies import sweep_decomposition as sd

    if MODE not in ("negatives", "roundtrip") or len(sys.argv) != 5:
        raise SystemExit(__doc__)
    data, out, cache = sys.argv[2:5]
    rc.RECIPES[MODE] = AdaptationAware(MODE, f"probe (training.md 52): {MODE}, d = pi/8, pi/4, "
                                       "3pi/8, C = 0.001", svm_c=0.001)
    raise SystemExit(sd.main(["--data", data, "--out", out, "--cache", cache, "--jobs", "2",
                              "--recipe", MODE]))
