"""One-off: persons of render 0, background windows of the outdoor scenes from one render and
the indoor scenes from the other."""
from pathlib import Path
from benchmark.data import load_dataset
from benchmark.crops.features import background_windows, person_windows
from viewadapt.detect import train_on_windows
OUTDOOR = {"carpark", "market", "park", "plaza", "promenade", "schoolyard", "street"}
out = Path("/tmp/s10/swap"); out.mkdir(exist_ok=True)
ds = {0: load_dataset(Path("/tmp/exp/dsfx")), 1: load_dataset(Path("/tmp/exp/dsfx_s1"))}
pos = list(person_windows(ds[0], 0).images(ds[0].root))
neg = {}
for k, d in ds.items():
    ws = background_windows(d, 0, stride=16)
    imgs = list(ws.images(d.root))
    outdoor = ws.meta.scene_id.isin(OUTDOOR).to_numpy()
    neg[k] = ([im for im, o in zip(imgs, outdoor) if o], [im for im, o in zip(imgs, outdoor) if not o])
    print(k, len(neg[k][0]), len(neg[k][1]), flush=True)
for name, (o, i) in {"out1in0": (1, 0), "out0in1": (0, 1)}.items():
    for seed in (0, 1, 2):
        f = out / f"p0{name}_s{seed}.npz"
        m = train_on_windows(pos, neg[o][0] + neg[i][1], seed=seed, frame_view="both",
                             svm_params={"C": 0.001}, acf_members=1)
        m.save(f)
        print(f, flush=True)
