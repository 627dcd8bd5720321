"""One-off: a dataset whose images come from two renders of the same draw, the clean one
(ds) and its camera-effects version (dsfx; the same renders through camera effects), linked
file by file. ``python hybrid_dataset.py test-effects OUT``: ds's manifest, its images at
elevations 0 and pi/8, dsfx's at pi/4 (hybrid_test_effects/). ``python hybrid_dataset.py
clean-negatives OUT``: dsfx's manifest and images, its elevation-0 backgrounds from ds
(hybrid_clean_negatives/)."""
import json, os, shutil, sys
from pathlib import Path
import numpy as np
import pandas as pd
ds, fx = Path("/tmp/exp/ds"), Path("/tmp/exp/dsfx")
KINDS = {  # base render, note, which (elevation, kind) come from the other render
    "test-effects": (ds, "elevation pi/4 images from the camera-effects render dsfx (same "
                     "renders), others from ds", lambda e, k: np.isclose(e, np.pi / 4)),
    "clean-negatives": (fx, "every image from the camera-effects render dsfx except the "
                        "elevation-0 backgrounds, from ds (same renders)",
                        lambda e, k: np.isclose(e, 0) and k == "background")}
base, note, other = KINDS[sys.argv[1]]
swap = fx if base == ds else ds
out = Path(sys.argv[2])
out.mkdir()
cfg = json.loads((base / "dataset.json").read_text())
cfg["hybrid"] = note
(out / "dataset.json").write_text(json.dumps(cfg, indent=1))
for f in ("manifest.parquet", "manifest.csv", "frames_coco.json"):
    shutil.copy(base / f, out / f)
m = pd.read_parquet(base / "manifest.parquet")
n_fx = 0
for p, e, k in zip(m["path"], m["elevation"], m["kind"]):
    src = (swap if other(e, k) else base) / p
    n_fx += src.is_relative_to(fx)
    dst = out / p
    dst.parent.mkdir(parents=True, exist_ok=True)
    os.symlink(src, dst)
for d in ("depth", "frames"):
    if (base / d).exists() and not (out / d).exists():
        os.symlink(base / d, out / d)
print(len(m), "files,", n_fx, "from dsfx")
