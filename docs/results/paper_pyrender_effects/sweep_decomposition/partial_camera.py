"""One-off: the `camera` recipe with one part of its training windows kept clean, in sweep_decomposition on
the clean render.

    python partial_camera.py rotations|positives DATA OUT CACHE
      rotations: the rotated negatives clean (the positives and plain backgrounds through the effects)
      positives: the positives clean (the plain backgrounds and their rotations through the effects)
"""
import sys

import benchmark.recipes as R
import benchmark.studies.sweep_decomposition as sd
from benchmark.crops.features import rotated_windows

CAM = R.get_recipe("camera")


class PartlyClean(R.Recipe):
    clean = "rotations"         # which sets stay clean: "rotations" or "positives"

    def _through(self, i):      # set i: 0 the positives, 1 the backgrounds, 2... their rotations
        return i >= 1 if self.clean == "positives" else i < 2

    def training_suffixes(self):
        plain = [("person", ""), ("background", "")] + [
            ("background", a) for a in self.negative_suffixes()]
        return [(k, (f"{a}|cam" if a else "cam") if self._through(i) else a)
                for i, (k, a) in enumerate(plain)]

    def training_sets(self, positives, background, warp=None):
        sets = [positives, background] + [rotated_windows(background, a) for a in self.rotations_deg]
        if warp is not None:
            sets = [warp(ws) for ws in sets]
        sets = [ws.through_camera(self.camera) if self._through(i) else ws for i, ws in enumerate(sets)]
        return [(k, a, ws) for (k, a), ws in zip(self.training_suffixes(), sets)]


part = sys.argv[1]
PartlyClean.clean = part
name = f"camera_{part}_clean"
rec = PartlyClean(name, f"as camera, the {part} without the effects",
                  rotations_deg=CAM.rotations_deg, camera=CAM.camera)
orig = R.get_recipe
R.get_recipe = lambda n: rec if n == name else orig(n)
R.RECIPES = dict(R.RECIPES, **{name: rec})
data, out, cache = sys.argv[2:5]
sys.exit(sd.main(["--data", data, "--out", out, "--cache", cache, "--recipe", name, "--jobs", "2"]))
