"""One-off: source models from the effects render (dsfx, seed 0) with every training window (persons and
elevation-0 background windows) once more through sensor noise (the camera recipe's noise range, its own
draw per window), C = 0.001, one ACF model, seeds 0-2; compared on the clip with p0n0 (the same without)."""
from pathlib import Path
from benchmark.data import load_dataset
from benchmark.crops.features import background_windows, person_windows
from viewadapt.camera.effects import SURVEILLANCE_CAMERA as CAM, CameraEffects
from viewadapt.detect import train_on_windows
out = Path("/tmp/s12/models"); out.mkdir(exist_ok=True)
fx = load_dataset(Path("/tmp/exp/dsfx"))
noise = CameraEffects(noise_sigma=CAM.noise_sigma)
pos = list(person_windows(fx, 0).through_camera(noise).images(fx.root))
neg = list(background_windows(fx, 0, stride=16).through_camera(noise).images(fx.root))
print(len(pos), len(neg), flush=True)
for seed in (0, 1, 2):
    f = out / f"p0n0noise_s{seed}.npz"
    train_on_windows(pos, neg, seed=seed, frame_view="both", svm_params={"C": 0.001},
                     acf_members=1).save(f)
    print(f, flush=True)
