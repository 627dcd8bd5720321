"""One-off: the `camera` recipe with its rotated negatives kept clean (only the positives and the plain
elevation-0 background windows through the camera effects), in sweep_decomposition on the clean render.

    python rot_clean.py DATA OUT CACHE
"""
import sys

import benchmark.recipes as R
import benchmark.studies.sweep_decomposition as sd
from benchmark.crops.features import rotated_windows

CAM = R.get_recipe("camera")


class RotationsClean(R.Recipe):
    def training_suffixes(self):
        return [("person", "cam"), ("background", "cam")] + [
            ("background", a) for a in self.negative_suffixes()]

    def training_sets(self, positives, background, warp=None):
        sets = [positives, background] + [rotated_windows(background, a) for a in self.rotations_deg]
        if warp is not None:
            sets = [warp(ws) for ws in sets]
        sets = [ws.through_camera(self.camera) if i < 2 else ws for i, ws in enumerate(sets)]
        return [(k, a, ws) for (k, a), ws in zip(self.training_suffixes(), sets)]


name = "camera_rotations_clean"
rec = RotationsClean(name, "as camera, the rotated negatives without the effects",
                     rotations_deg=CAM.rotations_deg, camera=CAM.camera)
orig = R.get_recipe
R.get_recipe = lambda n: rec if n == name else orig(n)
R.RECIPES = dict(R.RECIPES, **{name: rec})
data, out, cache = sys.argv[1:4]
sys.exit(sd.main(["--data", data, "--out", out, "--cache", cache, "--recipe", name, "--jobs", "2"]))
