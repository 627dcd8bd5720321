"""One-off: source models of the effects render (dsfx, seed 0) with one change to its training windows,
C = 0.001, one ACF model, seeds 0-2, for `benchmark.studies.footage_models` against the same without (the
render-swap study's p0n0 models). Training.md points 50 and 51.

    python source_variants.py clean-negatives   # elevation-0 background windows of the clean render (ds):
                                                # the same images without camera effects
    python source_variants.py extra-noise       # every window once more through the camera recipe's noise
"""
import sys
from pathlib import Path

from benchmark.crops.features import background_windows, person_windows
from benchmark.data import load_dataset
from viewadapt.camera.effects import SURVEILLANCE_CAMERA as CAM, CameraEffects
from viewadapt.detect import train_on_windows


def windows(variant):
    fx = load_dataset(Path("/tmp/exp/dsfx"))
    pos, bg = person_windows(fx, 0), background_windows(fx, 0, stride=16)
    if variant == "clean-negatives":
        clean = load_dataset(Path("/tmp/exp/ds"))
        bg_clean = background_windows(clean, 0, stride=16)
        assert [p for p, *_ in bg.items] == [p for p, *_ in bg_clean.items], "not the same images"
        return list(pos.images(fx.root)), list(bg_clean.images(clean.root))
    if variant == "extra-noise":
        noise = CameraEffects(noise_sigma=CAM.noise_sigma)
        return (list(pos.through_camera(noise).images(fx.root)),
                list(bg.through_camera(noise).images(fx.root)))
    raise SystemExit(f"unknown variant {variant!r}: clean-negatives or extra-noise")


if __name__ == "__main__":
    variant = sys.argv[1]
    pos, neg = windows(variant)
    out = Path("/tmp/s12/models"); out.mkdir(exist_ok=True)
    tag = {"clean-negatives": "p0n0clean", "extra-noise": "p0n0noise"}[variant]
    for seed in (0, 1, 2):
        f = out / f"{tag}_s{seed}.npz"
        train_on_windows(pos, neg, seed=seed, frame_view="both", svm_params={"C": 0.001},
                         acf_members=1).save(f)
        print(f, flush=True)
