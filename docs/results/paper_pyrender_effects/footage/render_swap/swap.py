"""One-off: ACF (and HOG) trained on the persons of one render and the backgrounds of another."""
import sys
from pathlib import Path
from benchmark.data import load_dataset
from benchmark.frames.methods import source_training_windows
from viewadapt.detect import train_on_windows
out = Path("/tmp/s10/swap"); out.mkdir(exist_ok=True)
ds = {0: load_dataset(Path("/tmp/exp/dsfx")), 1: load_dataset(Path("/tmp/exp/dsfx_s1"))}
win = {k: source_training_windows(d, "regularised") for k, d in ds.items()}
for p, n in [(0, 1), (1, 0), (0, 0), (1, 1)]:
    for seed in (0, 1, 2):
        f = out / f"p{p}n{n}_s{seed}.npz"
        if f.exists():
            continue
        m = train_on_windows(win[p][0], win[n][1], seed=seed, frame_view="both",
                             svm_params={"C": 0.001}, acf_members=1)
        m.training.update(persons_render=p, backgrounds_render=n)
        m.save(f)
        print(f, flush=True)
