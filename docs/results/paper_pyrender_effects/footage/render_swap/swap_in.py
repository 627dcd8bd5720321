"""One-off: persons and outdoor background windows of render 0; of the indoor scenes, one
half from render 1 and the other from render 0."""
from pathlib import Path
from benchmark.data import load_dataset
from benchmark.crops.features import background_windows, person_windows
from viewadapt.detect import train_on_windows
OUTDOOR = {"carpark", "market", "park", "plaza", "promenade", "schoolyard", "street"}
HALF_A = {"corridor", "lobby", "office"}
out = Path("/tmp/s10/swap")
ds = {0: load_dataset(Path("/tmp/exp/dsfx")), 1: load_dataset(Path("/tmp/exp/dsfx_s1"))}
pos = list(person_windows(ds[0], 0).images(ds[0].root))
parts = {}
for k, d in ds.items():
    ws = background_windows(d, 0, stride=16)
    imgs = list(ws.images(d.root))
    scene = ws.meta.scene_id.to_numpy()
    parts[k] = {g: [im for im, s in zip(imgs, scene) if sel(s)] for g, sel in
                {"out": lambda s: s in OUTDOOR, "a": lambda s: s in HALF_A,
                 "b": lambda s: s not in OUTDOOR and s not in HALF_A}.items()}
    print(k, {g: len(v) for g, v in parts[k].items()}, flush=True)
for name, (a, b) in {"inA1": (1, 0), "inB1": (0, 1)}.items():
    for seed in (0, 1, 2):
        f = out / f"p0{name}_s{seed}.npz"
        neg = parts[0]["out"] + parts[a]["a"] + parts[b]["b"]
        m = train_on_windows(pos, neg, seed=seed, frame_view="both", svm_params={"C": 0.001},
                             acf_members=1)
        m.save(f)
        print(f, flush=True)
