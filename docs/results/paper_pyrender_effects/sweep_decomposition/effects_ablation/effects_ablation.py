"""One-off: sweep_decomposition on the clean paper render under `rotated` plus ONE group of the
`camera` recipe's surveillance-camera effects (same ranges, so the same draws), to find which effect
brings back the covariant orientation map's cost at the truth.

    python effects_ablation.py GROUP DATA OUT CACHE     (GROUP: noise jpeg downscale blur photometric)
"""
import sys
from dataclasses import replace

import benchmark.recipes as R
import benchmark.studies.sweep_decomposition as sd
from viewadapt.camera.effects import SURVEILLANCE_CAMERA as CAM, CameraEffects

GROUPS = {
    "noise": dict(noise_sigma=CAM.noise_sigma),
    "jpeg": dict(jpeg_quality=CAM.jpeg_quality),
    "downscale": dict(downscale=CAM.downscale),
    "blur": dict(blur_sigma=CAM.blur_sigma),
    "photometric": dict(vignetting=CAM.vignetting, white_balance=CAM.white_balance,
                        exposure=CAM.exposure, gamma=CAM.gamma),
}
group, data, out, cache = sys.argv[1:5]
name = f"camera_{group}"
rec = replace(R.get_recipe("camera"), name=name, camera=CameraEffects(**GROUPS[group]),
              summary=f"as rotated, the training windows through the camera recipe's {group} only")
orig = R.get_recipe
R.get_recipe = lambda n: rec if n == name else orig(n)
R.RECIPES = dict(R.RECIPES, **{name: rec})
sys.exit(sd.main(["--data", data, "--out", out, "--cache", cache, "--recipe", name, "--jobs", "2"]))
