"""One-off: source models from the effects render's persons (dsfx, seed 0) and the clean render's elevation-0
background windows (ds: the same background images without camera effects), C = 0.001, one ACF model, seeds 0-2;
compared on the clip with the existing p0n0 models (the same with dsfx's background windows)."""
from pathlib import Path
from benchmark.data import load_dataset
from benchmark.crops.features import background_windows, person_windows
from viewadapt.detect import train_on_windows
out = Path("/tmp/s12/models"); out.mkdir(exist_ok=True)
fx, clean = load_dataset(Path("/tmp/exp/dsfx")), load_dataset(Path("/tmp/exp/ds"))
pos = list(person_windows(fx, 0).images(fx.root))
ws_fx, ws_cl = background_windows(fx, 0, stride=16), background_windows(clean, 0, stride=16)
assert [p for p, *_ in ws_fx.items] == [p for p, *_ in ws_cl.items], "not the same background images"
neg = list(ws_cl.images(clean.root))
print(len(pos), len(neg), flush=True)
for seed in (0, 1, 2):
    f = out / f"p0n0clean_s{seed}.npz"
    train_on_windows(pos, neg, seed=seed, frame_view="both", svm_params={"C": 0.001},
                     acf_members=1).save(f)
    print(f, flush=True)
